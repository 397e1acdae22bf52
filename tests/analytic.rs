//! Renders checked against closed forms computed here, independently of the renderer (f64,
//! the camera formula of docs/scene-format.md written out again).

use glam::DVec3;
use lancer_tests::{load, render};

/// The ray direction of pixel (i, j) by docs/scene-format.md's formula, in f64.
fn camera_ray(from: DVec3, to: DVec3, fov_deg: f64, w: u32, h: u32, i: u32, j: u32) -> DVec3 {
    let forward = (to - from).normalize();
    let right = forward.cross(DVec3::Y).normalize();
    let up = right.cross(forward);
    let t = (fov_deg.to_radians() / 2.0).tan();
    let x = (2.0 * (i as f64 + 0.5) / w as f64 - 1.0) * t * w as f64 / h as f64;
    let y = (1.0 - 2.0 * (j as f64 + 0.5) / h as f64) * t;
    (forward + x * right + y * up).normalize()
}

/// Ray–sphere in f64: the nearest hit distance and the discriminant (to skip silhouette pixels).
fn sphere_hit(o: DVec3, d: DVec3, c: DVec3, r: f64) -> (Option<f64>, f64) {
    let oc = o - c;
    let b = oc.dot(d);
    let disc = b * b - (oc.dot(oc) - r * r);
    if disc < 0.0 { (None, disc) } else { (Some(-b - disc.sqrt()), disc) }
}

#[test]
fn lambert_sphere_matches_the_formula_at_every_pixel() {
    // A scaled, moved sphere under one coloured light, hard shadows on (a lit convex sphere must
    // not shadow itself: acne would show as dark pixels here).
    let (w, h) = (96u32, 72u32);
    let (from, to, fov) = (DVec3::new(0.5, 1.0, -6.0), DVec3::new(0.2, 0.4, 0.0), 40.0);
    let (c, r) = (DVec3::new(0.3, 0.5, 0.5), 1.4);
    let light = DVec3::new(-4.0, 5.0, -3.0);
    let (light_col, intensity) = (DVec3::new(1.0, 0.9, 0.7), 0.8);
    let (col, diff) = (DVec3::new(0.9, 0.6, 0.3), 0.75);
    let src = format!(
        "[image]\nwidth = {w}\nheight = {h}\n[camera]\nfrom = [0.5, 1, -6]\nto = [0.2, 0.4, 0]\nfov = {fov}\n\
         [model]\nshadows = \"hard\"\nterms = [\"diffuse\"]\n\
         [[lights]]\nat = [-4, 5, -3]\ncolor = [1, 0.9, 0.7]\nintensity = {intensity}\n\
         [[objects]]\nshape = \"sphere\"\nscale = {r}\ntranslate = [0.3, 0.5, 0.5]\n\
         material = {{ color = [0.9, 0.6, 0.3], ambi = 0, diff = {diff} }}\n"
    );
    let frame = render(&load(&src), None, 2);
    let img = &frame.layer("diffuse").unwrap().pixels;
    let (mut checked, mut lit) = (0, 0);
    for j in 0..h {
        for i in 0..w {
            let d = camera_ray(from, to, fov, w, h, i, j);
            let (t, disc) = sphere_hit(from, d, c, r);
            if disc.abs() < 1e-3 {
                continue; // the silhouette: f32 and f64 may disagree on hit or miss
            }
            let expected = match t {
                None => DVec3::ZERO,
                Some(t) => {
                    let p = from + t * d;
                    let n = (p - c) / r;
                    let wdir = (light - p).normalize();
                    diff * n.dot(wdir).max(0.0) * col * light_col * intensity
                }
            };
            let got = img[(j * w + i) as usize].as_dvec3();
            assert!((got - expected).abs().max_element() < 2e-5, "pixel ({i}, {j}): got {got}, expected {expected}");
            checked += 1;
            lit += (expected.x > 0.0) as u32;
        }
    }
    assert!(checked > 6800 && lit > 900, "checked {checked} pixels, {lit} lit");
}

#[test]
fn ambient_image_is_ambi_times_colour_on_the_object_and_black_elsewhere() {
    let src = "[image]\nwidth = 40\nheight = 30\n[camera]\nfrom = [0, 0, -5]\nto = [0, 0, 0]\n[model]\nterms = [\"ambient\"]\n\
               [[objects]]\nshape = \"cube\"\nrotate = [20, 30, 0]\nmaterial = { color = [0.5, 0.25, 1], ambi = 0.2 }\n";
    let frame = render(&load(src), None, 1);
    let px = &frame.layer("ambient").unwrap().pixels;
    let on = glam::Vec3::new(0.1, 0.05, 0.2);
    assert!(px.iter().all(|p| *p == on || *p == glam::Vec3::ZERO));
    assert!(px.iter().filter(|p| **p == on).count() > 100);
}

#[test]
fn index_matched_glass_is_invisible() {
    // n = 1, alpha = 1 and no other term on the glass: rays pass straight through, and the
    // transmissive shadow model lets all light through it. Both glass objects rest on the floor
    // (coplanar contact: the cube's bottom face lies in the floor's plane).
    let base = "[image]\nwidth = 120\nheight = 90\nbackground = [0.2, 0.3, 0.4]\n\
                [camera]\nfrom = [0, 2, -7]\nto = [0, 1, 0]\nfov = 40\n\
                [model]\nshadows = \"transmissive\"\nterms = [\"ambient\", \"diffuse\", \"specular\", \"mirror\", \"refraction\"]\n\
                [[lights]]\nat = [-3, 8, -5]\n\
                [[objects]]\nshape = \"plane\"\nmaterial = { color = [0.8, 0.8, 0.8], ambi = 0.1, diff = 0.8, spec = 0.2, shine = 0.9 }\n\
                [[objects]]\nshape = \"cube\"\nscale = [0.4, 1.2, 0.4]\ntranslate = [0.3, 1.2, 2]\n\
                material = { color = [0.9, 0.2, 0.1], ambi = 0.1, diff = 0.8, spec = 0.3, shine = 0.95 }\n";
    let glass = "[[objects]]\nshape = \"sphere\"\nscale = 1.1\ntranslate = [-0.2, 1.1, -0.5]\n\
                 material = { ambi = 0, diff = 0, spec = 0, alpha = 1, n = 1 }\n\
                 [[objects]]\nshape = \"cube\"\nscale = 0.5\nrotate = [0, 40, 0]\ntranslate = [1.6, 0.5, -1]\n\
                 material = { ambi = 0, diff = 0, spec = 0, alpha = 1, n = 1 }\n";
    let without = render(&load(base), None, 2).beauty;
    let with = render(&load(&format!("{base}{glass}")), None, 2).beauty;
    let worst = without.iter().zip(&with).map(|(a, b)| (*a - *b).abs().max_element()).fold(0.0f32, f32::max);
    // Rays through the glass restart from offset exit points, so values may differ by rounding.
    assert!(worst < 1e-4, "largest difference {worst}");
}

/// The area covered by `object` (a TOML `[[objects]]` body) seen through a near-orthographic
/// camera from `from` (1000 units away) over a 4 × 4 window: covered pixels × pixel area.
fn silhouette_area(object: &str, from: &str, up: &str) -> f64 {
    let n = 400u32;
    let fov = 2.0 * (2.0f64 / 1000.0).atan().to_degrees();
    let src = format!(
        "[image]\nwidth = {n}\nheight = {n}\n[camera]\nfrom = {from}\nto = [0, 0, 0]\nup = {up}\nfov = {fov}\n\
         [model]\nmax_depth = 0\nterms = [\"ambient\"]\n[[objects]]\n{object}\nmaterial = {{ ambi = 1, color = [1, 1, 1] }}\n"
    );
    let frame = render(&load(&src), None, 2);
    let covered = frame.layer("ambient").unwrap().pixels.iter().filter(|p| p.x > 0.0).count();
    covered as f64 * (4.0 / n as f64).powi(2)
}

/// Area of the square [-1, 1]² clipped by the disk of radius `r` (1 < r < √2):
/// 4 ∫₀¹ min(1, √(r² − x²)) dx, with ∫ √(r² − x²) dx = x √(r² − x²)/2 + r²/2 · asin(x/r).
fn square_within_disk(r: f64) -> f64 {
    let c = (r * r - 1.0).sqrt();
    let primitive = |x: f64| x * (r * r - x * x).sqrt() / 2.0 + r * r / 2.0 * (x / r).asin();
    4.0 * (c + primitive(1.0) - primitive(c))
}

#[test]
fn silhouette_areas_match_closed_forms() {
    use std::f64::consts::PI;
    let front = ("[0, 0, -1000]", "[0, 1, 0]");
    let above = ("[0, 1000, 0]", "[0, 0, 1]");
    let cases = [
        ("shape = \"sphere\"", front, PI),
        ("shape = \"cube\"", front, 4.0),
        ("shape = \"cylinder\"", front, 4.0),
        ("shape = \"cone\"", front, 2.0),
        ("shape = \"disk\"", above, PI),
        ("shape = \"torus\"\nminor = 0.3", above, 4.0 * PI * 0.3),
        ("shape = \"cylinder\"\nscale = [0.5, 1.5, 0.5]\nrotate = [0, 0, 90]", front, 3.0),
        // Seen face-on, the sphere (radius 1.2) empties every line of sight with x² + y² < 0.44.
        (
            "shape = \"csg\"\nop = \"difference\"\na = { shape = \"cube\" }\nb = { shape = \"sphere\", scale = 1.2 }",
            front,
            4.0 - 0.44 * PI,
        ),
        (
            "shape = \"csg\"\nop = \"intersection\"\na = { shape = \"cube\" }\nb = { shape = \"sphere\", scale = 1.2 }",
            front,
            square_within_disk(1.2),
        ),
        (
            "shape = \"csg\"\nop = \"union\"\na = { shape = \"cube\", translate = [-0.5, 0, 0], scale = 0.5 }\nb = { shape = \"cube\", translate = [0.5, 0, 0], scale = 0.5 }",
            front,
            2.0,
        ),
    ];
    for (object, (from, up), expected) in cases {
        let area = silhouette_area(object, from, up);
        assert!((area / expected - 1.0).abs() < 0.01, "{object}: area {area:.4}, closed form {expected:.4}");
    }
}

#[test]
fn a_csg_lens_focuses_paraxial_rays_where_the_lensmaker_says() {
    use glam::{Affine3A, Vec3};
    use lancer_shading::ShadeContext;
    use lancer_shading::terms::refraction::passage;
    use lancer_shapes::{Csg, CsgNode, CsgOp, Geometry, Object, Shape};
    // A biconvex lens on the z axis: the intersection of two spheres of radius R whose centres
    // sit at ±(R − d/2), so the lens is d thick at its centre.
    let (r, d, n) = (3.0f32, 0.6f32, 1.5f32);
    let sphere = |z: f32| CsgNode::Leaf {
        shape: Shape::Sphere,
        node_from_leaf: Affine3A::from_translation(Vec3::new(0.0, 0.0, z)) * Affine3A::from_scale(Vec3::splat(r)),
    };
    let nodes = vec![sphere(r - d / 2.0), sphere(-(r - d / 2.0)), CsgNode::Op { op: CsgOp::Intersection, a: 0, b: 1 }];
    let lens = Shape::Csg(std::sync::Arc::new(Csg::new(nodes, 2).unwrap()));
    let geometry = Geometry::new(vec![Object::new(lens, Affine3A::IDENTITY, 0).unwrap()]);
    let ctx = ShadeContext {
        geometry: &geometry,
        materials: &[],
        lights: &[],
        max_depth: 5,
        textures: &[],
        reference: false,
    };
    // Lensmaker's equation for a thick lens with R1 = R, R2 = −R; the back focal distance is
    // measured from the back surface: f (1 − (n − 1) d / (n R1)).
    let (r64, d64, n64) = (r as f64, d as f64, n as f64);
    let f = 1.0 / ((n64 - 1.0) * (2.0 / r64 - (n64 - 1.0) * d64 / (n64 * r64 * r64)));
    let back_focus = d64 / 2.0 + f * (1.0 - (n64 - 1.0) * d64 / (n64 * r64));
    for h in [0.05f32, 0.1, 0.15] {
        let o = Vec3::new(h, 0.0, -10.0);
        let hit = geometry.closest_hit(lancer_shapes::Origin::free(o), Vec3::Z, 0.0, f32::INFINITY).unwrap();
        let t = passage(&ctx, &hit, Vec3::Z, n).expect("the ray gets through");
        // Where the outgoing ray crosses the axis (x = 0).
        let s = -t.from.point.x / t.dir.x;
        let z = (t.from.point.z + s * t.dir.z) as f64;
        assert!((z / back_focus - 1.0).abs() < 0.02, "height {h}: focus at z = {z:.4}, lensmaker {back_focus:.4}");
    }
}

#[test]
fn a_torus_seen_almost_edge_on_has_no_speckles() {
    // Grazing views are where a poorly conditioned quartic drops or invents roots: a pixel
    // whose four neighbours all disagree with it is a speckle.
    for (from, minor) in [("[0, 0.3, -20]", 0.25), ("[0, 0.05, -20]", 0.4), ("[3, 1.2, -20]", 0.1)] {
        let (w, h) = (200u32, 100u32);
        let src = format!(
            "[image]\nwidth = {w}\nheight = {h}\n[camera]\nfrom = {from}\nto = [0, 0, 0]\nfov = 9\n\
             [model]\nmax_depth = 0\nterms = [\"ambient\"]\n\
             [[objects]]\nshape = \"torus\"\nminor = {minor}\nmaterial = {{ ambi = 1 }}\n"
        );
        let frame = render(&load(&src), None, 2);
        let px = &frame.layer("ambient").unwrap().pixels;
        let on = |i: u32, j: u32| px[(j * w + i) as usize].x > 0.0;
        let mut speckles = Vec::new();
        for j in 1..h - 1 {
            for i in 1..w - 1 {
                let n = [on(i - 1, j), on(i + 1, j), on(i, j - 1), on(i, j + 1)];
                if n.iter().all(|&x| x != on(i, j)) {
                    speckles.push((i, j));
                }
            }
        }
        assert!(px.iter().filter(|p| p.x > 0.0).count() > 500, "{from}: the torus is in view");
        assert!(speckles.is_empty(), "{from}, minor {minor}: speckles at {speckles:?}");
    }
}

//! Swappable lighting models: variants change only their own term's image, `weight` scales a
//! term exactly, Schlick's weight on a render matches the formula, and soft shadows match the
//! geometry of a square area light (an independent numerical integration and a closed-form edge).

use glam::{Affine3A, DVec3, Vec3};
use lancer_core::{Light, Material};
use lancer_shading::{ParamValue, Params, Registry, ShadeContext, ShadowContext};
use lancer_shapes::{Geometry, Object, Origin, Shape};
use lancer_tests::{load, load_file, render, root};

fn with_model(scene: &str, model: &str) -> lancer_core::Frame {
    let mut loaded = load_file(std::path::Path::new(scene));
    let path = root().join(model);
    let src = std::fs::read_to_string(&path).unwrap();
    loaded.pipeline =
        lancer_scene::load_model(&src, model, &Registry::with_builtins()).unwrap_or_else(|e| panic!("{e}"));
    render(&loaded, Some(160), 2)
}

#[test]
fn swapping_the_specular_variant_changes_the_specular_image_only_among_camera_terms() {
    for scene in ["scenes/showcase.toml", "scenes/shine-ladder.toml", "scenes/glass.toml"] {
        let seed = with_model(scene, "models/seed.toml");
        for model in ["models/blinn.toml", "models/blinn-normalized.toml"] {
            let other = with_model(scene, model);
            assert!(seed.layer("ambient") == other.layer("ambient"), "{scene} {model}: ambient changed");
            assert!(seed.layer("diffuse") == other.layer("diffuse"), "{scene} {model}: diffuse changed");
            assert!(seed.layer("specular") != other.layer("specular"), "{scene} {model}: specular did not change");
        }
    }
}

#[test]
fn without_recursion_a_specular_swap_changes_the_specular_image_and_nothing_else() {
    // With mirror and refraction on, their images also carry the highlights seen in reflections;
    // without them, the specular image is the only one that may change.
    let model = |variant: &str| {
        format!(
            "max_depth = 0\nterms = [\"ambient\", \"diffuse\", {{ term = \"specular\", variant = \"{variant}\" }}]\n"
        )
    };
    let mut loaded = load_file(std::path::Path::new("scenes/showcase.toml"));
    let registry = Registry::with_builtins();
    loaded.pipeline = lancer_scene::load_model(&model("phong"), "phong", &registry).unwrap();
    let phong = render(&loaded, Some(128), 2);
    loaded.pipeline = lancer_scene::load_model(&model("blinn"), "blinn", &registry).unwrap();
    let blinn = render(&loaded, Some(128), 2);
    for (a, b) in phong.layers.iter().zip(&blinn.layers) {
        assert_eq!(a.name, b.name);
        assert!(
            (a == b) == (a.name != "specular"),
            "layer {} {}",
            a.name,
            if a == b { "unchanged" } else { "changed" }
        );
    }
}

#[test]
fn the_seed_model_file_is_the_handouts_default_model() {
    // The model a scene without [model] gets: the handout's (hard shadows, depth 5, the five
    // terms in their default variants). (mirrors.toml's own model leaves out refraction, which
    // has nothing to act on there.)
    let mut loaded = load_file(std::path::Path::new("scenes/mirrors.toml"));
    loaded.pipeline = Registry::with_builtins().default_pipeline();
    let default = render(&loaded, Some(160), 2);
    let seed = with_model("scenes/mirrors.toml", "models/seed.toml");
    assert!(default == seed, "the seed model file renders mirrors.toml differently from the default model");
}

#[test]
fn weight_scales_a_term_image_exactly() {
    let src = std::fs::read_to_string(root().join("scenes/showcase.toml")).unwrap();
    let half = src.replace("\"diffuse\",", "{ term = \"diffuse\", weight = 0.5 },");
    assert_ne!(src, half);
    let full = render(&load(&src), Some(96), 1);
    let halved = render(&load(&half), Some(96), 1);
    let (a, b) = (&full.layer("diffuse").unwrap().pixels, &halved.layer("diffuse").unwrap().pixels);
    assert!(a.iter().zip(b).all(|(x, y)| *x * 0.5 == *y), "halving is exact in binary floating point");
    assert!(full.layer("ambient") == halved.layer("ambient"), "ambient changed");
}

#[test]
fn schlick_mirror_on_a_render_follows_the_formula_from_n() {
    // A big glass-index cube face seen head-on, white background, only the mirror term: each
    // pixel's mirror image is F(θ) times the white background its reflected ray sees.
    let (w, h, fov) = (41u32, 41u32, 30.0f64);
    let src = format!(
        "[image]\nwidth = {w}\nheight = {h}\nbackground = [1, 1, 1]\n[camera]\nfrom = [0, 0, -4]\nto = [0, 0, 0]\nfov = {fov}\n\
         [model]\nmax_depth = 1\nterms = [{{ term = \"mirror\", variant = \"schlick\" }}]\n\
         [[objects]]\nshape = \"cube\"\nscale = [20, 20, 1]\nmaterial = {{ ambi = 0, diff = 0, spec = 1, n = 1.5 }}\n"
    );
    let frame = render(&load(&src), None, 1);
    let img = &frame.layer("mirror").unwrap().pixels;
    let centre = img[(h / 2 * w + w / 2) as usize];
    assert!((centre.x - 0.04).abs() < 1e-6, "head-on: ((n−1)/(n+1))² = 0.04, got {}", centre.x);
    // Off-centre pixels: θ from the camera formula, computed here in f64.
    let t = (fov.to_radians() / 2.0).tan();
    for (i, j) in [(0u32, 0u32), (5, 30), (40, 20)] {
        let x = (2.0 * (i as f64 + 0.5) / w as f64 - 1.0) * t;
        let y = (1.0 - 2.0 * (j as f64 + 0.5) / h as f64) * t;
        let cos = 1.0 / (1.0 + x * x + y * y).sqrt();
        let f = 0.04 + 0.96 * (1.0 - cos).powi(5);
        let got = img[(j * w + i) as usize].x as f64;
        assert!((got - f).abs() < 1e-5, "pixel ({i}, {j}): {got} vs {f}");
    }
}

/// Visible fraction of a square light (side `s`, height `hl`, centred above the origin) from the
/// floor point `(x, 0, 0)`, past a sphere (centre `c`, radius `r`), by dense f64 integration.
fn visible_fraction(x: f64, s: f64, hl: f64, c: DVec3, r: f64) -> f64 {
    let n = 300;
    let p = DVec3::new(x, 0.0, 0.0);
    let mut seen = 0;
    for i in 0..n {
        for k in 0..n {
            let q =
                DVec3::new((i as f64 + 0.5) / n as f64 * s - s / 2.0, hl, (k as f64 + 0.5) / n as f64 * s - s / 2.0);
            let d = q - p;
            let t = ((c - p).dot(d) / d.dot(d)).clamp(0.0, 1.0);
            seen += ((p + t * d - c).length() >= r) as u32;
        }
    }
    seen as f64 / (n * n) as f64
}

/// Where `f` (increasing in x) crosses `level`, by bisection on [lo, hi].
fn crossing(f: &dyn Fn(f64) -> f64, level: f64, mut lo: f64, mut hi: f64) -> f64 {
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < level { lo = mid } else { hi = mid }
    }
    0.5 * (lo + hi)
}

#[test]
fn soft_shadow_penumbra_matches_the_geometry_of_the_area_light() {
    let (s, hl, c, r) = (2.0f64, 5.0f64, DVec3::new(0.0, 1.5, 0.0), 0.5f64);
    let objects = vec![
        Object::new(Shape::Plane, Affine3A::IDENTITY, 0).unwrap(),
        Object::new(
            Shape::Sphere,
            Affine3A::from_scale_rotation_translation(Vec3::splat(r as f32), glam::Quat::IDENTITY, c.as_vec3()),
            0,
        )
        .unwrap(),
    ];
    let geometry = Geometry::new(objects);
    let materials = [Material::default()];
    let scene = ShadeContext {
        geometry: &geometry,
        materials: &materials,
        lights: &[],
        max_depth: 5,
        textures: &[],
        reference: false,
    };
    let ctx = ShadowContext::new(&scene);
    let light = Light { at: Vec3::new(0.0, hl as f32, 0.0), color: Vec3::ONE, intensity: 1.0, size: s as f32 };
    let soft = Registry::with_builtins()
        .build_shadow("soft", Params::new([("samples".to_owned(), ParamValue::Number(1024.0))]))
        .unwrap();
    let model_in = |ctx: &ShadowContext<'_>, x: f64| {
        // The floor's hit, from a ray coming straight down onto (x, 0, 0).
        let o = Origin::free(Vec3::new(x as f32, 0.1, 0.0));
        let floor = geometry.closest_hit(o, -Vec3::Y, 0.0, f32::INFINITY).expect("the floor is below");
        soft.model.transmittance(ctx, &floor, &light).x as f64
    };
    let model = |x: f64| model_in(&ctx, x);
    let reference = |x: f64| visible_fraction(x, s, hl, c, r);

    // The 10 %–90 % penumbra width on the +x side.
    let width = |f: &dyn Fn(f64) -> f64| crossing(f, 0.9, 0.0, 2.0) - crossing(f, 0.1, 0.0, 2.0);
    let (w_model, w_ref) = (width(&model), width(&reference));
    eprintln!("penumbra 10-90% width: soft model {w_model:.4}, geometric {w_ref:.4}");
    assert!((w_model / w_ref - 1.0).abs() < 0.03, "penumbra width {w_model} vs geometric {w_ref}");

    // Closed form of the outer edge: the tangent from the light's far edge (−s/2, hl) to the
    // sphere's cross-section meets the floor there; beyond it the whole light is seen.
    let q = glam::DVec2::new(-s / 2.0, hl);
    let d = glam::DVec2::new(c.x, c.y) - q;
    let a = (r / d.length()).asin();
    let outer = [a, -a]
        .iter()
        .map(|&t| {
            let dir = glam::DVec2::from_angle(t).rotate(d);
            q.x + dir.x * (-q.y / dir.y)
        })
        .fold(f64::MIN, f64::max);
    assert_eq!(model(outer * 1.01), 1.0, "fully lit just beyond the outer edge {outer}");
    assert!(model(outer * 0.95) < 1.0, "partly shadowed just inside the outer edge {outer}");
    assert!(reference(outer * 0.95) < 1.0 && reference(outer * 1.01) == 1.0);
    // The same point always gets the same answer, whatever was computed before and on which
    // thread (the jitter is a hash of the point, not a shared random state).
    let first = model(0.8);
    let later = std::thread::scope(|s| {
        s.spawn(|| {
            let other = ShadowContext::new(&scene);
            model_in(&other, 0.3);
            model_in(&other, 0.8)
        })
        .join()
        .unwrap()
    });
    assert_eq!(first, later);
    assert!((first - reference(0.8)).abs() < 0.03, "{first} vs {}", reference(0.8));
}

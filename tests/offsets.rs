//! Where secondary rays start beside huge objects: the offset is a bound on the hit point's
//! actual error (it does not grow with an object's scale), shadow rays are aimed at the light
//! from where they start, and the block tracer's cone from the light holds the rays' real end
//! points, so a scene renders the same through the block tracer and the BVH walk, and `hard` and
//! `transmissive` agree on an all-opaque scene.

use lancer_core::Frame;
use lancer_tests::{load, render};

/// A floor that is a cube scaled 10⁶ (its top face at y = 0), a small cube and a sphere on it,
/// one light; with `extra` tiny spheres far behind the camera, where no ray goes (past 128
/// objects, the render walks the BVH instead of the block tracer).
fn floor_scene(shadows: &str, extra: usize) -> String {
    let mut s = format!(
        "[image]\nwidth = 160\nheight = 120\n[camera]\nfrom = [0, 4, -9]\nto = [0, 0, 0]\nfov = 50\n\
         [model]\nterms = [\"ambient\", \"diffuse\"]\nshadows = \"{shadows}\"\n\
         [[lights]]\nat = [3, 8, -2]\n\
         [[objects]]\nshape = \"cube\"\nscale = 1e6\ntranslate = [0, -1e6, 0]\n\
         [[objects]]\nshape = \"cube\"\nscale = 0.7\ntranslate = [1.5, 0.7, 0]\n\
         [[objects]]\nshape = \"sphere\"\ntranslate = [-1.5, 1, 0.5]\n"
    );
    for i in 0..extra {
        s += &format!(
            "[[objects]]\nshape = \"sphere\"\nscale = 0.01\ntranslate = [{}, {}, -400]\n",
            (i % 13) as f32 - 6.0,
            (i / 13) as f32
        );
    }
    s
}

fn diffuse(frame: &Frame) -> &[glam::Vec3] {
    &frame.layer("diffuse").expect("a diffuse layer").pixels
}

fn differing(a: &[glam::Vec3], b: &[glam::Vec3]) -> usize {
    a.iter().zip(b).filter(|(x, y)| (**x - **y).abs().max_element() > 1e-6).count()
}

#[test]
fn regression_a_floor_scaled_a_million_is_lit_the_same_with_130_unseen_spheres() {
    // Found in review: shadow rays started 16 error bounds off the surface, and the bound grew
    // with the floor's scale (5.7 units at 10⁶): the rays started below the floor, kept their
    // direction from the hit point and ended beside the light; the block tracer's cone (which
    // assumed they end at the light) culled what they met, the BVH walk did not: 130 unseen
    // spheres turned the lit floor black, 15,578 of 19,200 pixels.
    for shadows in ["hard", "transmissive"] {
        let alone = render(&load(&floor_scene(shadows, 0)), None, 2);
        let crowded = render(&load(&floor_scene(shadows, 130)), None, 2);
        let (a, b) = (diffuse(&alone), diffuse(&crowded));
        assert_eq!(differing(a, b), 0, "{shadows}: pixels that differ with 130 unseen spheres");
        let lit = a.iter().filter(|p| p.max_element() > 0.05).count();
        assert!(lit > a.len() / 2, "{shadows}: the floor is lit ({lit} of {} pixels)", a.len());
    }
}

#[test]
fn regression_hard_and_transmissive_shadows_agree_on_an_opaque_scene() {
    // Found in review: `hard` limited its (moved) shadow ray by the hit-to-light distance,
    // `transmissive` by what was left past the start: on an all-opaque scene they disagreed.
    for extra in [0, 130] {
        let hard = render(&load(&floor_scene("hard", extra)), None, 1);
        let transmissive = render(&load(&floor_scene("transmissive", extra)), None, 1);
        assert_eq!(differing(diffuse(&hard), diffuse(&transmissive)), 0, "{extra} extra objects");
        assert_eq!(hard.beauty, transmissive.beauty, "{extra} extra objects");
    }
}

#[test]
fn a_hit_on_an_object_scaled_a_million_is_placed_to_its_own_rounding() {
    // The floor's top face at y = 0: the hit point's error is the rounding of the point, not
    // the scale's 0.36 of the f32 placement.
    let floor = glam::Affine3A::from_scale_rotation_translation(
        glam::Vec3::splat(1e6),
        glam::Quat::IDENTITY,
        glam::Vec3::new(0.0, -1e6, 0.0),
    );
    let object = lancer_shapes::Object::new(lancer_shapes::Shape::Cube, floor, 0).unwrap();
    let geometry = &lancer_shapes::Geometry::new(vec![object]);
    let from = lancer_shapes::Origin::free(glam::Vec3::new(0.3, 4.0, -9.0));
    let dir = (glam::Vec3::new(0.7, 0.0, 2.0) - from.point).normalize();
    let hit = geometry.closest_hit(from, dir, 0.0, f32::INFINITY).expect("the floor");
    assert!(hit.point.y.abs() <= 1e-6, "{}", hit.point);
    assert!(hit.error <= 4.0 * f32::EPSILON * hit.point.abs().max_element(), "error {}", hit.error);
    let up = geometry.spawn(&hit, glam::Vec3::Y);
    assert!(up.point.y.abs() < 1e-5, "the shadow ray starts a hair off the floor: {}", up.point);
}

#[test]
fn regression_a_light_inside_a_glass_torus_is_dimmed_by_its_one_wall() {
    // Found in review of the aimed shadow rays: the transmissive walk past a glass object that
    // the light is inside went on from the far wall, back towards the light, and counted what
    // lies between them: here an opaque ball in the tube beyond the light, which blacked out
    // the floor below.
    let scene = |shadows: &str| {
        format!(
            "[image]\nwidth = 33\nheight = 33\n[camera]\nfrom = [2, 0.5, -6]\nto = [2, 0, 0]\nfov = 20\n\
             [model]\nterms = [\"ambient\", \"diffuse\"]\nshadows = \"{shadows}\"\n\
             [[lights]]\nat = [2, 1.5, 0]\n\
             [materials.glass]\ncolor = [1, 1, 1]\nalpha = 0.5\nn = 1.5\n\
             [[objects]]\nshape = \"plane\"\n\
             [[objects]]\nshape = \"torus\"\nminor = 0.3\nscale = 2\ntranslate = [0, 1.5, 0]\nmaterial = \"glass\"\n\
             [[objects]]\nshape = \"sphere\"\nscale = 0.1\ntranslate = [2, 1.85, 0]\n"
        )
    };
    let lit = render(&load(&scene("none")), None, 1);
    let through = render(&load(&scene("transmissive")), None, 1);
    // The middle pixel sees the floor right below the light, through the tube's lower wall.
    let middle = 16 * 33 + 16;
    let (a, b) = (diffuse(&lit)[middle], diffuse(&through)[middle]);
    assert!(a.x > 0.05, "the floor there is lit: {a}");
    assert!((b.x / a.x - 0.5).abs() < 1e-4, "one wall: alpha = 0.5 of the light, got {}", b.x / a.x);
}

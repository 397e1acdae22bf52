//! `refraction:traced` and the shadows' `each_surface` against values worked out by hand: the
//! weight of a ray seen through glass (`alpha` at each surface), an object inside glass seen and
//! casting its shadow, nested glass of one index bending nothing, and the same bits whatever
//! the threads.

use glam::Vec3;
use lancer_tests::{load, render};

/// A 3 x 3 image looking down -z from z = 10 at the origin with a field of view of `fov`
/// degrees, in front of the background (0.2, 0.5, 0.8); `rest` holds the model and objects.
fn looking_down_z(fov: f32, rest: &str) -> String {
    format!(
        r#"
[image]
width = 3
height = 3
background = [0.2, 0.5, 0.8]

[camera]
from = [0, 0, 10]
to = [0, 0, 0]
fov = {fov}
{rest}"#
    )
}

/// [`looking_down_z`] at a glass slab (a cube scaled flat, its faces square to the view), with
/// `inside` placed in the slab; the model's refraction `variant` and shadows as given. Only the
/// refraction term adds anything: no lights reach a term that reads them.
fn slab(variant: &str, shadows: &str, inside: &str) -> String {
    looking_down_z(
        2.0,
        &format!(
            r#"
[model]
max_depth = 8
shadows = {shadows}
terms = ["ambient", "diffuse", "specular", "mirror", "refraction:{variant}"]

[[objects]]
shape = "cube"
scale = [3, 3, 1]
material = {{ ambi = 0, diff = 0, spec = 0, alpha = 0.6, n = 1.5 }}
{inside}
"#
        ),
    )
}

/// The centre pixel of the beauty image.
fn centre(src: &str) -> Vec3 {
    let frame = render(&load(src), None, 1);
    frame.beauty[4]
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() < 1e-5
}

#[test]
fn seen_through_a_slab_the_background_is_weighed_by_alpha_at_each_surface() {
    // Square to the faces nothing bends: the handout's path weighs the ray once (alpha · B),
    // the traced one at the entry and again at the exit (alpha² · B).
    let b = Vec3::new(0.2, 0.5, 0.8);
    assert!(close(centre(&slab("seed", "\"none\"", "")), 0.6 * b), "{}", centre(&slab("seed", "\"none\"", "")));
    let traced = centre(&slab("traced", "\"none\"", ""));
    assert!(close(traced, 0.36 * b), "{traced}");
}

#[test]
fn glass_inside_glass_of_the_same_index_only_weighs_the_ray() {
    // A ball of the slab's index inside it: two more surfaces, each weighing the ray by alpha,
    // so alpha⁴ · B, where the handout's path still gives alpha · B. (That the ball bends
    // nothing, n1 / n2 = 1, is the unit test's, with an oblique ray.)
    let ball = r#"
[[objects]]
shape = "sphere"
scale = 0.5
material = { ambi = 0, diff = 0, spec = 0, alpha = 0.6, n = 1.5 }
"#;
    let b = Vec3::new(0.2, 0.5, 0.8);
    let traced = centre(&slab("traced", "\"none\"", ball));
    assert!(close(traced, 0.6f32.powi(4) * b), "{traced}");
    assert!(close(centre(&slab("seed", "\"none\"", ball)), 0.6 * b));
}

#[test]
fn an_opaque_ball_inside_glass_shows_with_traced_and_is_hidden_by_the_handouts_path() {
    // A ball of ambient colour (0.9, 0.1, 0.1) in the slab: the traced ray meets it, weighed by
    // the one surface it crossed (alpha · ambi · colour); the handout's ray crosses the slab
    // without meeting it.
    let ball = r#"
[[objects]]
shape = "sphere"
scale = 0.5
material = { color = [0.9, 0.1, 0.1], ambi = 1, diff = 0 }
"#;
    let traced = centre(&slab("traced", "\"none\"", ball));
    assert!(close(traced, 0.6 * Vec3::new(0.9, 0.1, 0.1)), "{traced}");
    let seed = centre(&slab("seed", "\"none\"", ball));
    assert!(close(seed, 0.6 * Vec3::new(0.2, 0.5, 0.8)), "{seed}");
}

/// The floor under a glass ball (alpha 0.6) holding `inside`, lit from straight above through
/// it: the centre pixel of a camera between the floor and the ball looking straight down at the
/// shadow's middle. Only `diffuse` adds (diff 1, colour 1, `N·w` = 1), so the pixel is the light
/// the shadow model lets through.
fn shadow_under_glass(shadows: &str, inside: &str) -> Vec3 {
    shadow_under_glass_lit(shadows, inside, 0.0)
}

/// [`shadow_under_glass`] with a square area light of side `size` (0: a point light).
fn shadow_under_glass_lit(shadows: &str, inside: &str, size: f32) -> Vec3 {
    let src = format!(
        r#"
[image]
width = 3
height = 3

[camera]
from = [0, 0.5, 0]
to = [0, 0, 0]
up = [0, 0, 1]
fov = 2

[model]
shadows = {shadows}
terms = ["diffuse"]

[[lights]]
at = [0, 100, 0]
size = {size}

[[objects]]
shape = "plane"
material = {{ ambi = 0, diff = 1 }}

[[objects]]
shape = "sphere"
translate = [0, 3, 0]
material = {{ ambi = 0, diff = 0, alpha = 0.6, n = 1.5 }}
{inside}
"#
    );
    centre(&src)
}

#[test]
fn shadows_each_surface_let_alpha_through_at_each_surface_and_objects_inside_glass_cast_theirs() {
    // Straight down through the ball: once per object by default (alpha), at each of its two
    // surfaces with `each_surface` (alpha²).
    let once = shadow_under_glass("\"transmissive\"", "");
    let each = shadow_under_glass("{ model = \"transmissive\", each_surface = true }", "");
    assert!(close(once, Vec3::splat(0.6)), "{once}");
    assert!(close(each, Vec3::splat(0.36)), "{each}");
    // An opaque ball inside the glass one: crossed unseen by default, a full shadow when the
    // shadow ray is followed surface by surface.
    let core = r#"
[[objects]]
shape = "sphere"
scale = 0.3
translate = [0, 3, 0]
material = { color = [1, 1, 1] }
"#;
    assert!(close(shadow_under_glass("\"transmissive\"", core), Vec3::splat(0.6)));
    assert_eq!(shadow_under_glass("{ model = \"transmissive\", each_surface = true }", core), Vec3::ZERO);
    // Soft shadows of a small area light, every sample's ray through the ball: the same.
    let soft = shadow_under_glass_lit("{ model = \"soft\", samples = 16, each_surface = true }", "", 1.0);
    assert!(close(soft, Vec3::splat(0.36)), "{soft}");
    let soft = shadow_under_glass_lit("{ model = \"soft\", samples = 16, each_surface = true }", core, 1.0);
    assert_eq!(soft, Vec3::ZERO);
}

#[test]
fn the_ball_in_glass_scene_renders_the_same_bits_on_one_thread_and_two() {
    let loaded = lancer_tests::load_file("scenes/ball-in-glass.toml".as_ref());
    let (one, two) = (render(&loaded, Some(96), 1), render(&loaded, Some(96), 2));
    let bits =
        |f: &lancer_core::Frame| f.beauty.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(&one), bits(&two));
    // The ball shows: the traced image is red where it is.
    let (w, h) = (one.width as usize, one.height as usize);
    let middle = one.beauty[h / 2 * w + w / 2];
    assert!(middle.x > 2.0 * middle.z, "red in the middle of the cube: {middle}");
}

#[test]
fn a_glass_torus_is_left_and_entered_again() {
    // Along the z axis the ray crosses the ring's tube twice: in at z = 1.25, out at 0.75, in
    // again at −0.75, out at −1.25. With n = 1 nothing bends: the traced ray is weighed at all
    // four surfaces (alpha⁴ · B); the handout's path crosses each side of the ring as one
    // passage (alpha² · B).
    let src = |variant: &str| {
        looking_down_z(
            1.0,
            &format!(
                r#"
[model]
shadows = "none"
terms = ["refraction:{variant}"]

[[objects]]
shape = "torus"
material = {{ ambi = 0, diff = 0, spec = 0, alpha = 0.6, n = 1 }}
"#
            ),
        )
    };
    let b = Vec3::new(0.2, 0.5, 0.8);
    let traced = centre(&src("traced"));
    assert!(close(traced, 0.6f32.powi(4) * b), "{traced}");
    let seed = centre(&src("seed"));
    assert!(close(seed, 0.36 * b), "{seed}");
}

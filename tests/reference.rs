//! The reference path ([`RenderOptions::reference`]: every system one ray at a time in plain
//! code, each built-in term by its formula) against the fast paths: every shipped scene and
//! every robustness scene, each also with 130 unseen extra objects (more bounded objects than
//! the block tracer takes, so every ray walks the BVH), rendered both ways and compared layer by
//! layer.
//!
//! Every fast path claims the reference's bits: the camera's, the hit descriptions' and the
//! terms' eight lanes repeat the scalar operations in order, and the block tracer runs each
//! shape's own test. The one place the two may legitimately part is an exact tie, two surfaces
//! at the same distance along a ray, which the block tracer (first in its test order) and the
//! BVH walk (first visited) may break differently: then the pixel shows another object, and no
//! per-pixel tolerance would mean anything. None of these scenes has one (measured: every layer
//! of every scene equal to the bit, both ways), so no difference at all is allowed; a scene
//! added with such a tie should say so here, with the pixels it costs.

use glam::{Affine3A, Vec3};
use lancer_core::{Camera, Frame, ImageSettings};
use lancer_scene::Loaded;
use lancer_shading::{Prepared, RenderOptions};
use lancer_shapes::{Geometry, Object, Shape};

/// The images' width (the height keeps the scene's aspect ratio); a scene made smaller keeps
/// its own.
const WIDTH: u32 = 96;

/// The unseen objects added: with the scene's own, more than the 128 bounded objects the block
/// tracer takes.
const EXTRA: usize = 130;

/// The image settings of `loaded` at most [`WIDTH`] wide.
fn image_of(loaded: &Loaded) -> ImageSettings {
    let mut image = loaded.scene.image;
    if image.width > WIDTH {
        image.height = ((WIDTH as f64 * image.height as f64 / image.width as f64).round() as u32).max(1);
        image.width = WIDTH;
    }
    image
}

/// `prepared` with [`EXTRA`] tiny spheres no ray meets: a cluster a thousand times the scene's
/// size behind and below the camera (the scene's reach: its bounded objects, the camera and the
/// lights), each a ten-thousandth of that size, so each is seen from the scene under 10⁻⁷ rad.
fn with_extras(prepared: &Prepared, camera: &Camera) -> Prepared {
    // (The prepared frame is the camera's: it sits at its origin.)
    let eye = camera.seen_from(prepared.origin).origin.as_vec3();
    let (mut lo, mut hi) = (eye, eye);
    for b in prepared.geometry.objects.iter().filter_map(Object::bounds) {
        (lo, hi) = (lo.min(b.min), hi.max(b.max));
    }
    for light in &prepared.lights {
        (lo, hi) = (lo.min(light.at), hi.max(light.at));
    }
    let reach = (hi - lo).length().max(f32::MIN_POSITIVE.sqrt());
    let far = (lo + hi) * 0.5 - (camera.forward + camera.up).normalize() * reach * 1e3;
    let mut objects = prepared.geometry.objects.clone();
    objects.extend((0..EXTRA).map(|k| {
        let at = far + (camera.right * (k % 13) as f32 + camera.up * (k / 13) as f32) * reach * 1e-2;
        let placement = Affine3A::from_scale_rotation_translation(Vec3::splat(reach * 1e-4), Default::default(), at);
        Object::new(Shape::Sphere, placement, 0).expect("a sphere of a positive size")
    }));
    let bounded = objects.iter().filter(|o| o.bounds().is_some()).count();
    assert!(bounded > 128, "{bounded} bounded objects: the block tracer would take them");
    Prepared { geometry: Geometry::new(objects), ..prepared.clone() }
}

/// `prepared` rendered with every layer kept, by the reference path or not.
fn render(prepared: &Prepared, loaded: &Loaded, reference: bool) -> Frame {
    let options = RenderOptions { layers: true, reference, ..RenderOptions::default() };
    lancer_shading::render_prepared(prepared, &loaded.scene.camera, &image_of(loaded), &loaded.pipeline, options)
}

/// How two renders of the same scene differ: per layer (and the beauty image), the pixels whose
/// bits differ and the largest difference of a channel.
#[derive(Debug, Default)]
struct Difference {
    layers: Vec<(String, usize, f32)>,
}

impl Difference {
    fn of(a: &Frame, b: &Frame) -> Difference {
        let compare = |x: &[Vec3], y: &[Vec3]| {
            assert_eq!(x.len(), y.len());
            let bits = |v: &Vec3| v.to_array().map(f32::to_bits);
            let off = x.iter().zip(y).filter(|(p, q)| bits(p) != bits(q)).count();
            let most = x.iter().zip(y).map(|(p, q)| (*p - *q).abs().max_element()).fold(0.0f32, f32::max);
            (off, most)
        };
        let mut layers = Vec::new();
        for (la, lb) in a.layers.iter().zip(&b.layers) {
            assert_eq!(la.name, lb.name);
            let (off, most) = compare(&la.pixels, &lb.pixels);
            layers.push((la.name.clone(), off, most));
        }
        let (off, most) = compare(&a.beauty, &b.beauty);
        layers.push(("beauty".to_owned(), off, most));
        Difference { layers }
    }

    fn equal(&self) -> bool {
        self.layers.iter().all(|(_, off, _)| *off == 0)
    }
}

impl std::fmt::Display for Difference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.equal() {
            return f.write_str("equal to the bit");
        }
        let parts: Vec<String> = self
            .layers
            .iter()
            .filter(|(_, off, _)| *off > 0)
            .map(|(name, off, most)| format!("{name}: {off} px, at most {most:.3e}"))
            .collect();
        f.write_str(&parts.join("; "))
    }
}

/// Each scene rendered four ways, fast and reference, as it is and with the extra objects: the
/// two paths must agree to the bit either way, and the reference renders with and without the
/// extra objects too (they are unseen).
fn compare_all(scenes: &[(String, Loaded)]) {
    let mut report = Vec::new();
    let mut failed = Vec::new();
    for (name, loaded) in scenes {
        let prepared = lancer_shading::prepare(&loaded.scene).expect("scene prepares");
        let crowded = with_extras(&prepared, &loaded.scene.camera);
        let (fast, reference) = (render(&prepared, loaded, false), render(&prepared, loaded, true));
        let (fast_bvh, reference_bvh) = (render(&crowded, loaded, false), render(&crowded, loaded, true));
        let alone = Difference::of(&fast, &reference);
        let walked = Difference::of(&fast_bvh, &reference_bvh);
        // The extra objects are unseen: the reference renders with and without them agree.
        let unseen = Difference::of(&reference, &reference_bvh);
        report.push(format!("{name}: {alone} | with {EXTRA} more objects: {walked} | unseen: {unseen}"));
        if !alone.equal() {
            failed.push(format!("{name}: {alone}"));
        }
        if !walked.equal() {
            failed.push(format!("{name} with {EXTRA} more objects: {walked}"));
        }
        if !unseen.equal() {
            failed.push(format!("{name}: the extra objects are seen: {unseen}"));
        }
    }
    eprintln!("{}", report.join("\n"));
    assert!(failed.is_empty(), "the reference path differs:\n{}", failed.join("\n"));
}

#[test]
fn every_shipped_scene_renders_the_same_by_the_reference_path() {
    let scenes: Vec<(String, Loaded)> = lancer_tests::scene_files()
        .iter()
        .map(|p| {
            let name = p.strip_prefix(lancer_tests::root()).unwrap_or(p).display().to_string();
            (name, lancer_tests::load_file(p))
        })
        .collect();
    assert!(scenes.len() > 20, "{} scenes", scenes.len());
    compare_all(&scenes);
}

#[test]
fn every_robustness_scene_renders_the_same_by_the_reference_path() {
    let scenes = lancer_tests::robustness_scenes::all(WIDTH);
    assert!(scenes.len() > 20, "{} scenes", scenes.len());
    compare_all(&scenes);
}

//! `explain_pixel` against the full render: every pixel's per-term values and beauty are the
//! frame's, to the bit, and its ray tree adds up to them.

use glam::Vec3;
use lancer_scene::Loaded;
use lancer_shading::{PixelExplanation, explain_pixel};
use lancer_tests::{load, load_file, render};

/// Explains every pixel of `scene` at `width` with `samples` and compares with the frame.
/// Returns the explanations for further checks.
fn every_pixel_matches(scene: &str, width: u32, samples: u32) -> Vec<PixelExplanation> {
    every_pixel_of(load_file(scene.as_ref()), scene, width, samples)
}

/// [`every_pixel_matches`] for a loaded scene, named `scene` in messages.
fn every_pixel_of(mut loaded: Loaded, scene: &str, width: u32, samples: u32) -> Vec<PixelExplanation> {
    loaded.scene.image.samples = samples;
    let frame = render(&loaded, Some(width), 2);
    let mut image = loaded.scene.image;
    (image.width, image.height) = (frame.width, frame.height);
    let prepared = lancer_shading::prepare(&loaded.scene).unwrap();
    let beauty = &frame.beauty;
    let mut out = Vec::new();
    for y in 0..frame.height {
        for x in 0..frame.width {
            let e = explain_pixel(&prepared, &loaded.scene.camera, &image, &loaded.pipeline, x, y);
            let i = (y * frame.width + x) as usize;
            for (layer, (name, value)) in frame.layers.iter().zip(&e.layers) {
                assert_eq!(&layer.name, name);
                assert_eq!(
                    layer.pixels[i].to_array().map(f32::to_bits),
                    value.to_array().map(f32::to_bits),
                    "{scene} at {x},{y} ({samples} spp): {name}"
                );
            }
            assert_eq!(
                beauty[i].to_array().map(f32::to_bits),
                e.beauty.to_array().map(f32::to_bits),
                "{scene} at {x},{y}: beauty"
            );
            // The tree accounts for every layer: what its rays' terms added, each in the layer
            // it credits (a camera ray's term its own), and what misses saw.
            let mut sums = vec![Vec3::ZERO; e.layers.len()];
            for ray in &e.rays {
                for t in &ray.terms {
                    sums[ray.credit.unwrap_or(t.term)] += t.added;
                }
                if let Some(b) = ray.background {
                    sums[ray.credit.unwrap_or(e.layers.len() - 1)] += b;
                }
            }
            for (sum, (name, value)) in sums.iter().zip(&e.layers) {
                assert!(
                    (*sum - *value).abs().max_element() <= 1e-5 * value.abs().max_element().max(1.0),
                    "{scene} at {x},{y}: the tree's {name} adds to {sum}, the pixel holds {value}"
                );
            }
            let camera = e.rays.iter().filter(|r| r.parent.is_none()).count();
            assert_eq!(camera, samples as usize, "one camera ray per sample");
            out.push(e);
        }
    }
    out
}

#[test]
fn explained_pixels_hold_the_frames_values_to_the_bit() {
    let glass = every_pixel_matches("scenes/glass.toml", 40, 1);
    let refracted = glass.iter().filter(|e| e.rays.iter().any(|r| r.parent.is_some_and(|(_, t)| t == 4))).count();
    assert!(refracted > 50, "glass pixels explained: {refracted}");
    let mirrors = every_pixel_matches("scenes/mirrors.toml", 40, 1);
    let deep = mirrors.iter().filter(|e| e.rays.iter().any(|r| r.depth >= 3 && r.hit.is_some())).count();
    assert!(deep > 0, "mirror chains of depth 3 or more explained: {deep}");
    every_pixel_matches("scenes/showcase.toml", 32, 1);
    // Traced glass: the inner rays are in the tree, those that meet the cube from inside and
    // those that meet the ball inside it (object 3) after crossing into the cube (object 2).
    let inside = every_pixel_matches("scenes/ball-in-glass.toml", 40, 1);
    let inner = |e: &PixelExplanation| {
        e.rays.iter().any(|r| r.parent.is_some_and(|(_, t)| t == 4) && r.hit.as_ref().is_some_and(|h| !h.front))
    };
    let ball = |e: &PixelExplanation| {
        e.rays.iter().any(|r| {
            r.parent.is_some_and(|(p, t)| t == 4 && e.rays[p].hit.as_ref().is_some_and(|h| h.object == 2 && h.front))
                && r.hit.as_ref().is_some_and(|h| h.object == 3)
        })
    };
    assert!(inside.iter().filter(|e| inner(e)).count() > 50 && inside.iter().filter(|e| ball(e)).count() > 20);
    // 70 wide: two tiles to a band, the second 6 pixels wide, cut through its 8 x 8 cells.
    every_pixel_matches("scenes/shapes/torus.toml", 70, 1);
}

#[test]
fn explained_pixels_match_with_samples_that_straddle_waves() {
    // 17 samples: a 48×16 tile (tiles are 64×16, cut to the image) holds 13 056 samples, more
    // than three waves (4096 each), so a pixel's samples would be cut between waves if waves did
    // not keep them together.
    every_pixel_matches("scenes/showcase.toml", 48, 17);
}

/// Every traced light of every ray of `explained`: the transmittance explain prints, times the
/// light's `Col_L`, against the light arriving it prints (what the frame used), to the bit.
/// Returns (lights checked, lights that disagree, an example).
fn transmittance_disagreements(
    explained: &[PixelExplanation],
    lights: &[lancer_core::Light],
) -> (usize, usize, Option<String>) {
    let (mut checked, mut off, mut example) = (0, 0, None);
    for e in explained {
        for ray in &e.rays {
            for (k, l) in ray.lights.iter().enumerate().filter(|(_, l)| l.traced) {
                checked += 1;
                let product = lights[k].radiance() * l.transmittance;
                if product.to_array().map(f32::to_bits) != l.incoming.to_array().map(f32::to_bits) {
                    off += 1;
                    example.get_or_insert_with(|| {
                        format!(
                            "pixel {},{}: light {}: transmittance {} x Col_L = {product}, light arriving {}",
                            e.x,
                            e.y,
                            k + 1,
                            l.transmittance,
                            l.incoming
                        )
                    });
                }
            }
        }
    }
    (checked, off, example)
}

/// A floor that is a cube scaled 10⁶ (its top face at y = 0), a small cube, a glass ball and a
/// sphere on it, one light of side `size`.
fn huge_floor(shadows: &str, size: f32) -> String {
    format!(
        "[image]\nwidth = 40\nheight = 30\n[camera]\nfrom = [0, 4, -9]\nto = [0, 0, 0]\nfov = 50\n\
         [model]\nterms = [\"ambient\", \"diffuse\", \"refraction\"]\nshadows = \"{shadows}\"\n\
         [[lights]]\nat = [3, 8, -2]\nsize = {size:?}\n\
         [[objects]]\nshape = \"cube\"\nscale = 1e6\ntranslate = [0, -1e6, 0]\n\
         [[objects]]\nshape = \"cube\"\nscale = 0.7\ntranslate = [1.5, 0.7, 0]\n\
         [[objects]]\nshape = \"sphere\"\ntranslate = [-1.5, 1, 0.5]\n\
         [[objects]]\nshape = \"sphere\"\nscale = 0.8\ntranslate = [0, 0.8, -2]\n\
         material = {{ color = [0.9, 0.95, 1], diff = 0.1, alpha = 0.8, n = 1.5 }}\n"
    )
}

#[test]
fn regression_explain_prints_the_transmittance_the_frame_used() {
    // Explain asked the shadow model again, one ray at a time, for each hit and light; the
    // render asks it for blocks of hits, whose rays take other paths (the block tracer, through
    // a see-through object met alone; sample by sample for an area light), and the two need not
    // agree: on the floor scaled 10⁶ with transmissive or soft shadows, 100 of 1150 lights read
    // "transmittance 0" beside "light arriving 1".
    let mut report = Vec::new();
    let mut check = |scene: &str, explained: &[PixelExplanation], lights: &[lancer_core::Light]| {
        let (checked, off, example) = transmittance_disagreements(explained, lights);
        assert!(checked > 100, "{scene}: {checked} traced lights");
        if off > 0 {
            report.push(format!("{scene}: {off} of {checked} lights, e.g. {}", example.unwrap_or_default()));
        }
    };
    for (shadows, size) in [("transmissive", 0.0), ("soft", 0.0), ("soft", 1.5), ("hard", 0.0)] {
        let loaded = load(&huge_floor(shadows, size));
        let lights = lancer_shading::prepare(&loaded.scene).unwrap().lights;
        let scene = format!("the floor scaled 1e6, {shadows} shadows, a light of side {size}");
        check(&scene, &every_pixel_of(loaded, &scene, 40, 1), &lights);
    }
    for (scene, width) in [("scenes/soft-shadows.toml", 48), ("scenes/glass.toml", 40)] {
        let lights = lancer_shading::prepare(&load_file(scene.as_ref()).scene).unwrap().lights;
        check(scene, &every_pixel_matches(scene, width, 1), &lights);
    }
    assert!(report.is_empty(), "explain's transmittance x Col_L is not the light arriving:\n{}", report.join("\n"));
}

//! `explain_pixel` against the full render: every pixel's per-term values and beauty are the
//! frame's, to the bit, and its ray tree adds up to them.

use glam::Vec3;
use lancer_shading::{PixelExplanation, explain_pixel};
use lancer_tests::{load_file, render};

/// Explains every pixel of `scene` at `width` with `samples` and compares with the frame.
/// Returns the explanations for further checks.
fn every_pixel_matches(scene: &str, width: u32, samples: u32) -> Vec<PixelExplanation> {
    let mut loaded = load_file(scene.as_ref());
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

//! Adaptive anti-aliasing (`samples = { adaptive = T, depth = D }`) against what it promises:
//! which pixels are supersampled and their values found independently from plain one-sample
//! renders, and the same bits whatever the threads, the parts or a pixel explained alone.

use glam::Vec3;
use lancer_core::{Adaptive, Frame};
use lancer_scene::Loaded;
use lancer_tests::{load_file, render};

fn adaptive(path: &str, threshold: f32, depth: u32) -> Loaded {
    let mut loaded = load_file(path.as_ref());
    (loaded.scene.image.samples, loaded.scene.image.adaptive) = (1, Some(Adaptive { threshold, depth }));
    loaded
}

fn one_sample(path: &str) -> Loaded {
    let mut loaded = load_file(path.as_ref());
    (loaded.scene.image.samples, loaded.scene.image.adaptive) = (1, None);
    loaded
}

/// Every image of a frame (the beauty image, then the layers), bit for bit.
fn bits(f: &Frame) -> Vec<u32> {
    std::iter::once(&f.beauty)
        .chain(f.layers.iter().map(|l| &l.pixels))
        .flat_map(|px| px.iter().flat_map(|p| p.to_array().map(f32::to_bits)))
        .collect()
}

/// Which pixels of a `w` x `h` image whose one-sample beauty image is `first` the rule
/// supersamples, worked out here from the PNG bytes: those whose bytes differ from one of their
/// four neighbours' by `threshold` or more, summed over the channels, in steps of 1/255.
fn supersampled(first: &[Vec3], w: usize, h: usize, threshold: f32) -> Vec<bool> {
    let bytes: Vec<[u8; 3]> = first.iter().map(|p| p.to_array().map(lancer_core::srgb8)).collect();
    let differ = |a: usize, b: usize| {
        let steps: u32 = (0..3).map(|c| (bytes[a][c] as i32 - bytes[b][c] as i32).unsigned_abs()).sum();
        steps as f32 / 255.0 >= threshold
    };
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            (x > 0 && differ(i, i - 1))
                || (x + 1 < w && differ(i, i + 1))
                || (y > 0 && differ(i, i - w))
                || (y + 1 < h && differ(i, i + w))
        })
        .collect()
}

#[test]
fn a_supersampled_pixel_is_the_mean_of_its_centre_and_its_grid_the_others_keep_their_one_sample() {
    // A render three times as wide and high at one sample has its pixel centres exactly where
    // a depth-3 grid puts its samples: pixel (3x + i, 3y + j) is at (x + (i + ½)/3, y + (j + ½)/3).
    // 80 wide: two tiles to a band (64 and 16 pixels), three bands (16, 16 and 13 rows), so the
    // rule is checked across tile boundaries both ways.
    let (w, h, threshold) = (80usize, 45usize, 0.1);
    let path = "scenes/showcase.toml";
    let one = render(&one_sample(path), Some(w as u32), 1);
    let big = render(&one_sample(path), Some(3 * w as u32), 2);
    let aa = render(&adaptive(path, threshold, 3), Some(w as u32), 2);
    assert_eq!((one.width, one.height, big.width, big.height), (80, 45, 240, 135));
    let chosen = supersampled(&one.beauty, w, h, threshold);
    let count = chosen.iter().filter(|&&c| c).count();
    assert_eq!(aa.stats.supersampled, count as u64);
    assert!(count > w * h / 10 && count < w * h * 9 / 10, "{count} of {} pixels supersampled", w * h);
    let mut off_by_more = Vec::new();
    for (l, layer) in aa.layers.iter().enumerate() {
        for (i, got) in layer.pixels.iter().enumerate() {
            let first = one.layers[l].pixels[i];
            if !chosen[i] {
                assert_eq!(
                    got.to_array().map(f32::to_bits),
                    first.to_array().map(f32::to_bits),
                    "{} at {i}",
                    layer.name
                );
                continue;
            }
            let (x, y) = (i % w, i / w);
            let grid: Vec3 = (0..9).map(|k| big.layers[l].pixels[(3 * y + k / 3) * 3 * w + 3 * x + k % 3]).sum();
            let want = (first + grid) / 10.0;
            // The grid's directions are rounded apart from the big render's by an ulp or so.
            if (*got - want).abs().max_element() > 1e-4 * want.abs().max_element().max(1.0) {
                off_by_more.push((layer.name.clone(), x, y, *got, want));
            }
        }
    }
    assert!(off_by_more.is_empty(), "{} values off: {:?}", off_by_more.len(), &off_by_more[..off_by_more.len().min(5)]);
}

#[test]
fn adaptive_renders_are_the_same_bits_on_any_thread_count_in_parts_and_explained_alone() {
    // Depth 2 (five rays a supersampled pixel) and 3 (nine: the centre's stands for two samples).
    for (path, depth) in [("scenes/showcase.toml", 2), ("scenes/glass.toml", 3), ("scenes/meshes.toml", 2)] {
        let loaded = adaptive(path, 0.2, depth);
        let rays = if depth == 2 { 5 } else { 9 };
        let whole = render(&loaded, Some(72), 2);
        assert!(whole.stats.supersampled > 0, "{path}: nothing supersampled");
        assert!(bits(&render(&loaded, Some(72), 1)) == bits(&whole), "{path}: 1 and 2 threads differ");
        let mut image = loaded.scene.image;
        (image.width, image.height) = (whole.width, whole.height);
        let prepared = lancer_shading::prepare(&loaded.scene).unwrap();
        // Parts of interleaved bands, stacked (the browser's workers, `--tile I/3`): the bands'
        // pixels at their borders are compared with neighbours of other parts' bands.
        let row = whole.width as usize;
        for index in 0..3 {
            let options = lancer_shading::RenderOptions {
                layers: true,
                part: Some((index, 3)),
                compact: true,
                ..Default::default()
            };
            let part =
                lancer_shading::render_prepared(&prepared, &loaded.scene.camera, &image, &loaded.pipeline, options);
            let rows: Vec<u32> = lancer_shading::part_bands(whole.height, index, 3)
                .flat_map(|b| b * 16..((b + 1) * 16).min(whole.height))
                .collect();
            for (k, &y) in rows.iter().enumerate() {
                let (got, want) = (&part.beauty[k * row..(k + 1) * row], &whole.beauty[y as usize * row..][..row]);
                assert!(got == want, "{path}: part {index}/3, row {y}");
            }
        }
        // Every pixel explained alone holds the frame's values, with one camera ray or the
        // supersampled pixel's.
        let mut camera_rays = [0usize; 2];
        for y in 0..whole.height {
            for x in 0..whole.width {
                let e = lancer_shading::explain_pixel(&prepared, &loaded.scene.camera, &image, &loaded.pipeline, x, y);
                let i = (y * whole.width + x) as usize;
                for (layer, (_, value)) in whole.layers.iter().zip(&e.layers) {
                    assert_eq!(layer.pixels[i].to_array().map(f32::to_bits), value.to_array().map(f32::to_bits));
                }
                let n = e.rays.iter().filter(|r| r.parent.is_none()).count();
                assert!(n == 1 || n == rays, "{path} at {x},{y}: {n} camera rays");
                camera_rays[usize::from(n == rays)] += 1;
            }
        }
        assert_eq!(camera_rays[1] as u64, whole.stats.supersampled, "{path}: pixels explained as supersampled");
    }
}

#[test]
fn thresholds_at_the_ends_supersample_nothing_or_everything() {
    // At 3 only black beside white would differ enough: the glass scene has none, and its
    // image is the one-sample image's bits.
    let path = "scenes/glass.toml";
    let none = render(&adaptive(path, 3.0, 3), Some(64), 2);
    assert_eq!(none.stats.supersampled, 0);
    assert!(bits(&none) == bits(&render(&one_sample(path), Some(64), 2)));
    // At 0 every pixel differs enough from its neighbours (any difference is at least 0).
    let all = render(&adaptive(path, 0.0, 2), Some(64), 2);
    assert_eq!(all.stats.supersampled, (all.width * all.height) as u64);
}

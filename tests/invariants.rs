//! Invariants every render keeps: each term adds exactly its own image to the beauty image, the
//! beauty image is the same bits whether the per-term images are kept or not, the thread count
//! changes no bit, and nothing is NaN (the last three on every scene in `scenes/`); a compact part
//! holds the whole render's bands.

use lancer_tests::{load_file, render, render_with, scene_files};

/// `src` with its model's `terms = [...]` line replaced by `terms`.
fn with_terms(src: &str, terms: &[&str]) -> String {
    let list: Vec<String> = terms.iter().map(|t| format!("\"{t}\"")).collect();
    let replaced: Vec<String> = src
        .lines()
        .map(|l| if l.starts_with("terms = [") { format!("terms = [{}]", list.join(", ")) } else { l.to_owned() })
        .collect();
    assert!(replaced.iter().any(|l| l.starts_with("terms = [")), "the scene lists its terms");
    replaced.join("\n")
}

#[test]
fn each_term_adds_exactly_its_own_image_to_beauty() {
    // Rendering without a term takes exactly that term's image out of the beauty image: the
    // beauty image is the sum of what each term contributes, found by separate renders rather
    // than by adding the layers again. Camera-ray terms only, so removing one changes no other.
    let terms = ["ambient", "diffuse", "specular"];
    for scene in ["scenes/showcase.toml", "scenes/glass.toml", "scenes/coloured-lights.toml"] {
        let src = std::fs::read_to_string(lancer_tests::root().join(scene)).unwrap();
        let full = render(&lancer_tests::load(&with_terms(&src, &terms)), Some(64), 2);
        let beauty = &full.beauty;
        for k in terms {
            let rest: Vec<&str> = terms.iter().copied().filter(|t| *t != k).collect();
            let without = render(&lancer_tests::load(&with_terms(&src, &rest)), Some(64), 2).beauty;
            let layer = &full.layer(k).unwrap().pixels;
            for (i, ((b, w), l)) in beauty.iter().zip(&without).zip(layer).enumerate() {
                assert!((*b - *w - *l).abs().max_element() <= 1e-5, "{scene}: without {k}, pixel {i}");
            }
        }
    }
}

#[test]
fn no_render_has_a_nan_or_an_infinity() {
    for path in scene_files() {
        let frame = render(&load_file(&path), Some(80), 2);
        assert!(
            frame.layers.iter().all(|l| l.pixels.iter().all(|p| p.is_finite()))
                && frame.beauty.iter().all(|p| p.is_finite()),
            "{}: a NaN or infinity",
            path.display()
        );
    }
}

#[test]
fn the_thread_count_changes_no_bit() {
    for path in scene_files() {
        let loaded = load_file(&path);
        // Compared bit for bit (`==` on floats would let a 0 pass for a -0), the beauty image
        // and every layer.
        let bits = |f: &lancer_core::Frame| {
            let images = std::iter::once(&f.beauty).chain(f.layers.iter().map(|l| &l.pixels));
            images.flat_map(|px| px.iter().flat_map(|p| p.to_array().map(f32::to_bits))).collect::<Vec<u32>>()
        };
        let one = bits(&render(&loaded, Some(72), 1));
        let two = bits(&render(&loaded, Some(72), 2));
        let three = bits(&render_with(&loaded, Some(72), 3, false));
        assert!(one == two, "{}: renders differ across thread counts", path.display());
        assert!(one[..three.len()] == three[..], "{}: the beauty image differs on 3 threads", path.display());
    }
}

#[test]
fn the_beauty_image_is_the_sum_of_the_layers_and_the_same_bits_without_them() {
    // The render sums each tile's layers into the beauty image as it goes, and keeps the layers
    // only when asked: the same bits as summing the kept layers afterwards, on every scene.
    let bits = |px: &[glam::Vec3]| px.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<u32>>();
    for path in scene_files() {
        let loaded = load_file(&path);
        let with = render(&loaded, Some(72), 2);
        let without = render_with(&loaded, Some(72), 2, false);
        assert!(without.layers.is_empty() && !with.layers.is_empty(), "{}", path.display());
        let summed = lancer_core::Frame::from_layers(with.width, with.height, with.layers.clone(), Default::default());
        assert_eq!(bits(&with.beauty), bits(&summed.beauty), "{}: beauty is not the layers' sum", path.display());
        assert_eq!(bits(&with.beauty), bits(&without.beauty), "{}: beauty differs without layers", path.display());
    }
}

#[test]
fn the_terms_list_decides_which_images_exist() {
    let path = lancer_tests::root().join("scenes/showcase.toml");
    let src = std::fs::read_to_string(&path).unwrap();
    let only = src.replace(
        "terms = [\"ambient\", \"diffuse\", \"specular\", \"mirror\", \"refraction\"]",
        "terms = [\"diffuse\", \"ambient\"]",
    );
    assert_ne!(src, only, "the showcase lists the five terms");
    let full = render(&lancer_tests::load(&src), Some(64), 2);
    let two = render(&lancer_tests::load(&only), Some(64), 2);
    let names: Vec<&str> = two.layers.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["diffuse", "ambient", "background"]);
    // Camera-ray ambient and diffuse do not depend on which other terms run.
    assert!(full.layer("ambient") == two.layer("ambient"), "ambient depends on the other terms");
    assert!(full.layer("diffuse") == two.layer("diffuse"), "diffuse depends on the other terms");
    assert_ne!(full.beauty, two.beauty);
}

#[test]
fn regression_lanes_alive_at_once_grew_with_samples_per_pixel() {
    // A tile's camera rays were all generated at once (and every chunk kept the capacity of the
    // rays behind it): memory grew with the samples per pixel, and 4096 samples of a 16×9 image
    // were killed for memory. Now samples go in waves: the most lanes alive at once stays put.
    let src = std::fs::read_to_string(lancer_tests::root().join("scenes/showcase.toml")).unwrap();
    let peak = |spp: u32| {
        let mut loaded = lancer_tests::load(&src);
        (loaded.scene.image.width, loaded.scene.image.height, loaded.scene.image.samples) = (16, 9, spp);
        render(&loaded, None, 2).stats.peak_lanes
    };
    let (p16, p1024) = (peak(16), peak(1024));
    // 16 × 9 × 16 = 2304 camera rays fit in one wave; 1024 samples are 147,456 camera rays.
    assert!(p16 >= 2304, "{p16}");
    let bound = 2 * lancer_shading::WAVE as u64;
    assert!(p1024 <= bound, "{p1024} lanes alive at once at 1024 samples (bound {bound})");
}

#[test]
fn a_compact_part_holds_its_bands_of_the_whole_render_one_under_the_other() {
    // What the browser build's workers render: every k-th band of 16 rows, stacked. 150 rows
    // make ten bands, the last 6 rows high, so parts that hold it end with a short band.
    let loaded = load_file(std::path::Path::new("scenes/showcase.toml"));
    let mut image = loaded.scene.image;
    (image.width, image.height, image.samples) = (96, 150, 2);
    let prepared = lancer_shading::prepare(&loaded.scene).unwrap();
    let render = |part, compact| {
        let options = lancer_shading::RenderOptions { layers: true, part, compact, ..Default::default() };
        lancer_shading::render_prepared(&prepared, &loaded.scene.camera, &image, &loaded.pipeline, options)
    };
    let whole = render(None, false);
    let row_len = 96 * 3;
    let rows_of = |pixels: &[glam::Vec3]| -> Vec<Vec<u32>> {
        let bits: Vec<u32> = pixels.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect();
        bits.chunks(row_len).map(<[u32]>::to_vec).collect()
    };
    for (index, count) in [(0, 1), (0, 3), (1, 3), (2, 3), (9, 10), (4, 7)] {
        let part = render(Some((index, count)), true);
        let bands: Vec<u32> = lancer_shading::part_bands(150, index, count).collect();
        let expected_rows: Vec<u32> = bands.iter().flat_map(|b| b * 16..((b + 1) * 16).min(150)).collect();
        assert_eq!(part.height as usize, expected_rows.len(), "part {index}/{count}");
        assert_eq!(part.layers.len(), whole.layers.len());
        for (got, want) in std::iter::once((&part.beauty, &whole.beauty))
            .chain(part.layers.iter().map(|l| &l.pixels).zip(whole.layers.iter().map(|l| &l.pixels)))
        {
            let (got, want) = (rows_of(got), rows_of(want));
            for (k, &y) in expected_rows.iter().enumerate() {
                assert_eq!(got[k], want[y as usize], "part {index}/{count}: its row {k} is the image's row {y}");
            }
        }
        assert!(part.stats.camera_rays > 0);
    }
}

#[test]
fn scratch_buffers_kept_between_renders_change_no_bit() {
    // A browser worker renders band after band with the same kept buffers, and the studio
    // renders coarse then full, with other models in between: every render must be the bits of
    // one made with fresh buffers.
    let kept = lancer_shading::Scratches::default();
    let bits = |f: &lancer_core::Frame| -> Vec<u32> {
        std::iter::once(&f.beauty)
            .chain(f.layers.iter().map(|l| &l.pixels))
            .flat_map(|p| p.iter().flat_map(|v| v.to_array().map(f32::to_bits)))
            .collect()
    };
    for round in 0..2 {
        // (0 samples: adaptive anti-aliasing, whose scratch holds a tile and its border.)
        for (scene, samples) in [
            ("scenes/glass.toml", 1),
            ("scenes/showcase.toml", 2),
            ("scenes/meshes.toml", 1),
            ("scenes/showcase.toml", 0),
        ] {
            let loaded = load_file(std::path::Path::new(scene));
            let mut image = loaded.scene.image;
            (image.width, image.height) = (80, 50);
            match samples {
                0 => image.set_adaptive(lancer_core::Adaptive { threshold: 0.1, depth: 2 }),
                n => image.set_samples(n),
            }
            let prepared = lancer_shading::prepare(&loaded.scene).unwrap();
            // The scene's model, and its first two terms alone (buffers for fewer layers).
            let mut fewer = load_file(std::path::Path::new(scene)).pipeline;
            fewer.terms.truncate(2);
            for pipeline in [&loaded.pipeline, &fewer] {
                let render = |part, scratch| {
                    let options = lancer_shading::RenderOptions {
                        layers: true,
                        part,
                        compact: part.is_some(),
                        scratch,
                        ..Default::default()
                    };
                    lancer_shading::render_prepared(&prepared, &loaded.scene.camera, &image, pipeline, options)
                };
                for part in [None, Some((0, 4)), Some((3, 4))] {
                    assert_eq!(
                        bits(&render(part, Some(&kept))),
                        bits(&render(part, None)),
                        "{scene}, round {round}, {} terms, part {part:?}: kept buffers changed the image",
                        pipeline.terms.len()
                    );
                }
            }
        }
    }
}

//! insta snapshots of every scene in `scenes/` at a small size: one PNG per term image plus the
//! beauty image, and a text table of per-term statistics. Adding a scene adds its snapshots;
//! review changes with `cargo insta review`. CI (`CI=true`) refuses unreviewed snapshots.

use std::fmt::Write;

use lancer_tests::{load_file, render};

/// Snapshot width; the height keeps each scene's aspect ratio.
const WIDTH: u32 = 96;

#[test]
fn per_term_images_of_every_scene() {
    insta::glob!("../scenes", "**/*.toml", |path| {
        // One sample a pixel whatever the scene asks (a few, for a smooth picture): the
        // snapshots are of the model, not of the anti-aliasing, and stay as cheap as they were.
        let mut loaded = load_file(path);
        loaded.scene.image.samples = 1;
        let frame = render(&loaded, Some(WIDTH), 2);
        let beauty = &frame.beauty;
        let png = |px: &[glam::Vec3]| lancer_cli::output::encode_png(frame.width, frame.height, px).unwrap();

        let lum = |p: &glam::Vec3| 0.2126 * p.x as f64 + 0.7152 * p.y as f64 + 0.0722 * p.z as f64;
        let total: f64 = beauty.iter().map(lum).sum();
        let mut stats = format!(
            "{}x{}\n{:<12} {:>26} {:>10} {:>8}\n",
            frame.width, frame.height, "image", "mean rgb", "max", "share"
        );
        for (name, px) in frame.layers.iter().map(|l| (l.name.as_str(), &l.pixels[..])).chain([("beauty", &beauty[..])])
        {
            let n = px.len() as f64;
            let mean = px
                .iter()
                .fold([0.0f64; 3], |m, p| [m[0] + p.x as f64 / n, m[1] + p.y as f64 / n, m[2] + p.z as f64 / n]);
            let max = px.iter().map(|p| p.max_element()).fold(0.0f32, f32::max);
            let share = if total > 0.0 { px.iter().map(lum).sum::<f64>() / total } else { 0.0 };
            let _ = writeln!(
                stats,
                "{name:<12} {:>8.5} {:>8.5} {:>8.5} {max:>10.5} {:>7.2}%",
                mean[0],
                mean[1],
                mean[2],
                100.0 * share
            );
            insta::assert_binary_snapshot!(&format!("{name}.png"), png(px));
        }
        insta::assert_snapshot!("stats", stats);
    });
}

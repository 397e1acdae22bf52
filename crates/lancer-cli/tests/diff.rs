//! `lancer diff` as a student or an autograder runs it: images written here in every format it
//! reads (with analytic values), each named mismatch made on purpose and found, the exit codes,
//! bad input (a located error, nothing written), heatmaps, JSON, and two `--aov` folders.

use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::{files, lancer, stderr, stdout};

use glam::Vec3;
use lancer_core::srgb_decode;

const W: u32 = 32;
const H: u32 = 24;

/// Reproducible noise in linear values in [0, 1): every pixel unlike its neighbours, so no
/// transform of it looks like another.
fn noise(seed: u32) -> Vec<Vec3> {
    let mut s = seed.wrapping_mul(0x9E37_79B9) | 1;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        (s >> 8) as f32 / (1 << 24) as f32
    };
    (0..W * H).map(|_| Vec3::new(next(), next(), next())).collect()
}

/// A W × H image of `f(x, y)`.
fn grid(f: impl Fn(u32, u32) -> Vec3) -> Vec<Vec3> {
    (0..H).flat_map(|y| (0..W).map(move |x| (x, y))).map(|(x, y)| f(x, y)).collect()
}

/// An 8-bit sRGB PNG of linear values, as Lancer writes one.
fn png(path: &Path, w: u32, h: u32, linear: &[Vec3]) {
    image::RgbImage::from_raw(w, h, lancer_cli::output::to_srgb8(linear)).unwrap().save(path).unwrap();
}

/// An 8-bit PNG of these stored bytes.
fn png_bytes(path: &Path, w: u32, h: u32, bytes: Vec<u8>) {
    image::RgbImage::from_raw(w, h, bytes).unwrap().save(path).unwrap();
}

/// A linear OpenEXR, as Lancer writes one.
fn exr(path: &Path, w: u32, h: u32, linear: &[Vec3]) {
    std::fs::write(path, lancer_cli::output::encode_exr(w, h, linear).unwrap()).unwrap();
}

fn diff(dir: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["diff", "a.png", "b.png"];
    args.extend(extra);
    lancer(dir, &args)
}

/// The `looks like:` line of a report.
fn looks_like(o: &Output) -> String {
    let out = stdout(o);
    out.lines().find(|l| l.trim_start().starts_with("looks like:")).map(str::to_owned).unwrap_or_else(|| {
        panic!("no `looks like:` line in\n{out}{}", stderr(o));
    })
}

/// A pair of images written as a.png and b.png in a new folder: A noise, B `b` of it.
fn pair(b: impl Fn(&[Vec3]) -> Vec<Vec3>) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let a = noise(1);
    png(&dir.path().join("a.png"), W, H, &a);
    png(&dir.path().join("b.png"), W, H, &b(&a));
    dir
}

#[test]
fn identical_images_exit_0_across_formats() {
    let dir = pair(|a| a.to_vec());
    let o = diff(dir.path(), &[]);
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
    assert!(stdout(&o).contains("identical") && stdout(&o).contains("result: identical (exit 0)"), "{}", stdout(&o));
    // The same bytes as a binary PPM: the same values.
    let bytes = image::open(dir.path().join("a.png")).unwrap().into_rgb8().into_raw();
    let mut ppm = format!("P6\n# written by a student's renderer\n{W} {H}\n255\n").into_bytes();
    ppm.extend(&bytes);
    std::fs::write(dir.path().join("a.ppm"), ppm).unwrap();
    let o = lancer(dir.path(), &["diff", "a.ppm", "a.png"]);
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
    assert!(stdout(&o).starts_with(&format!("A: a.ppm (PPM P6, maximum 255, {W}x{H})")), "{}", stdout(&o));
}

#[test]
fn ppm_p3_p6_pgm_and_16_bit_png_read_the_values_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // P3 at maximum 15 with comments, against an EXR of the linear values those samples mean.
    let v15 = |x: u32, y: u32, c: u32| (x * 7 + y * 13 + c * 5) % 16;
    let mut p3 = format!("P3\n# ASCII, as a C course writes it\n{W} {H} # size\n15\n");
    for y in 0..H {
        for x in 0..W {
            p3 += &format!("{} {} {}\n", v15(x, y, 0), v15(x, y, 1), v15(x, y, 2));
        }
    }
    std::fs::write(d.join("a.ppm"), p3).unwrap();
    let linear = grid(|x, y| Vec3::from_array([0, 1, 2].map(|c| srgb_decode(v15(x, y, c) as f32 / 15.0))));
    exr(&d.join("a.exr"), W, H, &linear);
    let o = lancer(d, &["diff", "a.ppm", "a.exr", "--json"]);
    let report: serde_json::Value = serde_json::from_str(&stdout(&o)).expect("JSON");
    let max = report["max_abs_error"].as_f64().unwrap();
    assert!(report["identical"] == true || max < 1e-5, "the P3 is read as the EXR's values: {report}");
    assert_eq!(report["a_format"], "PPM P3, maximum 15");
    // P6 with two-byte samples against a 16-bit PNG of the same values: identical.
    let v16 = |x: u32, y: u32, c: u32| ((x * 4099 + y * 257 + c * 9973) % 65536) as u16;
    let mut p6 = format!("P6 {W} {H} 65535\n").into_bytes();
    let mut samples = Vec::new();
    for y in 0..H {
        for x in 0..W {
            for c in 0..3 {
                p6.extend(v16(x, y, c).to_be_bytes());
                samples.push(v16(x, y, c));
            }
        }
    }
    std::fs::write(d.join("deep.ppm"), p6).unwrap();
    image::ImageBuffer::<image::Rgb<u16>, _>::from_raw(W, H, samples).unwrap().save(d.join("deep.png")).unwrap();
    let o = lancer(d, &["diff", "deep.ppm", "deep.png"]);
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
    assert!(stdout(&o).contains("B: deep.png (PNG 16-bit RGB"), "{}", stdout(&o));
    // A 16-bit value is read to 1/65535, not to 8 bits: one step off is seen.
    let mut near = image::open(d.join("deep.png")).unwrap().into_rgb16();
    near.get_pixel_mut(3, 2).0[1] ^= 1;
    near.save(d.join("near.png")).unwrap();
    let o = lancer(d, &["diff", "deep.ppm", "near.png", "--json"]);
    let report: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert!((report["max_abs_error"].as_f64().unwrap() - 1.0 / 65535.0).abs() < 1e-7, "{report}");
    assert_eq!(report["max_abs_error_at"], serde_json::json!([3, 2]));
    // Grey: P2 and P5 at maximum 1000 hold the same values.
    let g = |x: u32, y: u32| (x * 31 + y * 17) % 1001;
    let mut p2 = format!("P2\n{W} {H}\n1000\n");
    let mut p5 = format!("P5\n{W} {H}\n1000\n").into_bytes();
    for y in 0..H {
        for x in 0..W {
            p2 += &format!("{} ", g(x, y));
            p5.extend((g(x, y) as u16).to_be_bytes());
        }
    }
    std::fs::write(d.join("g2.pgm"), p2).unwrap();
    std::fs::write(d.join("g5.pgm"), p5).unwrap();
    let o = lancer(d, &["diff", "g2.pgm", "g5.pgm"]);
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
}

#[test]
fn exit_codes_are_0_pass_1_differ_2_bad_input() {
    // B: A with every tenth pixel's red one 8-bit step up and one pixel's blue 3 steps.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = image::RgbImage::from_raw(W, H, lancer_cli::output::to_srgb8(&noise(2))).unwrap();
    let mut b = a.clone();
    for (i, p) in b.pixels_mut().enumerate() {
        if i % 10 == 0 {
            p.0[0] = if p.0[0] < 255 { p.0[0] + 1 } else { 254 };
        }
    }
    let p = b.get_pixel_mut(5, 5);
    p.0[2] = if p.0[2] > 128 { p.0[2] - 3 } else { p.0[2] + 3 };
    a.save(d.join("a.png")).unwrap();
    b.save(d.join("b.png")).unwrap();
    let code = |extra: &[&str]| diff(d, extra).status.code();
    assert_eq!(code(&[]), Some(1), "no threshold: differ");
    assert_eq!(code(&["--min-psnr", "40"]), Some(0));
    assert_eq!(code(&["--min-psnr", "80"]), Some(1));
    assert_eq!(code(&["--max-error", "3/255"]), Some(0));
    assert_eq!(code(&["--max-error", "2/255"]), Some(1));
    assert_eq!(code(&["--max-flip", "0.5"]), Some(0));
    assert_eq!(code(&["--max-flip", "0.5", "--min-psnr", "80"]), Some(1), "every threshold must be met");
    let o = diff(d, &["--min-psnr", "80"]);
    assert!(
        stdout(&o).contains("result: fail: PSNR") && stdout(&o).contains("is under --min-psnr 80"),
        "{}",
        stdout(&o)
    );
    // Only one pixel is off by more than the default tolerance of one 8-bit step.
    assert!(
        stdout(&diff(d, &[])).contains("(1 of 768) have a channel off by more than 1/255"),
        "{}",
        stdout(&diff(d, &[]))
    );
    // Bad input: a missing file, a folder against a file, flags out of range (clap's 2).
    assert_eq!(lancer(d, &["diff", "a.png", "missing.png"]).status.code(), Some(2));
    std::fs::create_dir(d.join("folder")).unwrap();
    let o = lancer(d, &["diff", "folder", "a.png"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("folder is a folder and a.png a file"), "{}", stderr(&o));
    assert_eq!(code(&["--tolerance", "2"]), Some(2));
}

#[test]
fn bad_input_names_the_file_and_what_was_expected_and_writes_no_heatmap() {
    let dir = pair(|a| a.to_vec());
    let d = dir.path();
    let before = files(d);
    let run = |b: &str, bytes: &[u8]| {
        std::fs::write(d.join(b), bytes).unwrap();
        let o = lancer(d, &["diff", "a.png", b, "--heatmap", "heat.png"]);
        assert_eq!(o.status.code(), Some(2), "{b}: {}", stderr(&o));
        let mut want = before.clone();
        want.push(b.to_owned());
        want.sort();
        assert_eq!(files(d), want, "no heatmap, no temporary file");
        std::fs::remove_file(d.join(b)).unwrap();
        stderr(&o)
    };
    let truncated = run("b.ppm", b"P6\n2 2\n255\n\x01\x02\x03\x04\x05\x06\x07");
    assert!(
        truncated.starts_with("error: b.ppm: byte 18: the pixels end early (the file is truncated): a 2x2 PPM with maximum value 255 holds 12 bytes of pixels, the file has 7"),
        "{truncated}"
    );
    let maxval = run("b.ppm", b"P6\n# by hand\n2 2 70000\n");
    assert!(
        maxval.starts_with("error: b.ppm: byte 17: expected the maximum value, a number from 1 to 65535"),
        "{maxval}"
    );
    let unknown = run("b.jpg", b"\xff\xd8\xff\xe0 not a PNG");
    assert!(unknown.starts_with("error: b.jpg: unknown image format"), "{unknown}");
    assert!(unknown.contains("expected a PNG, OpenEXR, PPM (P3, P6) or PGM (P2, P5) image"), "{unknown}");
    // A heatmap that is not a PNG is refused before anything is read.
    let o = lancer(d, &["diff", "a.png", "b.png", "--heatmap", "heat.jpg"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("give a file name ending in .png"), "{}", stderr(&o));
    assert_eq!(files(d), before);
}

#[test]
fn rows_upside_down_are_named() {
    let dir = pair(|a| grid(|x, y| a[((H - 1 - y) * W + x) as usize]));
    let o = diff(dir.path(), &[]);
    assert_eq!(o.status.code(), Some(1));
    let line = looks_like(&o);
    assert!(
        line.contains("looks like: the rows are upside down (identical once flipped): B is A flipped vertically"),
        "{line}"
    );
}

#[test]
fn linear_values_written_without_the_srgb_curve_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let a = noise(3);
    png(&dir.path().join("a.png"), W, H, &a);
    // The student's PNG holds the linear values themselves.
    let raw: Vec<u8> = a.iter().flat_map(|p| p.to_array()).map(|c| (c * 255.0).round() as u8).collect();
    png_bytes(&dir.path().join("b.png"), W, H, raw);
    let line = looks_like(&diff(dir.path(), &[]));
    assert!(line.contains("the sRGB curve is missing") && line.contains("once B is encoded"), "{line}");
}

#[test]
fn encoded_values_saved_as_linear_exr_are_named_as_the_curve_applied_twice() {
    let dir = tempfile::tempdir().unwrap();
    let a = noise(4);
    png(&dir.path().join("a.png"), W, H, &a);
    let encoded: Vec<Vec3> =
        a.iter().map(|p| Vec3::from_array(p.to_array().map(lancer_cli::output::srgb_encode))).collect();
    exr(&dir.path().join("b.exr"), W, H, &encoded);
    let line = looks_like(&lancer(dir.path(), &["diff", "a.png", "b.exr"]));
    assert!(line.contains("the sRGB curve is applied once too often"), "{line}");
}

#[test]
fn a_constant_factor_is_named_with_its_value() {
    let dir = pair(|a| a.iter().map(|p| *p * 0.5).collect());
    let o = diff(dir.path(), &["--json"]);
    let report: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let first = &report["looks_like"][0];
    assert_eq!(first["kind"], "factor", "{report}");
    assert!((first["factor"].as_f64().unwrap() - 0.5).abs() < 0.01, "{first}");
    let line = looks_like(&diff(dir.path(), &[]));
    assert!(line.contains("B is A times 0.50"), "{line}");
}

#[test]
fn channels_in_bgr_order_are_named() {
    let dir = pair(|a| a.iter().map(|p| Vec3::new(p.z, p.y, p.x)).collect());
    let line = looks_like(&diff(dir.path(), &[]));
    assert!(
        line.contains("looks like: the channels are in BGR order (identical once reordered): red and blue swapped"),
        "{line}"
    );
}

#[test]
fn a_half_pixel_shift_is_named_with_its_direction() {
    // B(x, y) = A(x + 0.5, y): the mean of each pixel and the next, in linear values.
    let dir = pair(|a| {
        let at = |x: u32, y: u32| a[(y * W + x.min(W - 1)) as usize];
        grid(|x, y| (at(x, y) + at(x + 1, y)) * 0.5)
    });
    let line = looks_like(&diff(dir.path(), &[]));
    assert!(
        line.contains("looks like: B is A shifted half a pixel to the left (PSNR") && line.contains("A(x + 0.5, y)"),
        "{line}"
    );
}

#[test]
fn a_whole_pixel_shift_is_named_with_its_direction() {
    // B(x, y) = A(x, y - 1): the picture one row down.
    let dir = pair(|a| grid(|x, y| a[(y.saturating_sub(1) * W + x) as usize]));
    let line = looks_like(&diff(dir.path(), &[]));
    assert!(
        line.contains("looks like: B is A moved one pixel down (identical once moved back): B(x, y) = A(x, y - 1)"),
        "{line}"
    );
}

#[test]
fn different_sizes_are_named_with_both_sizes_and_always_differ() {
    let dir = tempfile::tempdir().unwrap();
    png(&dir.path().join("a.png"), W, H, &noise(5));
    let big: Vec<Vec3> = (0..4 * W * H).map(|_| Vec3::splat(0.5)).collect();
    png(&dir.path().join("b.png"), 2 * W, 2 * H, &big);
    let o = diff(dir.path(), &["--min-psnr", "0", "--heatmap", "heat.png"]);
    assert_eq!(o.status.code(), Some(1));
    let out = stdout(&o);
    assert!(out.contains("sizes differ    A is 32x24, B is 64x48: B is exactly 2 times A's size each way"), "{out}");
    assert!(out.contains("no heatmap: the sizes differ"), "{out}");
    assert!(!dir.path().join("heat.png").exists());
}

#[test]
fn unrelated_images_name_no_mismatch() {
    let dir = tempfile::tempdir().unwrap();
    png(&dir.path().join("a.png"), W, H, &noise(6));
    png(&dir.path().join("b.png"), W, H, &noise(7));
    let o = diff(dir.path(), &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(!stdout(&o).contains("looks like"), "{}", stdout(&o));
}

#[test]
fn the_heatmap_shows_where_the_images_differ_with_a_legend_under_it() {
    // B: A with a bright 4x4 patch at (20, 8).
    let patch = |x: u32, y: u32| (20..24).contains(&x) && (8..12).contains(&y);
    let dir = tempfile::tempdir().unwrap();
    let a = grid(|x, _| Vec3::splat(0.1 + 0.01 * x as f32));
    png(&dir.path().join("a.png"), W, H, &a);
    png(&dir.path().join("b.png"), W, H, &grid(|x, y| if patch(x, y) { Vec3::ONE } else { a[(y * W + x) as usize] }));
    for of in ["flip", "abs"] {
        let o = diff(dir.path(), &["--heatmap", "heat.png", "--heatmap-of", of]);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert_eq!(files(dir.path()), ["a.png", "b.png", "heat.png"], "no temporary file left");
        let heat = image::open(dir.path().join("heat.png")).unwrap().into_rgb8();
        assert!(heat.width() >= W && heat.height() > H + 20, "a legend under the image: {:?}", heat.dimensions());
        let left = (heat.width() - W) / 2;
        let none = image::Rgb([0u8, 0, 4]);
        assert_ne!(*heat.get_pixel(left + 21, 9), none, "{of}: the patch shows");
        assert_eq!(*heat.get_pixel(left + 2, 20), none, "{of}: far from it, no error");
        // The legend's bar runs through the colour map under the image: dark at its left.
        let bar: Vec<_> =
            (0..heat.width()).map(|x| *heat.get_pixel(x, H + 12)).filter(|p| p.0 != [24, 24, 24]).collect();
        assert_eq!(bar.first(), Some(&none), "{of}");
        std::fs::remove_file(dir.path().join("heat.png")).unwrap();
    }
}

#[test]
fn json_reports_every_measure_and_the_worst_region() {
    let patch = |x: u32, y: u32| (4..7).contains(&x) && (18..21).contains(&y);
    let dir = pair(|a| grid(|x, y| if patch(x, y) { Vec3::ZERO } else { a[(y * W + x) as usize] }));
    let o = diff(dir.path(), &["--json"]);
    assert_eq!(o.status.code(), Some(1));
    let r: serde_json::Value = serde_json::from_str(&stdout(&o)).expect("JSON");
    assert_eq!(r["exit_code"], 1);
    assert_eq!(r["verdict"], "differ");
    assert!(r["psnr_db"].as_f64().unwrap() > 10.0);
    let flip = r["mean_flip"].as_f64().unwrap();
    assert!(flip > 0.0 && flip < 0.2, "{flip}");
    assert_eq!(r["pixels_over_tolerance"].as_u64(), Some(9));
    let worst = &r["worst_region"];
    assert_eq!((worst["x"].as_u64(), worst["y"].as_u64()), (Some(0), Some(16)), "{worst}");
    let px = (worst["pixel"][0].as_u64().unwrap() as u32, worst["pixel"][1].as_u64().unwrap() as u32);
    assert!(patch(px.0, px.1), "{px:?}");
    assert_eq!(worst["explain"], format!("lancer explain SCENE --width {W} --height {H} --pixel {},{}", px.0, px.1));
}

#[test]
fn the_worst_pixel_comes_with_a_lancer_explain_command_that_runs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "..", "scenes", "showcase.toml"].iter().collect();
    let scene = scene.canonicalize().unwrap().display().to_string();
    let o = lancer(d, &["render", &scene, "--width", "48", "-q", "-o", "a.png"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut b = image::open(d.join("a.png")).unwrap().into_rgb8();
    for (x, y) in [(30, 10), (31, 10), (30, 11), (31, 11)] {
        b.put_pixel(x, y, image::Rgb([255, 0, 255]));
    }
    b.save(d.join("b.png")).unwrap();
    let o = lancer(d, &["diff", "a.png", "b.png", "--scene", &scene]);
    let out = stdout(&o);
    let command =
        out.lines().map(str::trim).find(|l| l.starts_with("lancer explain ")).unwrap_or_else(|| panic!("{out}"));
    let args: Vec<&str> = command.split_whitespace().skip(1).collect();
    assert_eq!(args[..6], ["explain", scene.as_str(), "--width", "48", "--height", "27"], "{command}");
    assert!(["30,10", "31,10", "30,11", "31,11"].contains(&args[7]), "{command}");
    let o = lancer(d, &args);
    assert!(o.status.success() && !o.stdout.is_empty(), "{command}: {}", stderr(&o));
}

/// Copies the files of `from` into a new folder `to`.
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir(to).unwrap();
    for f in files(from) {
        std::fs::copy(from.join(&f), to.join(&f)).unwrap();
    }
}

#[test]
fn aov_folders_are_compared_term_by_term() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = lancer(d, &["render", "--width", "40", "-q", "-o", "a.png", "--aov", "a"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (w, h) = image::image_dimensions(d.join("a.png")).unwrap();
    copy_dir(&d.join("a"), &d.join("same"));
    let o = lancer(d, &["diff", "a", "same"]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
    let pairs = files(&d.join("a")).iter().filter(|f| f.ends_with(".png") || f.ends_with(".exr")).count();
    assert!(stdout(&o).contains(&format!("result: identical: all {pairs} pairs (exit 0)")), "{}", stdout(&o));
    // B: the diffuse PNG upside down, the mirror EXR missing, an extra image.
    copy_dir(&d.join("a"), &d.join("b"));
    let diffuse = image::open(d.join("a/diffuse.png")).unwrap().flipv();
    diffuse.save(d.join("b/diffuse.png")).unwrap();
    std::fs::remove_file(d.join("b/mirror.exr")).unwrap();
    std::fs::copy(d.join("a/ambient.png"), d.join("b/extra.png")).unwrap();
    let o = lancer(d, &["diff", "a", "b", "--heatmap", "heat"]);
    assert_eq!(o.status.code(), Some(1), "{}{}", stdout(&o), stderr(&o));
    let out = stdout(&o);
    assert!(out.contains(&format!("ambient.exr: identical (OpenEXR float RGB, linear, {w}x{h})")), "{out}");
    let diffuse = out.split("diffuse.png: differ").nth(1).unwrap_or_else(|| panic!("{out}"));
    let diffuse = diffuse.split("\nmirror").next().unwrap();
    assert!(diffuse.contains("looks like: the rows are upside down"), "{out}");
    assert!(out.contains("only in a: mirror.exr") && out.contains("only in b: extra.png"), "{out}");
    assert!(
        out.contains(&format!("result: differ: 1 of {} pairs differ, 2 files are in one folder only", pairs - 1)),
        "{out}"
    );
    assert!(!out.contains("manifest.json"), "Lancer's manifest is not an image to compare: {out}");
    let heat = files(&d.join("heat"));
    assert!(heat.contains(&"diffuse-png.png".to_owned()) && heat.contains(&"ambient-exr.png".to_owned()), "{heat:?}");
    // A broken file in one folder: exit 2, it is named, and no heatmap folder is made.
    std::fs::write(d.join("b/specular.png"), b"\x89PNG\r\n\x1a\nbut no more").unwrap();
    let o = lancer(d, &["diff", "a", "b", "--heatmap", "heat2", "--json"]);
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(stderr(&o).contains("error: b/specular.png: not a readable PNG file"), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_str(&stdout(&o)).expect("JSON even so");
    assert_eq!(report["exit_code"], 2);
    assert!(!d.join("heat2").exists());
}

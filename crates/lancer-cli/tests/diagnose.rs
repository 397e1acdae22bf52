//! `lancer diagnose` as a teacher or an autograder runs it: for each classic mistake of the
//! catalogue, an image rendered with it (by `lancer render`, at 96×54, written here as PNG, EXR
//! or PPM) is diagnosed as that mistake; right renders are `correct`, also once disturbed by
//! another renderer's rounding; `--term`, `--aov` and `--json`; and each kind of bad input is a
//! clear message with exit code 2.

use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::{lancer, stderr, stdout};

fn scene(name: &str) -> String {
    let p: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "..", "scenes", name].iter().collect();
    p.display().to_string()
}

/// Renders `scene_name` at 96×54 into `dir/file` with the extra flags (a mistake's).
fn render(dir: &Path, scene_name: &str, file: &str, extra: &[&str]) {
    let s = scene(scene_name);
    let mut args = vec!["render", s.as_str(), "--width", "96", "-q", "-o", file];
    args.extend(extra);
    let o = lancer(dir, &args);
    assert!(o.status.success(), "render {scene_name} {extra:?}: {}", stderr(&o));
}

/// `lancer diagnose SCENE --image FILE` plus `extra`.
fn diagnose(dir: &Path, scene_name: &str, file: &str, extra: &[&str]) -> Output {
    let s = scene(scene_name);
    let mut args = vec!["diagnose", s.as_str(), "--image", file];
    args.extend(extra);
    lancer(dir, &args)
}

/// The image rendered with `mistake`'s flags is diagnosed as `name`: the first line, the exit
/// code, the hint.
fn recognised(name: &str, scene_name: &str, mistake: &[&str], file: &str) {
    let dir = tempfile::tempdir().unwrap();
    render(dir.path(), scene_name, file, mistake);
    let o = diagnose(dir.path(), scene_name, file, &[]);
    let out = stdout(&o);
    assert_eq!(
        out.lines().next(),
        Some(format!("verdict: {name}").as_str()),
        "{scene_name} {mistake:?}:\n{out}{}",
        stderr(&o)
    );
    assert_eq!(o.status.code(), Some(1), "{out}");
    assert!(out.contains("\nhint: ") && out.contains("\nwhat it is: "), "{out}");
    assert!(out.contains(&format!("  {name} ")) && out.contains("(explains it)"), "{out}");
}

#[test]
fn specular_exponent_shine_is_recognised() {
    recognised(
        "specular:exponent-shine",
        "terms/specular.toml",
        &["--terms", "ambient,diffuse,specular:exponent-shine"],
        "s.png",
    );
}

#[test]
fn specular_sign_is_recognised() {
    recognised("specular:sign", "terms/specular.toml", &["--terms", "ambient,diffuse,specular:sign"], "s.exr");
}

#[test]
fn diffuse_no_clamp_is_recognised() {
    recognised("diffuse:no-clamp", "terms/diffuse.toml", &["--terms", "ambient,diffuse:no-clamp"], "s.png");
}

#[test]
fn mirror_sign_is_recognised() {
    recognised("mirror:sign", "terms/mirror.toml", &["--terms", "ambient,diffuse,specular,mirror:sign"], "s.png");
}

#[test]
fn refraction_sign_trap_is_recognised() {
    let terms = "ambient,diffuse,specular,mirror,refraction:sign-trap";
    recognised("refraction:sign-trap", "glass.toml", &["--terms", terms], "s.png");
}

#[test]
fn refraction_inverted_index_is_recognised() {
    let terms = "ambient,diffuse,specular,mirror,refraction:inverted-index";
    recognised("refraction:inverted-index", "glass.toml", &["--terms", terms], "s.exr");
    recognised(
        "refraction:inverted-index",
        "terms/refraction.toml",
        &["--terms", "ambient,diffuse,refraction:inverted-index"],
        "s.png",
    );
}

#[test]
fn refraction_no_exit_bend_is_recognised() {
    let terms = "ambient,diffuse,specular,mirror,refraction:no-exit-bend";
    recognised("refraction:no-exit-bend", "glass.toml", &["--terms", terms], "s.png");
}

#[test]
fn shadows_no_offset_is_recognised() {
    recognised("shadows:no-offset", "terms/diffuse.toml", &["--shadows", "no-offset"], "s.png");
}

#[test]
fn shadows_past_light_is_recognised() {
    // The wall behind the light: floor points reflected in the mirror ball, behind the camera,
    // see the light with the wall beyond it.
    recognised("shadows:past-light", "shapes/plane.toml", &["--shadows", "past-light"], "s.png");
}

#[test]
fn output_gamma_flipped_and_bgr_are_recognised() {
    for (name, flag) in [("output:gamma", "gamma"), ("output:flipped", "flipped"), ("output:bgr", "bgr")] {
        recognised(name, "terms/diffuse.toml", &["--output-mistake", flag], "s.png");
    }
    recognised("output:flipped", "glass.toml", &["--output-mistake", "flipped"], "s.exr");
}

#[test]
fn right_renders_are_correct_in_every_format_and_with_another_renderers_rounding() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["terms/diffuse.toml", "terms/specular.toml", "terms/mirror.toml", "glass.toml", "shapes/plane.toml"] {
        for file in ["r.png", "r.exr"] {
            render(dir.path(), name, file, &[]);
            let o = diagnose(dir.path(), name, file, &[]);
            assert_eq!(o.status.code(), Some(0), "{name} {file}:\n{}{}", stdout(&o), stderr(&o));
            assert!(stdout(&o).starts_with("verdict: correct\n"), "{}", stdout(&o));
        }
    }
    // The PNG written as a binary PPM, and every sample moved by up to one 8-bit step (as
    // another renderer rounding differently would): still correct.
    render(dir.path(), "glass.toml", "r.png", &[]);
    let png = image::open(dir.path().join("r.png")).unwrap().into_rgb8();
    let mut ppm = format!("P6\n# by hand\n{} {}\n255\n", png.width(), png.height()).into_bytes();
    ppm.extend(png.as_raw().iter().enumerate().map(|(i, &v)| match i % 3 {
        0 => v.saturating_add(1),
        1 => v.saturating_sub(1),
        _ => v,
    }));
    std::fs::write(dir.path().join("r.ppm"), ppm).unwrap();
    let o = diagnose(dir.path(), "glass.toml", "r.ppm", &[]);
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
    assert!(stdout(&o).contains("(PPM P6, maximum 255)"), "{}", stdout(&o));
}

#[test]
fn a_mistake_through_another_renderers_rounding_is_still_recognised() {
    let dir = tempfile::tempdir().unwrap();
    render(dir.path(), "terms/specular.toml", "s.png", &["--terms", "ambient,diffuse,specular:sign"]);
    let mut png = image::open(dir.path().join("s.png")).unwrap().into_rgb8();
    for (i, v) in png.iter_mut().enumerate() {
        *v = if i % 2 == 0 { v.saturating_add(1) } else { v.saturating_sub(1) };
    }
    png.save(dir.path().join("n.png")).unwrap();
    let o = diagnose(dir.path(), "terms/specular.toml", "n.png", &[]);
    assert!(stdout(&o).starts_with("verdict: specular:sign\n"), "{}", stdout(&o));
}

#[test]
fn one_term_is_diagnosed_against_its_layer_and_a_folder_layer_by_layer() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene("terms/specular.toml");
    let o = lancer(
        dir.path(),
        &[
            "render",
            &s,
            "--width",
            "96",
            "-q",
            "--aov",
            "aov",
            "-o",
            "aov/beauty.png",
            "--terms",
            "ambient,diffuse,specular:sign",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // The specular image alone: the mistake; the diffuse image alone: right.
    let o = diagnose(dir.path(), "terms/specular.toml", "aov/specular.png", &["--term", "specular"]);
    assert!(stdout(&o).starts_with("verdict: specular:sign\n"), "{}", stdout(&o));
    assert!(stdout(&o).contains("against the specular image"), "{}", stdout(&o));
    let o = diagnose(dir.path(), "terms/specular.toml", "aov/diffuse.exr", &["--term", "diffuse"]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
    // The whole folder: every layer of the model and the beauty image, EXR before PNG.
    let o = lancer(dir.path(), &["diagnose", &s, "--aov", "aov"]);
    let out = stdout(&o);
    assert!(out.starts_with("verdict: specular:sign\n"), "{out}");
    for layer in ["ambient", "diffuse", "specular", "beauty"] {
        assert!(
            out.contains(&format!("aov/{layer}.exr (OpenEXR float RGB, linear), against the {layer} image")),
            "{out}"
        );
    }
    let o = lancer(dir.path(), &["diagnose", &s, "--aov", "aov", "--term", "diffuse"]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
}

#[test]
fn json_gives_the_verdict_the_evidence_and_what_was_not_tried() {
    let dir = tempfile::tempdir().unwrap();
    render(dir.path(), "terms/diffuse.toml", "s.png", &["--output-mistake", "bgr"]);
    let o = diagnose(dir.path(), "terms/diffuse.toml", "s.png", &["--json"]);
    assert_eq!(o.status.code(), Some(1));
    let doc: serde_json::Value = serde_json::from_str(&stdout(&o)).expect("JSON");
    assert_eq!(doc["verdict"], "output:bgr");
    assert_eq!(doc["exit_code"], 1);
    assert_eq!(doc["candidates"][0]["name"], "output:bgr");
    assert_eq!(doc["candidates"][0]["explains"], true);
    assert!(doc["right_psnr_db"].as_f64().unwrap() < 30.0);
    assert!(doc["hint"].as_str().unwrap().contains("red, green, blue"));
    let not_tried: Vec<&str> =
        doc["not_tried"].as_array().unwrap().iter().map(|n| n["name"].as_str().unwrap()).collect();
    assert!(not_tried.contains(&"mirror:sign") && not_tried.contains(&"refraction:sign-trap"), "{not_tried:?}");
    // The diffuse scene has no object beyond its light: past-light changes nothing there.
    assert_eq!(doc["no_difference"], serde_json::json!(["shadows:past-light"]));
}

#[test]
fn mistakes_made_together_are_found_one_after_the_other() {
    // Rows upside down and the sign of the highlight: the first explains most of the image,
    // the second what the first leaves.
    let dir = tempfile::tempdir().unwrap();
    let two = ["--terms", "ambient,diffuse,specular:sign", "--output-mistake", "flipped"];
    render(dir.path(), "terms/specular.toml", "s.png", &two);
    let out = stdout(&diagnose(dir.path(), "terms/specular.toml", "s.png", &[]));
    assert!(out.starts_with("verdict: output:flipped\n"), "{out}");
    assert!(out.contains("\nalso: specular:sign (with it too, the image is "), "{out}");
    // Three in the glass scene: none alone explains the image, all three together do.
    let terms = "ambient,diffuse:no-clamp,specular:exponent-shine,mirror,refraction:no-exit-bend";
    render(dir.path(), "glass.toml", "g.png", &["--terms", terms]);
    let o = diagnose(dir.path(), "glass.toml", "g.png", &["--json"]);
    let doc: serde_json::Value = serde_json::from_str(&stdout(&o)).expect("JSON");
    let mut all: Vec<&str> = doc["also"].as_array().unwrap().iter().map(|a| a["name"].as_str().unwrap()).collect();
    all.push(doc["verdict"].as_str().unwrap());
    all.sort();
    assert_eq!(all, ["diffuse:no-clamp", "refraction:no-exit-bend", "specular:exponent-shine"], "{doc:#}");
    assert!(doc["reason"].as_str().unwrap().starts_with("no mistake alone explains the image"), "{doc:#}");
}

#[test]
fn an_image_no_mistake_explains_is_unclear() {
    // A model the catalogue has no mistake for (Oren–Nayar instead of Lambert), and an image
    // of another scene.
    let dir = tempfile::tempdir().unwrap();
    render(dir.path(), "terms/diffuse.toml", "o.png", &["--terms", "ambient,diffuse:oren-nayar"]);
    let o = diagnose(dir.path(), "terms/diffuse.toml", "o.png", &[]);
    let out = stdout(&o);
    assert!(out.starts_with("verdict: unclear\nwhy: no mistake of the catalogue explains the differences"), "{out}");
    assert!(out.contains("\nclosest: "), "{out}");
    assert_eq!(o.status.code(), Some(1));
    render(dir.path(), "terms/ambient.toml", "a.png", &[]);
    let out = stdout(&diagnose(dir.path(), "terms/diffuse.toml", "a.png", &[]));
    assert!(out.starts_with("verdict: unclear\nwhy: the image is far from every render"), "{out}");
}

/// Bad input: exit 2, nothing on stdout, the message on stderr.
fn refused(o: &Output, message: &str) {
    assert_eq!(o.status.code(), Some(2), "{}{}", stdout(o), stderr(o));
    assert!(stderr(o).contains(message), "expected `{message}` in\n{}", stderr(o));
    assert!(!stdout(o).contains("verdict"), "{}", stdout(o));
}

#[test]
fn a_missing_image_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    refused(&diagnose(dir.path(), "terms/specular.toml", "nothere.png", &[]), "reading image nothere.png");
}

#[test]
fn an_image_of_the_wrong_size_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene("terms/specular.toml");
    let o = lancer(dir.path(), &["render", &s, "--width", "64", "--height", "64", "-q", "-o", "sq.png"]);
    assert!(o.status.success());
    refused(
        &diagnose(dir.path(), "terms/specular.toml", "sq.png", &[]),
        "sq.png is 64x64, but the scene renders 480x270 (aspect 1.778): expected an image of the scene's size or shape (e.g. 64x36)",
    );
}

#[test]
fn an_unreadable_image_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.png"), b"GIF89a...").unwrap();
    refused(&diagnose(dir.path(), "terms/specular.toml", "s.png", &[]), "s.png: unknown image format");
}

#[test]
fn a_term_the_model_does_not_have_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    render(dir.path(), "terms/specular.toml", "s.png", &[]);
    refused(
        &diagnose(dir.path(), "terms/specular.toml", "s.png", &["--term", "mirror"]),
        "--term mirror: the model has no such term; its terms: ambient, diffuse, specular (or beauty)",
    );
}

#[test]
fn a_folder_without_images_or_with_images_of_two_sizes_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("aov")).unwrap();
    let s = scene("terms/specular.toml");
    refused(
        &lancer(dir.path(), &["diagnose", &s, "--aov", "aov"]),
        "aov holds no image of ambient, diffuse, specular, beauty",
    );
    refused(&lancer(dir.path(), &["diagnose", &s, "--aov", "none"]), "there is no folder none");
    let o = lancer(
        dir.path(),
        &["render", &s, "--width", "96", "-q", "--aov", "aov", "--aov-format", "png", "-o", "aov/beauty.png"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = lancer(dir.path(), &["render", &s, "--width", "48", "-q", "-o", "aov/diffuse.exr"]);
    assert!(o.status.success(), "{}", stderr(&o));
    refused(&lancer(dir.path(), &["diagnose", &s, "--aov", "aov"]), "is 48x27 but aov/ambient.png is 96x54");
}

#[test]
fn a_scene_that_does_not_load_is_bad_input_and_the_image_or_folder_is_required() {
    let dir = tempfile::tempdir().unwrap();
    refused(&lancer(dir.path(), &["diagnose", "nope.toml", "--image", "s.png"]), "reading scene nope.toml");
    let o = lancer(dir.path(), &["diagnose", &scene("glass.toml")]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--image <IMAGE>"), "{}", stderr(&o));
}

#[test]
fn terms_lists_the_mistakes_only_when_asked_and_render_refuses_an_output_mistake_in_parts() {
    let dir = tempfile::tempdir().unwrap();
    let normal = stdout(&lancer(dir.path(), &["terms"]));
    let mistakes = stdout(&lancer(dir.path(), &["terms", "--mistakes"]));
    assert!(!normal.contains("no-clamp") && !normal.contains("past-light"), "{normal}");
    for name in ["specular:sign", "shadows:no-offset", "output:gamma", "refraction:no-exit-bend"] {
        assert!(mistakes.contains(&format!("  {name} ")), "{mistakes}");
    }
    let o =
        lancer(dir.path(), &["render", "--width", "48", "--tile", "0/2", "--output-mistake", "gamma", "-o", "p.part"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--output-mistake shows a mistake in whole images"), "{}", stderr(&o));
    assert!(!dir.path().join("p.part").exists());
}

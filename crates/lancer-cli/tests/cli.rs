//! The `lancer` binary as a user runs it: the default render, per-term images, thread-count
//! independence, `lancer terms`, and bad input (clear error, non-zero exit, no output file).

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::{files, lancer, stderr, stdout};

fn scene(name: &str) -> String {
    let p: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "..", "scenes", name].iter().collect();
    p.canonicalize().unwrap().display().to_string()
}

#[test]
fn no_arguments_renders_the_embedded_showcase_to_render_png() {
    let dir = tempfile::tempdir().unwrap();
    let o = lancer(dir.path(), &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(dir.path().join("render.png")).unwrap();
    assert_eq!((img.width(), img.height()), (640, 360));
    assert!(stderr(&o).contains("rendered scenes/showcase.toml (embedded default)"));
    assert_eq!(files(dir.path()), ["render.png"], "no temporary file is left behind");
}

#[test]
fn aov_writes_every_term_and_beauty_and_the_exrs_sum_to_beauty() {
    let dir = tempfile::tempdir().unwrap();
    let o =
        lancer(dir.path(), &["render", &scene("glass.toml"), "--width", "64", "-o", "out.exr", "--aov", "aov", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(o.stderr.is_empty(), "--quiet prints nothing: {}", stderr(&o));
    let names = ["ambient", "background", "beauty", "diffuse", "mirror", "refraction", "specular"];
    let mut want: Vec<String> = names.iter().flat_map(|n| [format!("{n}.exr"), format!("{n}.png")]).collect();
    want.push("manifest.json".to_owned());
    want.sort();
    assert_eq!(files(&dir.path().join("aov")), want);
    let read = |p: &str| image::open(dir.path().join(p)).unwrap().into_rgb32f();
    let beauty = read("aov/beauty.exr");
    assert_eq!((beauty.width(), beauty.height()), (64, 36));
    assert_eq!(read("out.exr").as_raw(), beauty.as_raw(), "-o out.exr is the beauty image");
    let layers: Vec<_> = names.iter().filter(|n| **n != "beauty").map(|n| read(&format!("aov/{n}.exr"))).collect();
    for (i, b) in beauty.as_raw().iter().enumerate() {
        let sum: f32 = layers.iter().map(|l| l.as_raw()[i]).sum();
        assert!((sum - b).abs() <= 1e-6 * b.abs().max(1.0), "channel {i}: terms sum to {sum}, beauty {b}");
    }
}

#[test]
fn the_image_may_go_into_the_new_aov_folder_even_under_the_beauty_name() {
    let dir = tempfile::tempdir().unwrap();
    let args = ["render", "--width", "32", "-q", "-o", "aov/beauty.exr", "--aov", "aov", "--aov-format", "exr"];
    let o = lancer(dir.path(), &args);
    assert!(o.status.success(), "{}", stderr(&o));
    let names = files(&dir.path().join("aov"));
    assert!(names.contains(&"beauty.exr".to_owned()) && names.iter().all(|n| !n.ends_with(".tmp")), "{names:?}");
}

#[test]
fn one_and_two_threads_write_identical_bytes() {
    let dir = tempfile::tempdir().unwrap();
    for t in ["1", "2"] {
        let o = lancer(
            dir.path(),
            &[
                "render",
                &scene("showcase.toml"),
                "--width",
                "160",
                "--threads",
                t,
                "-o",
                &format!("t{t}.png"),
                "--aov",
                &format!("aov{t}"),
                "-q",
            ],
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let read = |p: &str| std::fs::read(dir.path().join(p)).unwrap();
    assert_eq!(read("t1.png"), read("t2.png"));
    // Every image; the manifest records times and threads, which differ.
    for f in files(&dir.path().join("aov1")).into_iter().filter(|f| f != "manifest.json") {
        assert_eq!(read(&format!("aov1/{f}")), read(&format!("aov2/{f}")), "{f}");
    }
}

#[test]
fn the_reference_path_writes_the_same_image() {
    let dir = tempfile::tempdir().unwrap();
    for (out, extra) in [("fast.exr", None), ("reference.exr", Some("--reference"))] {
        let mut args = vec!["render", "-q", "--width", "96", "-o", out];
        let glass = scene("glass.toml");
        args.push(&glass);
        args.extend(extra);
        let o = lancer(dir.path(), &args);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let read = |p: &str| std::fs::read(dir.path().join(p)).unwrap();
    assert_eq!(read("fast.exr"), read("reference.exr"));
}

#[test]
fn terms_lists_every_term_and_shadow_model() {
    let o = lancer(Path::new("."), &["terms"]);
    assert!(o.status.success());
    let out = String::from_utf8(o.stdout).unwrap();
    for name in
        ["ambient", "diffuse", "specular", "mirror", "refraction", "none:", "hard:", "transmissive:", "tint = false"]
    {
        assert!(out.contains(name), "`lancer terms` does not mention {name}:\n{out}");
    }
}

#[test]
fn a_bad_scene_is_a_located_error_with_no_output_file() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    std::fs::write(
        &bad,
        "[camera]\nfrom = [0, 0, -5]\nto = [0, 0, 0]\n[model]\nterms = [\"ambient\", \"specullar\"]\n",
    )
    .unwrap();
    let o = lancer(dir.path(), &["render", "bad.toml", "--aov", "aov"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(err.starts_with("error: bad.toml:5:21: unknown term `specullar` (did you mean `specular`?)"), "{err}");
    assert!(err.contains("^^^^^^^^^^^"), "the offending text is underlined: {err}");
    assert!(!err.contains("panicked"));
    assert_eq!(files(dir.path()), ["bad.toml"], "neither render.png nor the AOV directory appears");
}

#[test]
fn bad_files_and_flags_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let o = lancer(dir.path(), &["render", "missing.toml"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("reading scene missing.toml"), "{}", stderr(&o));

    let o = lancer(dir.path(), &["render", "-o", "out.jpg"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("must end in .png (sRGB 8-bit) or .exr (linear float)"));

    let o = lancer(dir.path(), &["render", "--threads", "0"]);
    assert_eq!(o.status.code(), Some(2), "clap rejects flags with its usage exit code");
    assert!(stderr(&o).contains("--threads"));

    let o = lancer(dir.path(), &["render", "--width", "16384", "--height", "16384"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("Lancer renders at most 67108864"), "{}", stderr(&o));

    let o = lancer(dir.path(), &["render", "--model", "nope.toml"]);
    assert!(stderr(&o).contains("reading model nope.toml"));

    // A typo in the image's folder is found before the render, and the per-term images are
    // not written without their image.
    let o = lancer(dir.path(), &["render", "--width", "16", "-o", "nowhere/out.png", "--aov", "aov"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("cannot write nowhere/out.png: there is no folder nowhere"), "{}", stderr(&o));
    assert_eq!(files(dir.path()), Vec::<String>::new());
}

#[test]
fn a_model_file_replaces_the_scenes_model() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("flat.toml"), "max_depth = 0\nshadows = \"none\"\nterms = [\"ambient\"]\n").unwrap();
    let o = lancer(
        dir.path(),
        &["render", &scene("showcase.toml"), "--model", "flat.toml", "--width", "48", "--aov", "aov", "-q"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        files(&dir.path().join("aov")),
        ["ambient.exr", "ambient.png", "background.exr", "background.png", "beauty.exr", "beauty.png", "manifest.json"]
    );
}

#[test]
fn a_bad_model_file_names_the_unknown_variant_or_parameter_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    // (model file, the text the error must point at, the message)
    let cases = [
        (
            "terms = [{ term = \"specular\", variant = \"blin\" }]\n",
            "\"blin\"",
            "term `specular` has no variant `blin` (did you mean `blinn`?)",
        ),
        (
            "terms = [{ term = \"specular\", variant = \"blinn\", exponnent = 8 }]\n",
            "exponnent",
            "`specular` has no parameter `exponnent` (did you mean `exponent`?)",
        ),
        (
            "shadows = { model = \"soft\", samples = 10 }\n",
            "10",
            "`soft`: parameter `samples`: expected a square number such as 4, 16 or 64, found 10",
        ),
        (
            "terms = [{ term = \"diffuse\", weight = -1 }]\n",
            "-1",
            "`diffuse`: parameter `weight`: expected a number of at least 0, found -1",
        ),
    ];
    for (model, at, message) in cases {
        std::fs::write(dir.path().join("m.toml"), model).unwrap();
        let o = lancer(dir.path(), &["render", "--model", "m.toml", "--aov", "aov"]);
        assert_eq!(o.status.code(), Some(1), "{model}");
        let expected = format!("error: m.toml:1:{}: {message}", model.find(at).unwrap() + 1);
        assert!(stderr(&o).starts_with(&expected), "{model}: expected {expected}\n{}", stderr(&o));
        assert_eq!(files(dir.path()), ["m.toml"], "nothing written for {model}");
    }
}

#[test]
fn terms_flag_picks_terms_and_variants() {
    let dir = tempfile::tempdir().unwrap();
    let o = lancer(
        dir.path(),
        &["render", "--terms", "diffuse,specular:blinn-normalized", "--width", "48", "--aov", "aov", "-q"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let want = ["background", "beauty", "diffuse", "specular"];
    let mut want: Vec<String> = want
        .iter()
        .flat_map(|n| [format!("{n}.exr"), format!("{n}.png")])
        .chain(["manifest.json".to_owned()])
        .collect();
    want.sort();
    assert_eq!(files(&dir.path().join("aov")), want);
    let o = lancer(dir.path(), &["render", "--terms", "diffuse,specullar", "-o", "x.png"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("unknown term `specullar` (did you mean `specular`?)"), "{}", stderr(&o));
    assert!(!dir.path().join("x.png").exists());
}

#[test]
fn regression_a_mesh_path_that_is_not_a_regular_file_is_refused_at_once() {
    // `/dev/zero` as a mesh was read without end (10 GB after 20 s).
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("zero.toml"),
        "[camera]\nfrom = [0, 0, -5]\nto = [0, 0, 0]\n[[objects]]\nshape = \"mesh\"\npath = \"/dev/zero\"\n",
    )
    .unwrap();
    let o = lancer(dir.path(), &["render", "zero.toml", "-o", "z.png"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("zero.toml:6:8: mesh `/dev/zero`: file /dev/zero is not a regular file"),
        "{}",
        stderr(&o)
    );
    assert_eq!(files(dir.path()), ["zero.toml"], "no output file");
}

#[test]
fn files_over_the_size_limit_are_refused_with_the_figure_and_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("big.obj"), "# padding\n".repeat(300_000)).unwrap();
    std::fs::write(
        dir.path().join("s.toml"),
        "[camera]\nfrom = [0, 0, -5]\nto = [0, 0, 0]\n[[objects]]\nshape = \"mesh\"\npath = \"big.obj\"\n",
    )
    .unwrap();
    let o = lancer(dir.path(), &["render", "s.toml", "-o", "s.png", "--max-file-size", "2"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("file big.obj is 3 MB, over the 2 MB limit (raise it with --max-file-size)"),
        "{}",
        stderr(&o)
    );
    // The scene file itself is checked the same way.
    let o = lancer(dir.path(), &["render", "/dev/zero", "-o", "s.png"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("scene /dev/zero is not a regular file"), "{}", stderr(&o));
    assert_eq!(files(dir.path()), ["big.obj", "s.toml"], "no output file");
}

#[cfg(unix)]
#[test]
fn ctrl_c_sigterm_and_sighup_during_a_render_stop_cleanly_and_leave_no_file() {
    // Found in review: SIGTERM and SIGHUP (what `timeout`, Slurm's `scancel` and Kubernetes send)
    // killed the render without cleaning up; only Ctrl-C did.
    for (signal, code, says) in [("INT", 130, "interrupted"), ("TERM", 143, "SIGTERM"), ("HUP", 129, "SIGHUP")] {
        let dir = tempfile::tempdir().unwrap();
        let child = Command::new(env!("CARGO_BIN_EXE_lancer"))
            .args(["render", "--width", "2048", "--samples", "16", "-o", "out.png", "--aov", "aov"])
            .current_dir(dir.path())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("lancer runs");
        std::thread::sleep(std::time::Duration::from_millis(400));
        let kill = Command::new("kill").args([&format!("-{signal}"), &child.id().to_string()]).status().unwrap();
        assert!(kill.success());
        let o = child.wait_with_output().unwrap();
        assert_eq!(o.status.code(), Some(code), "SIG{signal}: {}", stderr(&o));
        assert!(stderr(&o).contains(says), "SIG{signal}: {}", stderr(&o));
        assert!(files(dir.path()).is_empty(), "SIG{signal} left behind: {:?}", files(dir.path()));
    }
}

#[test]
fn explain_json_totals_are_the_aov_exr_values_of_the_pixel() {
    // A glass sphere pixel, a mirror chain five deep, and anti-aliased pixels with a Blinn model.
    /// A scene, extra flags, and pixels to explain.
    type Case<'a> = (&'a str, &'a [&'a str], &'a [(u32, u32)]);
    let cases: &[Case] = &[
        ("glass.toml", &[], &[(40, 20), (48, 16), (20, 20)]),
        ("mirrors.toml", &[], &[(22, 14), (28, 14)]),
        (
            "showcase.toml",
            &["--samples", "3", "--terms", "ambient,diffuse,specular:blinn,mirror,refraction"],
            &[(16, 22), (32, 18)],
        ),
    ];
    for (name, extra, pixels) in cases {
        let dir = tempfile::tempdir().unwrap();
        let path = scene(name);
        let mut args =
            vec!["render", &path, "--width", "64", "-o", "out.exr", "--aov", "aov", "--aov-format", "exr", "-q"];
        args.extend_from_slice(extra);
        let o = lancer(dir.path(), &args);
        assert!(o.status.success(), "{}", stderr(&o));
        let aov: Vec<String> = files(&dir.path().join("aov"))
            .into_iter()
            .filter_map(|f| f.strip_suffix(".exr").map(str::to_owned))
            .collect();
        for &(x, y) in *pixels {
            let pixel = format!("{x},{y}");
            let mut args = vec!["explain", &path[..], "--width", "64", "--pixel", &pixel, "--json"];
            args.extend_from_slice(extra);
            let o = lancer(dir.path(), &args);
            assert!(o.status.success(), "{}", stderr(&o));
            let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("explain --json prints JSON");
            let terms = doc["terms"].as_object().expect("a terms object");
            let mut names: Vec<String> = terms.keys().cloned().collect();
            names.push("beauty".to_owned());
            names.sort();
            assert_eq!(names, aov, "{name}: explain names the images --aov writes");
            for image in &aov {
                let value = if image == "beauty" { &doc["beauty"] } else { &terms[image] };
                let got: Vec<f32> = value.as_array().unwrap().iter().map(|c| c.as_f64().unwrap() as f32).collect();
                let exr = image::open(dir.path().join(format!("aov/{image}.exr"))).unwrap().into_rgb32f();
                let want = exr.get_pixel(x, y).0.to_vec();
                assert_eq!(got, want, "{name} at {pixel}: {image}");
            }
        }
        if *name == "glass.toml" {
            let o = lancer(dir.path(), &["explain", &path, "--width", "64", "--pixel", "40,20"]);
            let text = String::from_utf8_lossy(&o.stdout);
            assert!(
                text.contains("refraction ray") && text.contains("u_t = VctTransmis") && text.contains("J (exit)"),
                "{text}"
            );
            // With no term reading lights, the lights are named as not traced, not as behind.
            let o = lancer(
                dir.path(),
                &["explain", &path, "--width", "64", "--pixel", "40,20", "--terms", "ambient,mirror"],
            );
            let text = String::from_utf8_lossy(&o.stdout);
            assert!(
                text.contains("not traced: no term of the model reads lights") && !text.contains("behind"),
                "{text}"
            );
        }
    }
}

#[test]
fn explain_refuses_a_pixel_outside_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let o = lancer(dir.path(), &["explain", &scene("glass.toml"), "--width", "64", "--pixel", "64,3"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("pixel 64,3 is outside the 64x36 image"), "{}", stderr(&o));
    let o = lancer(dir.path(), &["explain", "--pixel", "3"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("expected X,Y"), "{}", stderr(&o));
    assert!(files(dir.path()).is_empty());
}

#[test]
fn stats_report_rays_by_kind_and_time_per_system() {
    let dir = tempfile::tempdir().unwrap();
    let o = lancer(
        dir.path(),
        &["render", &scene("glass.toml"), "--width", "64", "-o", "out.png", "--stats", "--stats-json", "stats.json"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stderr(&o);
    for words in [
        "Render Statistics",
        "Camera Rays:",
        "Reflected Rays:",
        "Refracted Rays:",
        "Shadow Ray Tests:",
        "trace (closest hits)",
        "term diffuse",
        "Rays per second per thread",
    ] {
        assert!(text.contains(words), "--stats says {words}: {text}");
    }
    let doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("stats.json")).unwrap()).unwrap();
    let rays = &doc["rays"];
    assert_eq!(rays["camera"], 64 * 36);
    let spawned: u64 = rays["spawned_by_term"].as_object().unwrap().values().map(|v| v.as_u64().unwrap()).sum();
    assert_eq!(spawned, rays["secondary"].as_u64().unwrap(), "every secondary ray was spawned by a term");
    assert!(rays["spawned_by_term"]["refraction"].as_u64().unwrap() > 0);
    assert!(doc["system_thread_seconds"]["trace"].as_f64().unwrap() > 0.0);
    assert_eq!(doc["model"]["shadows"]["name"], "transmissive");
}

#[test]
fn the_summary_line_shows_the_effective_model() {
    let dir = tempfile::tempdir().unwrap();
    let o = lancer(
        dir.path(),
        &["render", &scene("glass.toml"), "--width", "32", "--terms", "ambient,specular:blinn", "--samples", "2"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o)
            .contains("terms ambient:seed, specular:blinn; shadows transmissive; max_depth 5; 2 samples per pixel"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn samples_take_adaptive_anti_aliasing_and_bad_values_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let glass = scene("glass.toml");
    // The glass scene 48 wide with `--samples SAMPLES`: its summary line and `--stats-json`.
    let render = |samples: &str| {
        let o = lancer(
            dir.path(),
            &["render", &glass, "--width", "48", "--samples", samples, "-o", "aa.png", "--stats-json", "s.json"],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let doc: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("s.json")).unwrap()).unwrap();
        (stderr(&o), doc)
    };
    let (summary, doc) = render("adaptive:depth=2");
    assert!(summary.contains("max_depth 5; adaptive samples (threshold 0.3, depth 2)"), "{summary}");
    let supersampled = doc["adaptive"]["supersampled_pixels"].as_u64().unwrap();
    // Every pixel once; each tile's one-pixel border within the image once more (48 x 27 is two
    // bands of one tile each, 16 and 11 rows: the row under the first and the row above the
    // second); and 2 x 2 + 1 for each pixel supersampled.
    let border = 2 * 48;
    assert_eq!(doc["rays"]["camera"].as_u64().unwrap(), 48 * 27 + border + 5 * supersampled);
    assert_eq!(doc["adaptive"]["border_rays"].as_u64().unwrap(), border);
    assert!(supersampled > 0);
    // Depth 3: nine rays a supersampled pixel (the centre's stands for the middle cell too), and
    // `explain` says so.
    let (_, doc) = render("adaptive");
    let supersampled = doc["adaptive"]["supersampled_pixels"].as_u64().unwrap();
    assert_eq!(doc["rays"]["camera"].as_u64().unwrap(), 48 * 27 + border + 9 * supersampled);
    let o = lancer(
        dir.path(),
        &["explain", &glass, "--width", "48", "--samples", "adaptive:threshold=0", "--pixel", "20,10"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o)
            .contains("adaptive anti-aliasing (threshold 0, depth 3): supersampled, the mean of 10 samples in 9 rays"),
        "{}",
        stdout(&o)
    );
    for (bad, says) in [
        ("adaptive:threshold=4", "adaptive threshold: expected a number from 0 to 3, found `4`"),
        ("adaptive:depth=1", "adaptive depth: expected a whole number from 2 to 9, found `1`"),
        ("adaptive:size=2", "adaptive has no parameter `size`; it takes threshold and depth"),
        ("0", "expected a whole number of samples per pixel from 1 to 4096"),
    ] {
        let o = lancer(dir.path(), &["render", &glass, "--width", "48", "--samples", bad, "-o", "bad.png"]);
        assert_eq!(o.status.code(), Some(2), "{bad}");
        assert!(stderr(&o).contains(says), "{bad}: {}", stderr(&o));
        assert!(!dir.path().join("bad.png").exists());
    }
}

#[test]
fn regression_aov_images_of_an_earlier_render_with_other_terms_are_removed() {
    let dir = tempfile::tempdir().unwrap();
    let run = |terms: &str| {
        let o = lancer(
            dir.path(),
            &[
                "render",
                &scene("glass.toml"),
                "--width",
                "32",
                "--aov",
                "aov",
                "--aov-format",
                "exr",
                "--terms",
                terms,
                "-q",
            ],
        );
        assert!(o.status.success(), "{}", stderr(&o));
    };
    run("ambient,diffuse,specular");
    std::fs::write(dir.path().join("aov/notes.txt"), "mine").unwrap();
    run("ambient,diffuse");
    assert_eq!(
        files(&dir.path().join("aov")),
        ["ambient.exr", "background.exr", "beauty.exr", "diffuse.exr", "manifest.json", "notes.txt"],
        "specular.exr from the first render is gone; files Lancer did not write stay"
    );
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("aov/manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["model"]["terms"].as_array().unwrap().len(), 2);
    assert_eq!(manifest["files"].as_array().unwrap().len(), 4);
}

/// A scene with every flaw `lancer check` knows: the camera inside a glass ball, a light inside
/// an opaque ball, a glass ball reaching into a cube, an unused material, a colour above 1, and
/// specular and mirror terms with no material to act on (every `spec` is 0).
const FLAWED: &str = r#"[camera]
from = [0, 1, -6]
to = [0, 1, 0]

[model]
terms = ["ambient", "diffuse", "specular:blinn", "mirror"]

[materials.unused]
color = [0.5, 0.5, 0.5]

[[lights]]
at = [4, 1, 0]

[[lights]]
at = [0, 5, -5]

[[objects]]
shape = "sphere"
scale = 0.5
translate = [4, 1, 0]
material = { color = [0.2, 0.2, 0.2] }

[[objects]]
shape = "sphere"
translate = [0, 1, 0]
material = { color = [1, 1, 1], alpha = 0.9, n = 1.5, ambi = 0, diff = 0 }

[[objects]]
shape = "cube"
scale = 0.5
translate = [0.8, 1, 0]
material = { color = [1.2, 0.5, 0.5] }

[[objects]]
shape = "sphere"
scale = 0.5
translate = [0, 1, -6]
material = { color = [0.5, 0.5, 1], alpha = 0.5 }
"#;

#[test]
fn check_warns_about_a_flawed_scene_and_renders_nothing() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("flawed.toml"), FLAWED).unwrap();
    let o = lancer(dir.path(), &["check", "flawed.toml"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    for want in [
        "flawed.toml: loads and prepares",
        "4 object(s) (3 sphere, 1 cube), 2 light(s), 5 material(s)",
        "warning: flawed.toml:8:1: material `unused` is defined but no object uses it",
        "warning: flawed.toml:32:22: a material colour above 1 (1.2)",
        "warning: flawed.toml:1:1: the camera is inside object 4 (sphere, flawed.toml:34:1)",
        "warning: flawed.toml:11:1: light 1 is inside object 1 (sphere, flawed.toml:17:1): it lights nothing outside",
        "warning: flawed.toml:23:1: transparent object 2 (sphere, flawed.toml:23:1) reaches into object 3 (cube, flawed.toml:28:1)",
        "term `specular` adds nothing to this scene",
        "term `mirror` adds nothing to this scene",
    ] {
        assert!(out.contains(want), "check says `{want}`:\n{out}");
    }
    assert!(!out.contains("light 2 is inside"), "{out}");
    assert!(out.contains("(`refraction:traced` traces inside and shows it)"), "{out}");
    // With the path that traces inside, what reaches into the glass shows: no warning.
    let o = lancer(dir.path(), &["check", "flawed.toml", "--terms", "ambient,diffuse,refraction:traced"]);
    let traced = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success() && !traced.contains("reaches into"), "{traced}");
    assert!(traced.contains("the camera is inside object 4"), "the other warnings stay: {traced}");
    // A costly render is said so, with the figure, before it starts.
    let o = lancer(dir.path(), &["check", "--width", "4096", "--samples", "256"]);
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(out.contains("this render traces at least 7248 M rays (4096x2304 pixels x 256 samples"), "{out}");
    let o = lancer(dir.path(), &["check"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("0 warnings"), "the default scene is clean");
    assert!(files(dir.path()) == ["flawed.toml"], "check writes nothing");
    // A broken scene: the same located error as render, and a failure.
    std::fs::write(dir.path().join("bad.toml"), "[camera]\nfrom = [0, 0]\n").unwrap();
    let check = lancer(dir.path(), &["check", "bad.toml"]);
    let render = lancer(dir.path(), &["render", "bad.toml"]);
    assert!(!check.status.success() && !render.status.success());
    assert!(stderr(&check).contains("bad.toml:2:"), "{}", stderr(&check));
    assert_eq!(stderr(&check), stderr(&render));
}

#[test]
fn a_scene_alone_renders_and_aov_format_without_aov_warns() {
    let dir = tempfile::tempdir().unwrap();
    let o = lancer(dir.path(), &[&scene("glass.toml"), "--width", "32", "-o", "g.png", "--aov-format", "exr"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("warning: --aov-format has no effect without --aov DIR"), "{}", stderr(&o));
    assert_eq!(files(dir.path()), ["g.png"]);
}

#[test]
fn watch_renders_again_on_save_keeps_the_last_image_on_a_broken_save_and_stops_on_ctrl_c() {
    let dir = tempfile::tempdir().unwrap();
    let glass = std::fs::read_to_string(scene("glass.toml")).unwrap();
    std::fs::write(dir.path().join("s.toml"), &glass).unwrap();
    let log = std::fs::File::create(dir.path().join("log.txt")).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_lancer"))
        .args(["watch", "s.toml", "--width", "48", "-o", "out.png", "-q"])
        .current_dir(dir.path())
        .stderr(log)
        .spawn()
        .expect("lancer runs");
    let log = || std::fs::read_to_string(dir.path().join("log.txt")).unwrap();
    let wait_for = |what: &str, done: &dyn Fn() -> bool| {
        for _ in 0..200 {
            if done() {
                return;
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
        panic!("waited 10 s for {what}; log:\n{}", log());
    };
    let image = || std::fs::read(dir.path().join("out.png")).ok();
    wait_for("the first render", &|| log().contains("watching"));
    let first = image().expect("the first render wrote out.png");
    // An editor's save by rename: a new file moved over the old one.
    let save = |text: &str| {
        std::fs::write(dir.path().join("s.toml.tmp"), text).unwrap();
        std::fs::rename(dir.path().join("s.toml.tmp"), dir.path().join("s.toml")).unwrap();
    };
    save(&glass.replace("background = [", "background = [0.9, 0.1, 0.1] # was ["));
    wait_for("the render with the new background", &|| image().is_some_and(|i| i != first));
    let second = image().unwrap();
    // One save, one render: the render's own reading of the scene is no change.
    std::thread::sleep(std::time::Duration::from_millis(1500));
    assert_eq!(log().matches("rendering again").count(), 1, "{}", log());
    save("[camera]\nfrom = [0, 0]\n");
    wait_for("the broken save's error", &|| log().contains("s.toml:2:"));
    wait_for("watching again", &|| log().rsplit("s.toml:2:").next().is_some_and(|after| after.contains("watching")));
    assert_eq!(image().unwrap(), second, "a broken save keeps the last image");
    save(&glass);
    wait_for("the render after the fix", &|| image().is_some_and(|i| i == first));
    let kill = Command::new("kill").args(["-INT", &child.id().to_string()]).status().expect("kill runs");
    assert!(kill.success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    let mut left = files(dir.path());
    left.retain(|f| f != "log.txt");
    assert_eq!(left, ["out.png", "s.toml"], "no temporary file left");
}

#[test]
fn regression_watch_renders_the_last_of_two_saves_made_during_a_slow_render() {
    // Found in review: a save made while `watch` re-rendered was dropped (two saves, one render,
    // the image showed the intermediate file, nothing said so).
    let dir = tempfile::tempdir().unwrap();
    let glass = std::fs::read_to_string(scene("glass.toml")).unwrap();
    let (a, b) = (
        glass.replace("background = [", "background = [0.9, 0.1, 0.1] # was ["),
        glass.replace("background = [", "background = [0.1, 0.1, 0.9] # was ["),
    );
    // A render slow enough for both saves to land during it.
    let flags = ["--width", "640", "--samples", "64", "-q"];
    let mut args = vec!["render", "b.toml", "-o", "want.png"];
    std::fs::write(dir.path().join("b.toml"), &b).unwrap();
    args.extend(flags);
    let start = std::time::Instant::now();
    let o = lancer(dir.path(), &args);
    assert!(o.status.success(), "{}", stderr(&o));
    let render_time = start.elapsed();
    let want = std::fs::read(dir.path().join("want.png")).unwrap();
    std::fs::write(dir.path().join("s.toml"), &glass).unwrap();
    let log = std::fs::File::create(dir.path().join("log.txt")).unwrap();
    let mut watch = vec!["watch", "s.toml", "-o", "out.png"];
    watch.extend(flags);
    let mut child = Command::new(env!("CARGO_BIN_EXE_lancer"))
        .args(&watch)
        .current_dir(dir.path())
        .stderr(log)
        .spawn()
        .expect("lancer runs");
    let log = || std::fs::read_to_string(dir.path().join("log.txt")).unwrap();
    // Both saves in the first half of the first render (which reads the scene at once).
    std::thread::sleep(render_time / 8);
    std::fs::write(dir.path().join("s.toml"), &a).unwrap();
    std::thread::sleep(render_time / 8);
    std::fs::write(dir.path().join("s.toml"), &b).unwrap();
    let mut done = false;
    for _ in 0..600 {
        if std::fs::read(dir.path().join("out.png")).is_ok_and(|i| i == want) && log().contains("watching") {
            done = true;
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let _ = Command::new("kill").args(["-TERM", &child.id().to_string()]).status();
    let _ = child.wait();
    assert!(done, "the image never matched the file's last state; log:\n{}", log());
    assert!(log().contains("changed during the render: rendering again"), "{}", log());
}

#[test]
fn regression_a_model_file_replaces_only_what_it_sets() {
    // models/blinn.toml swaps the highlight: the showcase keeps its transmissive shadows and
    // depth (before, the file's own shadows and depth replaced them: 13,592 diffuse pixels moved).
    let dir = tempfile::tempdir().unwrap();
    let models: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "..", "models", "blinn.toml"].iter().collect();
    for (out, extra) in [("plain", None), ("blinn", Some(models.to_str().unwrap()))] {
        let mut args = vec!["render", "--width", "96", "--aov", out, "--aov-format", "exr", "-q"];
        if let Some(m) = extra {
            args.extend(["--model", m]);
        }
        let o = lancer(dir.path(), &args);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let read = |p: &str| std::fs::read(dir.path().join(p)).unwrap();
    for same in ["ambient.exr", "diffuse.exr", "background.exr"] {
        assert!(read(&format!("plain/{same}")) == read(&format!("blinn/{same}")), "{same} changed");
    }
    assert!(read("plain/specular.exr") != read("blinn/specular.exr"));
    let manifest: serde_json::Value = serde_json::from_slice(&read("blinn/manifest.json")).unwrap();
    assert_eq!(manifest["model"]["shadows"]["name"], "transmissive");
}

#[test]
fn terms_and_shadows_flags_share_one_syntax_and_keep_the_scenes_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let stats = |args: &[&str]| -> serde_json::Value {
        let mut all = vec!["render", "--width", "32", "-o", "x.png", "-q", "--stats-json", "s.json"];
        all.extend_from_slice(args);
        let o = lancer(dir.path(), &all);
        assert!(o.status.success(), "{}", stderr(&o));
        serde_json::from_slice(&std::fs::read(dir.path().join("s.json")).unwrap()).unwrap()
    };
    let soft = scene("soft-shadows.toml");
    // The scene's soft shadows take 64 samples; naming the same model keeps them.
    let doc = stats(&[&soft, "--shadows", "soft"]);
    assert_eq!(doc["model"]["shadows"]["params"]["samples"], 64.0);
    let doc = stats(&[&soft, "--shadows", "soft:samples=4:tint=true"]);
    assert_eq!(doc["model"]["shadows"]["params"]["samples"], 4.0);
    assert_eq!(doc["model"]["shadows"]["params"]["tint"], true);
    // A term in the scene's variant keeps the scene's parameters; a name alone is the default
    // variant, with none of them.
    let glossy = std::fs::read_to_string(scene("glass.toml"))
        .unwrap()
        .replace("\"specular\",", "{ term = \"specular\", variant = \"blinn\", exponent = 64 },");
    std::fs::write(dir.path().join("glossy.toml"), glossy).unwrap();
    let doc = stats(&["glossy.toml", "--terms", "ambient,specular:blinn"]);
    assert_eq!(doc["model"]["terms"][1]["params"]["exponent"], 64.0);
    let doc = stats(&["glossy.toml", "--terms", "ambient,specular"]);
    assert_eq!(doc["model"]["terms"][1]["variant"], "phong");
    assert_eq!(doc["model"]["terms"][1]["params"], serde_json::json!({}));
    // The same choice syntax in a scene file.
    let inline = std::fs::read_to_string(scene("glass.toml"))
        .unwrap()
        .replace("\"specular\",", "\"specular:blinn:exponent=32\",");
    std::fs::write(dir.path().join("inline.toml"), inline).unwrap();
    let doc = stats(&["inline.toml"]);
    assert_eq!(doc["model"]["terms"][2]["params"]["exponent"], 32.0);
    let doc = stats(&["--terms", "ambient,specular:blinn:exponent=64"]);
    assert_eq!(doc["model"]["terms"][1]["variant"], "blinn");
    assert_eq!(doc["model"]["terms"][1]["params"]["exponent"], 64.0);
    for (flag, bad, says) in [
        ("--shadows", "soft:64", "parameters as KEY=VALUE"),
        ("--shadows", "soft:square", "a shadow model has no variant `square`"),
        ("--terms", "specular:phong:exponent=3", "variants blinn, blinn-normalized of `specular` take `exponent`"),
    ] {
        let o = lancer(dir.path(), &["render", "--width", "32", "-o", "y.png", flag, bad]);
        assert!(!o.status.success() && stderr(&o).contains(says), "{bad}: {}", stderr(&o));
    }
    // Soft shadows with point lights only change nothing: said so.
    let o = lancer(dir.path(), &["render", "--width", "32", "-o", "y.png", "--shadows", "soft"]);
    assert!(stderr(&o).contains("every light here is a point"), "{}", stderr(&o));
    assert!(!dir.path().join("y.png").exists() || o.status.success());
}

#[test]
fn parts_merge_into_the_whole_render_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let read = |p: &str| std::fs::read(dir.path().join(p)).unwrap();
    for (name, extra) in
        [("glass.toml", &["--samples", "3"][..]), ("mirrors.toml", &[][..]), ("showcase.toml", &["--samples", "2"][..])]
    {
        let path = scene(name);
        let mut whole = vec!["render", &path, "--width", "120", "-o", "whole.exr", "--aov", "whole", "-q"];
        whole.extend_from_slice(extra);
        assert!(lancer(dir.path(), &whole).status.success());
        for n in [1u32, 2, 3, 5] {
            let mut parts = Vec::new();
            for i in 0..n {
                let (tile, out) = (format!("{i}/{n}"), format!("part{i}.lpart"));
                let mut args = vec!["render", &path, "--width", "120", "--tile", &tile, "-o", &out, "-q"];
                args.extend_from_slice(extra);
                let o = lancer(dir.path(), &args);
                assert!(o.status.success(), "{}", stderr(&o));
                parts.push(out);
            }
            // In any order.
            parts.reverse();
            let mut args = vec!["merge", "-o", "merged.exr", "--aov", "merged", "-q"];
            args.extend(parts.iter().map(String::as_str));
            let o = lancer(dir.path(), &args);
            assert!(o.status.success(), "{}", stderr(&o));
            assert!(read("merged.exr") == read("whole.exr"), "{name} in {n} parts");
            for f in files(&dir.path().join("whole")).into_iter().filter(|f| f != "manifest.json") {
                assert!(read(&format!("merged/{f}")) == read(&format!("whole/{f}")), "{name} in {n} parts: {f}");
            }
            assert_eq!(files(&dir.path().join("merged")), files(&dir.path().join("whole")));
            for p in &parts {
                std::fs::remove_file(dir.path().join(p)).unwrap();
            }
        }
    }
}

#[test]
fn a_missing_duplicated_mismatched_or_broken_part_is_an_error_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let render = |scene_name: &str, tile: &str, out: &str, width: &str| {
        let o = lancer(dir.path(), &["render", &scene(scene_name), "--width", width, "--tile", tile, "-o", out, "-q"]);
        assert!(o.status.success(), "{}", stderr(&o));
    };
    render("glass.toml", "0/3", "a0.lpart", "64");
    render("glass.toml", "1/3", "a1.lpart", "64");
    render("glass.toml", "2/3", "a2.lpart", "64");
    render("mirrors.toml", "2/3", "m2.lpart", "64");
    render("glass.toml", "2/3", "w2.lpart", "80");
    let bytes = std::fs::read(dir.path().join("a2.lpart")).unwrap();
    std::fs::write(dir.path().join("cut.lpart"), &bytes[..bytes.len() - 100]).unwrap();
    std::fs::write(dir.path().join("junk.lpart"), b"hello").unwrap();
    for (parts, says) in [
        (&["a0.lpart", "a1.lpart"][..], "part(s) 2 of 3 missing"),
        (&["a0.lpart", "a1.lpart", "a1.lpart", "a2.lpart"][..], "part 1 of 3 is given twice"),
        (
            &["a0.lpart", "a1.lpart", "m2.lpart"][..],
            "m2.lpart comes from another render than a0.lpart (they differ in the scene file's text",
        ),
        (
            &["a0.lpart", "a1.lpart", "w2.lpart"][..],
            "w2.lpart comes from another render than a0.lpart (they differ in the image's size",
        ),
        (&["a0.lpart", "a1.lpart", "cut.lpart"][..], "cut short?"),
        (&["a0.lpart", "junk.lpart"][..], "junk.lpart: not a Lancer part file"),
        (&["a0.lpart", "nope.lpart"][..], "nope.lpart"),
    ] {
        let mut args = vec!["merge", "-o", "out.png", "--aov", "aov"];
        args.extend_from_slice(parts);
        let o = lancer(dir.path(), &args);
        assert!(!o.status.success(), "{parts:?}");
        assert!(stderr(&o).contains(says), "{parts:?}: {}", stderr(&o));
        assert!(!dir.path().join("out.png").exists() && !dir.path().join("aov").exists(), "{parts:?} wrote something");
    }
    for (tile, says) in [("3/3", "I goes from 0 to N - 1"), ("1", "expected I/N"), ("0/40", "at most 3 parts")] {
        let o = lancer(dir.path(), &["render", &scene("glass.toml"), "--width", "64", "--tile", tile, "-o", "t.lpart"]);
        assert!(!o.status.success() && stderr(&o).contains(says), "{tile}: {}", stderr(&o));
    }
}

#[test]
fn export_pov_writes_blinn_as_povrays_half_vector_specular() {
    let dir = tempfile::tempdir().unwrap();
    // The mirror ball (spec 0.8, shine 0.9875): specular 0.79 and roughness 1/e, e = 4/(1 -
    // shine) = 320 unless the term gives its exponent (f32 figures: to 1e-5 of the value).
    let near = |x: f64, want: f64| (x - want).abs() <= 1e-5 * want;
    for (terms, e) in [("specular:blinn", 320.0), ("specular:blinn:exponent=64", 64.0)] {
        let o = lancer(dir.path(), &["export", "pov", &scene("bench/anchor.toml"), "--terms", terms, "-o", "b.pov"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let pov = std::fs::read_to_string(dir.path().join("b.pov")).unwrap();
        let number_after = |line: &str, word: &str| -> f64 {
            let rest = line.split(&format!(" {word} ")).nth(1).unwrap_or_else(|| panic!("{terms}: no {word}: {line}"));
            rest.split_whitespace().next().unwrap().parse().unwrap()
        };
        let ball = pov
            .lines()
            .filter(|l| l.contains("finish {"))
            .find(|l| l.contains(" specular ") && near(number_after(l, "specular"), 0.79))
            .unwrap_or_else(|| panic!("{terms}: no specular 0.79: {pov}"));
        assert!(near(number_after(ball, "roughness"), 1.0 / e), "{terms}: {ball}");
        assert!(!pov.contains(" phong 0.") && !pov.contains("`specular:blinn`"), "{terms}: written as Phong: {pov}");
    }
    // Normalised Blinn has no POV-Ray form (its N·w factor): the handout's Phong, said so.
    let o = lancer(
        dir.path(),
        &["export", "pov", &scene("bench/anchor.toml"), "--terms", "specular:blinn-normalized", "-o", "n.pov"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let pov = std::fs::read_to_string(dir.path().join("n.pov")).unwrap();
    assert!(pov.contains("`specular:blinn-normalized` is written as the handout's `specular`"), "{pov}");
}

#[test]
fn export_pov_writes_the_handouts_mapping_and_lists_what_povray_cannot_do() {
    let dir = tempfile::tempdir().unwrap();
    let o = lancer(dir.path(), &["export", "pov", &scene("bench/anchor.toml"), "-o", "anchor.pov"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let pov = std::fs::read_to_string(dir.path().join("anchor.pov")).unwrap();
    // The mirror ball: spec 0.8, shine 0.9875 → phong 0.79, phong_size 80, reflection 0.8.
    assert!(pov.contains("phong 0.79 phong_size 80.00") || pov.contains("phong 0.79 phong_size 79.99"), "{pov}");
    // The glass: alpha 0.9 → transmit 0.9, diffuse 0.05 / (1 - 0.9) = 0.5, ior 1.5.
    assert!(pov.contains("rgbt <1, 1, 1, 0.9>") && pov.contains("interior { ior 1.5 }"), "{pov}");
    assert!(pov.contains("right -x*1.7777778") && pov.contains("max_trace_level 6"), "depth 5 is 6 levels: {pov}");
    for shape in ["plane {", "sphere {", "box {", "cylinder {", "cone {", "torus {"] {
        assert!(pov.contains(shape), "{shape}");
    }
    // The handout's refraction path and once-per-object shadows are not POV-Ray's: said so.
    assert!(pov.contains("`refraction:seed` crosses transparent objects unshaded"), "{pov}");
    assert!(pov.contains("shadows `transmissive` count a closed transparent object once"), "{pov}");
    // Glass traced inside with shadows to match is POV-Ray's own tracing.
    let model: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "..", "models", "traced.toml"].iter().collect();
    let model = model.display().to_string();
    let o = lancer(dir.path(), &["export", "pov", &scene("bench/anchor.toml"), "--model", &model, "-o", "t.pov"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let pov = std::fs::read_to_string(dir.path().join("t.pov")).unwrap();
    assert!(pov.contains("// Everything in the scene has a POV-Ray counterpart."), "{pov}");
    // A variant POV-Ray does not have: said in the file and on stderr.
    let o = lancer(dir.path(), &["export", "pov", &scene("variants/schlick.toml"), "-o", "s.pov"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let pov = std::fs::read_to_string(dir.path().join("s.pov")).unwrap();
    assert!(
        pov.contains("// Not expressible in POV-Ray")
            && pov.contains("`mirror:schlick` is written as the handout's `mirror`"),
        "{pov}"
    );
    assert!(stderr(&o).contains("warning: POV-Ray: `mirror:schlick`"), "{}", stderr(&o));
    // Image maps go beside the file.
    let o = lancer(dir.path(), &["export", "pov", &scene("patterns.toml"), "-o", "p.pov"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.path().join("p-texture-0.png").exists() && dir.path().join("p-texture-1.png").exists());
}

/// A running `lancer serve`, killed when dropped.
struct Studio {
    child: std::process::Child,
    port: u16,
    token: String,
    /// The server's standard output, kept open.
    _out: std::io::BufReader<std::process::ChildStdout>,
}

impl Drop for Studio {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn studio(dir: &Path, extra: &[&str]) -> Studio {
    use std::io::BufRead;
    let mut child = Command::new(env!("CARGO_BIN_EXE_lancer"))
        .args(["serve", "--no-open", "--port", "0", "--width", "96"])
        .args(extra)
        .current_dir(dir)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("lancer serve runs");
    let mut line = String::new();
    let mut out = std::io::BufReader::new(child.stdout.take().unwrap());
    out.read_line(&mut line).unwrap();
    let url = line.trim().strip_prefix("Lancer studio: ").unwrap_or_else(|| panic!("printed `{line}`")).to_owned();
    assert!(url.starts_with("http://127.0.0.1:"), "binds 127.0.0.1 by default: {url}");
    let port = url["http://127.0.0.1:".len()..].split('/').next().unwrap().parse().unwrap();
    let token = url.rsplit("token=").next().unwrap().to_owned();
    Studio { child, port, token, _out: out }
}

/// One raw HTTP/1.1 request; the status line and headers.
fn http(port: u16, request: &str) -> String {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.set_read_timeout(Some(std::time::Duration::from_secs(5))).unwrap();
    s.write_all(request.as_bytes()).unwrap();
    let mut out = Vec::new();
    let mut buf = [0u8; 4096];
    while let Ok(n) = s.read(&mut buf) {
        if n == 0 {
            break;
        }
        out.extend_from_slice(&buf[..n]);
        if out.windows(4).any(|w| w == b"\r\n\r\n") && !request.contains("Upgrade") {
            break;
        }
        if request.contains("Upgrade") && out.windows(4).any(|w| w == b"\r\n\r\n") {
            break;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[test]
fn the_studio_answers_only_localhost_with_its_token_and_origin() {
    let dir = tempfile::tempdir().unwrap();
    let s = studio(dir.path(), &[]);
    let (p, t) = (s.port, s.token.clone());
    let get = |path: &str, host: &str, cookie: Option<&str>| {
        let cookie = cookie.map(|c| format!("Cookie: lancer_token_{p}={c}\r\n")).unwrap_or_default();
        http(p, &format!("GET {path} HTTP/1.1\r\nHost: {host}\r\n{cookie}Connection: close\r\n\r\n"))
    };
    let local = format!("127.0.0.1:{p}");
    // DNS rebinding: another Host is refused, whatever else the request holds.
    assert!(get("/", &format!("evil.example:{p}"), Some(&t)).starts_with("HTTP/1.1 403"));
    assert!(get("/", "127.0.0.1", Some(&t)).starts_with("HTTP/1.1 403"), "the port is part of the Host");
    for host in [local.clone(), format!("localhost:{p}"), format!("[::1]:{p}")] {
        assert!(get("/", &host, None).starts_with("HTTP/1.1 401"), "{host}: no token, no page");
    }
    assert!(get("/", &local, Some("0123")).starts_with("HTTP/1.1 403"), "a wrong token");
    // The launch URL's token becomes a strict cookie.
    let r = get(&format!("/?token={t}"), &local, None);
    assert!(r.starts_with("HTTP/1.1 303"), "{r}");
    let cookie = r.lines().find(|l| l.to_ascii_lowercase().starts_with("set-cookie:")).unwrap().to_owned();
    assert!(cookie.contains("HttpOnly") && cookie.contains("SameSite=Strict") && cookie.contains(&t), "{cookie}");
    let page = get("/", &local, Some(&t));
    assert!(page.starts_with("HTTP/1.1 200"), "{page}");
    let lower = page.to_ascii_lowercase();
    assert!(lower.contains("content-security-policy: default-src 'self'"), "{page}");
    assert!(!lower.contains("access-control-allow"), "no CORS headers");
    // No route reads a path a client names.
    for path in ["/../Cargo.toml", "/scenes/showcase.toml", "/app.js/../../README.md", "/%2e%2e/etc/passwd"] {
        let r = get(path, &local, Some(&t));
        assert!(r.starts_with("HTTP/1.1 404") || r.starts_with("HTTP/1.1 400"), "{path}: {r}");
    }
    // The WebSocket upgrade wants the page's own Origin.
    let upgrade = |origin: &str| {
        http(
            p,
            &format!(
                "GET /ws HTTP/1.1\r\nHost: {local}\r\nCookie: lancer_token_{p}={t}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n\
                 Sec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nOrigin: {origin}\r\n\r\n"
            ),
        )
    };
    assert!(upgrade("http://evil.example").starts_with("HTTP/1.1 403"));
    assert!(
        upgrade(&format!("http://localhost:{}", p + 1)).starts_with("HTTP/1.1 403"),
        "another port is another origin"
    );
    assert!(upgrade(&format!("http://{local}")).starts_with("HTTP/1.1 101"));
    // A bad address is refused.
    let o = Command::new(env!("CARGO_BIN_EXE_lancer"))
        .args(["serve", "--no-open", "--port", "0", "--host", "256.0.0.1"])
        .output()
        .unwrap();
    assert!(!o.status.success(), "a bad address is refused");
    // Meshes and textures only from under the scene's folder.
    std::fs::create_dir_all(dir.path().join("sub")).unwrap();
    std::fs::write(dir.path().join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    std::fs::write(
        dir.path().join("sub/s.toml"),
        "[camera]\nfrom = [0, 0, -5]\nto = [0, 0, 0]\n[[objects]]\nshape = \"mesh\"\npath = \"../tri.obj\"\n",
    )
    .unwrap();
    let o = lancer(dir.path(), &["serve", "sub/s.toml", "--no-open", "--port", "0"]);
    assert!(!o.status.success() && stderr(&o).contains("outside the scene's folder"), "{}", stderr(&o));
    assert!(lancer(dir.path(), &["check", "sub/s.toml"]).status.success(), "render and check may read it");
}

#[test]
fn serve_refuses_a_bad_allow_host_and_answers_to_a_good_one() {
    use std::io::BufRead;
    let serve = |extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_lancer"))
            .args(["serve", "--no-open", "--port", "0"])
            .args(extra)
            .output()
            .unwrap()
    };
    for (bad, says) in [
        ("lab pc", "space"),
        ("lab-pc.local:8470", "port"),
        ("http://lab-pc.local", "path"),
        ("lab_pc.local", "`_`"),
        ("", "empty"),
    ] {
        let o = serve(&["--allow-host", bad]);
        let e = stderr(&o);
        assert!(!o.status.success() && e.contains("--allow-host") && e.contains(says), "{bad:?}: {e}");
        assert!(o.stdout.is_empty(), "{bad:?}: nothing is served");
    }
    let o = serve(&["--read-only", "--allow-save"]);
    assert!(!o.status.success() && stderr(&o).contains("--allow-save"), "{}", stderr(&o));
    // A good name is printed after the address, and answered to.
    let dir = tempfile::tempdir().unwrap();
    let mut s = studio(dir.path(), &["--allow-host", "Lab-PC.local", "--read-only"]);
    let (p, t) = (s.port, s.token.clone());
    let mut line = String::new();
    s._out.read_line(&mut line).unwrap();
    assert_eq!(line.trim_end(), format!("  also: http://lab-pc.local:{p}/?token={t}"));
    let get = |host: &str| {
        http(p, &format!("GET / HTTP/1.1\r\nHost: {host}\r\nCookie: lancer_token_{p}={t}\r\nConnection: close\r\n\r\n"))
    };
    assert!(get(&format!("lab-pc.local:{p}")).starts_with("HTTP/1.1 200"));
    assert!(get(&format!("other-pc.local:{p}")).starts_with("HTTP/1.1 403"));
}

/// A client's WebSocket session on `s`: upgraded, with the first (hello) message read.
struct Socket(std::net::TcpStream);

impl Socket {
    fn open(s: &Studio) -> (Socket, serde_json::Value) {
        use std::io::{Read, Write};
        let mut tcp = std::net::TcpStream::connect(("127.0.0.1", s.port)).unwrap();
        tcp.set_read_timeout(Some(std::time::Duration::from_secs(20))).unwrap();
        let local = format!("127.0.0.1:{}", s.port);
        write!(
            tcp,
            "GET /ws HTTP/1.1\r\nHost: {local}\r\nCookie: lancer_token_{}={}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n\
             Sec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nOrigin: http://{local}\r\n\r\n",
            s.port, s.token
        )
        .unwrap();
        let mut head = Vec::new();
        let mut byte = [0u8; 1];
        while !head.ends_with(b"\r\n\r\n") {
            tcp.read_exact(&mut byte).unwrap();
            head.push(byte[0]);
        }
        assert!(head.starts_with(b"HTTP/1.1 101"));
        let mut socket = Socket(tcp);
        let hello = loop {
            let (op, data) = socket.read().expect("the hello");
            if op == 1 {
                break serde_json::from_slice(&data).unwrap();
            }
        };
        (socket, hello)
    }

    /// The next message: (opcode, payload); `None` once closed.
    fn read(&mut self) -> Option<(u8, Vec<u8>)> {
        use std::io::Read;
        let mut h = [0u8; 2];
        self.0.read_exact(&mut h).ok()?;
        let mut len = (h[1] & 127) as u64;
        if len == 126 {
            let mut b = [0u8; 2];
            self.0.read_exact(&mut b).ok()?;
            len = u16::from_be_bytes(b) as u64;
        } else if len == 127 {
            let mut b = [0u8; 8];
            self.0.read_exact(&mut b).ok()?;
            len = u64::from_be_bytes(b);
        }
        let mut data = vec![0u8; len as usize];
        self.0.read_exact(&mut data).ok()?;
        (h[0] & 15 != 8).then_some((h[0] & 15, data))
    }

    /// Sends a masked text message.
    fn send(&mut self, text: &[u8]) -> std::io::Result<()> {
        use std::io::Write;
        let mut frame = vec![0x81u8];
        let n = text.len();
        if n < 126 {
            frame.push(0x80 | n as u8);
        } else if n < 65536 {
            frame.push(0x80 | 126);
            frame.extend_from_slice(&(n as u16).to_be_bytes());
        } else {
            frame.push(0x80 | 127);
            frame.extend_from_slice(&(n as u64).to_be_bytes());
        }
        let mask = [7u8, 21, 42, 99];
        frame.extend_from_slice(&mask);
        frame.extend(text.iter().enumerate().map(|(i, b)| b ^ mask[i % 4]));
        self.0.write_all(&frame)
    }

    /// The header of the next complete full frame (skipping other messages).
    fn full_frame(&mut self) -> serde_json::Value {
        loop {
            let (op, data) = self.read().expect("a frame");
            if op != 2 {
                continue;
            }
            let len = u32::from_le_bytes(data[..4].try_into().unwrap()) as usize;
            let header: serde_json::Value = serde_json::from_slice(&data[4..4 + len]).unwrap();
            let last = header["offset"].as_u64().unwrap() + header["count"].as_u64().unwrap()
                == header["total"].as_u64().unwrap();
            if header["coarse"] == false && last {
                return header;
            }
        }
    }
}

fn resident_mb(pid: u32) -> f64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let kb: f64 =
        status.lines().find(|l| l.starts_with("VmRSS:")).unwrap().split_whitespace().nth(1).unwrap().parse().unwrap();
    kb / 1000.0
}

#[test]
fn a_storm_of_edits_from_two_tabs_renders_the_newest_and_keeps_memory_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let s = studio(dir.path(), &[]);
    let (mut a, hello) = Socket::open(&s);
    let (mut b, _) = Socket::open(&s);
    let first = a.full_frame();
    let rss_before = resident_mb(s.child.id());
    let mut state = hello["state"].clone();
    let started = std::time::Instant::now();
    for i in 0..400 {
        state["materials"][1]["diff"] = serde_json::json!((i % 100) as f64 / 100.0);
        let tab = if i % 2 == 0 { &mut a } else { &mut b };
        tab.send(state.to_string().as_bytes()).unwrap();
    }
    let sent = started.elapsed();
    // The server answers at once in the middle of it.
    let t = std::time::Instant::now();
    let page = http(
        s.port,
        &format!(
            "GET /app.css HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nCookie: lancer_token_{}={}\r\nConnection: close\r\n\r\n",
            s.port, s.port, s.token
        ),
    );
    assert!(page.starts_with("HTTP/1.1 200") && t.elapsed() < std::time::Duration::from_secs(5), "responsive");
    // Both tabs end on the newest edit's full image; far fewer renders than edits were made.
    let newest = first["generation"].as_u64().unwrap() + 400;
    for tab in [&mut a, &mut b] {
        loop {
            let h = tab.full_frame();
            if h["generation"].as_u64() == Some(newest) {
                break;
            }
            assert!(h["generation"].as_u64().unwrap() < newest);
        }
    }
    let rss_after = resident_mb(s.child.id());
    assert!(
        rss_after < rss_before + 200.0,
        "memory {rss_before:.0} MB -> {rss_after:.0} MB after 400 edits in {sent:?}"
    );
    // An oversized message closes that connection, and only that one.
    let (mut c, _) = Socket::open(&s);
    c.0.set_read_timeout(Some(std::time::Duration::from_secs(8))).unwrap();
    let sent = std::time::Instant::now();
    let _ = c.send(&vec![b' '; 300 * 1024]);
    while c.read().is_some() {}
    assert!(sent.elapsed() < std::time::Duration::from_secs(6), "closed by the server, not a read timeout");
    state["materials"][1]["diff"] = serde_json::json!(0.42);
    a.send(state.to_string().as_bytes()).unwrap();
    assert_eq!(a.full_frame()["generation"].as_u64(), Some(newest + 1));
}

#[test]
fn the_studio_saves_edits_into_the_scene_text_keeping_its_comments() {
    let dir = tempfile::tempdir().unwrap();
    let original = std::fs::read_to_string(scene("showcase.toml")).unwrap();
    std::fs::write(dir.path().join("s.toml"), &original).unwrap();
    let request = |s: &Studio, method: &str, path: &str| {
        http(
            s.port,
            &format!(
                "{method} {path} HTTP/1.1\r\nHost: 127.0.0.1:{0}\r\nCookie: lancer_token_{0}={1}\r\nOrigin: http://127.0.0.1:{0}\r\nContent-Length: 0\r\nConnection: close\r\n\r\n",
                s.port, s.token
            ),
        )
    };
    {
        let s = studio(dir.path(), &["s.toml"]);
        assert!(request(&s, "POST", "/api/save").starts_with("HTTP/1.1 403"), "no --allow-save, no writing");
    }
    let s = studio(dir.path(), &["s.toml", "--allow-save"]);
    let (mut ws, hello) = Socket::open(&s);
    ws.full_frame();
    let mut state = hello["state"].clone();
    // Materials in file order: the showcase's first is the floor.
    assert_eq!(state["materials"][0]["label"], "floor");
    state["materials"][0]["diff"] = serde_json::json!(0.3);
    state["model"]["terms"][2]["variant"] = serde_json::json!("blinn");
    ws.send(state.to_string().as_bytes()).unwrap();
    ws.full_frame();
    let body = |r: String| r.split("\r\n\r\n").nth(1).unwrap_or_default().to_owned();
    let download = request(&s, "GET", "/api/scene.toml");
    assert!(download.to_ascii_lowercase().contains("attachment; filename=\"s.toml\""), "{download}");
    let text = body(download);
    assert!(text.contains("\"specular:blinn\""), "{text}");
    // Comments and the untouched lines stay as they were.
    for line in original.lines().filter(|l| l.starts_with('#') || l.starts_with("[[objects]]")) {
        assert!(text.contains(line), "lost: {line}");
    }
    let foreign = http(
        s.port,
        &format!(
            "POST /api/save HTTP/1.1\r\nHost: 127.0.0.1:{0}\r\nCookie: lancer_token_{0}={1}\r\nOrigin: http://127.0.0.1:{2}\r\nContent-Length: 0\r\nConnection: close\r\n\r\n",
            s.port,
            s.token,
            s.port + 1
        ),
    );
    assert!(foreign.starts_with("HTTP/1.1 403"), "a page on another port cannot save: {foreign}");
    let saved = request(&s, "POST", "/api/save");
    assert!(saved.starts_with("HTTP/1.1 200"), "{saved}");
    let on_disk = std::fs::read_to_string(dir.path().join("s.toml")).unwrap();
    // The saved scene loads and holds the edit.
    let o = lancer(dir.path(), &["render", "s.toml", "--width", "32", "-o", "x.png", "-q", "--stats-json", "st.json"]);
    assert!(o.status.success(), "{}\n{on_disk}", stderr(&o));
    let stats: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.path().join("st.json")).unwrap()).unwrap();
    assert_eq!(stats["model"]["terms"][2]["variant"], "blinn");
    let floor = on_disk.split("[materials.floor]").nth(1).unwrap().split("\n[").next().unwrap();
    assert!(floor.contains("diff = 0.3"), "{floor}");
}

#[test]
fn regression_a_part_header_claiming_billions_is_refused_before_anything_is_sized() {
    // Found in review: a 100-byte part claiming count = 4e9 made merge allocate billions.
    let dir = tempfile::tempdir().unwrap();
    let sources = r#""sources":{"scene":"0000000000000000","model_file":null,"files":[],"model":"0000000000000000","image":"0000000000000000","version":"0.0.0"}"#;
    for figures in [
        r#""width":64,"height":36,"samples":1,"model":"m","index":0,"count":4000000000,"band_rows":16"#,
        r#""width":4000000000,"height":36,"samples":1,"model":"m","index":0,"count":1,"band_rows":16"#,
        r#""width":64,"height":36,"samples":1,"model":"m","index":0,"count":1,"band_rows":7"#,
    ] {
        let header = format!(
            r#"{{"identity":"0000000000000000",{sources},"scene":"s",{figures},"layers":["ambient"],"rays":[0,0,0],"seconds":0}}"#
        );
        std::fs::write(dir.path().join("p.lpart"), format!("LANCER-PART 2\n{header}\n")).unwrap();
        let o = lancer(dir.path(), &["merge", "p.lpart", "-o", "out.png"]);
        assert!(!o.status.success() && stderr(&o).contains("names no valid part"), "{}", stderr(&o));
        assert!(!dir.path().join("out.png").exists());
    }
}

/// A part file's three pieces: its first line, its header, its pixels.
fn split_part(bytes: &[u8]) -> (&[u8], serde_json::Value, &[u8]) {
    let first = bytes.iter().position(|&b| b == b'\n').unwrap() + 1;
    let end = first + bytes[first..].iter().position(|&b| b == b'\n').unwrap();
    (&bytes[..first], serde_json::from_slice(&bytes[first..end]).unwrap(), &bytes[end + 1..])
}

fn join_part(magic: &[u8], header: &serde_json::Value, pixels: &[u8]) -> Vec<u8> {
    let mut out = magic.to_vec();
    out.extend(serde_json::to_vec(header).unwrap());
    out.push(b'\n');
    out.extend(pixels);
    out
}

/// Every file under `dir`, relative to it.
fn tree(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                todo.push(p);
            } else {
                out.push(p.strip_prefix(dir).unwrap().display().to_string());
            }
        }
    }
    out.sort();
    out
}

#[test]
fn regression_merge_refuses_part_headers_whose_layers_are_paths_or_lancers_own_files() {
    // Found in review: a part whose layers were `../escaped` or an absolute path made
    // `merge --aov DIR` write and overwrite images outside DIR, with exit 0.
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("work");
    std::fs::create_dir(&dir).unwrap();
    let outside = root.path().join("outside");
    for (i, s) in [(0, "glass.toml"), (1, "glass.toml"), (2, "mirrors.toml")] {
        let part = if s == "glass.toml" { format!("{i}/2") } else { "1/2".to_owned() };
        let o =
            lancer(&dir, &["render", &scene(s), "--width", "48", "--tile", &part, "-o", &format!("p{i}.lpart"), "-q"]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let before = tree(root.path());
    let read = |n: &str| std::fs::read(dir.join(n)).unwrap();
    let (p0, p1, m1) = (read("p0.lpart"), read("p1.lpart"), read("p2.lpart"));
    let abs = format!("{}", outside.display());
    /// A change to both parts' headers or to the second's only, and what merge must say.
    type Edit<'a> = (bool, Box<dyn Fn(&mut serde_json::Value) + 'a>, &'a str);
    let edits: Vec<Edit> = vec![
        (true, Box::new(|h| h["layers"][0] = "../escaped".into()), "names a layer `../escaped`"),
        (true, Box::new(|h| h["layers"][0] = abs.clone().into()), "names a layer `/"),
        (true, Box::new(|h| h["layers"][0] = "beauty".into()), "names a layer `beauty`"),
        (true, Box::new(|h| h["layers"][0] = "manifest".into()), "names a layer `manifest`"),
        (true, Box::new(|h| h["layers"][0] = "a\u{1b}[31m".into()), "names a layer `a\\u{1b}[31m`"),
        (true, Box::new(|h| h["layers"][1] = h["layers"][0].clone()), "names the layer `ambient` twice"),
        (false, Box::new(|h| h["layers"][0] = "rim".into()), "has the layers rim, diffuse"),
        (false, Box::new(|h| h["identity"] = "0123456789abcdef".into()), "not its sources'"),
        (false, Box::new(|h| h["scene"] = "s\u{1b}]0;pwned\u{7}".into()), "control characters"),
        (
            false,
            Box::new(|h| {
                let (_, m, _) = split_part(&m1);
                h["sources"] = m["sources"].clone();
                h["identity"] = m["identity"].clone();
            }),
            "they differ in the scene file's text",
        ),
    ];
    for (both, edit, says) in &edits {
        let mut parts = Vec::new();
        for (k, bytes) in [&p0, &p1].into_iter().enumerate() {
            let (magic, mut header, pixels) = split_part(bytes);
            if *both || k == 1 {
                edit(&mut header);
            }
            parts.push(join_part(magic, &header, pixels));
        }
        std::fs::write(dir.join("h0.lpart"), &parts[0]).unwrap();
        std::fs::write(dir.join("h1.lpart"), &parts[1]).unwrap();
        let o = lancer(&dir, &["merge", "h0.lpart", "h1.lpart", "-o", "out.png", "--aov", "aov"]);
        assert_eq!(o.status.code(), Some(1), "{says}: {}", stderr(&o));
        assert!(stderr(&o).contains(says), "{says}: {}", stderr(&o));
        std::fs::remove_file(dir.join("h0.lpart")).unwrap();
        std::fs::remove_file(dir.join("h1.lpart")).unwrap();
        assert_eq!(tree(root.path()), before, "{says}: merge wrote something");
    }
    // The parts as rendered still merge.
    let o = lancer(&dir, &["merge", "p0.lpart", "p1.lpart", "-o", "out.png", "--aov", "aov", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A checkered floor and a glass ball, every position moved by `offset`.
fn moved_scene(offset: [f64; 3]) -> String {
    let at = |p: [f64; 3]| format!("[{:?}, {:?}, {:?}]", p[0] + offset[0], p[1] + offset[1], p[2] + offset[2]);
    format!(
        "[image]\nwidth = 64\nheight = 36\n[camera]\nfrom = {}\nto = {}\nfov = 40\n[model]\nshadows = \"transmissive\"\n\
         [[lights]]\nat = {}\n\
         [[objects]]\nshape = \"plane\"\ntranslate = {}\n\
         material = {{ color = {{ pattern = \"checker\", colors = [[0.9, 0.9, 0.9], [0.15, 0.2, 0.3]], scale = 0.5 }} }}\n\
         [[objects]]\nshape = \"sphere\"\ntranslate = {}\n\
         material = {{ color = [0.95, 0.97, 1.0], diff = 0.05, alpha = 0.85, n = 1.5 }}\n",
        at([0.0, 2.5, -8.0]),
        at([0.0, 0.8, 0.0]),
        at([-3.0, 8.0, -5.0]),
        at([0.0, 0.0, 0.0]),
        at([-1.2, 1.0, -1.5]),
    )
}

/// Every point of an explanation's tree (ray origins, hit points, point notes), in order.
fn points(ray: &serde_json::Value, out: &mut Vec<(String, [f64; 3])>) {
    let xyz = |v: &serde_json::Value| -> [f64; 3] { std::array::from_fn(|a| v[a].as_f64().expect("a number")) };
    out.push(("origin".into(), xyz(&ray["origin"])));
    if !ray["hit"].is_null() {
        out.push(("hit".into(), xyz(&ray["hit"]["point"])));
    }
    for term in ray["terms"].as_array().unwrap() {
        for note in term["notes"].as_array().unwrap() {
            let name = note["name"].as_str().unwrap();
            if name.starts_with("I (") || name.starts_with("J (") {
                out.push((name.to_owned(), xyz(&note["value"])));
            }
        }
    }
    for child in ray["children"].as_array().unwrap() {
        points(child, out);
    }
}

#[test]
fn explain_json_of_a_scene_far_from_the_origin_gives_world_coordinates() {
    // The render works from the camera (camera-relative, in f32); explain adds the camera's
    // position back, in f64: the same tree as at the origin, moved by the offset.
    let dir = tempfile::tempdir().unwrap();
    let offset = [1e6, -2e5, 7e5];
    let mut trees = Vec::new();
    for (name, offset) in [("near.toml", [0.0; 3]), ("far.toml", offset)] {
        std::fs::write(dir.path().join(name), moved_scene(offset)).unwrap();
        // A pixel through the glass ball: its entry I and exit J are noted.
        let o = lancer(dir.path(), &["explain", name, "--pixel", "40,22", "--json"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("explain --json prints JSON");
        let mut list = Vec::new();
        points(&doc["rays"][0], &mut list);
        trees.push(list);
    }
    let (near, far) = (&trees[0], &trees[1]);
    assert!(near.iter().any(|(name, _)| name == "J (exit)"), "the pixel goes through the ball: {near:?}");
    assert_eq!(far[0], ("origin".to_owned(), [1e6, -2e5 + 2.5, 7e5 - 8.0]), "the camera ray starts at `from`");
    assert_eq!(near.len(), far.len(), "the same tree: {near:?}\n{far:?}");
    for ((what, a), (other, b)) in near.iter().zip(far) {
        assert_eq!(what, other);
        for axis in 0..3 {
            assert!((b[axis] - offset[axis] - a[axis]).abs() < 1e-4, "{what}: {b:?} is not {a:?} moved by {offset:?}");
        }
    }
}

#[test]
fn export_pov_of_a_scene_far_from_the_origin_writes_world_coordinates() {
    // The prepared scene is measured from the camera; the export adds the camera's position
    // back, with the scene file's own numbers.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("far.toml"), moved_scene([1e6, -2e5, 7e5])).unwrap();
    let o = lancer(dir.path(), &["export", "pov", "far.toml", "-o", "far.pov"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let pov = std::fs::read_to_string(dir.path().join("far.pov")).unwrap();
    for line in [
        "location <1000000, -199997.5, 699992>",
        "light_source { <999997, -199992, 699995>",
        "matrix <1, 0, 0, 0, 1, 0, 0, 0, 1, 1000000, -200000, 700000>",
        "matrix <1, 0, 0, 0, 1, 0, 0, 0, 1, 999998.8, -199999, 699998.5>",
    ] {
        assert!(pov.contains(line), "{line}: {pov}");
    }
}

#[test]
fn explain_names_objects_and_materials_as_the_file_does() {
    // Materials are stored alphabetically ("aaa" before "zinc") while objects keep file order:
    // the explanation names both as the file writes them, never by a table index.
    let dir = tempfile::tempdir().unwrap();
    let src = "[camera]\nfrom = [0, 0, -5]\nto = [0, 0, 0]\n[image]\nwidth = 40\nheight = 20\n\
               [[lights]]\nat = [0, 5, -5]\n\
               [materials.zinc]\ncolor = [0.6, 0.6, 0.7]\n\
               [materials.aaa]\ncolor = [1, 0, 0]\n\
               [[objects]]\nshape = \"sphere\"\ntranslate = [-30, 0, 0]\nmaterial = \"aaa\"\n\
               [[objects]]\nshape = \"sphere\"\ntranslate = [0, 0, 0]\nmaterial = \"zinc\"\n\
               [[objects]]\nshape = \"sphere\"\ntranslate = [30, 0, 0]\nmaterial = { color = [0, 1, 0] }\n";
    std::fs::write(dir.path().join("names.toml"), src).unwrap();
    // The line of the second `[[objects]]` entry, counted here from the text itself.
    let line = src.lines().enumerate().filter(|(_, l)| *l == "[[objects]]").nth(1).unwrap().0 + 1;
    let o = lancer(dir.path(), &["explain", "names.toml", "--pixel", "20,10"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    let want = format!("hits object 2 (sphere, names.toml:{line}), material \"zinc\", at t = ");
    assert!(text.contains(&want), "wanted `{want}` in:\n{text}");
    let o = lancer(dir.path(), &["explain", "names.toml", "--pixel", "20,10", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("explain --json prints JSON");
    let hit = &doc["rays"][0]["hit"];
    assert_eq!(hit["object"], 2, "objects are numbered from 1 in file order");
    assert_eq!(hit["object_name"], format!("object 2 (sphere, names.toml:{line})"));
    assert_eq!(hit["material_name"], "zinc");
}

#[test]
fn regression_a_mistyped_subcommand_was_taken_for_a_scene_file() {
    // Found in use: `lancer chek x.toml` said "the subcommand 'x.toml' cannot be used with
    // '[SCENE]'", `lancer serv` "reading scene serv".
    let dir = tempfile::tempdir().unwrap();
    for (typed, meant) in [
        (&["chek", "x.toml"][..], "check"),
        (&["explian", "--pixel", "1,1"], "explain"),
        (&["rendr"], "render"),
        (&["serv"], "serve"),
        (&["--width", "8", "-q", "-o", "x.png", "rendr"], "render"),
    ] {
        let o = lancer(dir.path(), typed);
        assert_eq!(o.status.code(), Some(2), "{typed:?}: {}", stderr(&o));
        let word = typed.iter().find(|w| w.len() > 3 && !w.starts_with('-') && !w.contains('.')).unwrap();
        assert_eq!(stderr(&o), format!("error: unknown subcommand '{word}' — did you mean '{meant}'?\n"), "{typed:?}");
    }
    // Neither a file nor close to a subcommand: the scene is missing, and these are the
    // subcommands.
    let o = lancer(dir.path(), &["nothing.toml"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("scene file `nothing.toml` not found"), "{}", stderr(&o));
    assert!(stderr(&o).contains("the subcommands: render, watch, check, explain"), "{}", stderr(&o));
    assert!(files(dir.path()).is_empty(), "nothing rendered");
    // A file of such a name is a scene.
    std::fs::copy(scene("glass.toml"), dir.path().join("chek")).unwrap();
    let o = lancer(dir.path(), &["chek", "--width", "8", "-q", "-o", "x.png"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(files(dir.path()), ["chek", "x.png"]);
}

#[test]
fn regression_a_file_with_several_errors_told_only_one() {
    let dir = tempfile::tempdir().unwrap();
    let src = "[camera]\nfrom = [0, 0, -5]\nto = [0, 0, 0]\n[model]\nterms = [\"ambient\", \"specullar\"]\n\
               [[objects]]\nshape = \"spere\"\n[[objects]]\nshape = \"sphere\"\nmaterial = \"nope\"\n";
    std::fs::write(dir.path().join("bad.toml"), src).unwrap();
    for command in ["check", "render"] {
        let o = lancer(dir.path(), &[command, "bad.toml"]);
        assert_eq!(o.status.code(), Some(1));
        let err = stderr(&o);
        let at: Vec<usize> =
            ["bad.toml:5:21: unknown term", "bad.toml:7:9: unknown shape", "bad.toml:10:12: unknown material"]
                .iter()
                .map(|says| err.find(says).unwrap_or_else(|| panic!("{command} says `{says}`:\n{err}")))
                .collect();
        assert!(at.is_sorted() && at[0] == "error: ".len(), "in file order, the first after `error: `:\n{err}");
    }
}

#[test]
fn regression_terms_flag_errors_suggested_the_scene_file_syntax() {
    // `--terms diffuse:lambert:roughness=3` was told `{ term = "diffuse", variant = ... }`.
    let dir = tempfile::tempdir().unwrap();
    for given in ["ambient,diffuse:lambert:roughness=3", "ambient,diffuse:roughness=3"] {
        let o = lancer(dir.path(), &["check", "--terms", given]);
        assert_eq!(o.status.code(), Some(1));
        let err = stderr(&o);
        assert!(
            err.contains("variant oren-nayar of `diffuse` takes `roughness`: diffuse:oren-nayar:roughness=3"),
            "{given}: {err}"
        );
        assert!(!err.contains("term = "), "{given}: {err}");
    }
}

#[test]
fn regression_a_part_without_o_was_written_as_render_png() {
    // `--tile` without `-o` wrote a part file named `render.png`, which no viewer opens.
    let dir = tempfile::tempdir().unwrap();
    for part in ["0/2", "1/2"] {
        let o = lancer(dir.path(), &["render", "--width", "32", "--tile", part, "-q"]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert_eq!(files(dir.path()), ["render-0.lpart", "render-1.lpart"]);
    let o = lancer(dir.path(), &["merge", "render-0.lpart", "render-1.lpart", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(image::open(dir.path().join("render.png")).unwrap().width(), 32);
    // Named as an image, a part is refused before the render.
    let o = lancer(dir.path(), &["render", "--width", "32", "--tile", "0/2", "-o", "part.png"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("with --tile, -o names a part file"), "{}", stderr(&o));
    assert!(!dir.path().join("part.png").exists());
}

#[cfg(unix)]
#[test]
fn regression_o_dev_null_was_refused_for_its_missing_extension() {
    // `-o /dev/null` (to time a render, or check it runs) said the output must end in .png; and
    // the temporary file renamed over the path would have replaced the device.
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    for args in [
        &["render", "--width", "16", "-o", "/dev/null", "-q"][..],
        &["render", "--width", "16", "-o", "/dev/null", "--stats-json", "/dev/null", "-q"],
        &["render", "--width", "16", "--tile", "0/1", "-o", "/dev/null", "-q"],
    ] {
        let o = lancer(dir.path(), args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    }
    assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device(), "/dev/null is still a device");
    assert!(files(dir.path()).is_empty(), "{:?}", files(dir.path()));
    // A pipe gets the PNG as it is written.
    let o = lancer(dir.path(), &["render", "--width", "16", "-o", "/dev/stdout", "-q"]);
    assert!(o.status.success() && o.stdout.starts_with(b"\x89PNG"), "{}", stderr(&o));
    assert_eq!(image::load_from_memory(&o.stdout).unwrap().width(), 16);
}

#[test]
fn regression_shipped_scenes_warned_on_their_own() {
    // Found in use: `lancer check` warned about four shipped scenes (refraction listed with
    // nothing transparent; a lens reaching into its stand), teaching that warnings are noise.
    let root: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "..", "scenes"].iter().collect();
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|e| e == "toml") {
                out.push(p);
            }
        }
    }
    let mut scenes = Vec::new();
    walk(&root, &mut scenes);
    assert!(scenes.len() > 20, "{} scenes", scenes.len());
    let dir = tempfile::tempdir().unwrap();
    let noisy: Vec<String> = scenes
        .iter()
        .filter_map(|path| {
            let o = lancer(dir.path(), &["check", &path.display().to_string()]);
            let said = format!("{}{}", String::from_utf8_lossy(&o.stdout), stderr(&o));
            (!o.status.success() || said.contains("warning:") || !said.ends_with("\n0 warnings\n")).then_some(said)
        })
        .collect();
    assert!(noisy.is_empty(), "{}", noisy.join("\n"));
}

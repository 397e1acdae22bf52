//! `cargo xtask`: project chores that need more than cargo: the HTML render gallery (and its
//! check in a real browser) and plain per-scene renders.

mod bench;
mod compare;
mod course;
mod embree;
mod fuzz;
mod gallery;
mod portable;
mod studio;
mod web;
mod web_check;
mod webdriver;

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};

const USAGE: &str = "usage: cargo xtask <task> [options]

tasks:
  bench [--runs N] [--only web|embree|meshes|aa|glass]
            Lancer against POV-Ray 3.7 (when installed) on scenes/bench/anchor, 1 and 2 threads;
            render cost against the number of objects and triangles; the 1M-triangle field
            against Embree 3 (when libembree-dev is installed); the browser build in Chromium
            (when target/web is built); the targets, met or not
  compare [--width W] [--min-psnr DB] SCENE... [-- LANCER FLAGS]
            export each scene for POV-Ray 3.7 (with the flags, e.g. --terms), render it with both, and write both images, their
            difference and a page to target/compare/<scene>/; prints PSNR and the share of
            pixels that differ visibly, failing below --min-psnr (says so and stops when POV-Ray
            is not installed)
  course
            the course folder for students, target/course/: the scenes of course/ (each checked
            free of warnings), their reference images per term (PNG and EXR), the sheets of
            course/sheets/ (lancer sheet) and a README (docs/course.md is the teacher's text)
  course-check
            the starter crate's harness both ways: course/starter's tests must fail as shipped,
            name specular:exponent-shine for a term with that mistake, and pass with the
            solution kept in xtask/course-solution/
  fuzz [--runs N] [--seed S]
            mutate the scenes in scenes/ (lines, numbers, junk tokens and tables) and load, prepare
            and render each in-process; any panic, hang, unlocated error or NaN is written to
            target/fuzz/ (default 2000 runs, seed 1)
  gallery [--width W] [--samples N] [--shard I/N] [FILTER]
            render every scene in scenes/ (or those whose path contains FILTER) with its per-term
            images, and the comparison sheets of sheets/ (lancer sheet, at their own size), into
            target/gallery/index.html; with --shard, only every N-th render from the I-th (for
            several machines), recorded for gallery-merge
  studio-check [--screenshot FILE]
            lancer serve in Chromium through chromedriver: sliders, switches, variants, the
            inspector and a broken save, each checked; a screenshot (default docs/studio.png)
  gallery-merge
            the page from every shard's record in target/gallery/shards/
  gallery-check [--screenshot FILE]
            open target/gallery/index.html in headless Chromium; fail if any image did not load;
            save a screenshot (default target/gallery/screenshot.png)
  portable-check [--width W] [FILTER]
            render every scene (default 160 wide) with the renderer built for this processor and
            with the portable x86-64 build; fail unless every EXR they write has the same bytes
  web [--out DIR]
            the browser build: lancer-wasm for wasm32-unknown-unknown (with and without SIMD), the
            studio page set to render in the page, every shipped scene, into target/web/ (any
            static web server serves it); installs wasm-bindgen-cli at the crate's version into
            target/tools when missing
  web-check [--screenshots DIR]
            target/web served on loopback in headless Chromium (no other host reachable): every
            shipped scene's layers against the native render's bits, a slider, a broken edit, an
            EXR download, a dropped scene with an OBJ, a share link; screenshots at 1024x768 and
            1920x1080 (default docs/web-WxH.png)
  renders [--width W] [FILTER]
            every scene's per-term images into target/renders/<scene>/";

fn main() {
    if let Err(e) = run(std::env::args().skip(1).collect()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// The program `name` on the PATH, if any.
pub fn which(name: &str) -> Option<PathBuf> {
    std::env::var_os("PATH")?.to_str()?.split(':').map(|d| Path::new(d).join(name)).find(|p| p.is_file())
}

/// The repository's root folder.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask/ sits in the root").to_path_buf()
}

fn run(args: Vec<String>) -> Result<()> {
    match args.first().map(String::as_str) {
        Some("bench") => bench::run(&args[1..]),
        Some("compare") => compare::run(&args[1..]),
        Some("course") => course::build(&args[1..]),
        Some("course-check") => course::check(&args[1..]),
        Some("fuzz") => fuzz::run(&args[1..]),
        Some("gallery") => gallery::build(&args[1..]),
        Some("gallery-check") => gallery::check(&args[1..]),
        Some("gallery-merge") => gallery::merge(&args[1..]),
        Some("portable-check") => portable::run(&args[1..]),
        Some("studio-check") => studio::check(&args[1..]),
        Some("renders") => renders(&args[1..]),
        Some("web") => web::build(&args[1..]),
        Some("web-check") => web_check::check(&args[1..]),
        Some("-h" | "--help") | None => {
            println!("{USAGE}");
            Ok(())
        }
        Some(other) => bail!("unknown task `{other}`\n{USAGE}"),
    }
}

/// Every scene file under `scenes/`, sorted, keeping those whose path contains `filter`.
pub fn scenes(filter: Option<&str>) -> Result<Vec<PathBuf>> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
        for entry in std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))? {
            let p = entry?.path();
            if p.is_dir() {
                walk(&p, out)?;
            } else if p.extension().is_some_and(|e| e == "toml") {
                out.push(p);
            }
        }
        Ok(())
    }
    let mut list = Vec::new();
    walk(&root().join("scenes"), &mut list)?;
    list.sort();
    list.retain(|p| filter.is_none_or(|f| p.to_string_lossy().contains(f)));
    if list.is_empty() {
        bail!("no scene matches `{}`", filter.unwrap_or_default());
    }
    Ok(list)
}

/// Builds the release renderer and returns its path (under `CARGO_TARGET_DIR` when it is set,
/// where cargo puts it).
pub fn build_renderer() -> Result<PathBuf> {
    let status = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
        .args(["build", "--release", "--package", "lancer-cli"])
        .current_dir(root())
        .status()
        .context("running cargo build")?;
    if !status.success() {
        bail!("building the renderer failed");
    }
    let target = std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root().join("target"), |d| root().join(d));
    Ok(target.join("release/lancer"))
}

/// A task's command line: `--NAME VALUE` options and at most one free argument (a filter).
pub struct TaskArgs {
    /// The options given, in order, without their `--`.
    pub options: Vec<(String, String)>,
    /// The free argument.
    pub filter: Option<String>,
}

/// Splits `args` into the options named in `extra` and one free argument.
pub fn parse_common(args: &[String], extra: &[&str]) -> Result<TaskArgs> {
    let (mut opts, mut filter) = (Vec::new(), None);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if let Some(name) = a.strip_prefix("--").filter(|n| extra.contains(n)) {
            let v = it.next().with_context(|| format!("--{name} needs a value"))?;
            opts.push((name.to_owned(), v.clone()));
        } else if !a.starts_with('-') && filter.is_none() {
            filter = Some(a.clone());
        } else {
            bail!("unexpected argument `{a}`\n{USAGE}");
        }
    }
    Ok(TaskArgs { options: opts, filter })
}

fn renders(args: &[String]) -> Result<()> {
    let TaskArgs { options: opts, filter } = parse_common(args, &["width"])?;
    let lancer = build_renderer()?;
    let list = scenes(filter.as_deref())?;
    for (i, scene) in list.iter().enumerate() {
        let rel = scene.strip_prefix(root().join("scenes")).unwrap_or(scene).with_extension("");
        let out = root().join("target/renders").join(&rel);
        eprintln!("[{}/{}] {}", i + 1, list.len(), rel.display());
        let mut cmd = Command::new(&lancer);
        cmd.arg("render").arg(scene).arg("-o").arg(out.join("beauty.png")).arg("--aov").arg(&out).arg("--quiet");
        for (k, v) in &opts {
            cmd.arg(format!("--{k}")).arg(v);
        }
        if !cmd.status().context("running lancer")?.success() {
            bail!("rendering {} failed", scene.display());
        }
    }
    eprintln!("wrote {} scenes to {}", list.len(), root().join("target/renders").display());
    Ok(())
}

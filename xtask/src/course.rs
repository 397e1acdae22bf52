//! `cargo xtask course`: the course folder for students, `target/course/` (the exercises'
//! scenes, their reference images per term, the lecture sheets of `course/sheets/`, and a
//! README); and `cargo xtask course-check`: the starter crate's harness proved both ways (its
//! tests fail as shipped, name a mistaken term's mistake, and pass with the solution kept in
//! `xtask/course-solution/`).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail, ensure};

use crate::{build_renderer, parse_common, root};

/// Each exercise's scene (a file of `course/`) with the term image its students compare first.
const EXERCISES: &[(&str, &str)] = &[
    ("ex1-ambient", "ambient"),
    ("ex2-diffuse", "diffuse"),
    ("ex3-specular", "specular"),
    ("ex4-shadows", "diffuse"),
    ("ex5-mirror", "mirror"),
    ("ex6-refraction", "refraction"),
];

/// The files of the folder `dir` whose name ends in `.toml`, sorted.
fn toml_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("reading {}", dir.display()))?
        .map(|e| Ok(e?.path()))
        .collect::<Result<Vec<_>>>()?;
    files.retain(|p| p.is_file() && p.extension().is_some_and(|e| e == "toml"));
    files.sort();
    Ok(files)
}

/// The `[meta]` title and description of the scene file `path`.
fn meta(path: &Path) -> Result<(String, String)> {
    let src = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let doc: toml::Table = src.parse().with_context(|| format!("parsing {}", path.display()))?;
    let text = |k: &str| doc.get("meta").and_then(|m| m.get(k)).and_then(|v| v.as_str()).unwrap_or_default().to_owned();
    Ok((text("title"), text("description")))
}

/// Runs `cmd`, failing with its error output unless it succeeds; its standard output.
fn run(cmd: &mut Command, what: &str) -> Result<String> {
    let out = cmd.output().with_context(|| format!("running {what}"))?;
    if !out.status.success() {
        bail!("{what} failed:\n{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// `cargo xtask course`.
pub fn build(args: &[String]) -> Result<()> {
    let task = parse_common(args, &[])?;
    if let Some(f) = task.filter {
        bail!("unexpected argument `{f}`: cargo xtask course takes none");
    }
    let course = root().join("course");
    let scenes = toml_files(&course)?;
    for s in &scenes {
        let stem = s.file_stem().unwrap_or_default().to_string_lossy();
        ensure!(
            EXERCISES.iter().any(|(e, _)| *e == stem),
            "{} is not an exercise of xtask/src/course.rs (EXERCISES)",
            s.display()
        );
    }
    ensure!(scenes.len() == EXERCISES.len(), "course/ lacks an exercise's scene: {EXERCISES:?}");
    let lancer = build_renderer()?;
    let out = root().join("target/course");
    if out.exists() {
        std::fs::remove_dir_all(&out).with_context(|| format!("emptying {}", out.display()))?;
    }
    std::fs::create_dir_all(&out)?;
    for (name, _) in EXERCISES {
        let scene = course.join(format!("{name}.toml"));
        // A course scene teaches nothing it does not mean.
        let report = run(Command::new(&lancer).arg("check").arg(&scene), &format!("lancer check {}", scene.display()))?;
        ensure!(report.trim_end().ends_with("\n0 warnings"), "lancer check {} warns:\n{report}", scene.display());
        std::fs::copy(&scene, out.join(format!("{name}.toml")))?;
        let dir = out.join(name);
        let mut render = Command::new(&lancer);
        render.arg("render").arg(&scene).arg("-o").arg(dir.join("beauty.png")).arg("--aov").arg(&dir).arg("--quiet");
        run(&mut render, &format!("lancer render {}", scene.display()))?;
        eprintln!("course: {name}: reference images in {}", dir.display());
    }
    let sheets = toml_files(&course.join("sheets"))?;
    std::fs::create_dir_all(out.join("sheets"))?;
    for sheet in &sheets {
        let png = out.join("sheets").join(sheet.with_extension("png").file_name().unwrap_or_default());
        let mut cmd = Command::new(&lancer);
        cmd.arg("sheet").arg(sheet).arg("-o").arg(&png).arg("--quiet");
        run(&mut cmd, &format!("lancer sheet {}", sheet.display()))?;
        eprintln!("course: sheet {}", png.display());
    }
    std::fs::write(out.join("README.md"), readme(&course)?)?;
    eprintln!("course: {} exercises and {} sheets in {}", EXERCISES.len(), sheets.len(), out.display());
    Ok(())
}

/// The students' README of `target/course/`.
fn readme(course: &Path) -> Result<String> {
    let mut s = String::from(
        "# The course's reference images\n\n\
         Made by `cargo xtask course` from Lancer's `course/` folder; the exercises and the formulas are\n\
         in Lancer's `docs/course.md`. Every command below is run from this folder, with `lancer` on the\n\
         PATH (`cargo install --path crates/lancer-cli` in Lancer's checkout).\n\n\
         Each exercise has its scene (`exN-….toml`: camera, lights, objects, materials, and the model:\n\
         which terms, which shadows) and a folder of Lancer's images of it, 320 × 180:\n\n\
         - `beauty.png`, `beauty.exr`: the whole image (PNG: sRGB, 8 bits; EXR: linear floats);\n\
         - `<term>.png`, `<term>.exr`: each term's own contribution (`ambient`, `diffuse`, …); they\n  \
           add up to the beauty image, with `background.*` where rays hit nothing;\n\
         - `manifest.json`: what rendered them.\n\n\
         `sheets/` holds one lecture sheet per exercise: the right image beside the classic mistakes.\n\n\
         ## Checking your image\n\n\
         Render the exercise's scene with your own ray tracer at 320 × 180 (one ray through each\n\
         pixel's centre) and write a PNG or a PPM (`P3` or `P6`, what a C program writes easily). Then:\n\n\
         ```sh\n\
         lancer diff ex3-specular/beauty.png my.ppm --heatmap diff.png   # how far, where (PSNR, worst pixel, a heat map)\n\
         lancer diagnose ex3-specular.toml --image my.ppm                # which classic mistake, if any\n\
         lancer explain ex3-specular.toml --pixel 160,90                 # every input of every formula at one pixel\n\
         ```\n\n\
         `lancer diff` names the usual mismatches of an image writer too: the image upside down, the\n\
         sRGB curve missing, red and blue swapped, a half-pixel shift. `lancer diagnose` renders the\n\
         scene with the right model and with each classic mistake of the course and prints, on its\n\
         first line, `verdict: correct` or the mistake's name (`verdict: specular:sign`), then the\n\
         evidence and a hint. For one term's image alone: `lancer diagnose ex3-specular.toml --term\n\
         specular --image my-specular.ppm`, and `lancer diff ex3-specular/specular.png my-specular.ppm`.\n\n\
         ## The exercises\n\n",
    );
    for (name, term) in EXERCISES {
        let (title, description) = meta(&course.join(format!("{name}.toml")))?;
        let _ = writeln!(s, "### {title}\n\n{description}\n");
        let _ = writeln!(
            s,
            "- scene `{name}.toml`, images `{name}/`, sheet `sheets/{name}.png`\n- compare: `lancer diff {name}/beauty.png my.ppm` and `lancer diff {name}/{term}.png my-{term}.ppm`\n- diagnose: `lancer diagnose {name}.toml --image my.ppm`\n"
        );
    }
    Ok(s)
}

/// What Lancer's own cargo builds into: `CARGO_TARGET_DIR` (relative to the root) or `target/`.
fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root().join("target"), |d| root().join(d))
}

/// `cargo test --release --locked` of the starter crate whose manifest is `manifest`, into
/// Lancer's target folder: whether it passed, and what it printed. In release, because the
/// release build of `lancer` (and of the rim_light example) resolves the same dependencies with
/// the same features as the starter does, so they are not built again; a test build of the
/// whole workspace unifies other features (and the tests give the same answers either way).
fn starter_tests(manifest: &Path) -> Result<(bool, String)> {
    let mut cmd = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    cmd.args(["test", "--release", "--locked", "--test", "terms", "--manifest-path"])
        .arg(manifest)
        .env("CARGO_TARGET_DIR", target_dir())
        .env("RUST_BACKTRACE", "0");
    let out = cmd.output().context("running cargo test on the starter")?;
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    // A build error is no failing test: stop there.
    ensure!(text.contains("test result:"), "the starter's tests did not run:\n{text}");
    Ok((out.status.success(), text))
}

/// A copy of the course folder's scenes and starter under `dir`, its path dependencies made
/// absolute, with each file of `xtask/course-solution/` named in `overlay` in place of the
/// student's file named beside it.
fn starter_copy(dir: &Path, overlay: &[(String, String)]) -> Result<PathBuf> {
    if dir.exists() {
        std::fs::remove_dir_all(dir)?;
    }
    let (course, copy) = (root().join("course"), dir.join("course"));
    let starter = copy.join("starter");
    for sub in ["src", "tests"] {
        std::fs::create_dir_all(starter.join(sub))?;
        for entry in std::fs::read_dir(course.join("starter").join(sub))? {
            let p = entry?.path();
            if p.is_file() {
                std::fs::copy(&p, starter.join(sub).join(p.file_name().unwrap_or_default()))?;
            }
        }
    }
    for scene in toml_files(&course)? {
        std::fs::copy(&scene, copy.join(scene.file_name().unwrap_or_default()))?;
    }
    std::fs::copy(course.join("starter/Cargo.lock"), starter.join("Cargo.lock"))?;
    let manifest = std::fs::read_to_string(course.join("starter/Cargo.toml"))?;
    let crates = format!("path = \"{}/", root().join("crates").display());
    ensure!(
        manifest.contains("path = \"../../crates/"),
        "course/starter/Cargo.toml has no path dependency on ../../crates"
    );
    std::fs::write(starter.join("Cargo.toml"), manifest.replace("path = \"../../crates/", &crates))?;
    let solution = root().join("xtask/course-solution");
    for (from, to) in overlay {
        std::fs::copy(solution.join(from), starter.join("src").join(to)).with_context(|| format!("copying {from}"))?;
    }
    Ok(starter.join("Cargo.toml"))
}

/// `cargo xtask course-check`.
pub fn check(args: &[String]) -> Result<()> {
    let task = parse_common(args, &[])?;
    if let Some(f) = task.filter {
        bail!("unexpected argument `{f}`: cargo xtask course-check takes none");
    }
    let tests = ["ex1_ambient", "ex2_diffuse", "ex3_specular", "ex4_shadows", "ex5_mirror", "ex6_refraction"];
    let terms = ["ambient", "diffuse", "specular", "mirror", "refraction"];

    // As shipped: every test fails, each saying its term is still the stub.
    let (passed, text) = starter_tests(&root().join("course/starter/Cargo.toml"))?;
    ensure!(!passed, "the starter's tests pass as shipped: its terms are not stubs any more\n{text}");
    for t in tests {
        ensure!(text.contains(&format!("test {t} ... FAILED")), "as shipped, test {t} does not fail:\n{text}");
    }
    for t in terms {
        ensure!(
            text.contains(&format!("student-{t} differs from Lancer's {t}")) && text.contains(&format!("src/{t}.rs")),
            "as shipped, no report on student-{t}:\n{text}"
        );
    }
    println!("course-check: as shipped, the starter's 6 tests fail, each naming its stub");

    // A mistaken solution: the tests of its term fail with the mistake's name as the verdict,
    // the others pass.
    let dir = target_dir().join("course-check");
    let solution: Vec<(String, String)> = terms.iter().map(|t| (format!("{t}.rs"), format!("{t}.rs"))).collect();
    let mut mistaken = solution.clone();
    mistaken.retain(|(from, _)| from != "specular.rs");
    mistaken.push(("mistaken/specular.rs".to_owned(), "specular.rs".to_owned()));
    let (passed, text) = starter_tests(&starter_copy(&dir, &mistaken)?)?;
    ensure!(!passed, "with the exponent `shine` in the specular term, the starter's tests pass:\n{text}");
    for (t, fails) in tests.iter().map(|t| (t, t.contains("specular") || t.contains("shadows"))) {
        let want = format!("test {t} ... {}", if fails { "FAILED" } else { "ok" });
        ensure!(text.contains(&want), "with a mistaken specular term, expected `{want}`:\n{text}");
    }
    ensure!(
        text.contains("verdict: specular:exponent-shine"),
        "with the exponent `shine` in the specular term, the diagnosis does not name specular:exponent-shine:\n{text}"
    );
    println!("course-check: with the exponent `shine` in specular, ex3 and ex4 fail: verdict: specular:exponent-shine");
    // What a student with that mistake reads.
    if let Some(start) = text.find("---- ex3_specular stdout ----") {
        let block = &text[start..];
        let end = block[1..].find("\n----").or_else(|| block.find("\nfailures:")).map_or(block.len(), |e| e + 1);
        println!("{}", block[..end].trim_end());
    }

    // The solution: every test passes.
    let (passed, text) = starter_tests(&starter_copy(&dir, &solution)?)?;
    ensure!(passed, "with the solution, the starter's tests fail:\n{text}");
    std::fs::remove_dir_all(&dir)?;
    println!("course-check: with the solution (xtask/course-solution/), the starter's 6 tests pass");
    Ok(())
}

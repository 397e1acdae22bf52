//! `cargo xtask portable-check`: the renderer built for this processor against the portable
//! x86-64 build (the repository's default): every scene rendered by both, every file compared
//! byte for byte.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};

use crate::{TaskArgs, parse_common, root, scenes};

/// The flags of the build for this processor (AVX2, BMI and the rest where it has them), with
/// fused multiply-add off as the documented recipe has it.
const NATIVE: &str = "-C target-cpu=native -C target-feature=-fma";
/// What the default build is: the baseline x86-64 instruction set (SSE2), no more.
const PORTABLE: &str = "the default flags: baseline x86-64";

pub fn run(args: &[String]) -> Result<()> {
    let TaskArgs { options, filter } = parse_common(args, &["width"])?;
    let width = match options.iter().find(|(k, _)| k == "width") {
        Some((_, w)) => w.parse::<u32>().ok().filter(|w| *w > 0).with_context(|| format!("--width {w}: a width"))?,
        None => 160,
    };
    if !cfg!(target_arch = "x86_64") {
        println!("portable-check: the processor-specific build flags apply to x86-64 only; nothing to compare here");
        return Ok(());
    }
    // Both builds with their flags set here: flags in the environment (RUSTFLAGS,
    // CARGO_ENCODED_RUSTFLAGS) would replace the repository's, and a CARGO_TARGET_DIR would move
    // the binaries.
    let portable = build("target", None)?;
    let native = build("target/native", Some(NATIVE))?;
    if std::fs::read(&native)? == std::fs::read(&portable)? {
        println!(
            "portable-check: the build for this processor is the portable build here (a baseline \
             x86-64 processor): nothing to compare"
        );
        return Ok(());
    }
    let list = scenes(filter.as_deref())?;
    let out = root().join("target/portable-check");
    let (mut files, mut differ) = (0, Vec::new());
    for (i, scene) in list.iter().enumerate() {
        let rel = scene.strip_prefix(root().join("scenes")).unwrap_or(scene).with_extension("");
        eprintln!("[{}/{}] {}", i + 1, list.len(), rel.display());
        let (a, b) = (out.join("native").join(&rel), out.join("portable").join(&rel));
        render(&native, scene, &a, width)?;
        render(&portable, scene, &b, width)?;
        for name in listing(&a)? {
            files += 1;
            let (x, y) = (a.join(&name), b.join(&name));
            let same = std::fs::read(&x)? == std::fs::read(&y).with_context(|| format!("reading {}", y.display()))?;
            if !same {
                differ.push(rel.join(&name));
            }
        }
        if listing(&b)? != listing(&a)? {
            differ.push(rel.join("(the files written)"));
        }
    }
    if !differ.is_empty() {
        let list: Vec<String> = differ.iter().map(|p| format!("  {}", p.display())).collect();
        bail!(
            "the build for this processor ({NATIVE}) and the portable build ({PORTABLE}) wrote different bytes:\n{}\n\
             (both renders are in {})",
            list.join("\n"),
            out.display()
        );
    }
    println!(
        "portable-check: {} scenes at {width} wide, {files} EXR images (beauty and per term): the same bytes from the \
         build for this processor ({NATIVE}) as from the portable one ({PORTABLE})",
        list.len()
    );
    Ok(())
}

/// Builds the renderer into the target folder `dir` (under the repository) with the
/// repository's (portable) flags, or with `flags` instead; the binary's path.
fn build(dir: &str, flags: Option<&str>) -> Result<PathBuf> {
    let dir = root().join(dir);
    let mut cargo = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    cargo.args(["build", "--release", "--package", "lancer-cli"]).arg("--target-dir").arg(&dir);
    cargo.env_remove("RUSTFLAGS").env_remove("CARGO_ENCODED_RUSTFLAGS").env_remove("CARGO_BUILD_RUSTFLAGS");
    if let Some(flags) = flags {
        cargo.env("RUSTFLAGS", flags);
    }
    let status = cargo.current_dir(root()).status().context("running cargo build")?;
    if !status.success() {
        bail!("building the renderer ({}) failed", flags.unwrap_or("the repository's flags"));
    }
    Ok(dir.join("release").join(format!("lancer{}", std::env::consts::EXE_SUFFIX)))
}

/// Renders `scene` at `width` with its per-term images, as linear EXR (every bit of every
/// pixel), into the folder `out`.
fn render(lancer: &Path, scene: &Path, out: &Path, width: u32) -> Result<()> {
    if out.exists() {
        std::fs::remove_dir_all(out).with_context(|| format!("clearing {}", out.display()))?;
    }
    let status = Command::new(lancer)
        .arg("render")
        .arg(scene)
        .args(["--width", &width.to_string(), "--quiet", "--aov-format", "exr"])
        .arg("-o")
        .arg(out.join("render.exr"))
        .arg("--aov")
        .arg(out)
        .status()
        .with_context(|| format!("running {}", lancer.display()))?;
    if !status.success() {
        bail!("{} failed on {}", lancer.display(), scene.display());
    }
    Ok(())
}

/// The names of the images in `dir`, sorted (the manifest beside them holds timings, which
/// differ from run to run).
fn listing(dir: &Path) -> Result<Vec<String>> {
    let mut names = Vec::new();
    for entry in std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))? {
        let name = entry?.file_name().to_string_lossy().into_owned();
        if name.ends_with(".exr") {
            names.push(name);
        }
    }
    names.sort();
    Ok(names)
}

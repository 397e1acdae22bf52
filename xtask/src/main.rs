//! `cargo xtask`: project chores that need more than cargo. `renders` renders every scene in
//! `scenes/` with its per-term images into `target/renders/<scene>/`.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};

const USAGE: &str = "usage: cargo xtask renders [--width W] [FILTER]

  renders   render every scene in scenes/ (or those whose path contains FILTER) with its
            per-term images into target/renders/<scene>/";

fn main() {
    if let Err(e) = run(std::env::args().skip(1).collect()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask/ sits in the root").to_path_buf()
}

fn run(args: Vec<String>) -> Result<()> {
    match args.first().map(String::as_str) {
        Some("renders") => renders(&args[1..]),
        Some("-h" | "--help") | None => {
            println!("{USAGE}");
            Ok(())
        }
        Some(other) => bail!("unknown task `{other}`\n{USAGE}"),
    }
}

fn scenes(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    for entry in std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))? {
        let p = entry?.path();
        if p.is_dir() {
            scenes(&p, out)?;
        } else if p.extension().is_some_and(|e| e == "toml") {
            out.push(p);
        }
    }
    Ok(())
}

fn renders(args: &[String]) -> Result<()> {
    let (mut width, mut filter) = (None, None);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--width" => {
                width = Some(
                    it.next().context("--width needs a number")?.parse::<u32>().context("--width needs a number")?,
                )
            }
            f if !f.starts_with('-') && filter.is_none() => filter = Some(f.to_owned()),
            other => bail!("unexpected argument `{other}`\n{USAGE}"),
        }
    }
    let root = root();
    let status = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
        .args(["build", "--release", "--package", "lancer-cli"])
        .current_dir(&root)
        .status()
        .context("running cargo build")?;
    if !status.success() {
        bail!("building the renderer failed");
    }
    let lancer = root.join("target/release/lancer");
    let mut list = Vec::new();
    scenes(&root.join("scenes"), &mut list)?;
    list.sort();
    list.retain(|p| filter.as_ref().is_none_or(|f| p.to_string_lossy().contains(f.as_str())));
    if list.is_empty() {
        bail!("no scene matches {}", filter.unwrap_or_default());
    }
    for (i, scene) in list.iter().enumerate() {
        let rel = scene.strip_prefix(root.join("scenes")).unwrap_or(scene).with_extension("");
        let out = root.join("target/renders").join(&rel);
        eprintln!("[{}/{}] {}", i + 1, list.len(), rel.display());
        let mut cmd = Command::new(&lancer);
        cmd.arg("render").arg(scene).arg("-o").arg(out.join("beauty.png")).arg("--aov").arg(&out).arg("--quiet");
        if let Some(w) = width {
            cmd.args(["--width", &w.to_string()]);
        }
        if !cmd.status().context("running lancer")?.success() {
            bail!("rendering {} failed", scene.display());
        }
    }
    eprintln!("wrote {} scenes to {}", list.len(), root.join("target/renders").display());
    Ok(())
}

//! `cargo xtask web`: the browser build. Compiles `lancer-wasm` for `wasm32-unknown-unknown`
//! twice (with and without WebAssembly SIMD: the page picks the one the browser runs), runs the
//! wasm-bindgen CLI of exactly the crate's version on each, and writes `target/web/`: the
//! studio's page set to render in the page, its engine scripts, the modules, every shipped scene
//! with the meshes and textures it names, and a service worker that keeps all of it for
//! offline use. Any static web server can serve the folder.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};
use serde_json::json;

use crate::root;

/// The file that marks a folder as this task's output.
const MARKER: &str = ".lancer-web";

/// The most the compressed module may weigh (gzip, as a web server sends it).
const BUDGET: usize = 4 << 20;

/// The page's own files (`crates/lancer-studio/src/page/`), all of them: the served studio uses
/// the first three.
const PAGE_FILES: [&str; 5] = ["index.html", "app.js", "app.css", "local-engine.js", "render-worker.js"];

/// The two builds: a name and the code generation flags for the target.
const BUILDS: [(&str, &str); 2] = [("lancer_simd", "-Ctarget-feature=+simd128"), ("lancer_base", "")];

/// The version of a package in `Cargo.lock`.
fn locked_version(name: &str) -> Result<String> {
    let lock = std::fs::read_to_string(root().join("Cargo.lock")).context("reading Cargo.lock")?;
    let doc: toml::Table = lock.parse().context("reading Cargo.lock")?;
    let packages = doc.get("package").and_then(|p| p.as_array()).context("Cargo.lock lists no package")?;
    packages
        .iter()
        .find(|p| p.get("name").and_then(|n| n.as_str()) == Some(name))
        .and_then(|p| p.get("version")?.as_str().map(str::to_owned))
        .with_context(|| format!("Cargo.lock has no `{name}`"))
}

fn cargo() -> Command {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
}

/// The wasm-bindgen CLI at `version`: the one on the PATH or in `target/tools` if it is that
/// version, else installed into `target/tools` by cargo (a few minutes, once).
pub fn wasm_bindgen(version: &str) -> Result<PathBuf> {
    let tools = root().join("target/tools");
    let candidates = [tools.join("bin/wasm-bindgen")].into_iter().chain(crate::which("wasm-bindgen"));
    for c in candidates {
        let out = Command::new(&c).arg("--version").output();
        if let Ok(out) = out
            && String::from_utf8_lossy(&out.stdout).split_whitespace().nth(1) == Some(version)
        {
            return Ok(c);
        }
    }
    println!("installing wasm-bindgen-cli {version} into target/tools (cargo install, once)");
    // Not `--locked`: the CLI's own lock file names versions a registry mirror may not carry.
    // Without its default TLS stack (only its test runner downloads anything): a minute less.
    // Unoptimised (`--debug`): it installs in half the time (71 s against 148 s here) and writes
    // the same bytes, in 1.7 s a module instead of 0.4 s.
    let status = cargo()
        .args([
            "install",
            "wasm-bindgen-cli",
            "--no-default-features",
            "--debug",
            "--version",
            &format!("={version}"),
            "--root",
        ])
        .arg(&tools)
        .status()
        .context("running cargo install")?;
    if !status.success() {
        bail!("installing wasm-bindgen-cli {version} failed (cargo install wasm-bindgen-cli --version ={version})");
    }
    Ok(tools.join("bin/wasm-bindgen"))
}

/// Fails with what to run when the WebAssembly target is not installed.
fn check_target() -> Result<()> {
    let out = Command::new("rustc").args(["--print", "sysroot"]).output().context("running rustc")?;
    let sysroot = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
    if !sysroot.join("lib/rustlib/wasm32-unknown-unknown").is_dir() {
        bail!("the WebAssembly target is not installed: run `rustup target add wasm32-unknown-unknown`");
    }
    Ok(())
}

/// Builds both modules into `out/pkg/`.
fn build_modules(out: &Path) -> Result<()> {
    check_target()?;
    let bindgen = wasm_bindgen(&locked_version("wasm-bindgen")?)?;
    for (name, flags) in BUILDS {
        let dir = root().join("target/wasm").join(name);
        println!("building {name} (wasm32-unknown-unknown{})", if flags.is_empty() { "" } else { ", SIMD" });
        let status = cargo()
            .args(["build", "--release", "--package", "lancer-wasm", "--target", "wasm32-unknown-unknown"])
            .arg("--target-dir")
            .arg(&dir)
            // Only these flags, whatever the environment says (with `--target` they do not reach
            // build scripts).
            .env_remove("RUSTFLAGS")
            .env("CARGO_ENCODED_RUSTFLAGS", flags)
            // Built in parallel units and without line tables (wasm-bindgen drops them): a
            // third of the build time, the same floats (no unit changes how one rounds).
            .env("CARGO_PROFILE_RELEASE_CODEGEN_UNITS", "16")
            .env("CARGO_PROFILE_RELEASE_DEBUG", "false")
            .current_dir(root())
            .status()
            .context("running cargo build")?;
        if !status.success() {
            bail!("building lancer-wasm for wasm32-unknown-unknown failed");
        }
        let status = Command::new(&bindgen)
            .args(["--target", "web", "--no-typescript", "--out-name", name, "--out-dir"])
            .arg(out.join("pkg"))
            .arg(dir.join("wasm32-unknown-unknown/release/lancer_wasm.wasm"))
            .status()
            .context("running wasm-bindgen")?;
        if !status.success() {
            bail!("wasm-bindgen failed on {name}");
        }
    }
    Ok(())
}

/// The gzip size of `bytes` (level 9).
pub fn gzip_size(bytes: &[u8]) -> Result<usize> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    e.write_all(bytes)?;
    Ok(e.finish()?.len())
}

/// Copies the shipped scenes and the files they name into `out/scenes/`, and lists them in
/// `out/scenes/index.json`: each scene's path (from `scenes/`), its title (its first comment
/// line) and the files it names (paths from `scenes/`).
fn copy_scenes(out: &Path) -> Result<Vec<String>> {
    let registry = lancer_shading::Registry::with_builtins();
    let src_root = root().join("scenes");
    let mut listed = Vec::new();
    let mut files: Vec<String> = Vec::new();
    for path in crate::scenes(None)? {
        let rel = path.strip_prefix(&src_root)?.to_string_lossy().replace('\\', "/");
        let text = std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
        let dir = path.parent().context("a scene has a folder")?.to_path_buf();
        let named = std::cell::RefCell::new(Vec::new());
        let resolve = |p: &str| {
            let file = dir.join(p);
            named.borrow_mut().push(file.clone());
            std::fs::read(&file).map_err(|e| format!("{}: {e}", file.display()))
        };
        lancer_scene::load_scene_with(&text, &rel, &registry, &resolve).map_err(|e| anyhow::anyhow!("{e}"))?;
        let mut names = Vec::new();
        for f in named.into_inner() {
            let f = std::fs::canonicalize(&f)?;
            let r = f
                .strip_prefix(std::fs::canonicalize(&src_root)?)
                .with_context(|| format!("{rel} names {}, outside scenes/", f.display()))?
                .to_string_lossy()
                .replace('\\', "/");
            names.push(r.clone());
            if !files.contains(&r) {
                files.push(r);
            }
        }
        let title = text
            .lines()
            .next()
            .and_then(|l| l.strip_prefix('#'))
            .map(|t| t.trim().to_owned())
            .unwrap_or_else(|| rel.clone());
        listed.push(json!({ "path": rel, "title": title, "files": names }));
        files.push(rel);
    }
    for f in &files {
        let to = out.join("scenes").join(f);
        std::fs::create_dir_all(to.parent().context("a file has a folder")?)?;
        std::fs::copy(src_root.join(f), &to).with_context(|| format!("copying scenes/{f}"))?;
    }
    std::fs::write(out.join("scenes/index.json"), serde_json::to_string_pretty(&listed)?)?;
    Ok(files.iter().map(|f| format!("scenes/{f}")).chain(["scenes/index.json".to_owned()]).collect())
}

/// `cargo xtask web [--out DIR]`.
pub fn build(args: &[String]) -> Result<()> {
    let mut out = root().join("target/web");
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--out" => out = PathBuf::from(it.next().context("--out needs a folder")?),
            other => bail!("unknown option `{other}` (cargo xtask web [--out DIR])"),
        }
    }
    // Only a folder this task wrote (it leaves a marker; `target/web` is its own) or an empty one
    // is emptied: `--out ~` must not wipe a home folder.
    if out.exists() {
        let empty = std::fs::read_dir(&out).map(|mut d| d.next().is_none()).unwrap_or(false);
        let ours = out.join(MARKER).is_file() || out == root().join("target/web");
        if !empty && !ours {
            bail!("{} is not empty and was not written by `cargo xtask web`: give another --out", out.display());
        }
        std::fs::remove_dir_all(&out).with_context(|| format!("emptying {}", out.display()))?;
    }
    std::fs::create_dir_all(&out)?;
    std::fs::write(out.join(MARKER), "written by cargo xtask web: the folder is emptied by the next build\n")?;
    build_modules(&out)?;
    let page = root().join("crates/lancer-studio/src/page");
    for f in PAGE_FILES {
        let text = std::fs::read_to_string(page.join(f)).with_context(|| format!("reading the page's {f}"))?;
        // The one difference from the served page: it renders in the browser.
        let text = if f == "index.html" {
            let marked = text.replace("<body>", "<body data-engine=\"wasm\">");
            if marked == text {
                bail!("the page's index.html has no <body> to mark");
            }
            marked
        } else {
            text
        };
        std::fs::write(out.join(f), text)?;
    }
    let mut files: Vec<String> = PAGE_FILES.iter().map(|f| f.to_string()).collect();
    for (name, _) in BUILDS {
        files.push(format!("pkg/{name}.js"));
        files.push(format!("pkg/{name}_bg.wasm"));
    }
    files.extend(copy_scenes(&out)?);
    // The service worker: every file, under a cache named by their contents (a new build
    // replaces the old cache).
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    for f in &files {
        for b in std::fs::read(out.join(f)).with_context(|| format!("reading {f}"))? {
            hash = (hash ^ b as u64).wrapping_mul(0x100_0000_01b3);
        }
    }
    let sw = include_str!("web/sw.js")
        .replace("__CACHE__", &format!("lancer-{hash:016x}"))
        .replace("__FILES__", &serde_json::to_string(&[".".to_owned()].iter().chain(&files).collect::<Vec<_>>())?);
    std::fs::write(out.join("sw.js"), sw)?;
    for (name, _) in BUILDS {
        let wasm = std::fs::read(out.join(format!("pkg/{name}_bg.wasm")))?;
        let zipped = gzip_size(&wasm)?;
        println!("pkg/{name}_bg.wasm: {:.2} MB, {:.2} MB compressed (budget 4 MB)", mb(wasm.len()), mb(zipped));
        if zipped > BUDGET {
            bail!("pkg/{name}_bg.wasm is {:.2} MB compressed, over the 4 MB budget", mb(zipped));
        }
    }
    println!("wrote {} ({} files): serve it with any static web server, e.g.", out.display(), files.len() + 1);
    println!("  python3 -m http.server --directory {} 8000   then open http://localhost:8000/", out.display());
    Ok(())
}

fn mb(bytes: usize) -> f64 {
    bytes as f64 / (1 << 20) as f64
}

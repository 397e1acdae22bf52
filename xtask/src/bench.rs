//! `cargo xtask bench`: Lancer against POV-Ray 3.7 on the same scene (`scenes/bench/anchor.toml`
//! and `scenes/bench/anchor.pov`), and how render cost grows with the number of objects.

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

use anyhow::{Context, Result, bail};

use crate::{TaskArgs, build_renderer, parse_common, root};

/// Seconds of render reported by `lancer` ("... in 0.312 s: 4.42 M rays ...") and its ray count.
fn lancer_run(lancer: &Path, scene: &Path, threads: u32, extra: &[&str]) -> Result<(f64, f64)> {
    let out = Command::new(lancer)
        .arg("render")
        .arg(scene)
        .args(["--threads", &threads.to_string(), "-o"])
        .arg(std::env::temp_dir().join("lancer-bench.png"))
        .args(extra)
        .output()
        .context("running lancer")?;
    let text = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        bail!("lancer failed: {text}");
    }
    let secs = text.split(" in ").nth(1).and_then(|s| s.split(" s").next()).and_then(|s| s.parse().ok());
    let rays = text.split(": ").nth(1).and_then(|s| s.split(" M rays").next()).and_then(|s| s.parse::<f64>().ok());
    match (secs, rays) {
        (Some(s), Some(r)) => Ok((s, r * 1e6)),
        _ => bail!("could not read lancer's summary line: {text}"),
    }
}

/// POV-Ray's "Trace Time" in seconds for `scene` at `w`×`h` on `threads` threads.
fn povray_run(pov: &Path, w: u32, h: u32, threads: u32) -> Result<f64> {
    let out_png = std::env::temp_dir().join("lancer-bench-pov.png");
    let out = Command::new("povray")
        .arg(format!("+I{}", pov.display()))
        .args([format!("+W{w}"), format!("+H{h}"), "-A".into(), format!("+WT{threads}"), "-D".into()])
        .arg(format!("+O{}", out_png.display()))
        .current_dir(std::env::temp_dir())
        .output()
        .context("running povray")?;
    let text = String::from_utf8_lossy(&out.stderr).into_owned() + &String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        bail!("povray failed: {}", text.lines().rev().take(5).collect::<Vec<_>>().join("\n"));
    }
    // "  Trace Time:       0 hours  0 minutes  0 seconds (0.693 seconds)"
    let line = text.lines().find(|l| l.contains("Trace Time:")).context("povray printed no Trace Time")?;
    let secs = line.rsplit('(').next().and_then(|s| s.split_whitespace().next()).and_then(|s| s.parse().ok());
    secs.with_context(|| format!("could not read povray's trace time from `{line}`"))
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The median render time of `runs` renders of `scene` on `threads` threads, and its ray count.
fn median_run(lancer: &Path, scene: &Path, threads: u32, runs: usize) -> Result<(f64, f64)> {
    let mut times = Vec::with_capacity(runs);
    let mut rays = 0.0;
    for _ in 0..runs {
        let (t, r) = lancer_run(lancer, scene, threads, &[])?;
        times.push(t);
        rays = r;
    }
    Ok((median(times), rays))
}

fn povray_installed() -> bool {
    Command::new("povray").arg("--version").output().is_ok()
}

/// A scene of `n` small spheres on a grid over a floor, for the scaling series.
fn spheres_scene(n: usize) -> String {
    let side = (n as f64).sqrt().ceil() as usize;
    let spacing = 20.0 / side as f64;
    let mut s = String::from(
        "[image]\nwidth = 640\nheight = 360\n[camera]\nfrom = [0, 8, -14]\nto = [0, 0, 2]\nfov = 50\n\
         [model]\nmax_depth = 2\nshadows = \"hard\"\nterms = [\"ambient\", \"diffuse\", \"specular\", \"mirror\"]\n\
         [materials.m]\ncolor = [0.8, 0.4, 0.3]\ndiff = 0.8\nspec = 0.3\nshine = 0.9\n\
         [[lights]]\nat = [-6, 12, -8]\n[[objects]]\nshape = \"plane\"\n",
    );
    for k in 0..n {
        let (i, j) = (k % side, k / side);
        let x = -10.0 + (i as f64 + 0.5) * spacing;
        let z = -8.0 + (j as f64 + 0.5) * spacing;
        let r = spacing * 0.35;
        let _ =
            writeln!(s, "[[objects]]\nshape = \"sphere\"\nmaterial = \"m\"\nscale = {r}\ntranslate = [{x}, {r}, {z}]");
    }
    s
}

/// An OBJ height field of about `triangles` triangles over [-10, 10]², gently rippled.
fn heightfield_obj(triangles: usize) -> String {
    let n = ((triangles / 2) as f64).sqrt().round().max(1.0) as usize;
    let mut s = String::with_capacity(n * n * 60);
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (-10.0 + 20.0 * i as f64 / n as f64, -10.0 + 20.0 * j as f64 / n as f64);
            let y = 0.4 * (x * 1.3).sin() * (z * 0.9).cos() + 0.6;
            let _ = writeln!(s, "v {x:.5} {y:.5} {z:.5}");
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i + 1;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            let _ = writeln!(s, "f {a} {c} {d}\nf {a} {d} {b}");
        }
    }
    s
}

/// `cargo xtask bench [--runs N]`.
pub fn run(args: &[String]) -> Result<()> {
    let TaskArgs { options, filter } = parse_common(args, &["runs"])?;
    if let Some(f) = filter {
        bail!("unexpected argument `{f}`");
    }
    let runs: usize =
        options.iter().find(|(k, _)| k == "runs").map_or(Ok(5), |(_, v)| v.parse()).context("--runs needs a number")?;
    let lancer = build_renderer()?;
    let anchor = root().join("scenes/bench/anchor.toml");
    let pov = root().join("scenes/bench/anchor.pov");
    let has_pov = povray_installed();

    println!(
        "Anchor scene (scenes/bench/anchor.toml vs anchor.pov), 1280x720, no anti-aliasing, depth 5, median of {runs} runs"
    );
    println!(
        "{:<10} {:>12} {:>12} {:>10} {:>12} {:>14} {:>16}",
        "threads", "lancer (s)", "M rays", "M rays/s", "ns per ray", "povray (s)", "povray / lancer"
    );
    for threads in [1u32, 2] {
        let (t, rays) = median_run(&lancer, &anchor, threads, runs)?;
        let (pov_t, ratio) = if has_pov {
            let p = median((0..runs).map(|_| povray_run(&pov, 1280, 720, threads)).collect::<Result<Vec<_>>>()?);
            (format!("{p:.3}"), format!("{:.2}x", p / t))
        } else {
            ("-".into(), "-".into())
        };
        // Per-ray cost in thread-nanoseconds, comparable across thread counts and scenes.
        let ns = threads as f64 * t * 1e9 / rays;
        println!(
            "{threads:<10} {t:>12.3} {:>12.2} {:>10.1} {ns:>12.1} {pov_t:>14} {ratio:>16}",
            rays / 1e6,
            rays / 1e6 / t
        );
    }
    if !has_pov {
        println!(
            "POV-Ray is not installed, so the comparison was skipped: `apt-get install -y povray` (Debian) enables it."
        );
    } else {
        println!(
            "(POV-Ray's figure is its own Trace Time, start-up excluded; Lancer's is its render time, scene loading and file writing excluded.)"
        );
    }

    println!("\nScaling with the object count (a grid of spheres over a floor, 640x360, 2 threads, median of {runs})");
    println!("{:>8} {:>12} {:>12} {:>14}", "spheres", "render (s)", "M rays", "ns per ray");
    let dir = std::env::temp_dir().join("lancer-bench-scenes");
    std::fs::create_dir_all(&dir)?;
    for n in [10usize, 100, 1_000, 10_000] {
        let path = dir.join(format!("spheres-{n}.toml"));
        std::fs::write(&path, spheres_scene(n))?;
        let (t, rays) = median_run(&lancer, &path, 2, runs)?;
        // Two threads share the work: per-ray cost in thread-nanoseconds.
        println!("{n:>8} {t:>12.3} {:>12.2} {:>14.1}", rays / 1e6, 2.0 * t * 1e9 / rays);
    }

    println!("\nScaling with the triangle count (a rippled height-field mesh, 640x360, 2 threads, median of {runs})");
    println!("{:>10} {:>12} {:>12} {:>14}", "triangles", "render (s)", "M rays", "ns per ray");
    for n in [10_000usize, 100_000, 1_000_000] {
        let obj = dir.join(format!("field-{n}.obj"));
        std::fs::write(&obj, heightfield_obj(n))?;
        let path = dir.join(format!("field-{n}.toml"));
        std::fs::write(
            &path,
            format!(
                "[image]\nwidth = 640\nheight = 360\n[camera]\nfrom = [0, 7, -13]\nto = [0, 0, 1]\nfov = 50\n\
                 [model]\nmax_depth = 2\nshadows = \"hard\"\nterms = [\"ambient\", \"diffuse\", \"specular\", \"mirror\"]\n\
                 [[lights]]\nat = [-6, 12, -8]\n[[objects]]\nshape = \"mesh\"\npath = \"field-{n}.obj\"\n\
                 material = {{ color = [0.4, 0.7, 0.5], diff = 0.8, spec = 0.3, shine = 0.9 }}\n"
            ),
        )?;
        let (t, rays) = median_run(&lancer, &path, 2, runs)?;
        println!("{n:>10} {t:>12.3} {:>12.2} {:>14.1}", rays / 1e6, 2.0 * t * 1e9 / rays);
    }
    Ok(())
}

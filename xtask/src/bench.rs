//! `cargo xtask bench`: Lancer against POV-Ray 3.7 on the same scene (`scenes/bench/anchor.toml`
//! and `scenes/bench/anchor.pov`) and on two mesh scenes (exported by `lancer export pov`); how
//! render cost, loading time and memory grow with samples, objects and triangles; the 1M-triangle
//! field against Embree 3 ([`crate::embree`]) and the browser build against native renders.

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

use anyhow::{Context, Result, bail};

use crate::{TaskArgs, build_renderer, parse_common, root};

/// What one `lancer render` reported: render seconds, rays, scene loading seconds, peak memory
/// (MB, where the system tells it), and the whole command's wall time.
#[derive(Clone, Copy, Debug)]
struct Run {
    secs: f64,
    rays: f64,
    load: f64,
    peak_mb: f64,
    wall: f64,
    /// Camera, secondary and shadow rays.
    kinds: [u64; 3],
}

/// Runs `lancer render SCENE --threads N -o tmp.png EXTRA...` and reads its summary line
/// ("... in 0.312 s: 4.42 M rays ... (scene loaded in 0.010 s, peak memory 86.6 MB)").
fn lancer_run(lancer: &Path, scene: &Path, threads: u32, extra: &[&str]) -> Result<Run> {
    lancer_run_to(lancer, scene, threads, extra, "lancer-bench.png")
}

/// [`lancer_run`] writing its image to `image` in the temporary folder (two renders at once
/// write two files).
fn lancer_run_to(lancer: &Path, scene: &Path, threads: u32, extra: &[&str], image: &str) -> Result<Run> {
    let start = std::time::Instant::now();
    let out = Command::new(lancer)
        .arg("render")
        .arg(scene)
        .args(["--threads", &threads.to_string(), "-o"])
        .arg(std::env::temp_dir().join(image))
        .args(extra)
        .output()
        .context("running lancer")?;
    let wall = start.elapsed().as_secs_f64();
    let text = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        bail!("lancer failed: {text}");
    }
    // Read from the summary line only (a warning printed before it may hold the same words).
    let summary = text.lines().rev().find(|l| l.starts_with("rendered ")).unwrap_or("");
    let after =
        |key: &str, until: &str| -> Option<f64> { summary.split(key).nth(1)?.split(until).next()?.trim().parse().ok() };
    let peak_mb = after("peak memory ", " MB").unwrap_or(f64::NAN);
    match (after(" in ", " s"), after(": ", " M rays"), after("scene loaded in ", " s"), ray_kinds(&text)) {
        (Some(secs), Some(rays), Some(load), Some(kinds)) => {
            Ok(Run { secs, rays: rays * 1e6, load, peak_mb, wall, kinds })
        }
        _ => bail!("could not read lancer's summary line: {text}"),
    }
}

/// The camera, secondary and shadow ray counts of lancer's summary line: "rendered ... in 0.307
/// s: 4.37 M rays (921600 camera, 1314006 secondary, 2137739 shadow) -> ...".
fn ray_kinds(text: &str) -> Option<[u64; 3]> {
    let line = text.lines().rev().find(|l| l.starts_with("rendered "))?;
    let counts = line.split(" M rays (").nth(1)?.split(')').next()?;
    let kind = |name: &str| -> Option<u64> {
        counts
            .split(", ")
            .find_map(|c| c.strip_suffix(name).and_then(|n| n.strip_suffix(' ')).and_then(|n| n.parse().ok()))
    };
    Some([kind("camera")?, kind("secondary")?, kind("shadow")?])
}

/// POV-Ray's "Trace Time" in seconds for `scene` at `w`×`h` on `threads` threads.
fn povray_run(pov: &Path, w: u32, h: u32, threads: u32) -> Result<f64> {
    Ok(povray_times(pov, w, h, threads)?.1)
}

/// POV-Ray's "Parse Time" and "Trace Time" in seconds for `scene` at `w`×`h` on `threads` threads.
fn povray_times(pov: &Path, w: u32, h: u32, threads: u32) -> Result<(f64, f64)> {
    povray_times_with(pov, w, h, threads, &["-A"], &std::env::temp_dir().join("lancer-bench-pov.png"))
}

/// [`povray_times`] with the anti-aliasing options `antialias`, the image written to `out_png`.
fn povray_times_with(
    pov: &Path,
    w: u32,
    h: u32,
    threads: u32,
    antialias: &[&str],
    out_png: &Path,
) -> Result<(f64, f64)> {
    let out = Command::new("povray")
        .arg(format!("+I{}", pov.display()))
        .args([format!("+W{w}"), format!("+H{h}"), format!("+WT{threads}"), "-D".into()])
        .args(antialias)
        .arg(format!("+O{}", out_png.display()))
        // Beside the scene: an exported scene's image maps are found there.
        .current_dir(pov.parent().unwrap_or(Path::new(".")))
        .output()
        .context("running povray")?;
    let text = String::from_utf8_lossy(&out.stderr).into_owned() + &String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        bail!("povray failed: {}", text.lines().rev().take(5).collect::<Vec<_>>().join("\n"));
    }
    // "  Trace Time:       0 hours  0 minutes  0 seconds (0.693 seconds)"
    let time = |what: &str| -> Result<f64> {
        let line = text.lines().find(|l| l.contains(what)).with_context(|| format!("povray printed no {what}"))?;
        let secs = line.rsplit('(').next().and_then(|s| s.split_whitespace().next()).and_then(|s| s.parse().ok());
        secs.with_context(|| format!("could not read povray's {what} from `{line}`"))
    };
    Ok((time("Parse Time:")?, time("Trace Time:")?))
}

/// Adaptive anti-aliasing on the anchor at 1280x720, 2 threads: Lancer's `adaptive` (threshold
/// 0.3, depth 3) against POV-Ray's `+A0.3 +AM1 +R3` with the options `lancer export pov` writes
/// for it, and against Lancer's uniform 9 samples a pixel; each image's PSNR against Lancer at
/// 64 samples a pixel (the converged image), and Lancer's against POV-Ray's at the same settings.
fn aa_rows(
    lancer: &Path,
    runs: usize,
    has_pov: bool,
    json: &mut serde_json::Map<String, serde_json::Value>,
) -> Result<()> {
    let anchor = root().join("scenes/bench/anchor.toml");
    let pov = root().join("scenes/bench/anchor.pov");
    let tmp = std::env::temp_dir();
    let adaptive = "adaptive:threshold=0.3:depth=3";
    let read = |name: &str| -> Result<image::RgbImage> {
        Ok(image::open(tmp.join(name)).with_context(|| format!("reading {name}"))?.into_rgb8())
    };
    let run_to = |samples: &str, image: &str| -> Result<Run> {
        let all = (0..runs.max(1))
            .map(|_| lancer_run_to(lancer, &anchor, 2, &["--samples", samples], image))
            .collect::<Result<Vec<_>>>()?;
        Ok(median_by_secs(all))
    };
    println!(
        "\nAdaptive anti-aliasing (the anchor at 1280x720, 2 threads, median of {runs}; PSNR against Lancer at 64 samples a pixel)"
    );
    println!("{:<40} {:>10} {:>13} {:>12}", "", "render (s)", "camera rays", "PSNR (dB)");
    let reference = lancer_run_to(lancer, &anchor, 2, &["--samples", "64"], "lancer-bench-aa-64.png")?;
    let converged = read("lancer-bench-aa-64.png")?;
    let mut rows = serde_json::Map::new();
    for (key, what, samples, image) in [
        ("lancer_adaptive", "Lancer adaptive (0.3, depth 3)", adaptive, "lancer-bench-aa.png"),
        ("lancer_9spp", "Lancer 9 samples a pixel", "9", "lancer-bench-aa-9.png"),
        ("lancer_1spp", "Lancer 1 sample a pixel", "1", "lancer-bench-aa-1.png"),
    ] {
        let r = run_to(samples, image)?;
        let db = crate::compare::psnr(&read(image)?, &converged);
        println!("{what:<40} {:>10.3} {:>13} {db:>12.1}", r.secs, r.kinds[0]);
        rows.insert(
            key.into(),
            serde_json::json!({ "render_s": r.secs, "camera_rays": r.kinds[0], "psnr_vs_64spp_db": db }),
        );
    }
    println!("{:<40} {:>10.3} {:>13} {:>12}", "Lancer 64 samples a pixel", reference.secs, reference.kinds[0], "-");
    if has_pov {
        let flags = ["+A0.3", "+AM1", "+R3", "-J", "Antialias_Gamma=2.2"];
        let png = tmp.join("lancer-bench-aa-pov.png");
        let times = (0..runs.max(1))
            .map(|_| povray_times_with(&pov, 1280, 720, 2, &flags, &png))
            .collect::<Result<Vec<_>>>()?;
        let trace = median(times.iter().map(|t| t.1).collect());
        let pov_img = image::open(&png).context("reading POV-Ray's image")?.into_rgb8();
        let (db, same) =
            (crate::compare::psnr(&pov_img, &converged), crate::compare::psnr(&pov_img, &read("lancer-bench-aa.png")?));
        let lancer_s = rows["lancer_adaptive"]["render_s"].as_f64().unwrap_or(f64::NAN);
        println!("{:<40} {trace:>10.3} {:>13} {db:>12.1}", "POV-Ray +A0.3 +AM1 +R3 -J (trace time)", "-");
        println!(
            "POV-Ray's trace time / Lancer's adaptive render: {:.2}x; Lancer adaptive against POV-Ray's image: {same:.1} dB",
            trace / lancer_s
        );
        rows.insert(
            "povray".into(),
            serde_json::json!({ "trace_s": trace, "psnr_vs_64spp_db": db, "psnr_vs_lancer_adaptive_db": same, "ratio": trace / lancer_s }),
        );
    } else {
        println!(
            "POV-Ray is not installed, so its +A0.3 +R3 row was skipped: `apt-get install -y povray` (Debian) enables it."
        );
    }
    json.insert("adaptive".into(), rows.into());
    Ok(())
}

/// The scenes whose glass the two refraction paths render differently, compared with POV-Ray.
const GLASS_SCENES: [&str; 5] = [
    "scenes/glass.toml",
    "scenes/showcase.toml",
    "scenes/shapes/csg.toml",
    "scenes/meshes.toml",
    "scenes/ball-in-glass.toml",
];

/// The glass scenes against POV-Ray with the handout's refraction path (`seed`, with shadows
/// counting each object once) and with `refraction:traced` (shadows `each_surface`, as POV-Ray
/// traces both), at the scene's own samples and with adaptive anti-aliasing (0.3, depth 3: the
/// same rule in both renderers, so that what differs is the model, not where edges alias); the
/// target is the least PSNR of `traced` with adaptive anti-aliasing.
fn glass_rows(
    lancer: &Path,
    json: &mut serde_json::Map<String, serde_json::Value>,
    targets: &mut Vec<Target>,
) -> Result<()> {
    let Some(povray) = crate::which("povray") else {
        println!(
            "\nGlass against POV-Ray: POV-Ray is not installed, so it was skipped: `apt-get install -y povray` (Debian) enables it."
        );
        return Ok(());
    };
    let terms = "ambient,diffuse,specular,mirror";
    let seed = ["--terms", &format!("{terms},refraction:seed"), "--shadows", "transmissive"].map(String::from);
    let traced = ["--terms", &format!("{terms},refraction:traced"), "--shadows", "transmissive:each_surface=true"]
        .map(String::from);
    println!(
        "\nGlass against POV-Ray 3.7 (PSNR in dB; `lancer export pov` for each; the scene's samples | adaptive 0.3, depth 3)"
    );
    println!("{:<30} {:>14} {:>14} {:>14} {:>14}", "scene", "seed", "seed adaptive", "traced", "traced adaptive");
    let (mut rows, mut least_traced) = (serde_json::Map::new(), f64::INFINITY);
    for scene in GLASS_SCENES {
        let mut dbs = Vec::new();
        for flags in [&seed, &traced] {
            for aa in [&[][..], &["--samples".to_owned(), "adaptive".to_owned()][..]] {
                let extra: Vec<String> = flags.iter().chain(aa).cloned().collect();
                dbs.push(crate::compare::compare(lancer, &povray, &root().join(scene), None, &extra)?.psnr);
            }
        }
        println!("{scene:<30} {:>14.1} {:>14.1} {:>14.1} {:>14.1}", dbs[0], dbs[1], dbs[2], dbs[3]);
        least_traced = least_traced.min(dbs[3]);
        rows.insert(
            scene.into(),
            serde_json::json!({ "seed_db": dbs[0], "seed_adaptive_db": dbs[1], "traced_db": dbs[2], "traced_adaptive_db": dbs[3] }),
        );
    }
    json.insert("glass_vs_povray".into(), rows.into());
    targets.push(Target {
        what: "glass scenes, refraction:traced against POV-Ray (least PSNR, dB)",
        measured: least_traced,
        bound: 38.0,
        at_most: false,
    });
    Ok(())
}

/// The smallest of `v` (infinity for none).
fn least(v: impl IntoIterator<Item = f64>) -> f64 {
    v.into_iter().fold(f64::INFINITY, f64::min)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The run with the median render time of `runs` renders of `scene` on `threads` threads.
fn median_run(lancer: &Path, scene: &Path, threads: u32, runs: usize, extra: &[&str]) -> Result<Run> {
    let all = (0..runs.max(1)).map(|_| lancer_run(lancer, scene, threads, extra)).collect::<Result<Vec<_>>>()?;
    Ok(median_by_secs(all))
}

/// The run with the median render time of `all` (not empty).
fn median_by_secs(mut all: Vec<Run>) -> Run {
    all.sort_by(|a, b| a.secs.total_cmp(&b.secs));
    all[all.len() / 2]
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

/// Writes the height field of about `n` triangles (`field-N.obj`) and its scene (`field-N.toml`:
/// the camera and light of [`crate::embree::FIELD`], a mirror-like material, hard shadows) into
/// `dir`: their paths.
fn field_files(dir: &Path, n: usize) -> Result<(std::path::PathBuf, std::path::PathBuf)> {
    let obj = dir.join(format!("field-{n}.obj"));
    std::fs::write(&obj, heightfield_obj(n))?;
    let path = dir.join(format!("field-{n}.toml"));
    let f = &crate::embree::FIELD;
    let v = |p: [f64; 3]| format!("[{}, {}, {}]", p[0], p[1], p[2]);
    std::fs::write(
        &path,
        format!(
            "[image]\nwidth = {}\nheight = {}\n[camera]\nfrom = {}\nto = {}\nfov = {}\n\
             [model]\nmax_depth = {}\nshadows = \"hard\"\nterms = [\"ambient\", \"diffuse\", \"specular\", \"mirror\"]\n\
             [[lights]]\nat = {}\n[[objects]]\nshape = \"mesh\"\npath = \"field-{n}.obj\"\n\
             material = {{ color = [0.4, 0.7, 0.5], diff = 0.8, spec = 0.3, shine = 0.9 }}\n",
            f.width,
            f.height,
            v(f.from),
            v(f.to),
            f.fov,
            f.max_depth,
            v(f.light)
        ),
    )?;
    Ok((obj, path))
}

/// The folder of the scenes the bench generates (created if need be), kept between runs: the
/// 1M-triangle field's OBJ alone is 36 MB.
fn scenes_dir() -> Result<std::path::PathBuf> {
    let dir = std::env::temp_dir().join("lancer-bench-scenes");
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}

/// The height field at 10k, 100k and 1M triangles (640x360, 2 threads): render time, ns per ray,
/// loading time and peak memory, and the memory per triangle (the growth of the peak from 10k to
/// 1M triangles, so the renderer's own fixed cost drops out).
fn mesh_rows(
    lancer: &Path,
    dir: &Path,
    runs: usize,
    json: &mut serde_json::Map<String, serde_json::Value>,
    targets: &mut Vec<Target>,
) -> Result<()> {
    println!("\nScaling with the triangle count (a rippled height-field mesh, 640x360, 2 threads, median of {runs})");
    println!(
        "{:>10} {:>12} {:>12} {:>14} {:>10} {:>11}",
        "triangles", "render (s)", "M rays", "ns per ray", "load (s)", "peak (MB)"
    );
    let mut mesh_rows = Vec::new();
    let mut meshes = Vec::new();
    for n in [10_000usize, 100_000, 1_000_000] {
        let (_, path) = field_files(dir, n)?;
        let r = median_run(lancer, &path, 2, runs, &[])?;
        let ns = 2.0 * r.secs * 1e9 / r.rays;
        println!("{n:>10} {:>12.3} {:>12.2} {ns:>14.1} {:>10.3} {:>11.1}", r.secs, r.rays / 1e6, r.load, r.peak_mb);
        mesh_rows.push(serde_json::json!({
            "triangles": n, "render_s": r.secs, "rays": r.rays, "ns_per_ray": ns, "load_s": r.load, "peak_mb": r.peak_mb,
        }));
        meshes.push((n, r, ns));
    }
    // Memory per triangle: the growth of the peak from 10,000 to 1,000,000 triangles.
    let (small, large) = (meshes[0], meshes[2]);
    let per_triangle = (large.1.peak_mb - small.1.peak_mb) * 1e6 / (large.0 - small.0) as f64;
    println!("memory per triangle (growth of the peak from 10k to 1M triangles): {per_triangle:.0} bytes");
    json.insert("meshes".into(), mesh_rows.into());
    json.insert("bytes_per_triangle".into(), per_triangle.into());
    targets.push(Target { what: "1M triangles: ns per ray", measured: large.2, bound: 300.0, at_most: true });
    targets.push(Target {
        what: "1M triangles: loading with the BVH build (s)",
        measured: large.1.load,
        bound: 0.5,
        at_most: true,
    });
    targets.push(Target {
        what: "1M triangles: bytes per triangle",
        measured: per_triangle,
        bound: 100.0,
        at_most: true,
    });
    Ok(())
}

/// The 1M-triangle height field on 1 thread against the same rays priced at Embree 3's
/// single-ray rates (the harness of [`crate::embree`]), taken in pairs (Lancer, then Embree):
/// rows, JSON under `embree`, and the target; says why when it cannot be measured (Embree not
/// installed, the harness failing, the two frames not the same rays), and the bench goes on.
fn embree_rows(
    lancer: &Path,
    dir: &Path,
    runs: usize,
    json: &mut serde_json::Map<String, serde_json::Value>,
    targets: &mut Vec<Target>,
) {
    println!(
        "\nMeshes against Embree 3: the 1M-triangle height field, {}x{}, 1 thread, {runs} pairs of runs (Lancer, then Embree), medians",
        crate::embree::FIELD.width,
        crate::embree::FIELD.height
    );
    match embree_measure(lancer, dir, runs) {
        Ok(m) => {
            println!("{:<9} {:>12} {:>12} {:>12} {:>12}", "rays", "lancer", "embree", "embree ns", "priced (s)");
            for (k, what) in ["camera", "mirror", "shadow"].iter().enumerate() {
                println!(
                    "{what:<9} {:>12} {:>12} {:>12.1} {:>12.4}",
                    m.lancer_rays[k],
                    m.embree_rays[k],
                    m.ns[k],
                    m.lancer_rays[k] as f64 * m.ns[k] * 1e-9
                );
            }
            println!(
                "Lancer's frame {:.3} s (shading included), the Embree-priced frame {:.3} s (rays only): {:.2}x (median of \
                 the pairs); Embree's own frame {:.3} s",
                m.lancer_s, m.priced_s, m.ratio, m.embree_s
            );
            println!(
                "loading on 1 thread: Lancer {:.3} s (OBJ read, BVH built), Embree's BVH build alone {:.3} s ({} triangles)",
                m.lancer_load_s, m.embree_build_s, m.triangles
            );
            json.insert(
                "embree".into(),
                serde_json::json!({
                    "lancer_s": m.lancer_s, "priced_s": m.priced_s, "ratio": m.ratio, "embree_s": m.embree_s,
                    "lancer_rays": m.lancer_rays, "embree_rays": m.embree_rays, "embree_ns_per_ray": m.ns,
                    "lancer_load_s": m.lancer_load_s, "embree_build_s": m.embree_build_s,
                }),
            );
            targets.push(Target {
                what: "1M triangles, 1 thread: Lancer's frame / the Embree-priced frame",
                measured: m.ratio,
                bound: 1.5,
                at_most: true,
            });
        }
        Err(e) => {
            println!("  not measured: {e:#}");
            json.insert("embree".into(), serde_json::json!({ "not_measured": format!("{e:#}") }));
        }
    }
}

/// What [`embree_rows`] prints: medians over the pairs of runs.
struct EmbreeTimes {
    lancer_s: f64,
    priced_s: f64,
    ratio: f64,
    embree_s: f64,
    lancer_rays: [u64; 3],
    embree_rays: [u64; 3],
    /// Embree's nanoseconds per ray of each kind.
    ns: [f64; 3],
    lancer_load_s: f64,
    embree_build_s: f64,
    triangles: u64,
}

type Pair = (Run, crate::embree::Priced);

fn embree_measure(lancer: &Path, dir: &Path, runs: usize) -> Result<EmbreeTimes> {
    let harness = crate::embree::build(&root().join("target/bench"))?;
    let (obj, scene) = field_files(dir, 1_000_000)?;
    let mut pairs: Vec<Pair> = Vec::new();
    for _ in 0..runs.max(1) {
        let r = lancer_run(lancer, &scene, 1, &[])?;
        let p = crate::embree::run(&harness, &obj, &crate::embree::FIELD)?;
        same_rays(r.kinds, p.kinds.map(|k| k.0))?;
        pairs.push((r, p));
    }
    let med = |f: &dyn Fn(&Pair) -> f64| median(pairs.iter().map(f).collect());
    // Lancer's own rays (camera, secondary, shadow) at Embree's rate for each kind (a kind of
    // which Lancer traced none costs nothing, whatever Embree's rate).
    let priced = |(r, p): &Pair| -> f64 {
        r.kinds.iter().zip(p.rates()).map(|(&n, rate)| if n == 0 { 0.0 } else { n as f64 * rate }).sum()
    };
    let ns = [0, 1, 2].map(|k| med(&|(_, p): &Pair| p.rates()[k] * 1e9));
    let last = &pairs[pairs.len() - 1];
    Ok(EmbreeTimes {
        lancer_s: med(&|(r, _): &Pair| r.secs),
        priced_s: med(&priced),
        ratio: med(&|pair: &Pair| pair.0.secs / priced(pair)),
        embree_s: med(&|(_, p): &Pair| p.kinds.iter().map(|k| k.1).sum()),
        lancer_rays: last.0.kinds,
        embree_rays: last.1.kinds.map(|k| k.0),
        ns,
        lancer_load_s: med(&|(r, _): &Pair| r.load),
        embree_build_s: med(&|(_, p): &Pair| p.build),
        triangles: last.1.triangles,
    })
}

/// Fails unless Lancer's frame and the harness's are the same rays: the same camera rays, and
/// secondary and shadow counts within 0.5 % (the two tracers round a few grazing hits on
/// triangle edges differently). A kind Lancer traced that the harness did not cannot be priced.
fn same_rays(lancer: [u64; 3], embree: [u64; 3]) -> Result<()> {
    let names = ["camera", "mirror (secondary)", "shadow"];
    for k in 0..3 {
        let (a, b) = (lancer[k] as f64, embree[k] as f64);
        let close = if k == 0 { a == b } else { (a - b).abs() <= 0.005 * a.max(b) };
        if !close || (a > 0.0 && b == 0.0) {
            bail!(
                "Lancer and the Embree harness did not trace the same frame: {} rays {} against {} (Lancer's: {lancer:?}, \
                 Embree's: {embree:?})",
                names[k],
                lancer[k],
                embree[k]
            );
        }
    }
    Ok(())
}

/// One target of the benchmark: what is measured, the bound, and whether it is met.
struct Target {
    what: &'static str,
    measured: f64,
    bound: f64,
    at_most: bool,
}

impl Target {
    fn met(&self) -> bool {
        if self.at_most { self.measured <= self.bound } else { self.measured >= self.bound }
    }
}

/// The share of the machine's CPU time other programs used over half a second (from
/// `/proc/stat`); `None` where that file does not exist (not Linux).
fn busy_share() -> Option<f64> {
    let first = std::fs::read_to_string("/proc/stat").ok()?;
    std::thread::sleep(std::time::Duration::from_millis(500));
    let second = std::fs::read_to_string("/proc/stat").ok()?;
    busy_between(&first, &second)
}

/// The busy share of all CPUs between two readings of `/proc/stat`: 1 − idle time / all time,
/// from the first (`cpu`) line's user, nice, system, idle, iowait, irq, softirq and steal
/// counters (idle and iowait are idle).
fn busy_between(first: &str, second: &str) -> Option<f64> {
    let counters = |stat: &str| -> Option<(u64, u64)> {
        let line = stat.lines().next()?;
        let fields: Vec<u64> = line.strip_prefix("cpu ")?.split_whitespace().filter_map(|f| f.parse().ok()).collect();
        let idle = fields.get(3)? + fields.get(4).copied().unwrap_or(0);
        Some((fields.iter().take(8).sum(), idle))
    };
    let ((total0, idle0), (total1, idle1)) = (counters(first)?, counters(second)?);
    let total = total1.saturating_sub(total0).max(1);
    Some(1.0 - idle1.saturating_sub(idle0) as f64 / total as f64)
}

/// Warns when other programs keep the CPU busy: the timings would be slower than the machine is.
fn check_quiet(when: &str) -> Option<f64> {
    let busy = busy_share();
    if let Some(b) = busy.filter(|&b| b > 0.15) {
        eprintln!(
            "warning: {when} the benchmark, other programs (or the host) used {:.0} % of the CPU: the figures \
             are slower than this machine is (close them and run again)",
            b * 100.0
        );
    }
    busy
}

/// `cargo xtask bench [--runs N] [--only web|embree|meshes|aa|glass]`: prints the tables and the targets, and
/// writes them as JSON to `target/bench/bench.json` (with `--only`, only those rows, to
/// `target/bench/bench-<ONLY>.json`).
pub fn run(args: &[String]) -> Result<()> {
    let TaskArgs { options, filter } = parse_common(args, &["runs", "only"])?;
    if let Some(f) = filter {
        bail!("unexpected argument `{f}`");
    }
    let runs: usize =
        options.iter().find(|(k, _)| k == "runs").map_or(Ok(5), |(_, v)| v.parse()).context("--runs needs a number")?;
    let only = options.iter().find(|(k, _)| k == "only").map(|(_, v)| v.as_str());
    let lancer = build_renderer()?;
    if let Some(only) = only {
        let (mut json, mut targets) = (serde_json::Map::new(), Vec::new());
        match only {
            "web" => web_rows(&lancer, runs, &mut json, &mut targets),
            "aa" => aa_rows(&lancer, runs, povray_installed(), &mut json)?,
            "glass" => glass_rows(&lancer, &mut json, &mut targets)?,
            "embree" => embree_rows(&lancer, &scenes_dir()?, runs, &mut json, &mut targets),
            "meshes" => mesh_rows(&lancer, &scenes_dir()?, runs, &mut json, &mut targets)?,
            _ => bail!(
                "--only takes `web` (the browser build against native renders of the anchor), `embree` (the \
                 1M-triangle field against Embree 3), `meshes` (the height field from 10k to 1M triangles: time, \
                 loading and memory per triangle), `aa` (adaptive anti-aliasing against POV-Ray's and 9 samples) \
                 or `glass` (the glass scenes against POV-Ray with both refraction paths)"
            ),
        }
        print_targets(&targets);
        let dir = root().join("target/bench");
        std::fs::create_dir_all(&dir)?;
        let file = dir.join(format!("bench-{only}.json"));
        std::fs::write(&file, serde_json::to_string_pretty(&serde_json::Value::Object(json))?)?;
        println!("\n(written as JSON to {})", file.display());
        return Ok(());
    }
    let busy_before = check_quiet("before");
    let anchor = root().join("scenes/bench/anchor.toml");
    let pov = root().join("scenes/bench/anchor.pov");
    let has_pov = povray_installed();
    let mut json = serde_json::Map::new();
    let mut targets: Vec<Target> = Vec::new();

    // Each ratio below divides two medians, each with its own noise (this 2-core VM's speed
    // moves by several percent from one run to the next): three times the runs of the other
    // tables, at about two seconds a round.
    let rounds = 3 * runs.max(1);
    println!(
        "Anchor scene (scenes/bench/anchor.toml vs anchor.pov), 1280x720, no anti-aliasing, depth 5, median of {rounds} interleaved runs"
    );
    println!(
        "{:<8} {:>11} {:>12} {:>8} {:>16} {:>11} {:>10} {:>11} {:>16}",
        "threads",
        "lancer (s)",
        "fastest (s)",
        "M rays",
        "M rays/thread-s",
        "ns per ray",
        "peak (MB)",
        "povray (s)",
        "povray / lancer"
    );
    // Round after round, each round one run of every configuration (Lancer and POV-Ray, one
    // thread and two): the machine's speed drifts by several percent over a minute, and
    // interleaved, the runs of every configuration (whose medians the ratios divide) sample
    // the same stretch of time.
    let mut lancer_runs: [Vec<Run>; 2] = [Vec::new(), Vec::new()];
    let mut pov_runs: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    // And two single-thread renders at once, as separate processes: a reference for what the
    // machine gives two threads that share no memory (its caches and clock are still shared).
    let mut side_by_side = Vec::new();
    for _ in 0..rounds {
        for (k, threads) in [1u32, 2].into_iter().enumerate() {
            lancer_runs[k].push(lancer_run(&lancer, &anchor, threads, &[])?);
            if has_pov {
                pov_runs[k].push(povray_run(&pov, 1280, 720, threads)?);
            }
        }
        let (a, b) = std::thread::scope(|s| {
            let other = s.spawn(|| lancer_run_to(&lancer, &anchor, 1, &[], "lancer-bench-side.png"));
            let mine = lancer_run(&lancer, &anchor, 1, &[]);
            (mine, other.join().expect("the second render's thread does not panic"))
        });
        // The slower of the two: a 2-thread render ends with its slower worker.
        side_by_side.push(a?.secs.max(b?.secs));
    }
    let mut anchor_rows = Vec::new();
    let mut by_threads = Vec::new();
    // The fastest run of each thread count, for the speed-up: the host only ever slows a run
    // down, and a 2-thread run is slowed when either of its cores is, so its median takes in
    // more of the host's noise than a 1-thread run's does.
    let fastest: Vec<f64> = lancer_runs.iter().map(|r| least(r.iter().map(|r| r.secs))).collect();
    for (k, threads) in [1u32, 2].into_iter().enumerate() {
        let r = median_by_secs(std::mem::take(&mut lancer_runs[k]));
        let pov_t = has_pov.then(|| median(std::mem::take(&mut pov_runs[k])));
        // Per-ray cost in thread-nanoseconds, comparable across thread counts and scenes.
        let ns = threads as f64 * r.secs * 1e9 / r.rays;
        let per_thread = r.rays / 1e6 / r.secs / threads as f64;
        println!(
            "{threads:<8} {:>11.3} {:>12.3} {:>8.2} {per_thread:>16.1} {ns:>11.1} {:>10.1} {:>11} {:>16}",
            r.secs,
            fastest[k],
            r.rays / 1e6,
            r.peak_mb,
            pov_t.map_or("-".into(), |p| format!("{p:.3}")),
            pov_t.map_or("-".into(), |p| format!("{:.2}x", p / r.secs)),
        );
        anchor_rows.push(serde_json::json!({
            "threads": threads, "lancer_s": r.secs, "fastest_s": fastest[k], "rays": r.rays, "m_rays_per_thread_s": per_thread,
            "ns_per_ray": ns, "peak_mb": r.peak_mb, "povray_s": pov_t, "ratio": pov_t.map(|p| p / r.secs),
        }));
        by_threads.push((r, pov_t));
    }
    json.insert("anchor".into(), anchor_rows.into());
    let (one, two) = (by_threads[0].0, by_threads[1].0);
    let scaling = fastest[0] / fastest[1];
    let of_medians = one.secs / two.secs;
    let side = 2.0 * fastest[0] / least(side_by_side);
    println!(
        "1 -> 2 threads: {scaling:.2}x, fastest run against fastest run of {rounds} each ({of_medians:.2}x on the medians); \
         for reference, two 1-thread renders at once, as separate processes: {side:.2}x one alone"
    );
    json.insert("thread_scaling".into(), of_medians.into());
    json.insert("thread_scaling_fastest".into(), scaling.into());
    json.insert("thread_scaling_side_by_side".into(), side.into());
    if let Some(p) = by_threads[1].1 {
        targets.push(Target {
            what: "anchor, 2 threads: POV-Ray trace time / Lancer render time",
            measured: p / two.secs,
            bound: 8.0,
            at_most: false,
        });
    }
    targets.push(Target {
        what: "anchor, 2 threads: M rays per thread-second",
        measured: two.rays / 1e6 / two.secs / 2.0,
        bound: 18.0,
        at_most: false,
    });
    targets.push(Target {
        what: "anchor: 1 -> 2 threads speed-up (fastest runs)",
        measured: scaling,
        bound: 1.9,
        at_most: false,
    });
    if has_pov {
        println!(
            "(POV-Ray's figure is its own Trace Time, start-up excluded; Lancer's is its render time, scene loading and file writing excluded.)"
        );
    } else {
        println!(
            "POV-Ray is not installed, so the comparison was skipped: `apt-get install -y povray` (Debian) enables it."
        );
    }

    // Per-term images: the 720p anchor with --aov (EXR and PNG per term, and beauty).
    let aov_dir = std::env::temp_dir().join("lancer-bench-aov");
    let aov = median_run(&lancer, &anchor, 2, runs, &["--aov", &aov_dir.display().to_string()])?;
    // Writing the images: the command's extra wall time over the same render without them.
    let writing = (aov.wall - aov.secs - aov.load).max(0.0) - (two.wall - two.secs - two.load).max(0.0);
    println!(
        "\nAnchor with every per-term image (--aov: EXR and PNG), 2 threads: render {:.3} s, writing the images {:.3} s, peak memory {:.1} MB",
        aov.secs, writing, aov.peak_mb
    );
    json.insert(
        "aov".into(),
        serde_json::json!({ "render_s": aov.secs, "writing_s": writing, "peak_mb": aov.peak_mb }),
    );
    targets.push(Target {
        what: "anchor with --aov: peak memory (MB)",
        measured: aov.peak_mb,
        bound: 100.0,
        at_most: true,
    });
    targets.push(Target {
        what: "anchor with --aov: writing time / render time",
        measured: writing / aov.secs,
        bound: 1.0,
        at_most: true,
    });

    // Samples per pixel: time linear, memory flat.
    println!("\nSamples per pixel (scenes/showcase.toml at 320x180, 2 threads, median of {})", runs.min(3));
    println!("{:>8} {:>12} {:>12} {:>12}", "samples", "render (s)", "M rays", "peak (MB)");
    let showcase = root().join("scenes/showcase.toml");
    let mut spp_rows = Vec::new();
    let mut spp = Vec::new();
    for samples in [1u32, 16, 256] {
        let n = samples.to_string();
        let r =
            median_run(&lancer, &showcase, 2, runs.min(3), &["--width", "320", "--height", "180", "--samples", &n])?;
        println!("{samples:>8} {:>12.3} {:>12.2} {:>12.1}", r.secs, r.rays / 1e6, r.peak_mb);
        spp_rows
            .push(serde_json::json!({ "samples": samples, "render_s": r.secs, "rays": r.rays, "peak_mb": r.peak_mb }));
        spp.push(r);
    }
    json.insert("samples".into(), spp_rows.into());
    targets.push(Target {
        what: "256 spp time / 16 spp time",
        measured: spp[2].secs / spp[1].secs,
        bound: 20.0,
        at_most: true,
    });
    targets.push(Target {
        what: "peak memory at 256 spp minus at 16 spp (MB)",
        measured: spp[2].peak_mb - spp[1].peak_mb,
        bound: 20.0,
        at_most: true,
    });

    aa_rows(&lancer, runs, has_pov, &mut json)?;
    glass_rows(&lancer, &mut json, &mut targets)?;

    println!("\nScaling with the object count (a grid of spheres over a floor, 640x360, 2 threads, median of {runs})");
    println!("{:>8} {:>12} {:>12} {:>14}", "spheres", "render (s)", "M rays", "ns per ray");
    let dir = scenes_dir()?;
    let mut sphere_rows = Vec::new();
    for n in [10usize, 100, 1_000, 10_000] {
        let path = dir.join(format!("spheres-{n}.toml"));
        std::fs::write(&path, spheres_scene(n))?;
        let r = median_run(&lancer, &path, 2, runs, &[])?;
        // Two threads share the work: per-ray cost in thread-nanoseconds.
        let ns = 2.0 * r.secs * 1e9 / r.rays;
        println!("{n:>8} {:>12.3} {:>12.2} {ns:>14.1}", r.secs, r.rays / 1e6);
        sphere_rows.push(serde_json::json!({ "spheres": n, "render_s": r.secs, "rays": r.rays, "ns_per_ray": ns }));
    }

    json.insert("spheres".into(), sphere_rows.into());

    // Scenes of many objects, each its own `[[objects]]` table: the whole command (reading,
    // loading, the checks `lancer check` makes, preparing, a 16x9 render) once each, its time
    // and peak memory (Lancer's own figures). About 15 s in all; each file is deleted after
    // (the larger is 135 MB).
    println!(
        "\nLarge scenes (the sphere grid as [[objects]] tables: read, loaded, checked, prepared, a 16x9 render; 2 threads, one run)"
    );
    println!("{:>10} {:>10} {:>12} {:>10} {:>11}", "objects", "file (MB)", "command (s)", "load (s)", "peak (MB)");
    let mut large_rows = Vec::new();
    let mut largest = None;
    for n in [100_000usize, 1_000_000] {
        let path = dir.join(format!("spheres-{n}.toml"));
        let text = spheres_scene(n);
        let mb = text.len() as f64 / 1e6;
        std::fs::write(&path, text)?;
        let r = lancer_run(&lancer, &path, 2, &["--width", "16", "--height", "9"]);
        let _ = std::fs::remove_file(&path);
        let r = r?;
        println!("{n:>10} {mb:>10.1} {:>12.3} {:>10.3} {:>11.1}", r.wall, r.load, r.peak_mb);
        large_rows.push(serde_json::json!({
            "objects": n, "file_mb": mb, "command_s": r.wall, "load_s": r.load, "peak_mb": r.peak_mb,
        }));
        largest = Some(r);
    }
    json.insert("large_scenes".into(), large_rows.into());
    if let Some(r) = largest {
        targets.push(Target {
            what: "10^6 objects: read, load, check and prepare (whole command, s)",
            measured: r.wall,
            bound: 20.0,
            at_most: true,
        });
        targets.push(Target {
            what: "10^6 objects: peak memory (MB)",
            measured: r.peak_mb,
            bound: 2000.0,
            at_most: true,
        });
    }

    mesh_rows(&lancer, &dir, runs, &mut json, &mut targets)?;

    embree_rows(&lancer, &dir, runs, &mut json, &mut targets);

    // Mesh scenes against POV-Ray: each exported by `lancer export pov` (so both render the same
    // scene) and traced by both at 1280x720 on two threads.
    let mut mesh_pov_rows = Vec::new();
    if has_pov {
        println!(
            "\nMesh scenes against POV-Ray 3.7 (each exported by `lancer export pov`), 1280x720, 2 threads, median of {runs}"
        );
        println!("{:<58} {:>11} {:>11} {:>16}", "scene", "lancer (s)", "povray (s)", "povray / lancer");
        let meshes = root().join("scenes/meshes.toml");
        let field = dir.join("field-100000.toml");
        // One sample a pixel, as POV-Ray's `-A` (meshes.toml asks for four, for its checker floor).
        let opaque = ["--terms", "ambient,diffuse,specular,mirror", "--shadows", "hard", "--samples", "1"];
        let cases: [(&str, &Path, &[&str]); 2] = [
            ("scenes/meshes.toml, opaque (as CI compares it)", &meshes, &opaque),
            ("height field, 100,000 triangles, mirror, hard shadows", &field, &[]),
        ];
        for (k, (what, scene, flags)) in cases.iter().enumerate() {
            let size = ["--width", "1280", "--height", "720"];
            let extra: Vec<&str> = size.iter().chain(flags.iter()).copied().collect();
            let pov_dir = dir.join(format!("pov-{k}"));
            std::fs::create_dir_all(&pov_dir)?;
            let pov_file = pov_dir.join("scene.pov");
            let out = Command::new(&lancer)
                .args(["export", "pov"])
                .arg(scene)
                .args(&extra)
                .arg("-o")
                .arg(&pov_file)
                .output()
                .context("running lancer export pov")?;
            if !out.status.success() {
                bail!("lancer export pov failed: {}", String::from_utf8_lossy(&out.stderr));
            }
            let r = median_run(&lancer, scene, 2, runs, &extra)?;
            let p = median((0..runs.max(1)).map(|_| povray_run(&pov_file, 1280, 720, 2)).collect::<Result<Vec<_>>>()?);
            println!("{what:<58} {:>11.3} {p:>11.3} {:>15.2}x", r.secs, p / r.secs);
            mesh_pov_rows
                .push(serde_json::json!({ "scene": what, "lancer_s": r.secs, "povray_s": p, "ratio": p / r.secs }));
            targets.push(Target {
                what: if k == 0 {
                    "scenes/meshes.toml opaque, 2 threads: POV-Ray / Lancer"
                } else {
                    "mesh-heavy scene (100k-triangle field), 2 threads: POV-Ray / Lancer"
                },
                measured: p / r.secs,
                bound: 5.0,
                at_most: false,
            });
        }
        // Loading the 1M-triangle field: Lancer's (the OBJ read and the BVH built, from the
        // triangle-count table) against POV-Ray's parse of the exported mesh2 (which builds its
        // bounding tree), a 16x9 render so that the trace is nothing.
        let field = dir.join("field-1000000.toml");
        let pov_dir = dir.join("pov-field-1m");
        std::fs::create_dir_all(&pov_dir)?;
        let pov_file = pov_dir.join("scene.pov");
        let out = Command::new(&lancer)
            .args(["export", "pov"])
            .arg(&field)
            .arg("-o")
            .arg(&pov_file)
            .output()
            .context("running lancer export pov")?;
        if !out.status.success() {
            bail!("lancer export pov failed: {}", String::from_utf8_lossy(&out.stderr));
        }
        let parse =
            median((0..runs.max(1)).map(|_| povray_times(&pov_file, 16, 9, 1).map(|t| t.0)).collect::<Result<_>>()?);
        // On one thread, as POV-Ray parses.
        let tiny = ["--width", "16", "--height", "9"];
        let load = median(
            (0..runs.max(1)).map(|_| lancer_run(&lancer, &field, 1, &tiny).map(|r| r.load)).collect::<Result<_>>()?,
        );
        println!(
            "1M-triangle field on 1 thread: Lancer loads it (OBJ read, BVH built) in {load:.3} s, POV-Ray parses its export in {parse:.3} s"
        );
        json.insert("field_1m_load".into(), serde_json::json!({ "lancer_load_s": load, "povray_parse_s": parse }));
        targets.push(Target {
            what: "1M triangles: Lancer's load and BVH / POV-Ray's parse",
            measured: load / parse,
            bound: 1.0,
            at_most: true,
        });
    }
    json.insert("meshes_vs_povray".into(), mesh_pov_rows.into());

    web_rows(&lancer, runs, &mut json, &mut targets);

    print_targets(&targets);
    let rows: Vec<serde_json::Value> = targets
        .iter()
        .map(|t| serde_json::json!({ "what": t.what, "measured": t.measured, "bound": t.bound, "at_most": t.at_most, "met": t.met() }))
        .collect();
    json.insert("targets".into(), rows.into());
    let busy_after = check_quiet("after");
    json.insert("cpu_busy_before".into(), busy_before.into());
    json.insert("cpu_busy_after".into(), busy_after.into());
    let dir = root().join("target/bench");
    std::fs::create_dir_all(&dir)?;
    let path = dir.join("bench.json");
    std::fs::write(&path, serde_json::to_string_pretty(&serde_json::Value::Object(json))?)?;
    println!("\n(written as JSON to {})", path.display());
    Ok(())
}

/// The browser build (target/web) in headless Chromium against native renders of the anchor by
/// `lancer` (each browser render beside a native one): rows, JSON under `wasm`, and the targets;
/// says why when it cannot be measured.
fn web_rows(
    lancer: &Path,
    runs: usize,
    json: &mut serde_json::Map<String, serde_json::Value>,
    targets: &mut Vec<Target>,
) {
    println!(
        "\nIn the browser: target/web (cargo xtask web) in headless Chromium, anchor 1280x720, {runs} pairs of \
         renders (native, then the browser), medians"
    );
    let anchor = root().join("scenes/bench/anchor.toml");
    let mut native = |threads: u32| lancer_run(lancer, &anchor, threads, &[]).map(|r| r.secs);
    match crate::web_check::measure(runs, &mut native) {
        Ok(w) => {
            let mut rows = Vec::new();
            println!("{:<8} {:>10} {:>11} {:>22}", "workers", "wasm (s)", "native (s)", "wasm / native (pairs)");
            for a in &w.anchor {
                println!("{:<8} {:>10.3} {:>11.3} {:>21.2}x", a.workers, a.wasm, a.native, a.ratio);
                rows.push(serde_json::json!({ "workers": a.workers, "wasm_s": a.wasm, "native_s": a.native, "ratio": a.ratio }));
            }
            let (coarse, full) = w.latency;
            println!(
                "slider to image at 640x360 on 2 workers: coarse {coarse:.0} ms, full {full:.0} ms (module {})",
                if w.simd { "with SIMD" } else { "without SIMD" }
            );
            json.insert(
                "wasm".into(),
                serde_json::json!({ "anchor": rows, "latency_coarse_ms": coarse, "latency_full_ms": full, "simd": w.simd }),
            );
            if let Some(a) = w.anchor.first() {
                targets.push(Target {
                    what: "anchor in the browser, 1 worker / native 1 thread",
                    measured: a.ratio,
                    bound: 2.0,
                    at_most: true,
                });
            }
            targets.push(Target {
                what: "browser slider to coarse image, 640x360, 2 workers (ms)",
                measured: coarse,
                bound: 100.0,
                at_most: true,
            });
            targets.push(Target {
                what: "browser slider to full image, 640x360, 2 workers (ms)",
                measured: full,
                bound: 500.0,
                at_most: true,
            });
        }
        Err(e) => {
            println!("  not measured: {e:#}");
            json.insert("wasm".into(), serde_json::json!({ "not_measured": format!("{e:#}") }));
        }
    }
}

fn print_targets(targets: &[Target]) {
    println!("\nTargets");
    for t in targets {
        println!(
            "  {:<60} {:>9.2} {} {:<6} {}",
            t.what,
            t.measured,
            if t.at_most { "<=" } else { ">=" },
            t.bound,
            if t.met() { "met" } else { "NOT MET" }
        );
    }
}

#[cfg(test)]
mod tests {
    use super::{busy_between, ray_kinds, same_rays};

    #[test]
    fn the_ray_counts_are_read_from_the_summary_line_only() {
        let text = "warning: something about 5 M rays (1 camera)\nrendered scenes/bench/anchor.toml at 1280x720 (terms \
                    ambient:seed; shadows hard; max_depth 5; 1 sample per pixel) in 0.307 s: 4.37 M rays (921600 camera, \
                    1314006 secondary, 2137739 shadow), 14.2 M rays/s -> /tmp/x.png (scene loaded in 0.000 s)\n";
        assert_eq!(ray_kinds(text), Some([921_600, 1_314_006, 2_137_739]));
        // A kind missing, or written otherwise: no counts rather than a zero.
        assert_eq!(ray_kinds("rendered x in 1 s: 1 M rays (5 camera, 6 shadow) -> y"), None);
        assert_eq!(ray_kinds("rendered x in 1 s: 1 M rays (5 camera, 6 secondary, 7 shadows) -> y"), None);
        assert_eq!(ray_kinds("no summary"), None);
    }

    #[test]
    fn frames_of_other_rays_are_not_priced() {
        assert!(same_rays([230_400, 156_106, 156_561], [230_400, 156_091, 156_538]).is_ok());
        assert!(same_rays([230_400, 156_106, 156_561], [230_399, 156_106, 156_561]).is_err(), "camera rays differ");
        assert!(same_rays([230_400, 156_106, 156_561], [230_400, 146_038, 156_561]).is_err(), "a depth less");
        assert!(same_rays([10, 0, 0], [10, 0, 0]).is_ok());
        assert!(same_rays([10, 0, 5], [10, 0, 0]).is_err(), "shadow rays Embree did not trace");
    }

    #[test]
    fn the_busy_share_counts_idle_and_iowait_as_idle() {
        let first = "cpu  100 0 50 800 50 0 0 0 0 0\ncpu0 50 0 25 400 25 0 0 0 0 0\n";
        // 100 more ticks: 30 user, 10 system, 50 idle, 10 iowait.
        let second = "cpu  130 0 60 850 60 0 0 0 0 0\ncpu0 65 0 30 425 30 0 0 0 0 0\n";
        let busy = busy_between(first, second).unwrap();
        assert!((busy - 0.4).abs() < 1e-12, "{busy}");
        // Nothing read: no share.
        assert_eq!(busy_between("", second), None);
        assert_eq!(busy_between("intr 5\n", second), None);
    }
}

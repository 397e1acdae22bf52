//! `cargo xtask compare SCENE`: the scene exported for POV-Ray 3.7 (`lancer export pov`), rendered
//! by both at the same size, depth and samples, and compared: both images, a difference image
//! and a page in `target/compare/<scene>/`, with the PSNR and the share of pixels that differ
//! visibly. Without POV-Ray it says so and stops.

use std::path::Path;
use std::process::Command;

use anyhow::{Context, Result, bail};

use crate::{build_renderer, root, which};

/// A pixel differs visibly when a channel is off by more than this many 8-bit steps.
const VISIBLE: u8 = 8;

/// `cargo xtask compare [--width W] [--min-psnr DB] SCENE... [-- LANCER FLAGS]` (flags such as `--terms` given
/// to both `lancer render` and `lancer export`).
pub fn run(args: &[String]) -> Result<()> {
    let (mut widths, mut scenes, mut least) = (Vec::new(), Vec::new(), None::<f64>);
    let (args, extra) = match args.iter().position(|a| a == "--") {
        Some(i) => (&args[..i], &args[i + 1..]),
        None => (args, &[][..]),
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if a == "--width" {
            widths.push(it.next().context("--width needs a value")?.clone());
        } else if a == "--min-psnr" {
            least = Some(it.next().and_then(|v| v.parse().ok()).context("--min-psnr needs a number of dB")?);
        } else if a.starts_with('-') {
            bail!("unknown option `{a}` (cargo xtask compare [--width W] [--min-psnr DB] SCENE... [-- LANCER FLAGS])");
        } else {
            scenes.push(a.clone());
        }
    }
    if scenes.is_empty() {
        bail!(
            "cargo xtask compare [--width W] [--min-psnr DB] SCENE... [-- LANCER FLAGS]: name at least one scene file"
        );
    }
    let Some(povray) = which("povray") else {
        let absent = "POV-Ray 3.7 is not installed (Debian: apt-get install povray): nothing compared";
        // Asked to hold a figure, a missing POV-Ray is a failure, not a pass.
        if least.is_some() {
            bail!("{absent}");
        }
        println!("{absent}");
        return Ok(());
    };
    let lancer = build_renderer()?;
    println!("{:<36} {:>9} {:>10} {:>10}", "scene", "PSNR (dB)", "visible %", "size");
    let mut low = Vec::new();
    for scene in &scenes {
        let r = compare(&lancer, &povray, Path::new(scene), widths.first().map(String::as_str), extra)?;
        println!(
            "{:<36} {:>9.1} {:>10.2} {:>10}",
            scene,
            r.psnr,
            100.0 * r.visible,
            format!("{}x{}", r.width, r.height)
        );
        if least.is_some_and(|l| r.psnr < l) {
            low.push(format!("{scene} ({:.1} dB)", r.psnr));
        }
    }
    println!("pages in {}", root().join("target/compare").display());
    if !low.is_empty() {
        bail!("below {} dB: {}", least.unwrap_or_default(), low.join(", "));
    }
    Ok(())
}

/// One scene rendered by both and compared.
pub(crate) struct Compared {
    /// Lancer's image against POV-Ray's.
    pub(crate) psnr: f64,
    /// The share of pixels that differ visibly.
    pub(crate) visible: f64,
    width: u32,
    height: u32,
}

/// Renders `scene` with Lancer (`lancer`) and with POV-Ray (`povray`) from `lancer export pov`,
/// both with the flags `extra` (and `width`), and compares the images; the pages go to
/// `target/compare/<scene>`.
pub(crate) fn compare(
    lancer: &Path,
    povray: &Path,
    scene: &Path,
    width: Option<&str>,
    extra: &[String],
) -> Result<Compared> {
    let scene = std::fs::canonicalize(scene).with_context(|| format!("no scene {}", scene.display()))?;
    let rel = scene.strip_prefix(root().join("scenes")).unwrap_or(&scene).with_extension("");
    let out = root().join("target/compare").join(rel.to_string_lossy().replace('/', "-"));
    std::fs::create_dir_all(&out)?;
    let mut size: Vec<&str> = width.map(|w| vec!["--width", w]).unwrap_or_default();
    size.extend(extra.iter().map(String::as_str));
    let run = |cmd: &mut Command, what: &str| -> Result<String> {
        let o = cmd.output().with_context(|| format!("running {what}"))?;
        let text = String::from_utf8_lossy(&o.stderr).into_owned() + &String::from_utf8_lossy(&o.stdout);
        if !o.status.success() {
            bail!("{what} failed:\n{text}");
        }
        Ok(text)
    };
    run(
        Command::new(lancer).arg("render").arg(&scene).args(&size).args(["-q", "-o"]).arg(out.join("lancer.png")),
        "lancer render",
    )?;
    let exported = run(
        Command::new(lancer).args(["export", "pov"]).arg(&scene).args(&size).arg("-o").arg(out.join("scene.pov")),
        "lancer export pov",
    )?;
    let lancer_img = image::open(out.join("lancer.png"))?.into_rgb8();
    let (w, h) = lancer_img.dimensions();
    let pov_text = std::fs::read_to_string(out.join("scene.pov"))?;
    let mut pov = Command::new(povray);
    pov.current_dir(&out)
        .args(["+Iscene.pov", &format!("+W{w}"), &format!("+H{h}"), "-D", "-V", "+WT2", "+Opovray.png"])
        .args(antialias_of(&pov_text));
    run(&mut pov, "povray")?;
    let pov_img = image::open(out.join("povray.png"))?.into_rgb8();
    if pov_img.dimensions() != (w, h) {
        bail!("POV-Ray wrote {:?}, Lancer {w}x{h}", pov_img.dimensions());
    }
    let mut visible = 0usize;
    let mut diff = image::RgbImage::new(w, h);
    for ((a, b), d) in lancer_img.pixels().zip(pov_img.pixels()).zip(diff.pixels_mut()) {
        let mut worst = 0u8;
        for c in 0..3 {
            let e = a.0[c].abs_diff(b.0[c]);
            worst = worst.max(e);
            d.0[c] = e.saturating_mul(4);
        }
        visible += usize::from(worst > VISIBLE);
    }
    diff.save(out.join("difference.png"))?;
    let psnr = psnr(&lancer_img, &pov_img);
    let share = visible as f64 / (w * h) as f64;
    let notes: Vec<String> =
        exported.lines().filter_map(|l| l.strip_prefix("warning: POV-Ray: ")).map(str::to_owned).collect();
    let html = format!(
        "<!doctype html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>Lancer vs POV-Ray: {name}</title>\
         <style>body{{font-family:sans-serif;margin:2em;background:#111;color:#ddd}}figure{{display:inline-block;margin:0 1em 1em 0}}\
         img{{image-rendering:pixelated;max-width:100%}}</style></head><body><h1>{name}: Lancer vs POV-Ray 3.7</h1>\
         <p>{w}x{h}; PSNR {psnr:.1} dB; {pct:.2} % of pixels differ by more than {VISIBLE}/255 in a channel.</p>{notes}\
         <figure><img src=\"lancer.png\" alt=\"Lancer\"><figcaption>Lancer</figcaption></figure>\
         <figure><img src=\"povray.png\" alt=\"POV-Ray\"><figcaption>POV-Ray 3.7 (scene.pov)</figcaption></figure>\
         <figure><img src=\"difference.png\" alt=\"difference\"><figcaption>|difference| x 4</figcaption></figure></body></html>\n",
        name = scene.display(),
        pct = 100.0 * share,
        notes = if notes.is_empty() {
            String::new()
        } else {
            format!(
                "<p>Not expressible in POV-Ray:</p><ul>{}</ul>",
                notes.iter().map(|n| format!("<li>{n}</li>")).collect::<String>()
            )
        }
    );
    std::fs::write(out.join("index.html"), html)?;
    Ok(Compared { psnr, visible: share, width: w, height: h })
}

/// The anti-aliasing options of the exported scene's `// Render:` line (`-A` when it has none):
/// `+A…`, `-A`, `+R…`, `-J` and `Antialias_…=…`.
fn antialias_of(pov_text: &str) -> Vec<String> {
    let line = pov_text.lines().find(|l| l.starts_with("// Render:")).unwrap_or_default();
    let flags: Vec<String> = line
        .split_whitespace()
        .filter(|t| {
            t.starts_with("+A") || *t == "-A" || t.starts_with("+R") || *t == "-J" || t.starts_with("Antialias_")
        })
        .map(str::to_owned)
        .collect();
    if flags.is_empty() { vec!["-A".to_owned()] } else { flags }
}

/// The PSNR in dB of two 8-bit images of the same size, over every channel of every pixel
/// (infinite when they are the same).
pub fn psnr(a: &image::RgbImage, b: &image::RgbImage) -> f64 {
    let sum: f64 = a.as_raw().iter().zip(b.as_raw()).map(|(x, y)| (x.abs_diff(*y) as f64).powi(2)).sum();
    let mse = sum / a.as_raw().len().max(1) as f64;
    if mse > 0.0 { 10.0 * (255.0f64 * 255.0 / mse).log10() } else { f64::INFINITY }
}

//! `lancer diff A B`: two images, or two folders of per-term images (as `render --aov` writes
//! them), compared for people checking their own renderer against Lancer's images and for
//! autograders. It reports PSNR, the mean and largest absolute errors, the share of pixels off
//! by more than a tolerance, the mean ꟻLIP ([`flip`]), the worst 16×16 block with the command
//! that explains its worst pixel, and names the usual mismatches ([`mismatch`]); it can draw a
//! heatmap of the errors ([`heatmap`]), print JSON, and sets its exit code by thresholds.
//!
//! Everything is compared in the display domain: sRGB-encoded values clamped to [0, 1] (a PNG's
//! or PPM's stored values; an EXR's linear values encoded). Exit codes: 0 pass, 1 differ, 2 bad
//! input (the process exits with it after printing the report: `main_with` returns only 0 or 1).

mod flip;
mod heatmap;
pub(crate) mod metrics;
mod mismatch;
pub(crate) mod read;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use serde::Serialize;

use read::Image;

/// The side of the blocks searched for the worst region.
const BLOCK: u32 = 16;

/// The default of `--max-file-size`, in MB.
const MAX_FILE_MB: u64 = 1024;

/// What `lancer diff --help` says after the flags: the exit codes and the domain.
const AFTER_HELP: &str = "\
Values are compared in the display domain: sRGB-encoded, clamped to [0, 1] (PNG, PPM and PGM
values as stored, taken as sRGB; EXR values linear, encoded for the comparison).

Exit codes:
  0  pass: identical, or, given any of --min-psnr, --max-error, --max-flip, every one met
  1  differ: not identical (without thresholds), a threshold not met, sizes that differ, or
     files that only one of two folders holds
  2  bad input: a file unreadable or of an unknown format, a folder against a file, a bad
     heatmap path (nothing is written then)";

/// `lancer diff`'s command line.
#[derive(Args)]
#[command(after_help = AFTER_HELP)]
pub(crate) struct DiffArgs {
    /// The reference: an image (PNG, OpenEXR, PPM P3/P6 or PGM P2/P5), or a folder of
    /// per-term images as `render --aov` writes (`<term>.exr`, `<term>.png`, `beauty.*`).
    a: PathBuf,
    /// The image, or folder, to compare with A (folders are compared file by file, by name).
    b: PathBuf,
    /// A pixel is off when a channel differs by more than this (display domain; a number or a
    /// fraction such as 2/255; by more than a millionth over it, so float rounding of an exact
    /// step does not count). The default, one 8-bit step, lets two renderers round differently.
    #[arg(long, value_name = "E", default_value = "1/255", value_parser = parse_level)]
    tolerance: Level,
    /// Pass only if the PSNR is at least DB (identical images pass any).
    #[arg(long, value_name = "DB", value_parser = parse_db)]
    min_psnr: Option<f64>,
    /// Pass only if no channel of any pixel differs by more than E (display domain, 0 to 1; a
    /// number or a fraction such as 4/255; with the tolerance's slack of a millionth).
    #[arg(long, value_name = "E", value_parser = parse_level)]
    max_error: Option<Level>,
    /// Pass only if the mean ꟻLIP is at most F (0 to 1).
    #[arg(long, value_name = "F", value_parser = parse_unit)]
    max_flip: Option<f64>,
    /// Write each pixel's error as a PNG, with a colour legend and its scale under the image
    /// (for two folders: a folder, one `<term>-<ext>.png` per pair).
    #[arg(long, value_name = "FILE.png")]
    heatmap: Option<PathBuf>,
    /// Which error the heatmap shows: ꟻLIP (0 to 1), or the largest absolute error of a
    /// pixel's channels (scaled to the largest found).
    #[arg(long, value_enum, default_value_t = HeatmapOf::Flip)]
    heatmap_of: HeatmapOf,
    /// Pixels per degree of visual angle for ꟻLIP (67: a 0.7 m wide 4K screen seen from 0.7 m).
    #[arg(long, value_name = "PPD", default_value_t = flip::DEFAULT_PPD, value_parser = parse_ppd)]
    ppd: f32,
    /// The scene the images are of, to fill in the `lancer explain` command of the worst pixel.
    #[arg(long, value_name = "SCENE")]
    scene: Option<PathBuf>,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
    /// Largest image file read, in MB.
    #[arg(long, value_name = "MB", default_value_t = MAX_FILE_MB, value_parser = clap::value_parser!(u64).range(1..))]
    max_file_size: u64,
}

/// What `--heatmap` draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum HeatmapOf {
    /// The ꟻLIP error, 0 to 1.
    Flip,
    /// The largest absolute error of the pixel's channels (display domain).
    Abs,
}

/// A level in [0, 1] as given (`2/255`) and its value.
#[derive(Clone, Debug)]
struct Level {
    value: f64,
    text: String,
}

impl Level {
    /// `0.00392 (1/255)` for a fraction, the number alone otherwise.
    fn describe(&self) -> String {
        if self.text.contains('/') { format!("{} ({:.5})", self.text, self.value) } else { self.text.clone() }
    }
}

/// A number or a fraction `N/D`, from 0 to 1.
fn parse_level(s: &str) -> Result<Level, String> {
    let expected = || format!("expected a number from 0 to 1 or a fraction such as 2/255, got `{s}`");
    let value = match s.split_once('/') {
        Some((n, d)) => {
            let (n, d): (f64, f64) =
                (n.trim().parse().map_err(|_| expected())?, d.trim().parse().map_err(|_| expected())?);
            if d == 0.0 {
                return Err(expected());
            }
            n / d
        }
        None => s.trim().parse().map_err(|_| expected())?,
    };
    if !(0.0..=1.0).contains(&value) {
        return Err(expected());
    }
    Ok(Level { value, text: s.trim().to_owned() })
}

/// A number from 0 to 1.
fn parse_unit(s: &str) -> Result<f64, String> {
    s.trim()
        .parse()
        .ok()
        .filter(|v| (0.0..=1.0).contains(v))
        .ok_or_else(|| format!("expected a number from 0 to 1, got `{s}`"))
}

/// A finite number of decibels.
fn parse_db(s: &str) -> Result<f64, String> {
    s.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("expected a number of dB, e.g. 40, got `{s}`"))
}

/// Pixels per degree, from 1 to 1000.
fn parse_ppd(s: &str) -> Result<f32, String> {
    s.trim()
        .parse::<f32>()
        .ok()
        .filter(|v| (1.0..=1000.0).contains(v))
        .ok_or_else(|| format!("expected pixels per degree from 1 to 1000, e.g. 67, got `{s}`"))
}

/// Runs `lancer diff`; prints the report (stdout) or the error (stderr), and exits with 1 or 2
/// when the images differ or the input is bad.
pub(crate) fn run(args: DiffArgs) -> Result<()> {
    let code = match diff(&args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            2
        }
    };
    crate::output::outputs_done();
    if code != 0 {
        use std::io::Write;
        let _ = std::io::stdout().flush();
        std::process::exit(code);
    }
    Ok(())
}

/// The comparison; its exit code.
fn diff(args: &DiffArgs) -> Result<i32> {
    let is_dir =
        |p: &Path| std::fs::metadata(p).map(|m| m.is_dir()).with_context(|| format!("reading {}", p.display()));
    match (is_dir(&args.a)?, is_dir(&args.b)?) {
        (false, false) => single(args),
        (true, true) => folders(args),
        (a_dir, _) => {
            let (dir, file) = if a_dir { (&args.a, &args.b) } else { (&args.b, &args.a) };
            bail!(
                "{} is a folder and {} a file: compare two images, or two folders of per-term images",
                dir.display(),
                file.display()
            )
        }
    }
}

/// Two image files.
fn single(args: &DiffArgs) -> Result<i32> {
    if let Some(path) = &args.heatmap
        && !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png"))
    {
        bail!("--heatmap {}: the heatmap is a PNG image: give a file name ending in .png", path.display());
    }
    let a = read::read(&args.a, args.max_file_size)?;
    let b = read::read(&args.b, args.max_file_size)?;
    let pair = compare(args.a.display().to_string(), args.b.display().to_string(), &a, &b, args)?;
    if let (Some(path), Some(png)) = (&args.heatmap, &pair.heatmap) {
        crate::output::write_atomic(path, png)?;
    }
    let code = pair.report.exit_code();
    if args.json {
        let mut doc = serde_json::to_value(&pair.report).expect("plain data serialises");
        doc["exit_code"] = code.into();
        println!("{}", serde_json::to_string_pretty(&doc).expect("plain data serialises"));
    } else {
        let mut out = String::new();
        let r = &pair.report;
        let _ = writeln!(out, "A: {} ({}, {}x{})", r.a, r.a_format, r.a_size[0], r.a_size[1]);
        let _ = writeln!(out, "B: {} ({}, {}x{})", r.b, r.b_format, r.b_size[0], r.b_size[1]);
        r.details(&mut out, "");
        if args.heatmap.is_some() && pair.heatmap.is_none() {
            let _ = writeln!(out, "no heatmap: the sizes differ");
        }
        let _ = writeln!(out, "result: {}", r.result_line());
        print!("{out}");
    }
    Ok(code)
}

/// A report and, when asked for, its heatmap's PNG bytes.
struct Pair {
    report: PairReport,
    heatmap: Option<Vec<u8>>,
}

/// What one comparison found (printed as text or JSON).
#[derive(Serialize)]
struct PairReport {
    a: String,
    b: String,
    a_format: String,
    b_format: String,
    a_size: [u32; 2],
    b_size: [u32; 2],
    /// The domain the measures are in.
    domain: &'static str,
    identical: bool,
    /// The sizes, when they differ (nothing else is measured then).
    size_mismatch: Option<String>,
    /// Null when identical.
    psnr_db: Option<f64>,
    mean_abs_error: Option<f64>,
    max_abs_error: Option<f64>,
    max_abs_error_at: Option<[u32; 2]>,
    tolerance: f64,
    #[serde(skip)]
    tolerance_text: String,
    pixels_over_tolerance: Option<usize>,
    share_over_tolerance: Option<f64>,
    mean_flip: Option<f64>,
    ppd: f32,
    worst_region: Option<Region>,
    looks_like: Vec<Look>,
    notes: Vec<String>,
    /// The thresholds not met.
    failed: Vec<String>,
    /// `identical`, `pass`, `fail` or `differ`.
    verdict: &'static str,
}

/// The worst block of the ꟻLIP map and its worst pixel.
#[derive(Serialize)]
struct Region {
    x: u32,
    y: u32,
    width: u32,
    height: u32,
    mean_flip: f32,
    pixel: [u32; 2],
    pixel_flip: f32,
    /// The command that explains the pixel.
    explain: String,
}

/// A named mismatch.
#[derive(Serialize)]
struct Look {
    kind: &'static str,
    description: String,
    detail: String,
    /// Null when the images are identical once it is undone.
    psnr_db: Option<f64>,
    undo: String,
    factor: Option<f64>,
}

impl PairReport {
    fn exit_code(&self) -> i32 {
        match self.verdict {
            "identical" | "pass" => 0,
            _ => 1,
        }
    }

    /// The report's measures, a line each, every line after `indent`.
    fn details(&self, out: &mut String, indent: &str) {
        let mut line = |label: &str, text: String| {
            let _ = writeln!(out, "{indent}  {label:<15} {text}");
        };
        if let Some(sizes) = &self.size_mismatch {
            line("sizes differ", sizes.clone());
        } else if self.identical {
            line("identical", format!("every pixel is the same ({})", self.domain));
        } else {
            let _ = writeln!(out, "{indent}compared in the {}:", self.domain);
            let mut line = |label: &str, text: String| {
                let _ = writeln!(out, "{indent}  {label:<15} {text}");
            };
            line("PSNR", format!("{:.2} dB", self.psnr_db.unwrap_or(f64::INFINITY)));
            let at = self.max_abs_error_at.unwrap_or_default();
            line(
                "absolute error",
                format!(
                    "mean {:.5}, max {:.5} (at pixel {},{})",
                    self.mean_abs_error.unwrap_or(0.0),
                    self.max_abs_error.unwrap_or(0.0),
                    at[0],
                    at[1]
                ),
            );
            let total = u64::from(self.a_size[0]) * u64::from(self.a_size[1]);
            line(
                "over tolerance",
                format!(
                    "{:.2} % of the pixels ({} of {total}) have a channel off by more than {}",
                    100.0 * self.share_over_tolerance.unwrap_or(0.0),
                    self.pixels_over_tolerance.unwrap_or(0),
                    self.tolerance_text
                ),
            );
            line(
                "FLIP",
                format!("mean {:.5} (LDR-FLIP at {} pixels per degree)", self.mean_flip.unwrap_or(0.0), self.ppd),
            );
            if let Some(r) = &self.worst_region {
                line(
                    "worst region",
                    format!(
                        "the {}x{} block at {},{} (mean FLIP {:.4}); its worst pixel is {},{} (FLIP {:.4}):",
                        r.width, r.height, r.x, r.y, r.mean_flip, r.pixel[0], r.pixel[1], r.pixel_flip
                    ),
                );
                line("", r.explain.clone());
            }
            for (k, l) in self.looks_like.iter().enumerate() {
                let score = match l.psnr_db {
                    Some(db) => format!("PSNR {db:.1} dB {}", l.undo),
                    None => format!("identical {}", l.undo),
                };
                let lead = if k == 0 { "looks like" } else { "  or" };
                let _ = writeln!(out, "{indent}  {lead}: {} ({score}): {}", l.description, l.detail);
            }
        }
        for n in &self.notes {
            let _ = writeln!(out, "{indent}  note: {n}");
        }
    }

    /// The verdict in words.
    fn result_line(&self) -> String {
        match self.verdict {
            "identical" => "identical (exit 0)".to_owned(),
            "pass" => "pass: every threshold met (exit 0)".to_owned(),
            "fail" => format!("fail: {} (exit 1)", self.failed.join("; ")),
            _ if self.size_mismatch.is_some() => "differ: the sizes differ (exit 1)".to_owned(),
            _ => "differ (exit 1; --min-psnr, --max-error or --max-flip accept small differences)".to_owned(),
        }
    }
}

/// `path` as one word for a shell: as it is when plain, else in single quotes.
fn shell_word(path: &Path) -> String {
    let s = path.display().to_string();
    if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "_-./+=:,@".contains(c)) {
        s
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

/// Compares `b` with `a` (named `a_name`, `b_name` in the report) by `args`' settings.
fn compare(a_name: String, b_name: String, a: &Image, b: &Image, args: &DiffArgs) -> Result<Pair> {
    let thresholds = args.min_psnr.is_some() || args.max_error.is_some() || args.max_flip.is_some();
    let mut notes: Vec<String> = a.notes.iter().map(|n| format!("A: {n}")).collect();
    notes.extend(b.notes.iter().map(|n| format!("B: {n}")));
    let mut report = PairReport {
        a: a_name,
        b: b_name,
        a_format: a.format.clone(),
        b_format: b.format.clone(),
        a_size: [a.width, a.height],
        b_size: [b.width, b.height],
        domain: "display domain (sRGB-encoded values clamped to [0, 1])",
        identical: false,
        size_mismatch: None,
        psnr_db: None,
        mean_abs_error: None,
        max_abs_error: None,
        max_abs_error_at: None,
        tolerance: args.tolerance.value,
        tolerance_text: args.tolerance.describe(),
        pixels_over_tolerance: None,
        share_over_tolerance: None,
        mean_flip: None,
        ppd: args.ppd,
        worst_region: None,
        looks_like: Vec::new(),
        notes,
        failed: Vec::new(),
        verdict: "differ",
    };
    if (a.width, a.height) != (b.width, b.height) {
        let mut sizes = format!("A is {}x{}, B is {}x{}", a.width, a.height, b.width, b.height);
        if let Some(hint) = mismatch::size_hint((a.width, a.height), (b.width, b.height)) {
            let _ = write!(sizes, ": {hint}");
        }
        report.size_mismatch = Some(sizes);
        report.failed.push("the sizes differ".to_owned());
        report.verdict = if thresholds { "fail" } else { "differ" };
        return Ok(Pair { report, heatmap: None });
    }
    let m = metrics::measure(a, b, args.tolerance.value);
    let identical = m.mse == 0.0;
    let pixels = a.display.len().max(1);
    let flip_map = if identical {
        vec![0.0; a.display.len()]
    } else {
        flip::flip_map(&a.display, &b.display, a.width as usize, args.ppd)
    };
    let mean_flip = flip_map.iter().map(|&e| f64::from(e)).sum::<f64>() / pixels as f64;
    let psnr = metrics::psnr(m.mse);
    report.identical = identical;
    report.psnr_db = (!identical).then_some(psnr);
    report.mean_abs_error = Some(m.mean_abs);
    report.max_abs_error = Some(m.max_abs);
    report.max_abs_error_at = Some([m.max_at.0, m.max_at.1]);
    report.pixels_over_tolerance = Some(m.over);
    report.share_over_tolerance = Some(m.over as f64 / pixels as f64);
    report.mean_flip = Some(mean_flip);
    if identical && m.linear_max_abs > 0.0 {
        report.notes.push(format!(
            "the linear values differ by up to {:.4} where the display clamps them (above 1 or below 0)",
            m.linear_max_abs
        ));
    }
    if let Some(block) = metrics::worst_block(&flip_map, a.width, a.height, BLOCK) {
        let scene = args.scene.as_deref().map(shell_word).unwrap_or_else(|| "SCENE".to_owned());
        report.worst_region = Some(Region {
            x: block.x,
            y: block.y,
            width: block.width,
            height: block.height,
            mean_flip: block.mean,
            pixel: [block.pixel.0, block.pixel.1],
            pixel_flip: block.value,
            explain: format!(
                "lancer explain {scene} --width {} --height {} --pixel {},{}",
                a.width, a.height, block.pixel.0, block.pixel.1
            ),
        });
    }
    if !identical {
        report.looks_like = mismatch::explain(a, b, psnr)
            .into_iter()
            .map(|f| Look {
                kind: f.kind,
                description: f.what,
                detail: f.detail,
                psnr_db: f.psnr.is_finite().then_some(f.psnr),
                undo: f.undo,
                factor: f.factor,
            })
            .collect();
    }
    if let Some(min) = args.min_psnr
        && psnr < min
    {
        report.failed.push(format!("PSNR {psnr:.2} dB is under --min-psnr {min}"));
    }
    if let Some(max) = &args.max_error
        && m.max_abs > max.value + metrics::SLACK
    {
        report.failed.push(format!(
            "the largest absolute error, {:.5}, is over --max-error {}",
            m.max_abs,
            max.describe()
        ));
    }
    if let Some(max) = args.max_flip
        && mean_flip > max
    {
        report.failed.push(format!("the mean FLIP, {mean_flip:.5}, is over --max-flip {max}"));
    }
    report.verdict = match (identical, thresholds, report.failed.is_empty()) {
        (true, _, _) => "identical",
        (false, true, true) => "pass",
        (false, true, false) => "fail",
        (false, false, _) => "differ",
    };
    let heatmap = match args.heatmap {
        None => None,
        Some(_) => {
            let (map, top, title) = match args.heatmap_of {
                HeatmapOf::Flip => (flip_map, 1.0, "FLIP"),
                HeatmapOf::Abs => (metrics::abs_map(a, b), heatmap::nice_top(m.max_abs as f32), "ABS ERROR"),
            };
            Some(heatmap::encode(&heatmap::draw(&map, a.width, a.height, top, title))?)
        }
    };
    Ok(Pair { report, heatmap })
}

/// The file names of a folder that name images (by extension), sorted, and the others (hidden
/// files and Lancer's `manifest.json` left out).
fn list(dir: &Path) -> Result<(Vec<String>, Vec<String>)> {
    let (mut images, mut others) = (Vec::new(), Vec::new());
    for entry in std::fs::read_dir(dir).with_context(|| format!("reading the folder {}", dir.display()))? {
        let entry = entry.with_context(|| format!("reading the folder {}", dir.display()))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') || name == "manifest.json" || !entry.path().is_file() {
            continue;
        }
        let ext = Path::new(&name).extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("png" | "exr" | "ppm" | "pgm" | "pnm") => images.push(name),
            _ => others.push(name),
        }
    }
    images.sort();
    others.sort();
    Ok((images, others))
}

/// Pairs the image names of two folders: the same name first, then, of those left, one on each
/// side with the same stem (`diffuse.exr` and `diffuse.ppm`); and the names left on each side.
fn pair_up(a: &[String], b: &[String]) -> (Vec<(String, String)>, Vec<String>, Vec<String>) {
    let stem = |n: &str| Path::new(n).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut pairs: Vec<(String, String)> = a.iter().filter(|n| b.contains(n)).map(|n| (n.clone(), n.clone())).collect();
    let mut left_a: Vec<String> = a.iter().filter(|n| !b.contains(n)).cloned().collect();
    let mut left_b: Vec<String> = b.iter().filter(|n| !a.contains(n)).cloned().collect();
    let mut k = 0;
    while k < left_a.len() {
        let s = stem(&left_a[k]);
        let same_a = left_a.iter().filter(|n| stem(n) == s).count();
        let same_b: Vec<usize> = (0..left_b.len()).filter(|&j| stem(&left_b[j]) == s).collect();
        if same_a == 1 && same_b.len() == 1 {
            pairs.push((left_a.remove(k), left_b.remove(same_b[0])));
        } else {
            k += 1;
        }
    }
    pairs.sort();
    (pairs, left_a, left_b)
}

/// The heatmap's file name for the pair whose A is `name`: `diffuse.exr` → `diffuse-exr.png`.
fn heatmap_name(name: &str) -> String {
    let p = Path::new(name);
    let stem = p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    match p.extension() {
        Some(e) => format!("{stem}-{}.png", e.to_string_lossy()),
        None => format!("{stem}.png"),
    }
}

/// Two folders of per-term images, file by file.
fn folders(args: &DiffArgs) -> Result<i32> {
    let (a_names, a_other) = list(&args.a)?;
    let (b_names, b_other) = list(&args.b)?;
    if a_names.is_empty() && b_names.is_empty() {
        bail!(
            "neither {} nor {} holds an image (.png, .exr, .ppm, .pgm): expected two folders of per-term images",
            args.a.display(),
            args.b.display()
        );
    }
    let (pairs, only_a, only_b) = pair_up(&a_names, &b_names);
    let mut results: Vec<(String, Result<Pair>)> = Vec::new();
    for (na, nb) in &pairs {
        let label = if na == nb { na.clone() } else { format!("{na} vs {nb}") };
        let result = (|| {
            let a = read::read(&args.a.join(na), args.max_file_size)?;
            let b = read::read(&args.b.join(nb), args.max_file_size)?;
            compare(na.clone(), nb.clone(), &a, &b, args)
        })();
        results.push((label, result));
    }
    let errors = results.iter().filter(|(_, r)| r.is_err()).count();
    // Heatmaps only when every pair was read: bad input leaves nothing behind.
    if errors == 0
        && let Some(dir) = &args.heatmap
    {
        crate::output::create_output_dir(dir)?;
        for ((na, _), (_, result)) in pairs.iter().zip(&results) {
            if let Ok(Pair { heatmap: Some(png), .. }) = result {
                crate::output::write_atomic(&dir.join(heatmap_name(na)), png)?;
            }
        }
    }
    let differ = results.iter().filter(|(_, r)| r.as_ref().is_ok_and(|p| p.report.exit_code() != 0)).count();
    let one_side = only_a.len() + only_b.len();
    let code = if errors > 0 {
        2
    } else if differ > 0 || one_side > 0 {
        1
    } else {
        0
    };
    let thresholds = args.min_psnr.is_some() || args.max_error.is_some() || args.max_flip.is_some();
    let all_identical = results.iter().all(|(_, r)| r.as_ref().is_ok_and(|p| p.report.identical));
    let mut result = match code {
        2 => format!("error: {errors} of {} pairs could not be compared (exit 2)", pairs.len()),
        0 if all_identical => format!("identical: all {} pairs (exit 0)", pairs.len()),
        0 => format!("pass: every threshold met by all {} pairs (exit 0)", pairs.len()),
        _ => {
            let mut why = Vec::new();
            if differ > 0 {
                why.push(format!("{differ} of {} pairs {}", pairs.len(), if thresholds { "fail" } else { "differ" }));
            }
            if one_side > 0 {
                why.push(format!("{one_side} files are in one folder only"));
            }
            format!("differ: {} (exit 1)", why.join(", "))
        }
    };
    if let Some(dir) = args.heatmap.as_ref().filter(|_| errors == 0) {
        let _ = write!(result, "; heatmaps in {}", dir.display());
    }
    for (_, r) in &results {
        if let Err(e) = r {
            eprintln!("error: {e:#}");
        }
    }
    if args.json {
        let pairs: Vec<serde_json::Value> = results
            .iter()
            .map(|(label, r)| match r {
                Ok(p) => serde_json::to_value(&p.report).expect("plain data serialises"),
                Err(e) => serde_json::json!({ "pair": label, "error": format!("{e:#}") }),
            })
            .collect();
        let doc = serde_json::json!({
            "a": args.a.display().to_string(),
            "b": args.b.display().to_string(),
            "pairs": pairs,
            "only_in_a": only_a,
            "only_in_b": only_b,
            "ignored": a_other.iter().map(|n| args.a.join(n)).chain(b_other.iter().map(|n| args.b.join(n))).map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "result": result,
            "exit_code": code,
        });
        println!("{}", serde_json::to_string_pretty(&doc).expect("plain data serialises"));
        return Ok(code);
    }
    let mut out = String::new();
    let (da, db) = (args.a.display(), args.b.display());
    let _ = writeln!(
        out,
        "comparing the folders {da} and {db} file by file, in the display domain (sRGB-encoded values clamped to [0, 1])"
    );
    for (label, r) in &results {
        match r {
            Err(e) => {
                let _ = writeln!(out, "{label}: error: {e:#}");
            }
            Ok(p) if p.report.identical && p.report.notes.is_empty() => {
                let _ = writeln!(
                    out,
                    "{label}: identical ({}, {}x{})",
                    p.report.a_format, p.report.a_size[0], p.report.a_size[1]
                );
            }
            Ok(p) => {
                let r = &p.report;
                let _ = writeln!(
                    out,
                    "{label}: {} ({}, {}x{} against {}, {}x{})",
                    r.result_line(),
                    r.a_format,
                    r.a_size[0],
                    r.a_size[1],
                    r.b_format,
                    r.b_size[0],
                    r.b_size[1]
                );
                r.details(&mut out, "  ");
            }
        }
    }
    if !only_a.is_empty() {
        let _ = writeln!(out, "only in {da}: {}", only_a.join(", "));
    }
    if !only_b.is_empty() {
        let _ = writeln!(out, "only in {db}: {}", only_b.join(", "));
    }
    let ignored: Vec<String> =
        a_other.iter().map(|n| format!("{da}/{n}")).chain(b_other.iter().map(|n| format!("{db}/{n}"))).collect();
    if !ignored.is_empty() {
        let _ = writeln!(out, "not images, not compared: {}", ignored.join(", "));
    }
    let _ = writeln!(out, "result: {result}");
    print!("{out}");
    Ok(code)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn folders_pair_by_name_then_by_stem_across_formats() {
        let a = names(&["ambient.exr", "ambient.png", "beauty.png", "diffuse.exr", "mirror.png", "x.png", "x.exr"]);
        let b = names(&["ambient.png", "beauty.png", "diffuse.ppm", "extra.png", "x.pgm"]);
        let (pairs, only_a, only_b) = pair_up(&a, &b);
        let pairs: Vec<(&str, &str)> = pairs.iter().map(|(p, q)| (p.as_str(), q.as_str())).collect();
        assert_eq!(
            pairs,
            [("ambient.png", "ambient.png"), ("beauty.png", "beauty.png"), ("diffuse.exr", "diffuse.ppm")]
        );
        // `x` has two files on A's side for one on B's: which pairs is not guessed.
        assert_eq!(only_a, ["ambient.exr", "mirror.png", "x.png", "x.exr"]);
        assert_eq!(only_b, ["extra.png", "x.pgm"]);
    }

    #[test]
    fn levels_take_numbers_and_fractions_from_0_to_1() {
        assert_eq!(parse_level("2/255").unwrap().value, 2.0 / 255.0);
        assert_eq!(parse_level("0.01").unwrap().value, 0.01);
        assert_eq!(parse_level("2/255").unwrap().describe(), "2/255 (0.00784)");
        for bad in ["1.5", "-0.1", "1/0", "a/255", "x"] {
            assert!(parse_level(bad).is_err(), "{bad}");
        }
        assert!(parse_ppd("0.5").is_err() && parse_ppd("67").is_ok());
        assert!(parse_db("inf").is_err() && parse_db("40").is_ok());
    }

    #[test]
    fn heatmap_names_and_shell_words() {
        assert_eq!(heatmap_name("diffuse.exr"), "diffuse-exr.png");
        assert_eq!(heatmap_name("beauty.png"), "beauty-png.png");
        assert_eq!(shell_word(Path::new("scenes/glass.toml")), "scenes/glass.toml");
        assert_eq!(shell_word(Path::new("my scene's.toml")), r"'my scene'\''s.toml'");
    }
}

//! `cargo xtask fuzz`: scenes from `scenes/` mutated line by line and token by token (lines
//! deleted, duplicated or swapped; numbers replaced by `nan`, `inf`, `-0`, `1e38`, negative or
//! huge values; junk tokens and tables inserted), each loaded, prepared and rendered tiny,
//! in-process; now and then a scene's OBJ or PNG files mutated instead (PNG: bytes flipped,
//! cut short, its header's size changed), and part-file headers of `lancer merge` mutated (their
//! fields, layer names made paths or Lancer's own files). Any panic, hang, unlocated error,
//! non-finite pixel or hostile layer name accepted is a failure, written to `target/fuzz/`.

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use lancer_shading::{Registry, RenderOptions};

/// Longest a case may take (load, prepare and an at most 16×16 render) before it is a hang.
const HANG: Duration = Duration::from_secs(20);

/// Numbers a mutation puts in place of a number.
const NUMBERS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "+inf",
    "-0",
    "0",
    "-0.0",
    "1e38",
    "-1e38",
    "3.5e38",
    "1e-38",
    "1e-45",
    "-1",
    "-1000000",
    "16385",
    "4294967296",
    "99999999999999999999",
    "0.5",
    "2",
    "64",
    "65",
    "1e6",
    "1e-7",
    "1e-6",
    "1e4",
    "1e30",
    "-1e30",
    "-5",
    "0.0001",
    "1000",
    "100000",
    "0.999999",
    "1.000001",
    "3",
    "-0.5",
    "1e-30",
    "7e-39",
];

/// Tokens and tables a mutation inserts.
const JUNK: &[&str] = &[
    // OBJ lines and pieces (for the mesh files), then TOML.
    "f 1 2 3",
    "f -1 -2 -3",
    "f 1/1/1 2/2/2 3/3/3 4/4/4",
    "f 0 0 0",
    "v 1e30 -1e30 0",
    "vn 0 0 0",
    "vt",
    "//",
    "\\",
    "\r",
    "]",
    "[",
    "{",
    "}",
    "=",
    ",",
    "\"",
    "'",
    "#",
    "[[objects]]",
    "[[lights]]",
    "[model]",
    "[camera]",
    "[image]",
    "[materials.m]",
    "x = 1",
    "shape = \"torus\"",
    "shape = \"mesh\"",
    "shape = \"csg\"",
    "op = \"difference\"",
    "a = { shape = \"sphere\" }",
    "b = { shape = \"cube\", scale = 0 }",
    "material = \"nope\"",
    "material = \"m\"",
    "terms = []",
    "terms = [\"mirror\", \"mirror\"]",
    "shadows = \"soft\"",
    "max_depth = 64",
    "samples = 4096",
    "samples = { adaptive = 0 }",
    "samples = { adaptive = nan, depth = 1.5 }",
    "samples = { depth = 9 }",
    "scale = [0, 1, 1]",
    "scale = 1e-7",
    "rotate = [1e38, 0, 0]",
    "translate = [nan, 0, 0]",
    "at = [0, 0, 0]",
    "color = { pattern = \"checker\", scale = 1e-30 }",
    "color = { pattern = \"image\", path = \".\" }",
    "path = \"../README.md\"",
    "path = \"../../README.md\"",
    "path = \".\"",
    "fov = 179.9",
    "fov = 0",
    "up = [0, 0, 0]",
    "from = [0, 0, 0]",
    "to = [0, 0, 0]",
    "minor = 10",
    "n = 2.5",
    "alpha = 1",
    "size = 1e30",
    "width = 1",
    "height = 1",
    "\u{feff}",
    "\u{0}",
    "é",
    "\\",
    "\"\"\"",
    "1 = 2",
    "[[objects]]\nshape = \"plane\"",
    "[[lights]]\nat = [0, 1e30, 0]\nsize = 1e30",
    "[model]\nterms = [\"refraction\"]\nmax_depth = 64",
];

/// Replacement words for string values.
const WORDS: &[&str] = &[
    "sphere",
    "cube",
    "plane",
    "cylinder",
    "cone",
    "torus",
    "disk",
    "mesh",
    "csg",
    "union",
    "intersection",
    "difference",
    "checker",
    "image",
    "hard",
    "soft",
    "none",
    "transmissive",
    "ambient",
    "diffuse",
    "specular",
    "mirror",
    "refraction",
    "blinn",
    "fresnel",
    "traced",
    "refraction:traced",
    "each_surface",
    "oren-nayar",
    "",
    "x",
];

/// Runs the fuzzer: `--runs N` (default 2000) cases from `--seed S` (default 1).
pub fn run(args: &[String]) -> Result<()> {
    let (mut runs, mut seed) = (2000u64, 1u64);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| -> Result<u64> {
            it.next().and_then(|v| v.parse().ok()).with_context(|| format!("{name} needs a whole number"))
        };
        match a.as_str() {
            "--runs" => runs = value("--runs")?,
            "--seed" => seed = value("--seed")?,
            other => bail!("unknown option `{other}` (cargo xtask fuzz [--runs N] [--seed S])"),
        }
    }
    let seeds: Vec<(PathBuf, String)> = crate::scenes(None)?
        .into_iter()
        .map(|p| std::fs::read_to_string(&p).map(|s| (p, s)))
        .collect::<Result<_, _>>()?;
    let with_meshes: Vec<usize> =
        (0..seeds.len()).filter(|&k| seeds[k].1.contains(".obj") || seeds[k].1.contains(".png")).collect();
    let out_dir = crate::root().join("target/fuzz");
    // Panics are caught and counted; their messages would drown the report.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let start = Instant::now();
    let mut tally = Tally::default();
    for i in 0..runs {
        let mut rng = fastrand::Rng::with_seed(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ i);
        // One case in twenty is a merge of part files, one of them with a mutated header.
        if rng.usize(..20) == 0 {
            let outcome = part_case(&mut rng);
            tally.count(&outcome);
            if let Outcome::Failure(why) = &outcome {
                eprintln!("case {i} (part header): {why}");
            }
            continue;
        }
        // One case in ten keeps a scene with meshes or textures as it is and mutates its OBJ
        // and PNG files instead.
        let meshes = (!with_meshes.is_empty() && rng.usize(..10) == 0).then(|| rng.u64(..));
        let (path, text) = match meshes {
            Some(_) => &seeds[with_meshes[rng.usize(..with_meshes.len())]],
            None => &seeds[rng.usize(..seeds.len())],
        };
        let mutated = if meshes.is_some() { text.clone() } else { mutate(&mut rng, text) };
        let outcome = run_case(path, mutated.clone(), meshes);
        tally.count(&outcome);
        if let (Outcome::LoadError(kind), true) = (&outcome, std::env::var_os("LANCER_FUZZ_ERRORS").is_some()) {
            println!("refused: {kind}");
        }
        if let Outcome::Failure(why) = &outcome {
            std::fs::create_dir_all(&out_dir)?;
            let file = out_dir.join(format!("seed{seed}-case{i}.toml"));
            let how = match meshes {
                Some(m) => format!("its OBJ files mutated with seed {m}"),
                None => "mutated".to_owned(),
            };
            std::fs::write(&file, format!("# {why}\n# {how} from {}\n{mutated}", path.display()))?;
            eprintln!("case {i}: {why} -> {}", file.display());
            if why.starts_with("hang") {
                // The case's thread cannot be stopped: report and leave.
                break;
            }
        }
        if (i + 1) % 10_000 == 0 {
            eprintln!("{} cases, {:.0} s: {tally}", i + 1, start.elapsed().as_secs_f64());
        }
    }
    std::panic::set_hook(default_hook);
    println!("fuzz: {} cases from seed {seed} in {:.1} s: {tally}", tally.cases, start.elapsed().as_secs_f64());
    if tally.failures > 0 {
        bail!("{} failing case(s), written to {}", tally.failures, out_dir.display());
    }
    Ok(())
}

#[derive(Default)]
struct Tally {
    cases: u64,
    rendered: u64,
    load_errors: u64,
    failures: u64,
}

impl Tally {
    fn count(&mut self, o: &Outcome) {
        self.cases += 1;
        match o {
            Outcome::Rendered => self.rendered += 1,
            Outcome::LoadError(_) => self.load_errors += 1,
            Outcome::Failure(_) => self.failures += 1,
        }
    }
}

impl std::fmt::Display for Tally {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} rendered, {} refused with a located error, {} failures (panic, hang, unlocated error, NaN)",
            self.rendered, self.load_errors, self.failures
        )
    }
}

enum Outcome {
    Rendered,
    LoadError(String),
    Failure(String),
}

/// A PNG file's bytes mutated: some bytes flipped, the file cut short, or its header's width
/// and height replaced (the header's checksum made again, so the decoder reads them).
fn mutate_png(rng: &mut fastrand::Rng, mut bytes: Vec<u8>) -> Vec<u8> {
    match rng.usize(..3) {
        0 if !bytes.is_empty() => {
            for _ in 0..rng.usize(1..8) {
                let i = rng.usize(..bytes.len());
                bytes[i] ^= 1 << rng.u32(..8);
            }
        }
        1 => bytes.truncate(rng.usize(..=bytes.len())),
        _ if bytes.len() >= 33 => {
            // IHDR: length (4), "IHDR" (4), width (4), height (4), ..., CRC at 29..33.
            let sides = [0u32, 1, 7, 8192, 23_000, 65_535, 1 << 24, u32::MAX];
            bytes[16..20].copy_from_slice(&sides[rng.usize(..sides.len())].to_be_bytes());
            bytes[20..24].copy_from_slice(&sides[rng.usize(..sides.len())].to_be_bytes());
            let crc = crc32(&bytes[12..29]);
            bytes[29..33].copy_from_slice(&crc.to_be_bytes());
        }
        _ => {}
    }
    bytes
}

/// The CRC-32 of PNG chunks (ISO 3309, reflected, polynomial 0xEDB88320).
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = u32::MAX;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

/// Values a header mutation puts in a field.
fn hostile_value(rng: &mut fastrand::Rng) -> serde_json::Value {
    use serde_json::json;
    let values = [
        json!("../escaped"),
        json!("/tmp/lancer-fuzz-escaped"),
        json!("beauty"),
        json!("manifest"),
        json!("background"),
        json!(""),
        json!("a/b"),
        json!("a\u{0}b"),
        json!("\u{1b}[31m"),
        json!("x".repeat(5000)),
        json!("ambient"),
        json!(null),
        json!(-1),
        json!(0),
        json!(1),
        json!(4_000_000_000u64),
        json!(u64::MAX),
        json!(1e300),
        json!([]),
        json!(["ambient", "ambient"]),
        json!({}),
    ];
    values[rng.usize(..values.len())].clone()
}

/// Two parts of a small render, the second with its header mutated (a field replaced, removed,
/// or a layer name made hostile), merged in memory: a merge must fail with an error or give
/// layers named only as terms (or the background) are.
fn part_case(rng: &mut fastrand::Rng) -> Outcome {
    use lancer_cli::part::{Header, Sources, digest, encode, merge_bytes};
    let (width, height) = (8u32, 40u32);
    let layers = ["ambient", "diffuse", "background"];
    let frame = lancer_core::Frame::from_layers(
        width,
        height,
        layers
            .iter()
            .map(|n| lancer_core::Layer {
                name: (*n).to_owned(),
                pixels: vec![lancer_core::Vec3::splat(0.25); (width * height) as usize],
            })
            .collect(),
        lancer_core::RenderStats::default(),
    );
    let sources = Sources {
        scene: digest(b"scene"),
        model_file: None,
        files: vec![("tex.png".to_owned(), digest(b"tex"))],
        model: digest(b"model"),
        image: digest(b"image"),
        version: "0".to_owned(),
    };
    let header = |index| Header {
        identity: sources.fingerprint(),
        sources: sources.clone(),
        scene: "s.toml".to_owned(),
        width,
        height,
        samples: 1,
        model: "ambient, diffuse".to_owned(),
        index,
        count: 2,
        band_rows: lancer_shading::TILE,
        layers: layers.iter().map(|n| (*n).to_owned()).collect(),
        rays: [1, 2, 3],
        seconds: 0.5,
    };
    let (Ok(first), Ok(second)) = (encode(&header(0), &frame), encode(&header(1), &frame)) else {
        return Outcome::Failure("a part of a valid render does not encode".to_owned());
    };
    let line = second.iter().position(|&b| b == b'\n').map_or(0, |i| i + 1);
    let end = line + second[line..].iter().position(|&b| b == b'\n').unwrap_or(second.len() - line);
    let Ok(mut json) = serde_json::from_slice::<serde_json::Value>(&second[line..end]) else {
        return Outcome::Failure("a valid part's header does not read".to_owned());
    };
    for _ in 0..rng.usize(1..4) {
        let keys: Vec<String> = json.as_object().map(|o| o.keys().cloned().collect()).unwrap_or_default();
        let Some(key) = (!keys.is_empty()).then(|| keys[rng.usize(..keys.len())].clone()) else { break };
        // (Through `pointer_mut`: an earlier mutation may have made a field anything.)
        let place = match rng.usize(..4) {
            0 => format!("/layers/{}", rng.usize(..3)),
            1 => format!("/{key}"),
            2 => {
                if let Some(o) = json.as_object_mut() {
                    o.remove(&key);
                }
                continue;
            }
            _ => "/sources/files/0/0".to_owned(),
        };
        if let Some(v) = json.pointer_mut(&place) {
            *v = hostile_value(rng);
        }
    }
    let mut mutated = second[..line].to_vec();
    mutated.extend(serde_json::to_vec(&json).unwrap_or_default());
    mutated.extend_from_slice(&second[end.min(second.len())..]);
    let named = vec![("p0.lpart".into(), first), ("p1.lpart".into(), mutated)];
    match std::panic::catch_unwind(|| merge_bytes(named)) {
        Err(_) => Outcome::Failure(format!("merge panicked on the header {json}")),
        Ok(Err(e)) => Outcome::LoadError(format!("{e:#}")),
        Ok(Ok((frame, _, _))) => {
            match frame.layers.iter().find(|l| !(lancer_shading::is_term_name(&l.name) || l.name == "background")) {
                Some(l) => Outcome::Failure(format!("merge accepted the layer name {:?}", l.name)),
                None => Outcome::Rendered,
            }
        }
    }
}

/// One to four mutations of `text`.
fn mutate(rng: &mut fastrand::Rng, text: &str) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    // Mostly one mutation: a file with several broken lines is refused at the first.
    let count = [1, 1, 1, 2, 2, 3, 4][rng.usize(..7)];
    for _ in 0..count {
        if lines.is_empty() {
            lines.push(String::new());
        }
        let at = rng.usize(..lines.len());
        // Numbers most often: they reach the geometry and the shading; structure less often,
        // since most structural damage is (rightly) a syntax error.
        match [0, 1, 2, 3, 3, 3, 3, 3, 3, 5, 5, 6, 6][rng.usize(..13)] {
            0 => {
                lines.remove(at);
            }
            1 => lines.insert(at, lines[at].clone()),
            2 => {
                let other = rng.usize(..lines.len());
                lines.swap(at, other);
            }
            3 => {
                // A number of a line that has numbers replaced.
                let with: Vec<usize> = (0..lines.len()).filter(|&i| !number_spans(&lines[i]).is_empty()).collect();
                if with.is_empty() {
                    lines.insert(at, JUNK[rng.usize(..JUNK.len())].to_owned());
                } else {
                    let at = with[rng.usize(..with.len())];
                    let numbers = number_spans(&lines[at]);
                    let (s, e) = numbers[rng.usize(..numbers.len())];
                    let new = NUMBERS[rng.usize(..NUMBERS.len())];
                    lines[at] = format!("{}{new}{}", &lines[at][..s], &lines[at][e..]);
                }
            }
            5 => {
                let line = &lines[at];
                let pos = rng.usize(..=line.len());
                let pos = (0..=pos).rev().find(|&p| line.is_char_boundary(p)).unwrap_or(0);
                let junk = JUNK[rng.usize(..JUNK.len())];
                lines[at] = format!("{}{junk}{}", &line[..pos], &line[pos..]);
            }
            _ => {
                // A quoted word replaced by another.
                let line = &lines[at];
                if let Some(s) = line.find('"')
                    && let Some(len) = line[s + 1..].find('"')
                {
                    let word = WORDS[rng.usize(..WORDS.len())];
                    lines[at] = format!("{}\"{word}\"{}", &line[..s], &line[s + 2 + len..]);
                } else {
                    lines.insert(at, JUNK[rng.usize(..JUNK.len())].to_owned());
                }
            }
        }
    }
    lines.join("\n")
}

/// Byte ranges of the numbers in `line` (outside comments).
fn number_spans(line: &str) -> Vec<(usize, usize)> {
    let code = line.split('#').next().unwrap_or("");
    let b = code.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = b[i].is_ascii_digit() || (b[i] == b'-' && b.get(i + 1).is_some_and(u8::is_ascii_digit));
        let inside_word = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_' || b[i - 1] == b'.');
        if starts && !inside_word {
            let s = i;
            i += 1;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b"._+-".contains(&b[i])) {
                i += 1;
            }
            out.push((s, i));
        } else {
            i += 1;
        }
    }
    out
}

/// Loads, prepares and renders `text` (as the scene at `path`, reading its files from its
/// folder, its OBJ files mutated when `meshes` gives a seed) on a worker thread, within [`HANG`].
fn run_case(path: &Path, text: String, meshes: Option<u64>) -> Outcome {
    let (tx, rx) = mpsc::channel();
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let name = path.display().to_string();
    std::thread::spawn(move || {
        let result = std::panic::catch_unwind(|| case(&dir, &name, &text, meshes));
        let _ = tx.send(result.unwrap_or_else(|e| {
            let msg = e
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Outcome::Failure(format!("panic: {msg}"))
        }));
    });
    match rx.recv_timeout(HANG) {
        Ok(outcome) => outcome,
        Err(_) => Outcome::Failure(format!("hang: no result after {} s", HANG.as_secs())),
    }
}

fn case(dir: &Path, name: &str, text: &str, meshes: Option<u64>) -> Outcome {
    // Files as the command line reads them: regular files only, at most 64 MB here.
    let resolve = |rel: &str| -> Result<Vec<u8>, String> {
        let p = dir.join(rel);
        let meta = std::fs::metadata(&p).map_err(|e| e.to_string())?;
        if !meta.is_file() || meta.len() > 64_000_000 {
            return Err("not a regular file under the limit".into());
        }
        let bytes = std::fs::read(&p).map_err(|e| e.to_string())?;
        Ok(match meshes {
            Some(seed) if rel.ends_with(".obj") => {
                let mut rng = fastrand::Rng::with_seed(seed);
                mutate(&mut rng, &String::from_utf8_lossy(&bytes)).into_bytes()
            }
            Some(seed) if rel.ends_with(".png") => mutate_png(&mut fastrand::Rng::with_seed(seed), bytes),
            _ => bytes,
        })
    };
    let registry = Registry::with_builtins();
    let loaded = match lancer_scene::load_scene_with(text, name, &registry, &resolve) {
        Ok(l) => l,
        Err(e) => {
            return if e.line >= 1 && e.column >= 1 && !e.to_string().is_empty() {
                Outcome::LoadError(e.kind.to_string())
            } else {
                Outcome::Failure(format!("an error without a place: {e}"))
            };
        }
    };
    let prepared = match lancer_shading::prepare(&loaded.scene) {
        Ok(p) => p,
        Err(e) => return Outcome::Failure(format!("loaded, then refused by prepare without a place: {e}")),
    };
    let _ = lancer_scene::check(&loaded.scene, &loaded.pipeline, &prepared, &loaded.places);
    let mut image = loaded.scene.image;
    image.width = image.width.min(16);
    image.height = image.height.min(16);
    image.samples = image.samples.min(2);
    let frame = lancer_shading::render_prepared(
        &prepared,
        &loaded.scene.camera,
        &image,
        &loaded.pipeline,
        RenderOptions { layers: true, ..RenderOptions::default() },
    );
    let images = frame.layers.iter().map(|l| (l.name.as_str(), &l.pixels)).chain([("beauty", &frame.beauty)]);
    for (name, pixels) in images {
        if let Some(i) = pixels.iter().position(|p| !p.is_finite()) {
            return Outcome::Failure(format!("a non-finite value in {name} at pixel {i}"));
        }
    }
    // The middle pixel explained: the same values as the frame's, to the bit.
    let (x, y) = (image.width / 2, image.height / 2);
    let e = lancer_shading::explain_pixel(&prepared, &loaded.scene.camera, &image, &loaded.pipeline, x, y);
    let i = (y * image.width + x) as usize;
    for (layer, (name, value)) in frame.layers.iter().zip(&e.layers) {
        if layer.pixels[i].to_array().map(f32::to_bits) != value.to_array().map(f32::to_bits) {
            return Outcome::Failure(format!(
                "explain gives {value} for {name} at {x},{y}, the frame {}",
                layer.pixels[i]
            ));
        }
    }
    Outcome::Rendered
}

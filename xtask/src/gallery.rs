//! The render gallery: every scene with its per-term images side by side, and comparison sheets
//! that swap one part of the model at a time, written as one self-contained HTML page with
//! relative image paths (`target/gallery/index.html`); and its check in headless Chromium.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};

use crate::{TaskArgs, build_renderer, parse_common, root, scenes};

/// The terms a model without `terms` gets, in order (the built-in defaults).
const DEFAULT_TERMS: [&str; 5] = ["ambient", "diffuse", "specular", "mirror", "refraction"];

/// One comparison: the same scene rendered once per column, showing the same images per row.
struct Sheet {
    id: &'static str,
    title: &'static str,
    description: &'static str,
    scene: &'static str,
    rows: &'static [&'static str],
    columns: &'static [(&'static str, &'static [&'static str])],
}

const SHEETS: &[Sheet] = &[
    Sheet {
        id: "shine-ladder",
        title: "The shine ladder",
        description: "The handout's figure: diff = spec = 0.5 and shine 0.99, 0.8, 0.5, 0.2 from left to right, so highlight exponents 1/(1 − shine) of 100, 5, 2 and 1.25. The higher the shine, the smaller and sharper the highlight; the specular row shows the highlight alone.",
        scene: "shine-ladder.toml",
        rows: &["specular", "diffuse", "beauty"],
        columns: &[("seed (Phong)", &[])],
    },
    Sheet {
        id: "specular",
        title: "Phong vs Blinn vs normalised Blinn",
        description: "The shine ladder with each specular variant. Blinn uses the half vector with exponent 4/(1 − shine), which keeps the seed highlight's size; the energy-normalised variant scales the lobe by (e + 8)/(8π), so sharp highlights become brighter instead of only smaller. Ambient and diffuse are bit-identical across the three.",
        scene: "shine-ladder.toml",
        rows: &["specular", "beauty"],
        columns: &[
            ("phong", &["--terms", "ambient,diffuse,specular:phong"]),
            ("blinn", &["--terms", "ambient,diffuse,specular:blinn"]),
            ("blinn-normalized", &["--terms", "ambient,diffuse,specular:blinn-normalized"]),
        ],
    },
    Sheet {
        id: "diffuse",
        title: "Lambert vs Oren–Nayar",
        description: "Clay spheres lit from near the camera. Oren–Nayar (roughness 20°, its default) models a rough surface: it darkens less towards the rim than Lambert, so the spheres look flatter, like clay or the Moon.",
        scene: "variants/oren-nayar.toml",
        rows: &["diffuse", "beauty"],
        columns: &[
            ("lambert", &["--terms", "ambient,diffuse:lambert,specular"]),
            ("oren-nayar", &["--terms", "ambient,diffuse:oren-nayar,specular"]),
        ],
    },
    Sheet {
        id: "mirror",
        title: "Constant vs Schlick mirror",
        description: "Water with spec = 1 and n = 1.33. The seed's constant mirror reflects spec everywhere, a perfect mirror; Fresnel–Schlick reflects about 2% head-on (F0 = ((n − 1)/(n + 1))²) and almost everything towards the horizon.",
        scene: "variants/schlick.toml",
        rows: &["mirror", "beauty"],
        columns: &[
            ("constant", &["--terms", "ambient,diffuse,mirror:constant"]),
            ("schlick", &["--terms", "ambient,diffuse,mirror:schlick"]),
        ],
    },
    Sheet {
        id: "refraction",
        title: "Seed vs Fresnel refraction",
        description: "Glass with alpha = 1 and no other term. The seed refraction passes alpha of the light through; the Fresnel variant reflects part of it at each surface (bright rims at grazing angles) and passes the rest.",
        scene: "variants/fresnel.toml",
        rows: &["refraction", "beauty"],
        columns: &[
            ("seed", &["--terms", "ambient,diffuse,refraction:seed"]),
            ("fresnel", &["--terms", "ambient,diffuse,refraction:fresnel"]),
        ],
    },
    Sheet {
        id: "shadows",
        title: "Shadow models",
        description: "A clay sphere and a glass cube under a 2 × 2 area light. none: no shadows at all; hard: the handout's, any object blocks the light's centre; transmissive: the glass lets alpha of the light through; soft: the area light is sampled on a stratified grid, giving penumbrae.",
        scene: "soft-shadows.toml",
        rows: &["diffuse", "beauty"],
        columns: &[
            ("none", &["--shadows", "none"]),
            ("hard", &["--shadows", "hard"]),
            ("transmissive", &["--shadows", "transmissive"]),
            ("soft", &["--shadows", "soft"]),
        ],
    },
    Sheet {
        id: "depth",
        title: "The depth limit, 0 to 5",
        description: "Two facing mirrors: each reflection costs one level of recursion, so max_depth = k shows k nested reflections; at 0 the mirrors show only their own faint colour.",
        scene: "mirrors.toml",
        rows: &["beauty"],
        columns: &[
            ("max_depth 0", &["--max-depth", "0"]),
            ("1", &["--max-depth", "1"]),
            ("2", &["--max-depth", "2"]),
            ("3", &["--max-depth", "3"]),
            ("4", &["--max-depth", "4"]),
            ("5", &["--max-depth", "5"]),
        ],
    },
];

struct Rendered {
    rel: String,
    title: String,
    description: String,
    layers: Vec<String>,
    seconds: f64,
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

fn slug(s: &str) -> String {
    s.chars().map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_lowercase() } else { '-' }).collect()
}

/// The `[meta]` title and description and the term names, in model order, of a scene file.
fn describe(path: &Path) -> Result<(String, String, Vec<String>)> {
    let src = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let doc: toml::Table = src.parse().with_context(|| format!("parsing {}", path.display()))?;
    let meta = doc.get("meta").and_then(|m| m.as_table());
    let text = |k: &str| meta.and_then(|m| m.get(k)).and_then(|v| v.as_str()).map(str::to_owned);
    let stem = path.file_stem().unwrap_or_default().to_string_lossy().into_owned();
    let terms = doc.get("model").and_then(|m| m.get("terms")).and_then(|t| t.as_array()).map(|list| {
        list.iter()
            .filter_map(|e| e.as_str().or_else(|| e.get("term").and_then(|t| t.as_str())).map(str::to_owned))
            .collect::<Vec<_>>()
    });
    Ok((
        text("title").unwrap_or(stem),
        text("description").unwrap_or_default(),
        terms.unwrap_or_else(|| DEFAULT_TERMS.iter().map(|s| s.to_string()).collect()),
    ))
}

fn render(lancer: &Path, scene: &Path, dir: &Path, args: &[&str], opts: &[(String, String)]) -> Result<f64> {
    let mut cmd = Command::new(lancer);
    cmd.arg("render").arg(scene).arg("-o").arg(dir.join("beauty.png")).arg("--aov").arg(dir);
    cmd.args(["--aov-format", "png", "--quiet"]).args(args);
    for (k, v) in opts {
        cmd.arg(format!("--{k}")).arg(v);
    }
    let start = Instant::now();
    let out = cmd.output().context("running lancer")?;
    if !out.status.success() {
        bail!("rendering {} failed:\n{}", scene.display(), String::from_utf8_lossy(&out.stderr));
    }
    Ok(start.elapsed().as_secs_f64())
}

/// `cargo xtask gallery [--width W] [--samples N] [--shard I/N] [FILTER]`. With `--shard`, only
/// every N-th render from the I-th is made, and what was made is recorded for `gallery-merge`.
pub fn build(args: &[String]) -> Result<()> {
    let TaskArgs { options: mut opts, filter } = parse_common(args, &["width", "samples", "shard"])?;
    let shard = match opts.iter().position(|(k, _)| k == "shard") {
        Some(i) => Some(parse_shard(&opts.remove(i).1)?),
        None => None,
    };
    let lancer = build_renderer()?;
    let out = root().join("target/gallery");
    // Shards may be writing the same folder: only a whole build starts afresh.
    if shard.is_none() && out.exists() {
        std::fs::remove_dir_all(&out).with_context(|| format!("clearing {}", out.display()))?;
    }
    let list = scenes(filter.as_deref())?;
    let scenes_dir = root().join("scenes");
    let sheets: Vec<&Sheet> =
        SHEETS.iter().filter(|s| filter.as_deref().is_none_or(|f| s.scene.contains(f) || s.id.contains(f))).collect();
    let jobs = list.len() + sheets.iter().map(|s| s.columns.len()).sum::<usize>();
    let mine = |job: usize| shard.is_none_or(|(i, n)| job % n == i);
    let share = (0..jobs).filter(|&j| mine(j)).count();
    let (mut done, mut total_seconds) = (0, 0.0);
    let mut progress = |label: &str, seconds: f64| {
        done += 1;
        total_seconds += seconds;
        eprintln!("[{done:>2}/{share}] {label} ({seconds:.2} s)");
    };

    let mut rendered = Vec::new();
    let mut job = 0;
    for scene in &list {
        let rel =
            scene.strip_prefix(&scenes_dir).unwrap_or(scene).with_extension("").to_string_lossy().replace('\\', "/");
        job += 1;
        if !mine(job - 1) {
            continue;
        }
        let dir = out.join("scenes").join(&rel);
        let seconds = render(&lancer, scene, &dir, &[], &opts)?;
        progress(&format!("scenes/{rel}.toml"), seconds);
        let (title, description, terms) = describe(scene)?;
        let mut layers: Vec<String> = terms.into_iter().filter(|t| dir.join(format!("{t}.png")).exists()).collect();
        if dir.join("background.png").exists() {
            layers.push("background".into());
        }
        rendered.push(Rendered { rel, title, description, layers, seconds });
    }
    let mut columns = Vec::new();
    for sheet in &sheets {
        for (label, extra) in sheet.columns {
            job += 1;
            if !mine(job - 1) {
                continue;
            }
            let dir = out.join("sheets").join(sheet.id).join(slug(label));
            let seconds = render(&lancer, &scenes_dir.join(sheet.scene), &dir, extra, &opts)?;
            progress(&format!("sheet {}: {label}", sheet.id), seconds);
            columns.push(format!("{}/{}", sheet.id, slug(label)));
        }
    }

    if let Some((i, n)) = shard {
        let record = serde_json::json!({
            "shard": [i, n],
            "jobs": jobs,
            "options": opts.iter().map(|(k, v)| [k, v]).collect::<Vec<_>>(),
            "filter": filter,
            "seconds": total_seconds,
            "scenes": rendered.iter().map(|r| serde_json::json!({
                "rel": r.rel, "title": r.title, "description": r.description, "layers": r.layers, "seconds": r.seconds,
            })).collect::<Vec<_>>(),
            "columns": columns,
        });
        let file = out.join("shards").join(format!("{i}-of-{n}.json"));
        std::fs::create_dir_all(file.parent().expect("a folder"))?;
        std::fs::write(&file, serde_json::to_string_pretty(&record)?).context("writing the shard record")?;
        eprintln!("shard {i}/{n}: {} renders, {total_seconds:.1} s -> {}", share, file.display());
        return Ok(());
    }
    write_page(&out, &rendered, &sheets, &opts, total_seconds)
}

/// `I/N` with `0 <= I < N`.
fn parse_shard(s: &str) -> Result<(usize, usize)> {
    let parsed = s.split_once('/').and_then(|(i, n)| Some((i.trim().parse().ok()?, n.trim().parse().ok()?)));
    match parsed {
        Some((i, n)) if i < n => Ok((i, n)),
        _ => bail!("--shard expects I/N with I from 0 to N - 1, e.g. 0/4; got `{s}`"),
    }
}

fn write_page(
    out: &Path,
    rendered: &[Rendered],
    sheets: &[&Sheet],
    opts: &[(String, String)],
    seconds: f64,
) -> Result<()> {
    let html = page(rendered, sheets, opts, seconds);
    std::fs::write(out.join("index.html"), html).context("writing index.html")?;
    let size: u64 = walk_size(out);
    eprintln!(
        "wrote {} ({} scenes, {} sheets, {:.1} MB, {:.1} s of rendering)",
        out.join("index.html").display(),
        rendered.len(),
        sheets.len(),
        size as f64 / 1e6,
        seconds
    );
    Ok(())
}

/// `cargo xtask gallery-merge`: the page from the records of every shard of one sharded build
/// (all in `target/gallery/shards/`, their images under `target/gallery/`).
pub fn merge(args: &[String]) -> Result<()> {
    if let Some(a) = args.first() {
        bail!("unexpected argument `{a}`: gallery-merge reads target/gallery/shards/");
    }
    let out = root().join("target/gallery");
    let dir = out.join("shards");
    let mut records: Vec<serde_json::Value> = Vec::new();
    for entry in
        std::fs::read_dir(&dir).with_context(|| format!("reading {} (run gallery --shard first)", dir.display()))?
    {
        let p = entry?.path();
        let text = std::fs::read_to_string(&p).with_context(|| format!("reading {}", p.display()))?;
        records.push(serde_json::from_str(&text).with_context(|| format!("{} is not a shard record", p.display()))?);
    }
    let Some(first) = records.first() else { bail!("no shard records in {}", dir.display()) };
    let n = first["shard"][1].as_u64().context("a shard record without its count")? as usize;
    let mut seen = vec![false; n];
    for r in &records {
        if r["shard"][1] != first["shard"][1] || r["options"] != first["options"] || r["filter"] != first["filter"] {
            bail!(
                "the shard records in {} come from different builds (shard counts, options or filters differ)",
                dir.display()
            );
        }
        let i = r["shard"][0].as_u64().context("a shard record without its index")? as usize;
        if i >= n || std::mem::replace(&mut seen[i], true) {
            bail!("shard {i}/{n} is recorded twice or out of range");
        }
    }
    let missing: Vec<String> = seen.iter().enumerate().filter(|(_, s)| !**s).map(|(i, _)| i.to_string()).collect();
    if !missing.is_empty() {
        bail!("shard(s) {} of {n} missing in {}", missing.join(", "), dir.display());
    }
    let opts: Vec<(String, String)> = first["options"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|kv| Some((kv[0].as_str()?.to_owned(), kv[1].as_str()?.to_owned())))
        .collect();
    let filter = first["filter"].as_str();
    let text = |v: &serde_json::Value| v.as_str().unwrap_or_default().to_owned();
    // The scenes in the order a whole build lists them.
    let order: Vec<String> = scenes(filter)?
        .iter()
        .map(|s| {
            s.strip_prefix(root().join("scenes")).unwrap_or(s).with_extension("").to_string_lossy().replace('\\', "/")
        })
        .collect();
    let mut rendered: Vec<Rendered> = records
        .iter()
        .flat_map(|r| r["scenes"].as_array().cloned().unwrap_or_default())
        .map(|s| Rendered {
            rel: text(&s["rel"]),
            title: text(&s["title"]),
            description: text(&s["description"]),
            layers: s["layers"].as_array().into_iter().flatten().map(text).collect(),
            seconds: s["seconds"].as_f64().unwrap_or(0.0),
        })
        .collect();
    rendered.sort_by_key(|r| order.iter().position(|o| *o == r.rel).unwrap_or(usize::MAX));
    let sheets: Vec<&Sheet> =
        SHEETS.iter().filter(|s| filter.is_none_or(|f| s.scene.contains(f) || s.id.contains(f))).collect();
    let columns: usize = records.iter().map(|r| r["columns"].as_array().map_or(0, Vec::len)).sum();
    let want = sheets.iter().map(|s| s.columns.len()).sum::<usize>();
    if rendered.len() != order.len() || columns != want {
        bail!(
            "the shards rendered {} scenes and {columns} sheet columns where the build has {} and {want}",
            rendered.len(),
            order.len()
        );
    }
    let seconds: f64 = records.iter().map(|r| r["seconds"].as_f64().unwrap_or(0.0)).sum();
    write_page(&out, &rendered, &sheets, &opts, seconds)
}

fn walk_size(dir: &Path) -> u64 {
    std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| {
            let p = e.path();
            if p.is_dir() { walk_size(&p) } else { e.metadata().map(|m| m.len()).unwrap_or(0) }
        })
        .sum()
}

fn figure(src: &str, caption: &str, class: &str) -> String {
    format!(
        "<figure class=\"{class}\"><a href=\"{src}\"><img src=\"{src}\" alt=\"{c}\" loading=\"eager\"></a><figcaption>{c}</figcaption></figure>",
        c = escape(caption)
    )
}

fn page(scenes: &[Rendered], sheets: &[&Sheet], opts: &[(String, String)], seconds: f64) -> String {
    let mut h = String::new();
    let options: String = opts.iter().map(|(k, v)| format!(" --{k} {v}")).collect();
    let _ = write!(
        h,
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
         <title>Lancer gallery</title>\n<style>{CSS}</style></head>\n<body>\n\
         <header><h1>Lancer gallery</h1><p>Every scene in <code>scenes/</code> with the image of each term of its \
         lighting model beside the beauty image (their exact sum), and comparison sheets that swap one part of the \
         model at a time. {} scenes, {} comparison sheets, {:.1} s of rendering. Made by <code>cargo xtask gallery{}</code>.</p>\n<nav>",
        scenes.len(),
        sheets.len(),
        seconds,
        escape(&options)
    );
    h.push_str("<strong>Comparisons:</strong> ");
    for s in sheets {
        let _ = write!(h, "<a href=\"#sheet-{}\">{}</a> ", s.id, escape(s.title));
    }
    h.push_str("<br><strong>Scenes:</strong> ");
    for s in scenes {
        let _ = write!(h, "<a href=\"#scene-{}\">{}</a> ", slug(&s.rel), escape(&s.title));
    }
    h.push_str("</nav></header>\n<main>\n");
    if !sheets.is_empty() {
        h.push_str("<h2 class=\"part\">Comparison sheets</h2>\n");
    }
    for s in sheets {
        let _ = write!(
            h,
            "<section id=\"sheet-{}\"><h3>{}</h3><p>{}</p><p class=\"meta\">scenes/{}</p>\
             <div class=\"sheet\" style=\"grid-template-columns: 7em repeat({}, minmax(0, 520px))\"><div></div>",
            s.id,
            escape(s.title),
            escape(s.description),
            escape(s.scene),
            s.columns.len()
        );
        for (label, _) in s.columns {
            let _ = write!(h, "<div class=\"col\">{}</div>", escape(label));
        }
        for row in s.rows {
            let _ = write!(h, "<div class=\"row\">{}</div>", escape(row));
            for (label, _) in s.columns {
                let src = format!("sheets/{}/{}/{row}.png", s.id, slug(label));
                let _ = write!(h, "{}", figure(&src, &format!("{row}, {label}"), "cell"));
            }
        }
        h.push_str("</div></section>\n");
    }
    h.push_str("<h2 class=\"part\">Scenes</h2>\n");
    for s in scenes {
        let _ = write!(
            h,
            "<section id=\"scene-{}\"><h3>{}</h3><p>{}</p><p class=\"meta\">scenes/{}.toml · rendered in {:.2} s</p>\
             <div class=\"scene\">{}<div class=\"terms\">",
            slug(&s.rel),
            escape(&s.title),
            escape(&s.description),
            escape(&s.rel),
            s.seconds,
            figure(&format!("scenes/{}/beauty.png", s.rel), "beauty = the sum of the images on the right", "beauty")
        );
        for layer in &s.layers {
            let _ = write!(h, "{}", figure(&format!("scenes/{}/{layer}.png", s.rel), layer, "term"));
        }
        h.push_str("</div></div></section>\n");
    }
    h.push_str("</main>\n<script>");
    h.push_str(SCRIPT);
    h.push_str("</script>\n</body></html>\n");
    h
}

const CSS: &str = "body{font:15px/1.45 system-ui,sans-serif;margin:0;background:#16181d;color:#e6e6e6}\
header,main{max-width:1400px;margin:auto;padding:0 1.5em}h1{margin:.8em 0 .2em}\
a{color:#8cb4ff}nav{font-size:13px;line-height:1.9}nav a{margin-right:.6em}\
h2.part{border-bottom:1px solid #444;margin-top:1.5em}section{margin:2em 0}h3{margin:.2em 0}\
p{max-width:70em;margin:.3em 0}.meta{color:#999;font-size:13px}code{color:#ffd27f}\
figure{margin:0}img{display:block;width:100%;height:auto;image-rendering:auto;background:#000}\
figcaption{font-size:12px;color:#bbb;text-align:center;padding:2px 0}\
.scene{display:grid;grid-template-columns:minmax(0,2fr) minmax(0,3fr);gap:1em;align-items:start}\
.terms{display:grid;grid-template-columns:repeat(3,minmax(0,1fr));gap:.6em}\
.sheet{display:grid;gap:.5em;align-items:center}.col{text-align:center;font-weight:600}\
.row{font-weight:600;text-align:right;padding-right:.5em}";

/// Records, once the page has loaded, how many images loaded and which did not: the browser check
/// reads these attributes.
const SCRIPT: &str = "window.addEventListener('load',function(){var all=Array.prototype.slice.call(document.images);\
var broken=all.filter(function(i){return !(i.complete&&i.naturalWidth>0)});\
document.body.setAttribute('data-images-total',all.length);\
document.body.setAttribute('data-images-broken',broken.length);\
document.body.setAttribute('data-broken-list',broken.map(function(i){return i.getAttribute('src')}).join(' '));});";

fn chromium() -> Result<PathBuf> {
    for name in ["chromium", "chromium-browser", "google-chrome"] {
        if let Ok(out) = Command::new("which").arg(name).output()
            && out.status.success()
        {
            return Ok(PathBuf::from(String::from_utf8_lossy(&out.stdout).trim()));
        }
    }
    bail!("no Chromium found: install Debian's `chromium` package (apt-get install -y chromium) to check the gallery")
}

fn headless(browser: &Path, profile: &Path) -> Command {
    let mut cmd = Command::new(browser);
    cmd.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
        "--virtual-time-budget=20000",
    ])
    .arg(format!("--user-data-dir={}", profile.display()));
    cmd
}

/// The value of `name="..."` in the first tag that has it.
fn attribute(dom: &str, name: &str) -> Option<String> {
    let at = dom.find(&format!("{name}=\""))? + name.len() + 2;
    Some(dom[at..].split('"').next()?.to_owned())
}

/// `cargo xtask gallery-check [--screenshot FILE]`.
pub fn check(args: &[String]) -> Result<()> {
    let TaskArgs { options: opts, filter: extra } = parse_common(args, &["screenshot"])?;
    if let Some(e) = extra {
        bail!("unexpected argument `{e}`");
    }
    let index = root().join("target/gallery/index.html");
    if !index.exists() {
        bail!("{} does not exist: run `cargo xtask gallery` first", index.display());
    }
    let shot =
        opts.iter().find(|(k, _)| k == "screenshot").map_or(root().join("target/gallery/screenshot.png"), |(_, v)| {
            let p = PathBuf::from(v);
            if p.is_absolute() { p } else { std::env::current_dir().unwrap_or_default().join(p) }
        });
    let browser = chromium()?;
    let profile = std::env::temp_dir().join(format!("lancer-chromium-{}", std::process::id()));
    let url = format!("file://{}", index.display());

    let out = headless(&browser, &profile).arg("--dump-dom").arg(&url).output().context("running Chromium")?;
    let dom = String::from_utf8_lossy(&out.stdout);
    let (Some(total), Some(broken)) = (attribute(&dom, "data-images-total"), attribute(&dom, "data-images-broken"))
    else {
        bail!(
            "Chromium did not report the page's images (did the page load?)\n{}",
            String::from_utf8_lossy(&out.stderr).lines().take(10).collect::<Vec<_>>().join("\n")
        );
    };
    let (total, broken): (usize, usize) = (total.parse()?, broken.parse()?);
    let expected = std::fs::read_to_string(&index)?.matches("<img ").count();
    if broken > 0 {
        bail!("{broken} of {total} images did not load: {}", attribute(&dom, "data-broken-list").unwrap_or_default());
    }
    if total != expected || total == 0 {
        bail!("the browser saw {total} images, the page has {expected}");
    }

    let status = headless(&browser, &profile)
        .arg(format!("--screenshot={}", shot.display()))
        .arg("--window-size=1400,1800")
        .arg(&url)
        .output()
        .context("running Chromium for the screenshot")?;
    let _ = std::fs::remove_dir_all(&profile);
    if !status.status.success() || !shot.exists() {
        bail!("Chromium could not take the screenshot:\n{}", String::from_utf8_lossy(&status.stderr));
    }
    eprintln!("all {total} images of the gallery loaded in Chromium; screenshot: {}", shot.display());
    Ok(())
}

//! The render gallery: every scene with its per-term images side by side, and the comparison
//! sheets of `sheets/` (each swaps one part of the model at a time; `lancer sheet` draws it),
//! written as one self-contained HTML page with relative image paths
//! (`target/gallery/index.html`); and its check in headless Chromium.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};

use crate::{TaskArgs, build_renderer, parse_common, root, scenes};

/// The terms a model without `terms` gets, in order (the built-in defaults).
const DEFAULT_TERMS: [&str; 5] = ["ambient", "diffuse", "specular", "mirror", "refraction"];

/// A comparison sheet of `sheets/`: a sheet file (a scene in a grid of changes to its model)
/// that `lancer sheet` draws into one picture; its title and description are read from the file
/// for the page.
struct Sheet {
    /// The file's name without `.toml`.
    id: String,
    title: String,
    description: String,
    /// The scene, as the sheet file names it (relative to `sheets/`).
    scene: String,
}

/// Every sheet file in `sheets/`, by file name, keeping those whose name or scene contains
/// `filter`.
fn sheets(filter: Option<&str>) -> Result<Vec<Sheet>> {
    let dir = root().join("sheets");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .with_context(|| format!("reading {}", dir.display()))?
        .map(|e| Ok(e?.path()))
        .collect::<Result<Vec<_>>>()?;
    files.retain(|p| p.extension().is_some_and(|e| e == "toml"));
    files.sort();
    let mut list = Vec::new();
    for path in files {
        let src = std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
        let doc: toml::Table = src.parse().with_context(|| format!("parsing {}", path.display()))?;
        let text = |k: &str| doc.get(k).and_then(|v| v.as_str()).unwrap_or_default().to_owned();
        let id = path.file_stem().unwrap_or_default().to_string_lossy().into_owned();
        let sheet = Sheet { title: text("title"), description: text("description"), scene: text("scene"), id };
        if filter.is_none_or(|f| sheet.scene.contains(f) || sheet.id.contains(f)) {
            list.push(sheet);
        }
    }
    Ok(list)
}

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

fn render(lancer: &Path, scene: &Path, dir: &Path, opts: &[(String, String)]) -> Result<f64> {
    let mut cmd = Command::new(lancer);
    cmd.arg("render").arg(scene).arg("-o").arg(dir.join("beauty.png")).arg("--aov").arg(dir);
    cmd.args(["--aov-format", "png", "--quiet"]);
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

/// `lancer sheet` on `sheets/ID.toml`, into `out/sheets/ID.png`, at the sheet's own size (a
/// projector's, so its text stays readable; it costs about a second for all of them): of the
/// gallery's options only `--samples` is passed on.
fn render_sheet(lancer: &Path, sheet: &Sheet, out: &Path, opts: &[(String, String)]) -> Result<f64> {
    let dir = out.join("sheets");
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let file = root().join("sheets").join(format!("{}.toml", sheet.id));
    let mut cmd = Command::new(lancer);
    cmd.arg("sheet").arg(&file).arg("-o").arg(dir.join(format!("{}.png", sheet.id))).arg("--quiet");
    for (k, v) in opts.iter().filter(|(k, _)| k == "samples") {
        cmd.arg(format!("--{k}")).arg(v);
    }
    let start = Instant::now();
    let result = cmd.output().context("running lancer sheet")?;
    if !result.status.success() {
        bail!("lancer sheet {} failed:\n{}", file.display(), String::from_utf8_lossy(&result.stderr));
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
    let sheets = sheets(filter.as_deref())?;
    let jobs = list.len() + sheets.len();
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
        let seconds = render(&lancer, scene, &dir, &opts)?;
        progress(&format!("scenes/{rel}.toml"), seconds);
        let (title, description, terms) = describe(scene)?;
        let mut layers: Vec<String> = terms.into_iter().filter(|t| dir.join(format!("{t}.png")).exists()).collect();
        if dir.join("background.png").exists() {
            layers.push("background".into());
        }
        rendered.push(Rendered { rel, title, description, layers, seconds });
    }
    let mut made = Vec::new();
    for sheet in &sheets {
        job += 1;
        if !mine(job - 1) {
            continue;
        }
        let seconds = render_sheet(&lancer, sheet, &out, &opts)?;
        progress(&format!("sheets/{}.toml", sheet.id), seconds);
        made.push(sheet.id.clone());
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
            "sheets": made,
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
    sheets: &[Sheet],
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
    let sheets = sheets(filter)?;
    let made: usize = records.iter().map(|r| r["sheets"].as_array().map_or(0, Vec::len)).sum();
    if rendered.len() != order.len() || made != sheets.len() {
        bail!(
            "the shards rendered {} scenes and {made} sheets where the build has {} and {}",
            rendered.len(),
            order.len(),
            sheets.len()
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

fn page(scenes: &[Rendered], sheets: &[Sheet], opts: &[(String, String)], seconds: f64) -> String {
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
        let _ = write!(h, "<a href=\"#sheet-{}\">{}</a> ", s.id, escape(&s.title));
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
        let _ = writeln!(
            h,
            "<section id=\"sheet-{}\"><h3>{}</h3><p>{}</p><p class=\"meta\">sheets/{}.toml · scene {} · \
             <code>lancer sheet sheets/{}.toml -o {}.png</code></p>{}</section>",
            s.id,
            escape(&s.title),
            escape(&s.description),
            s.id,
            escape(s.scene.trim_start_matches("../")),
            s.id,
            s.id,
            figure(
                &format!("sheets/{}.png", s.id),
                "the sheet as lancer sheet draws it (click for its full size)",
                "sheet"
            )
        );
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
figure.sheet{max-width:1400px}";

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

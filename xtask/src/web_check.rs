//! `cargo xtask web-check`: the browser build (`target/web`, from `cargo xtask web`) served on
//! loopback by a small static server here and driven in Debian's Chromium through chromedriver,
//! with every host but loopback unreachable. It checks what a student does: each shipped scene
//! picked renders with float layers equal to the native render's, bit for bit; a slider changes
//! its term's image only; a scene dropped with an OBJ renders; a broken edit shows its located
//! error at its line and keeps the image; a downloaded EXR is the native file's bytes; a share
//! link opens the same scene; and screenshots at 1024x768 and 1920x1080 go to `docs/`.

use std::io::{BufRead, BufReader, Write};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use lancer_studio::session::Session;
use serde_json::json;

use crate::webdriver::Driver;
use crate::{root, which};

/// Serves the files under `dir` on `127.0.0.1` (GET only; no path outside `dir`), on a thread,
/// until the process ends; returns the port.
pub fn serve_static(dir: PathBuf) -> Result<u16> {
    let listener = TcpListener::bind("127.0.0.1:0")?;
    let port = listener.local_addr()?.port();
    std::thread::spawn(move || {
        for stream in listener.incoming().flatten() {
            let dir = dir.clone();
            std::thread::spawn(move || {
                let _ = answer(&dir, stream);
            });
        }
    });
    Ok(port)
}

fn answer(dir: &Path, mut stream: std::net::TcpStream) -> Result<()> {
    let mut reader = BufReader::new(stream.try_clone()?);
    loop {
        let mut request = String::new();
        if reader.read_line(&mut request)? == 0 {
            return Ok(());
        }
        loop {
            let mut header = String::new();
            if reader.read_line(&mut header)? == 0 || header.trim().is_empty() {
                break;
            }
        }
        let mut parts = request.split_whitespace();
        let (method, target) = (parts.next().unwrap_or(""), parts.next().unwrap_or("/"));
        let path = target.split(['?', '#']).next().unwrap_or("/");
        let rel = if path.ends_with('/') { format!("{path}index.html") } else { path.to_owned() };
        let safe = !rel.split('/').any(|c| c == "..") && method == "GET";
        let file = dir.join(rel.trim_start_matches('/'));
        let (status, body) = match std::fs::read(&file) {
            Ok(b) if safe => ("200 OK", b),
            _ => ("404 Not Found", b"not found".to_vec()),
        };
        let kind = match file.extension().and_then(|e| e.to_str()) {
            Some("html") => "text/html; charset=utf-8",
            Some("js") => "text/javascript; charset=utf-8",
            Some("css") => "text/css; charset=utf-8",
            Some("wasm") => "application/wasm",
            Some("json") => "application/json",
            Some("png") => "image/png",
            _ => "application/octet-stream",
        };
        write!(
            stream,
            "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-store\r\n\r\n",
            body.len()
        )?;
        stream.write_all(&body)?;
    }
}

/// The page's hash of a layer's floats (FNV-1a over their bits, `window.studio.hash`).
fn fnv(pixels: &[glam::Vec3]) -> u32 {
    let mut h = 2_166_136_261u32;
    for p in pixels {
        for c in p.to_array() {
            h ^= c.to_bits();
            h = h.wrapping_mul(16_777_619);
        }
    }
    h
}

/// A scene's native render as the page asks for it (the file's state, the full image).
struct Native {
    layers: Vec<(String, Vec<glam::Vec3>)>,
    width: u32,
    height: u32,
}

fn native(name: &str, text: &str, files: &dyn Fn(&str) -> Result<Vec<u8>, String>) -> Result<Native> {
    let registry = lancer_shading::Registry::with_builtins();
    let s = Session::load(&registry, name, text, files, &Default::default()).map_err(|e| anyhow::anyhow!("{e}"))?;
    let frame = s.render(&s.loaded, false, None).map_err(anyhow::Error::msg)?;
    let mut layers: Vec<(String, Vec<glam::Vec3>)> = frame.layers.into_iter().map(|l| (l.name, l.pixels)).collect();
    layers.insert(0, ("beauty".into(), frame.beauty));
    Ok(Native { layers, width: frame.width, height: frame.height })
}

/// The generation of the newest full frame, once it is newer than `after` (and its scene is
/// `scene` when given).
fn full_after(d: &Driver, what: &str, after: i64) -> Result<i64> {
    let v = d.until(
        what,
        &format!(
            "const f = window.studio && window.studio.frame(); return f && !f.coarse && f.generation > {after} ? f.generation : null;"
        ),
    )?;
    Ok(v.as_i64().unwrap_or(0))
}

fn generation(d: &Driver) -> Result<i64> {
    Ok(d.js("const f = window.studio.frame(); return f ? f.generation : 0;", json!([]))?.as_i64().unwrap_or(0))
}

/// Compares the page's layers with a native render's, bit for bit; on a difference, how many
/// floats differ and by how much.
fn compare(d: &Driver, what: &str, n: &Native) -> Result<()> {
    let frame = d.js("return window.studio.frame()", json!([]))?;
    if frame["width"] != json!(n.width) || frame["height"] != json!(n.height) {
        bail!(
            "{what}: the page shows {}x{}, the native render is {}x{}",
            frame["width"],
            frame["height"],
            n.width,
            n.height
        );
    }
    for (name, pixels) in &n.layers {
        let got = d.js("return window.studio.hash(arguments[0])", json!([name]))?;
        if got == json!(fnv(pixels)) {
            continue;
        }
        use base64::Engine as _;
        let b64 = d.js("return window.studio.layerBase64(arguments[0])", json!([name]))?;
        let bytes = base64::engine::general_purpose::STANDARD.decode(b64.as_str().unwrap_or(""))?;
        let page: Vec<f32> = bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        let mine: Vec<f32> = pixels.iter().flat_map(|p| p.to_array()).collect();
        let differ = page.iter().zip(&mine).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
        let worst = page.iter().zip(&mine).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        bail!(
            "{what}: layer {name} differs from the native render in {differ} of {} floats (largest difference {worst:e})",
            mine.len()
        );
    }
    Ok(())
}

const SET: &str = "const e = document.querySelector(arguments[0]); if (!e) return 'no ' + arguments[0]; \
    if (e.type === 'checkbox') e.checked = arguments[1]; else e.value = arguments[1]; \
    window.studio.editAt = performance.now(); e.dispatchEvent(new Event('input')); return true;";

pub fn check(args: &[String]) -> Result<()> {
    let mut docs = root().join("docs");
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--screenshots" => docs = PathBuf::from(it.next().context("--screenshots needs a folder")?),
            other => bail!("unknown option `{other}` (cargo xtask web-check [--screenshots DIR])"),
        }
    }
    let web = root().join("target/web");
    if !web.join("index.html").is_file() {
        bail!("{} holds no build: run `cargo xtask web` first", web.display());
    }
    let chromedriver = which("chromedriver").context(
        "chromedriver is not installed (Debian: apt-get install chromium chromium-driver, the same version)",
    )?;
    let port = serve_static(web)?;
    // Every host name resolves to nothing but loopback's: the page must need no network.
    let (d, _driver) = crate::webdriver::start_with(
        chromedriver,
        (1500, 1000),
        &["--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1"],
    )?;
    let result = run(&d, port, &docs);
    let _ = d.call("DELETE", "", json!({}));
    result
}

fn run(d: &Driver, port: u16, docs: &Path) -> Result<()> {
    let base = format!("http://127.0.0.1:{port}/");
    d.call("POST", "/url", json!({ "url": base }))?;
    let started = Instant::now();
    let mut g = full_after(d, "the first full image", 0)?;
    let info = d.js("return window.studio.engineInfo()", json!([]))?;
    println!("page loaded: first full image after {:.1} s ({info})", started.elapsed().as_secs_f64());

    // 1. Every shipped scene, picked from the list, equals its native render.
    let scenes_dir = root().join("scenes");
    let shipped = crate::scenes(None)?;
    for path in &shipped {
        let rel = path.strip_prefix(&scenes_dir)?.to_string_lossy().replace('\\', "/");
        let text = std::fs::read_to_string(path)?;
        let name = rel.rsplit('/').next().unwrap_or(&rel).to_owned();
        let dir = path.parent().context("a scene has a folder")?.to_path_buf();
        let n = native(&name, &text, &|p: &str| std::fs::read(dir.join(p)).map_err(|e| e.to_string()))?;
        let t = Instant::now();
        d.js(
            "const s = document.getElementById('scenes'); s.value = arguments[0]; s.dispatchEvent(new Event('change')); return true;",
            json!([rel]),
        )?;
        g = full_after(d, &format!("{rel}'s full image"), g)?;
        // A frame of the newly picked scene (the first may still have been the last scene's).
        d.until(
            &format!("{rel} shown"),
            &format!("return document.getElementById('scene').textContent.startsWith({:?})", name),
        )?;
        g = g.max(generation(d)?);
        compare(d, &rel, &n)?;
        println!(
            "{rel}: {}x{}, every layer bit-identical to the native render ({:.2} s)",
            n.width,
            n.height,
            t.elapsed().as_secs_f64()
        );
    }
    let seen = d.js(
        "return performance.getEntriesByType('resource').map((e) => e.name).filter((u) => !u.startsWith(arguments[0]) && !u.startsWith('blob:'))",
        json!([base]),
    )?;
    if seen.as_array().is_some_and(|a| !a.is_empty()) {
        bail!("the page fetched from beyond the page's own server: {seen}");
    }
    println!("the page fetched nothing beyond its own server");

    // 2. A slider: the diffuse image changes, the ambient one keeps its bits.
    d.js(
        "const s = document.getElementById('scenes'); s.value = 'showcase.toml'; s.dispatchEvent(new Event('change')); return true;",
        json!([]),
    )?;
    g = full_after(d, "the showcase again", g)?;
    let hash = |name: &str| d.js("return window.studio.hash(arguments[0])", json!([name]));
    let before = (hash("ambient")?, hash("diffuse")?);
    let ok = d.js(SET, json!(["fieldset[data-material='1'] input[data-param='diff']", "0.3"]))?;
    if ok != json!(true) {
        bail!("the floor's diff slider: {ok}");
    }
    g = full_after(d, "the image after the diff slider", g)?;
    let t = d.js(
        "const s = window.studio, a = s.arrivals.filter((x) => x.at >= s.editAt); \
         const c = a.find((x) => x.coarse), f = a.find((x) => !x.coarse); \
         return [c ? c.at - s.editAt : -1, f ? f.at - s.editAt : -1];",
        json!([]),
    )?;
    let after = (hash("ambient")?, hash("diffuse")?);
    if before.0 != after.0 || before.1 == after.1 {
        bail!(
            "moving diff: ambient {:?} -> {:?} (must not change), diffuse {:?} -> {:?} (must change)",
            before.0,
            after.0,
            before.1,
            after.1
        );
    }
    println!("diff slider: diffuse changed, ambient bit-identical; coarse after {} ms, full after {} ms", t[0], t[1]);

    // 3. A broken edit: its line marked, the message located, the image kept.
    let beauty = hash("beauty")?;
    let text = d.js("return document.getElementById('source').value", json!([]))?;
    let text = text.as_str().context("the scene's text")?.to_owned();
    let broken_line = text.lines().position(|l| l.starts_with("width")).context("a width line")? + 1;
    let broken = text.replacen("width = ", "width = \"wide\" # ", 1);
    d.js(
        "const e = document.getElementById('source'); e.value = arguments[0]; e.dispatchEvent(new Event('input')); return true;",
        json!([broken]),
    )?;
    let error = d.until(
        "the broken edit's error",
        "const e = document.getElementById('source-error'); return !e.hidden ? e.textContent : null",
    )?;
    let marked =
        d.js("const b = document.querySelector('#gutter .bad'); return b ? b.textContent : null", json!([]))?;
    if marked != json!(broken_line.to_string()) || !error.as_str().unwrap_or("").contains(&format!(":{broken_line}:")) {
        bail!("a broken width on line {broken_line}: the gutter marks {marked}, the error says {error}");
    }
    if hash("beauty")? != beauty {
        bail!("a broken edit replaced the image");
    }
    println!(
        "broken edit: line {broken_line} marked, `{}`, image kept",
        error.as_str().unwrap_or("").lines().next().unwrap_or("")
    );
    d.js(
        "const e = document.getElementById('source'); e.value = arguments[0]; e.dispatchEvent(new Event('input')); return true;",
        json!([text]),
    )?;
    d.until("the fixed edit", "return document.getElementById('source-error').hidden || null")?;
    g = full_after(d, "the image after the fix", g)?;

    // 4. The EXR download is the native file, byte for byte.
    let edited = d.js("return document.getElementById('source').value", json!([]))?;
    let edited = edited.as_str().context("the edited text")?.to_owned();
    let n = native("showcase.toml", &edited, &|_| Err("no file".into()))?;
    d.js("document.querySelector('#thumbs figure[data-layer=\"diffuse\"]').click(); document.getElementById('exr').click(); return true;", json!([]))?;
    let got = d.until("the EXR download", "return window.studio.lastDownload && window.studio.lastDownload.name.endsWith('.exr') ? window.studio.lastDownload : null")?;
    use base64::Engine as _;
    let bytes = base64::engine::general_purpose::STANDARD.decode(got["bytes"].as_str().unwrap_or(""))?;
    let diffuse = &n.layers.iter().find(|(name, _)| name == "diffuse").context("a diffuse layer")?.1;
    let want = lancer_cli::output::encode_exr(n.width, n.height, diffuse)?;
    if bytes != want {
        bail!("the downloaded {} ({} bytes) is not the native EXR ({} bytes)", got["name"], bytes.len(), want.len());
    }
    println!("download: {} is the native EXR's {} bytes", got["name"].as_str().unwrap_or(""), want.len());

    // 5. A dropped scene with its OBJ file.
    let obj = "v -1 0 0\nv 1 0 0\nv 0 1.5 0\nv 0 0.5 -1\nf 1 2 3\nf 1 4 2\nf 2 4 3\nf 3 4 1\n";
    let scene = "[camera]\nfrom = [0, 1, -4]\nto = [0, 0.5, 0]\n[image]\nwidth = 160\nheight = 120\n\
                 [[lights]]\nat = [3, 5, -4]\n[[objects]]\nshape = \"mesh\"\npath = \"tetra.obj\"\n\
                 material = { color = [0.9, 0.5, 0.2], ambi = 0.2, diff = 0.7 }\n";
    let n = native("mine.toml", scene, &|p: &str| {
        if p == "tetra.obj" { Ok(obj.as_bytes().to_vec()) } else { Err(format!("no {p}")) }
    })?;
    d.js(
        "const dt = new DataTransfer(); dt.items.add(new File([arguments[0]], 'mine.toml')); dt.items.add(new File([arguments[1]], 'tetra.obj')); \
         document.dispatchEvent(new DragEvent('drop', { dataTransfer: dt, bubbles: true, cancelable: true })); return true;",
        json!([scene, obj]),
    )?;
    d.until("the dropped scene", "return document.getElementById('scene').textContent.startsWith('mine.toml')")?;
    full_after(d, "the dropped scene's image", g)?;
    compare(d, "the dropped scene", &n)?;
    println!("dropped mine.toml with tetra.obj: rendered, every layer bit-identical to the native render");

    // 6. A share link opens the same scene (the text of an edited shipped one: a link carries
    // no file).
    d.js(
        "const s = document.getElementById('scenes'); s.value = 'glass.toml'; s.dispatchEvent(new Event('change')); return true;",
        json!([]),
    )?;
    d.until("glass.toml shown", "return document.getElementById('scene').textContent.startsWith('glass.toml')")?;
    let ok = d.js(SET, json!(["fieldset[data-material='0'] input[data-param='shine']", "0.9"]))?;
    if ok != json!(true) {
        bail!("the glass's shine slider: {ok}");
    }
    full_after(d, "the edited glass", g)?;
    d.until(
        "the text with the edit",
        "return document.getElementById('source').value.includes('shine = 0.9\\n') || null",
    )?;
    let beauty = hash("beauty")?;
    d.js("document.getElementById('share').click(); return true;", json!([]))?;
    let link = d.until("the share link", "return location.hash.startsWith('#scene=') ? location.href : null")?;
    let link = link.as_str().unwrap_or("").to_owned();
    d.call("POST", "/url", json!({ "url": "about:blank" }))?;
    d.call("POST", "/url", json!({ "url": link }))?;
    full_after(d, "the shared scene's image", 0)?;
    if hash("beauty")? != beauty {
        bail!("the share link ({} characters) shows another image", link.len());
    }
    println!("share link ({} characters): the same image", link.len());

    // 7. The module without SIMD (for a browser without it) gives the same bits too.
    d.call("POST", "/url", json!({ "url": format!("{base}?simd=0&scene=glass.toml") }))?;
    full_after(d, "glass.toml without SIMD", 0)?;
    let info = d.js("return window.studio.engineInfo()", json!([]))?;
    if info["simd"] != json!(false) {
        bail!("?simd=0 still runs the SIMD module: {info}");
    }
    let glass = scenes_dir.join("glass.toml");
    let n = native("glass.toml", &std::fs::read_to_string(&glass)?, &|_| Err("no file".into()))?;
    compare(d, "glass.toml without SIMD", &n)?;
    println!("glass.toml with the module built without SIMD: every layer bit-identical to the native render");

    // 8. Screenshots for the README.
    std::fs::create_dir_all(docs)?;
    for (w, h) in [(1024u32, 768u32), (1920, 1080)] {
        d.call("POST", "/window/rect", json!({ "width": w, "height": h }))?;
        d.call("POST", "/url", json!({ "url": base }))?;
        full_after(d, "the image for the screenshot", 0)?;
        std::thread::sleep(Duration::from_millis(300));
        let scroll =
            d.js("return document.documentElement.scrollWidth > document.documentElement.clientWidth", json!([]))?;
        if scroll == json!(true) {
            bail!("at {w}x{h} the page scrolls sideways");
        }
        let png = d.call("GET", "/screenshot", json!({}))?;
        let bytes = base64::engine::general_purpose::STANDARD.decode(png.as_str().context("a screenshot")?)?;
        let file = docs.join(format!("web-{w}x{h}.png"));
        std::fs::write(&file, bytes)?;
        println!("screenshot {}", file.display());
    }
    println!("web-check: all checks passed");
    Ok(())
}

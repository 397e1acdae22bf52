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
use serde_json::{Value, json};

use crate::webdriver::{Driver, SET};
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

/// The scene loads counted by the page's engine, and the newest full frame: `(key, generation)`.
fn shown(d: &Driver) -> Result<(i64, i64, bool)> {
    let v = d.js(
        "const f = window.studio.frame(), k = window.studio.engineInfo().key; return [k, f ? f.key : -1, f ? f.generation : 0, !!(f && !f.coarse)];",
        json!([]),
    )?;
    let n = |i: usize| v[i].as_i64().unwrap_or(-1);
    Ok((n(0), n(2), n(0) == n(1) && v[3] == json!(true)))
}

/// Runs `action` (a script that opens a scene) and waits for the first full frame of the scene it
/// loads (not a late frame of the one before).
fn open_and_wait(d: &Driver, what: &str, action: &str, args: Value) -> Result<()> {
    let (key, ..) = shown(d)?;
    d.js(action, args)?;
    d.until(
        what,
        &format!(
            "const f = window.studio.frame(), k = window.studio.engineInfo().key; return k > {key} && f && f.key === k && !f.coarse || null;"
        ),
    )?;
    Ok(())
}

/// Picks the shipped scene `rel` from the list, as a student would, and waits for its image.
fn pick(d: &Driver, rel: &str) -> Result<()> {
    open_and_wait(
        d,
        &format!("{rel}'s full image"),
        "const s = document.getElementById('scenes'); s.value = arguments[0]; s.dispatchEvent(new Event('change')); return true;",
        json!([rel]),
    )
}

/// Records the requests made to it that come from the page (their `Referer` or `Origin` is the
/// page's server, `page`): what every host but loopback resolves to during the check.
/// Chromium's own background requests name no page.
fn trap_server(page: u16) -> Result<(u16, std::sync::Arc<std::sync::Mutex<Vec<String>>>)> {
    let listener = TcpListener::bind("127.0.0.1:0")?;
    let port = listener.local_addr()?.port();
    let seen = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let log = seen.clone();
    std::thread::spawn(move || {
        for stream in listener.incoming().flatten() {
            let log = log.clone();
            std::thread::spawn(move || {
                let _ = stream.set_read_timeout(Some(Duration::from_secs(5)));
                let mut reader = BufReader::new(stream);
                let mut request = String::new();
                let _ = reader.read_line(&mut request);
                let mut from_page = false;
                loop {
                    let mut header = String::new();
                    if reader.read_line(&mut header).unwrap_or(0) == 0 || header.trim().is_empty() {
                        break;
                    }
                    let lower = header.to_ascii_lowercase();
                    if (lower.starts_with("referer:") || lower.starts_with("origin:"))
                        && lower.contains(&format!("127.0.0.1:{page}"))
                    {
                        from_page = true;
                    }
                }
                if from_page && let Ok(mut l) = log.lock() {
                    l.push(request.trim().to_owned());
                }
            });
        }
    });
    Ok((port, seen))
}

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
    // Every host name but loopback's goes to a server that only counts who came: the page
    // must need no network.
    let (trap, seen) = trap_server(port)?;
    let rules = format!("--host-resolver-rules=MAP * 127.0.0.1:{trap}, EXCLUDE 127.0.0.1");
    // (Chromium's own background traffic, its updater's and the like, is switched off: what
    // the trap sees is the page's.)
    let quiet = [
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-domain-reliability",
        "--disable-client-side-phishing-detection",
        "--disable-sync",
        "--no-first-run",
        "--no-default-browser-check",
        "--disable-default-apps",
        "--metrics-recording-only",
    ];
    let args: Vec<&str> = quiet.iter().copied().chain([rules.as_str()]).collect();
    let (d, _driver) = crate::webdriver::start_with(chromedriver, (1500, 1000), &args)?;
    let result = run(&d, port, &docs);
    let _ = d.call("DELETE", "", json!({}));
    result?;
    let seen = seen.lock().map(|s| s.clone()).unwrap_or_default();
    if !seen.is_empty() {
        bail!("the page reached beyond its own server: {seen:?}");
    }
    println!(
        "the page asked nothing of any host but its own server (its content security policy refused nothing; every other host led to a trap that saw no request from it)"
    );
    println!("web-check: all checks passed");
    Ok(())
}

fn run(d: &Driver, port: u16, docs: &Path) -> Result<()> {
    let base = format!("http://127.0.0.1:{port}/");
    d.call("POST", "/url", json!({ "url": base }))?;
    let started = Instant::now();
    d.until("the first full image", "const f = window.studio && window.studio.frame(); return f && !f.coarse || null")?;
    let info = d.js("return window.studio.engineInfo()", json!([]))?;
    println!("page loaded: first full image after {:.1} s ({info})", started.elapsed().as_secs_f64());
    if info["simd"] != json!(true) {
        bail!("Chromium runs WebAssembly SIMD, yet the page chose the module without it: {info}");
    }

    // 1. Every shipped scene, picked from the list, equals its native render.
    let scenes_dir = root().join("scenes");
    let native_of = |rel: &str| -> Result<Native> {
        let path = scenes_dir.join(rel);
        let text = std::fs::read_to_string(&path)?;
        let dir = path.parent().context("a scene has a folder")?.to_path_buf();
        native(rel, &text, &|p: &str| std::fs::read(dir.join(p)).map_err(|e| e.to_string()))
    };
    for path in crate::scenes(None)? {
        let rel = path.strip_prefix(&scenes_dir)?.to_string_lossy().replace('\\', "/");
        let n = native_of(&rel)?;
        let t = Instant::now();
        pick(d, &rel)?;
        compare(d, &rel, &n)?;
        println!(
            "{rel}: {}x{}, every layer bit-identical to the native render ({:.2} s)",
            n.width,
            n.height,
            t.elapsed().as_secs_f64()
        );
    }

    // 2. A slider: the diffuse image changes, the ambient one keeps its bits.
    pick(d, "showcase.toml")?;
    let hash = |name: &str| d.js("return window.studio.hash(arguments[0])", json!([name]));
    let before = (hash("ambient")?, hash("diffuse")?);
    let (_, g, _) = shown(d)?;
    let ok = d.js(SET, json!(["fieldset[data-name='floor'] input[data-param='diff']", "0.3"]))?;
    if ok != json!(true) {
        bail!("the floor's diff slider: {ok}");
    }
    full_after(d, "the image after the diff slider", g)?;
    let t = d.js(crate::webdriver::SINCE_EDIT, json!([]))?;
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

    // 3. A broken edit: its line marked, the message located, the image kept; a slider moved
    // meanwhile renders the last good scene.
    let beauty = hash("beauty")?;
    let text = d.js("return document.getElementById('source').value", json!([]))?;
    let text = text.as_str().context("the scene's text")?.to_owned();
    let broken_line = text.lines().position(|l| l.starts_with("width")).context("a width line")? + 1;
    let broken = text.replacen("width = ", "width = \"wide\" # ", 1);
    let type_text = "const e = document.getElementById('source'); e.value = arguments[0]; e.dispatchEvent(new Event('input')); return true;";
    d.js(type_text, json!([broken]))?;
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
    let (_, g, _) = shown(d)?;
    d.js(SET, json!(["fieldset[data-name='floor'] input[data-param='diff']", "0.35"]))?;
    full_after(d, "a slider moved while the text is broken", g)?;
    let kept = d.js("return document.getElementById('source').value", json!([]))?;
    if kept != json!(broken) {
        bail!("a slider moved while the text was broken replaced the typing");
    }
    println!(
        "broken edit: line {broken_line} marked, `{}`, image kept; a slider still renders, the typing stays",
        error.as_str().unwrap_or("").lines().next().unwrap_or("")
    );
    open_and_wait(d, "the image after the fix", type_text, json!([text]))?;
    d.until("the fixed edit", "return document.getElementById('source-error').hidden || null")?;

    // 4. The downloads are the native files, byte for byte.
    let edited = d.js("return document.getElementById('source').value", json!([]))?;
    let edited = edited.as_str().context("the edited text")?.to_owned();
    let n = native("showcase.toml", &edited, &|_| Err("no file".into()))?;
    use base64::Engine as _;
    for (button, ext) in [("exr", ".exr"), ("png", ".png")] {
        d.js(
            "window.studio.lastDownload = null; document.querySelector('#thumbs figure[data-layer=\"diffuse\"]').click(); document.getElementById(arguments[0]).click(); return true;",
            json!([button]),
        )?;
        let got = d.until(
            "the download",
            &format!("const l = window.studio.lastDownload; return l && l.name.endsWith('{ext}') ? l : null"),
        )?;
        let bytes = base64::engine::general_purpose::STANDARD.decode(got["bytes"].as_str().unwrap_or(""))?;
        let diffuse = &n.layers.iter().find(|(name, _)| name == "diffuse").context("a diffuse layer")?.1;
        let want = match button {
            "exr" => lancer_cli::output::encode_exr(n.width, n.height, diffuse)?,
            _ => lancer_cli::output::encode_png(n.width, n.height, diffuse)?,
        };
        if bytes != want {
            bail!(
                "the downloaded {} ({} bytes) is not the native file ({} bytes)",
                got["name"],
                bytes.len(),
                want.len()
            );
        }
        println!("download: {} is the native file's {} bytes", got["name"].as_str().unwrap_or(""), want.len());
    }

    // 5. A dropped scene with its OBJ file.
    let obj = "v -1 0 0\nv 1 0 0\nv 0 1.5 0\nv 0 0.5 -1\nf 1 2 3\nf 1 4 2\nf 2 4 3\nf 3 4 1\n";
    let scene = "[camera]\nfrom = [0, 1, -4]\nto = [0, 0.5, 0]\n[image]\nwidth = 160\nheight = 120\n\
                 [[lights]]\nat = [3, 5, -4]\n[[objects]]\nshape = \"mesh\"\npath = \"meshes/tetra.obj\"\n\
                 material = { color = [0.9, 0.5, 0.2], ambi = 0.2, diff = 0.7 }\n";
    let n = native("mine.toml", scene, &|p: &str| {
        if p == "meshes/tetra.obj" { Ok(obj.as_bytes().to_vec()) } else { Err(format!("no {p}")) }
    })?;
    open_and_wait(
        d,
        "the dropped scene's image",
        "const dt = new DataTransfer(); dt.items.add(new File([arguments[0]], 'mine.toml')); dt.items.add(new File([arguments[1]], 'tetra.obj')); \
         document.dispatchEvent(new DragEvent('drop', { dataTransfer: dt, bubbles: true, cancelable: true })); return true;",
        json!([scene, obj]),
    )?;
    compare(d, "the dropped scene", &n)?;
    println!(
        "dropped mine.toml with tetra.obj (named meshes/tetra.obj): every layer bit-identical to the native render"
    );

    // 6. A share link opens the same scene: an edited shipped one, whose files it finds too.
    pick(d, "meshes.toml")?;
    let (_, g, _) = shown(d)?;
    let ok = d.js(SET, json!(["fieldset[data-material='0'] input[data-param='shine']", "0.9"]))?;
    if ok != json!(true) {
        bail!("a shine slider: {ok}");
    }
    full_after(d, "the edited scene", g)?;
    let beauty = hash("beauty")?;
    d.js("document.getElementById('share').click(); return true;", json!([]))?;
    let link = d.until("the share link", "return location.hash.startsWith('#scene=') ? location.href : null")?;
    let link = link.as_str().unwrap_or("").to_owned();
    d.call("POST", "/url", json!({ "url": "about:blank" }))?;
    d.call("POST", "/url", json!({ "url": link }))?;
    d.until(
        "the shared scene's image",
        "const f = window.studio && window.studio.frame(); return f && !f.coarse || null",
    )?;
    if hash("beauty")? != beauty {
        bail!("the share link ({} characters) shows another image", link.len());
    }
    println!("share link of an edited meshes.toml ({} characters): the same image", link.len());

    // 7. More workers than cores, and a scene picked while another renders: the same bits.
    d.call("POST", "/url", json!({ "url": format!("{base}?workers=5&scene=glass.toml") }))?;
    d.until(
        "glass.toml on 5 workers",
        "const f = window.studio && window.studio.frame(); return f && !f.coarse || null",
    )?;
    compare(d, "glass.toml on 5 workers", &native_of("glass.toml")?)?;
    d.js(
        "const s = document.getElementById('scenes'); s.value = 'bench/anchor.toml'; s.dispatchEvent(new Event('change')); return true;",
        json!([]),
    )?;
    std::thread::sleep(Duration::from_millis(150));
    pick(d, "mirrors.toml")?;
    compare(d, "mirrors.toml picked while the anchor rendered", &native_of("mirrors.toml")?)?;
    println!("5 workers, and a scene picked during another's render: every layer bit-identical");

    // 8. The module without SIMD (for a browser without it) gives the same bits too.
    d.call("POST", "/url", json!({ "url": format!("{base}?simd=0&scene=glass.toml") }))?;
    d.until(
        "glass.toml without SIMD",
        "const f = window.studio && window.studio.frame(); return f && !f.coarse || null",
    )?;
    let info = d.js("return window.studio.engineInfo()", json!([]))?;
    if info["simd"] != json!(false) {
        bail!("?simd=0 still runs the SIMD module: {info}");
    }
    compare(d, "glass.toml without SIMD", &native_of("glass.toml")?)?;
    println!("glass.toml with the module built without SIMD: every layer bit-identical to the native render");

    let refused = d.js("return window.studio.violations()", json!([]))?;
    if refused.as_array().is_some_and(|a| !a.is_empty()) {
        bail!("the page's content security policy refused: {refused}");
    }

    // 9. Screenshots for the README, with no sideways scroll.
    std::fs::create_dir_all(docs)?;
    for (w, h) in [(1024u32, 768u32), (1920, 1080)] {
        d.call("POST", "/window/rect", json!({ "width": w, "height": h }))?;
        d.call("POST", "/url", json!({ "url": base }))?;
        d.until(
            "the image for the screenshot",
            "const f = window.studio && window.studio.frame(); return f && !f.coarse || null",
        )?;
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
    Ok(())
}

/// What `cargo xtask bench` measures of the browser build: the anchor's full render at 1 and 2
/// workers, each render beside a native one on as many threads, and the latency of a slider
/// move at 640x360 on 2 workers (median ms to the coarse and to the full image, of `runs` moves).
pub struct WebTimes {
    /// One row per worker count (1, then 2).
    pub anchor: Vec<AnchorTimes>,
    /// Median slider-to-coarse and slider-to-full times, ms.
    pub latency: (f64, f64),
    /// Whether the SIMD module ran.
    pub simd: bool,
}

/// The anchor in the browser on `workers` workers against native renders on as many threads,
/// taken in pairs (a native render, then the browser's) so that a machine that speeds up or
/// slows down during the bench moves both sides of a pair alike.
pub struct AnchorTimes {
    pub workers: u32,
    /// Median browser render time, s.
    pub wasm: f64,
    /// Median native render time, s.
    pub native: f64,
    /// Median of the pairs' ratios (browser / native).
    pub ratio: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() { f64::NAN } else { v[v.len() / 2] }
}

/// Measures the browser build (see [`WebTimes`]): `native(threads)` renders the anchor natively
/// and gives its render time in seconds. An error says what is missing.
pub fn measure(runs: usize, native: &mut dyn FnMut(u32) -> Result<f64>) -> Result<WebTimes> {
    let web = root().join("target/web");
    if !web.join("index.html").is_file() {
        bail!("no browser build in target/web (run `cargo xtask web`)");
    }
    let chromedriver = which("chromedriver")
        .context("chromedriver is not installed (Debian: apt-get install chromium chromium-driver)")?;
    let port = serve_static(web)?;
    let (d, _driver) = crate::webdriver::start(chromedriver, (1500, 1000))?;
    let result = (|| {
        let mut anchor = Vec::new();
        let mut simd = false;
        for workers in [1u32, 2] {
            let url = format!("http://127.0.0.1:{port}/?workers={workers}&scene=bench/anchor.toml");
            d.call("POST", "/url", json!({ "url": url }))?;
            d.until_within(
                "the anchor",
                "const f = window.studio && window.studio.frame(); return f && !f.coarse && f.width === 1280 || null",
                Duration::from_secs(120),
            )?;
            simd = d.js("return window.studio.engineInfo().simd", json!([]))? == json!(true);
            // One render of each first, not counted: the browser compiles the module's hot code
            // in tiers, and the native side's files come into the page cache.
            let (mut wasm, mut own) = (Vec::new(), Vec::new());
            for k in 0..=runs.max(1) {
                let n = native(workers)?;
                d.js("return window.studio.bench(1)", json!([]))?;
                let times =
                    d.until_within("the anchor's render", "return window.studio.benchTimes", Duration::from_secs(120))?;
                let t = times
                    .as_array()
                    .and_then(|a| a.first())
                    .and_then(Value::as_f64)
                    .with_context(|| format!("the page gave no render time ({times})"))?
                    / 1000.0;
                if k > 0 {
                    wasm.push(t);
                    own.push(n);
                }
            }
            let ratio = median(wasm.iter().zip(&own).map(|(w, n)| w / n).collect());
            anchor.push(AnchorTimes { workers, wasm: median(wasm), native: median(own), ratio });
        }
        d.call("POST", "/url", json!({ "url": format!("http://127.0.0.1:{port}/?workers=2&scene=showcase.toml") }))?;
        d.until("the showcase", "const f = window.studio && window.studio.frame(); return f && !f.coarse || null")?;
        let (mut coarse, mut full) = (Vec::new(), Vec::new());
        for k in 0..runs.max(3) {
            let before = generation(&d)?;
            d.js(
                SET,
                json!([
                    "fieldset[data-name='floor'] input[data-param='diff']",
                    format!("{:.3}", 0.3 + 0.05 * k as f64)
                ]),
            )?;
            full_after(&d, "the image after a slider move", before)?;
            let t = d.js(crate::webdriver::SINCE_EDIT, json!([]))?;
            coarse.push(t[0].as_f64().unwrap_or(f64::NAN));
            full.push(t[1].as_f64().unwrap_or(f64::NAN));
        }
        Ok(WebTimes { anchor, latency: (median(coarse), median(full)), simd })
    })();
    let _ = d.call("DELETE", "", json!({}));
    result
}

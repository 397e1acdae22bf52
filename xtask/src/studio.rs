//! `cargo xtask studio-check`: `lancer serve` driven in Debian's Chromium through WebDriver
//! (chromedriver, spoken to over plain HTTP with `ureq`: a dozen W3C WebDriver calls to a local
//! driver need no TLS stack, which the WebDriver client crates bring). It moves sliders and
//! switches as a student would, checks what each image does, times the updates and saves a
//! screenshot for the README.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use serde_json::{Value, json};

use crate::webdriver::{Driver, Killed, SET};
use crate::{build_renderer, root, which};

/// The generation of the newest full frame, once it is newer than `after`.
const FULL_AFTER: &str = "const f = window.studio && window.studio.frame(); return f && !f.coarse && f.generation > arguments[0] ? f.generation : null;";

pub fn check(args: &[String]) -> Result<()> {
    let mut screenshot = root().join("docs/studio.png");
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--screenshot" => screenshot = PathBuf::from(it.next().context("--screenshot needs a file")?),
            other => bail!("unknown option `{other}` (cargo xtask studio-check [--screenshot FILE])"),
        }
    }
    let lancer = build_renderer()?;
    let chromedriver = which("chromedriver").context(
        "chromedriver is not installed (Debian: apt-get install chromium chromium-driver, the same version)",
    )?;
    let work = std::env::temp_dir().join(format!("lancer-studio-check-{}", std::process::id()));
    std::fs::create_dir_all(&work)?;
    let scene = work.join("showcase.toml");
    let original = std::fs::read_to_string(root().join("scenes/showcase.toml"))?;
    std::fs::write(&scene, &original)?;

    let mut serve = Killed(
        Command::new(&lancer)
            .args(["serve", "--no-open", "--port", "0"])
            .arg(&scene)
            .stdout(Stdio::piped())
            .spawn()
            .context("starting lancer serve")?,
    );
    let mut line = String::new();
    BufReader::new(serve.0.stdout.take().context("serve's output")?).read_line(&mut line)?;
    let url =
        line.trim().strip_prefix("Lancer studio: ").with_context(|| format!("serve printed `{line}`"))?.to_owned();
    println!("serve: {url}");

    let (d, _driver) = crate::webdriver::start(chromedriver, (1500, 1000))?;
    let result = run(&d, &url, &scene, &original, &screenshot);
    let _ = d.call("DELETE", "", json!({}));
    let _ = std::fs::remove_dir_all(&work);
    result
}

fn run(d: &Driver, url: &str, scene: &Path, original: &str, screenshot: &Path) -> Result<()> {
    d.call("POST", "/url", json!({ "url": url }))?;
    let mut generation =
        d.until("the first full image", &FULL_AFTER.replace("arguments[0]", "0"))?.as_i64().unwrap_or(0);
    // The page shows each image's 8-bit levels from a table: the same levels as the formula's.
    let levels = d.js("return window.studio.checkLevels()", json!([]))?;
    if levels["wrong"].as_array().is_none_or(|w| !w.is_empty()) || levels["checked"].as_u64().unwrap_or(0) < 1_000_000 {
        bail!("the page's display levels differ from the sRGB formula's: {levels}");
    }
    println!("display levels: the table's equal the formula's at {} values", levels["checked"]);
    let hash = |name: &str| d.js("return window.studio.hash(arguments[0])", json!([name]));
    let hashes = |names: &[&str]| -> Result<Vec<Value>> { names.iter().map(|n| hash(n)).collect() };
    let mut edit = |what: &str, selector: &str, value: Value| -> Result<(f64, f64, f64, f64)> {
        let ok = d.js(SET, json!([selector, value]))?;
        if ok != json!(true) {
            bail!("{what}: {ok}");
        }
        generation = d.until(what, &FULL_AFTER.replace("arguments[0]", &generation.to_string()))?.as_i64().unwrap_or(0);
        // Time from the edit to the first coarse and to the full frame of a newer generation.
        let t = d.js(crate::webdriver::SINCE_EDIT, json!([]))?;
        let render = d.js("return window.studio.frame().seconds", json!([]))?.as_f64().unwrap_or(f64::NAN);
        let ms = |k: usize| t[k].as_f64().unwrap_or(-1.0);
        Ok((ms(0), ms(1), ms(2), render * 1000.0))
    };

    // 1. A material's diff: the diffuse image changes, the ambient one not at all.
    let before = hashes(&["ambient", "diffuse"])?;
    let (coarse, full, received, render) = edit(
        "the image after moving floor's diff",
        "fieldset[data-name='floor'] input[data-param='diff']",
        json!("0.3"),
    )?;
    let after = hashes(&["ambient", "diffuse"])?;
    if before[0] != after[0] || before[1] == after[1] {
        bail!(
            "moving diff: ambient {:?} -> {:?} (must not change), diffuse {:?} -> {:?} (must change)",
            before[0],
            after[0],
            before[1],
            after[1]
        );
    }
    println!(
        "diff slider: diffuse image changed, ambient bit-identical; coarse image drawn after {coarse:.0} ms, full drawn after {full:.0} ms \
         (received after {received:.0} ms; its render on the server {render:.0} ms)"
    );

    // 2. Switching a term off takes its image out of the sum.
    let beauty = hash("beauty")?;
    edit("the image without specular", "input[type=checkbox][data-term='specular']", json!(false))?;
    let layers = d.js("return window.studio.frame().layers", json!([]))?;
    if layers.as_array().is_some_and(|l| l.iter().any(|n| n == "specular")) || hash("beauty")? == beauty {
        bail!("specular switched off: layers {layers}, beauty unchanged: {}", hash("beauty")? == beauty);
    }
    edit("the image with specular again", "input[type=checkbox][data-term='specular']", json!(true))?;
    println!("specular off: its image is gone and the beauty image changed; on again");

    // 3. Phong -> Blinn: the specular image changes; ambient, diffuse and background do not.
    let before = hashes(&["ambient", "diffuse", "background", "specular"])?;
    edit("the image with Blinn", "select[data-term='specular']", json!("blinn"))?;
    let after = hashes(&["ambient", "diffuse", "background", "specular"])?;
    if before[..3] != after[..3] || before[3] == after[3] {
        bail!("blinn: {before:?} -> {after:?}");
    }
    println!("specular:blinn: only the specular image changed (ambient, diffuse, background bit-identical)");

    // 4. A pixel click: the tree's totals are the pixel's values.
    let (x, y) = (200, 250);
    d.js(
        "const c = document.getElementById('main'), r = c.getBoundingClientRect(); \
         c.dispatchEvent(new MouseEvent('click', { clientX: r.left + (arguments[0] + 0.5) * r.width / c.width, clientY: r.top + (arguments[1] + 0.5) * r.height / c.height, bubbles: true })); return true;",
        json!([x, y]),
    )?;
    let doc = d.until("the pixel inspector", "return document.getElementById('inspector').dataset.json || null")?;
    let doc: Value = serde_json::from_str(doc.as_str().unwrap_or("null"))?;
    let names: Vec<String> = doc["terms"].as_object().context("terms in the explanation")?.keys().cloned().collect();
    for name in &names {
        let here = d.js("return window.studio.pixel(arguments[0], arguments[1], arguments[2])", json!([name, x, y]))?;
        let want: Vec<f32> =
            here.as_array().into_iter().flatten().filter_map(|v| v.as_f64()).map(|v| v as f32).collect();
        let got: Vec<f32> =
            doc["terms"][name].as_array().into_iter().flatten().filter_map(|v| v.as_f64()).map(|v| v as f32).collect();
        if want != got {
            bail!("pixel {x},{y}: the inspector says {name} = {got:?}, the image holds {want:?}");
        }
    }
    println!("pixel {x},{y}: the inspector's totals equal the image's values for {}", names.join(", "));

    // 5. The images the page put together from the stretches each full frame sent (what changed
    // since the last) are the bits a page that connects now is sent whole.
    let frame = d.js("return window.studio.frame()", json!([]))?;
    let mut names: Vec<String> = vec!["beauty".into()];
    names.extend(frame["layers"].as_array().into_iter().flatten().filter_map(|n| n.as_str().map(String::from)));
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let patched = hashes(&names)?;
    let lost = d.js("return window.studio.lost || 0", json!([]))?;
    if lost != json!(0) {
        bail!("the page could not put {lost} frames together");
    }
    d.call("POST", "/url", json!({ "url": url }))?;
    let again = d.until("the first full image after a reload", &FULL_AFTER.replace("arguments[0]", "0"))?;
    if again != frame["generation"] {
        bail!("after a reload the page shows frame {again}, not the newest full frame {}", frame["generation"]);
    }
    let whole = hashes(&names)?;
    if whole != patched {
        bail!(
            "the images put together from changed stretches ({patched:?}) are not the ones sent whole ({whole:?}) for {names:?}"
        );
    }
    println!("{} images put together from the stretches sent: the bits a new page is sent whole", names.len());

    // 6. A broken save: the error shows, the image stays.
    let beauty = hash("beauty")?;
    std::fs::write(scene, "[camera]\nfrom = [0, 0]\n")?;
    let error = d.until("the error of a broken save", "const e = document.getElementById('error'); return !e.hidden && e.textContent.includes('showcase.toml:2:') ? e.textContent : null")?;
    if hash("beauty")? != beauty {
        bail!("a broken save replaced the image");
    }
    println!(
        "broken save: the page shows `{}` and keeps the image",
        error.as_str().unwrap_or("").lines().next().unwrap_or("")
    );
    std::fs::write(scene, original)?;
    d.until("the reload after the fix", "return document.getElementById('error').hidden || null")?;

    d.js("document.querySelector('#thumbs figure[data-layer=\"beauty\"]').click(); return true;", json!([]))?;
    std::thread::sleep(Duration::from_millis(300));
    let png = d.call("GET", "/screenshot", json!({}))?;
    use base64::Engine as _;
    let bytes = base64::engine::general_purpose::STANDARD.decode(png.as_str().context("a screenshot")?)?;
    if let Some(dir) = screenshot.parent() {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(screenshot, bytes)?;
    println!("studio-check: all checks passed; screenshot {}", screenshot.display());
    Ok(())
}

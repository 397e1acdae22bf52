//! A WebDriver client for the browser checks (`studio-check`, `web-check`): chromedriver spoken
//! to over plain HTTP with `ureq` (a dozen W3C WebDriver calls to a local driver need no TLS
//! stack, which the WebDriver client crates bring), and headless Chromium.

use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use serde_json::{Value, json};

/// A child process killed when dropped.
pub struct Killed(pub Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

pub struct Driver {
    base: String,
    session: String,
}

impl Driver {
    pub fn call(&self, method: &str, path: &str, body: Value) -> Result<Value> {
        let url = format!("{}/session/{}{path}", self.base, self.session);
        // An error status carries the driver's message (a script's exception): read it too.
        let response = match method {
            "GET" => ureq::get(&url).config().http_status_as_error(false).build().call(),
            "DELETE" => ureq::delete(&url).config().http_status_as_error(false).build().call(),
            _ => ureq::post(&url).config().http_status_as_error(false).build().send_json(body),
        };
        let mut response = response.with_context(|| format!("WebDriver {method} {path}"))?;
        let ok = response.status().is_success();
        let v: Value = response.body_mut().read_json().context("a WebDriver answer")?;
        if !ok {
            bail!("WebDriver {method} {path}: {}", v["value"]["message"].as_str().unwrap_or(&v.to_string()));
        }
        Ok(v["value"].clone())
    }

    /// Runs `script` (a function body; `arguments` are `args`) in the page.
    pub fn js(&self, script: &str, args: Value) -> Result<Value> {
        self.call("POST", "/execute/sync", json!({ "script": script, "args": args }))
    }

    /// Waits (up to 20 s) until `script` returns something truthy, and returns it.
    pub fn until(&self, what: &str, script: &str) -> Result<Value> {
        self.until_within(what, script, Duration::from_secs(20))
    }

    /// [`Driver::until`] with a time limit of its own.
    pub fn until_within(&self, what: &str, script: &str, limit: Duration) -> Result<Value> {
        let start = Instant::now();
        loop {
            let v = self.js(script, json!([]))?;
            if !(v.is_null() || v == json!(false)) {
                return Ok(v);
            }
            if start.elapsed() > limit {
                let error = self.js(
                    "const e = document.getElementById('error'); return e && !e.hidden ? e.textContent : 'none shown'",
                    json!([]),
                )?;
                bail!("waited {} s for {what} (page error: {error})", limit.as_secs());
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

pub fn free_port() -> Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
}

/// Changes the input matching `arguments[0]` to `arguments[1]` as a user would (an input
/// event), noting when in `window.studio.editAt`: the studio page's edits, in both checks.
pub const SET: &str = "const e = document.querySelector(arguments[0]); if (!e) return 'no ' + arguments[0]; \
    if (e.type === 'checkbox') e.checked = arguments[1]; else e.value = arguments[1]; \
    window.studio.editAt = performance.now(); e.dispatchEvent(new Event('input')); return true;";

/// The milliseconds from the last edit ([`SET`]) to the first coarse and the first full image of a
/// newer frame drawn on the page (on the canvas, not only received), and to that full image's
/// arrival (put together from its messages, before it is drawn); -1 for one not drawn yet.
pub const SINCE_EDIT: &str = "const s = window.studio, a = s.arrivals.filter((x) => x.at >= s.editAt && x.drawn !== null); \
    const c = a.find((x) => x.coarse), f = a.find((x) => !x.coarse); \
    return [c ? c.drawn - s.editAt : -1, f ? f.drawn - s.editAt : -1, f ? f.at - s.editAt : -1];";

/// Starts chromedriver and a headless Chromium session whose window is `size`; the driver is
/// stopped when the second value is dropped (after the session is deleted).
pub fn start(chromedriver: PathBuf, size: (u32, u32)) -> Result<(Driver, Killed)> {
    start_with(chromedriver, size, &[])
}

/// [`start`] with more Chromium switches.
pub fn start_with(chromedriver: PathBuf, size: (u32, u32), more: &[&str]) -> Result<(Driver, Killed)> {
    let port = free_port()?;
    let driver = Killed(
        Command::new(chromedriver)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .context("starting chromedriver")?,
    );
    let base = format!("http://127.0.0.1:{port}");
    let start = Instant::now();
    let mut args: Vec<String> = ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    args.push(format!("--window-size={},{}", size.0, size.1));
    args.extend(more.iter().map(|s| s.to_string()));
    let session = loop {
        let caps = json!({ "capabilities": { "alwaysMatch": { "goog:chromeOptions": { "args": args } } } });
        match ureq::post(&format!("{base}/session")).send_json(&caps) {
            Ok(mut r) => {
                let v: Value = r.body_mut().read_json()?;
                break v["value"]["sessionId"].as_str().context("a WebDriver session")?.to_owned();
            }
            Err(_) if start.elapsed() < Duration::from_secs(10) => std::thread::sleep(Duration::from_millis(100)),
            Err(e) => bail!("chromedriver did not start a session: {e}"),
        }
    };
    Ok((Driver { base, session }, driver))
}

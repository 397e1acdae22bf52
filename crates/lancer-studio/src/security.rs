//! The studio's routes and what guards them: a Host allow-list (against DNS rebinding), a
//! per-run token exchanged for a `SameSite=Strict` cookie, the Origin of WebSocket upgrades,
//! small body and message limits, a content security policy. No route reads a path a client
//! gives. The Host allow-list holds localhost, the addresses `lancer serve` printed and the names
//! given with `--allow-host` ([`allowed_host`] checks them).

use std::net::IpAddr;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use anyhow::{Context, Result};
use axum::Router;
use axum::body::Body;
use axum::extract::ws::{CloseFrame, Message, WebSocket, WebSocketUpgrade};
use axum::extract::{DefaultBodyLimit, Query, Request, State as Axum};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use serde::Deserialize;

use crate::server::Timeouts;
use crate::worker::{EVERY_PAGE, Sent, Shared, lock};

const INDEX: &str = crate::PAGE[0].1;
const SCRIPT: &str = crate::PAGE[1].1;
const STYLE: &str = crate::PAGE[2].1;

/// The most a request body or a WebSocket message may hold: an edit is a few kilobytes.
const LIMIT: usize = 256 * 1024;

/// The cookie's name, with the port: two studios on one machine keep their own.
fn cookie_name(port: u16) -> String {
    format!("lancer_token_{port}")
}

/// Equal, in a time that does not depend on where they differ.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// 128 random bits, in hex.
pub(crate) fn new_token() -> Result<String> {
    let mut bytes = [0u8; 16];
    getrandom::fill(&mut bytes).map_err(|e| anyhow::anyhow!("{e}")).context("drawing the studio's token")?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

#[derive(Clone)]
struct Guard {
    shared: Arc<Shared>,
    token: String,
    cookie: String,
    /// Host header values the server answers to.
    hosts: Vec<String>,
    /// Origins a WebSocket may come from.
    origins: Vec<String>,
    timeouts: Timeouts,
}

/// An address as a Host header (and a URL) carries it: IPv6 in brackets.
pub(crate) fn host_of(address: IpAddr) -> String {
    match address {
        IpAddr::V4(a) => a.to_string(),
        IpAddr::V6(a) => format!("[{a}]"),
    }
}

/// An `--allow-host` name as the Host header carries it, without the port: a DNS name (labels of
/// letters, digits and `-`, joined by dots; lowercased) or an IP address (IPv6 in brackets, given
/// with or without them). Anything else, a port, a path, a scheme, spaces, is refused with what
/// is wrong.
pub fn allowed_host(text: &str) -> Result<String, String> {
    let bare = text.strip_prefix('[').and_then(|t| t.strip_suffix(']')).unwrap_or(text);
    if let Ok(address) = bare.parse::<IpAddr>() {
        return Ok(host_of(address));
    }
    let like = "a name like lab-pc.local or an address like 192.168.1.20";
    if text.is_empty() {
        return Err(format!("an empty name: give {like}"));
    }
    if text.chars().any(char::is_whitespace) {
        return Err(format!("`{text}` holds a space: give one name ({like}); repeat --allow-host for more"));
    }
    if text.contains('/') || text.contains('?') || text.contains('#') {
        return Err(format!("`{text}` holds a scheme or a path: give the name alone ({like})"));
    }
    if text.contains(':') {
        return Err(format!("`{text}` holds a port: give the name alone (the studio's --port is added to it)"));
    }
    if text.len() > 253 {
        return Err(format!("`{text}` is longer than a host name may be (253 characters)"));
    }
    for label in text.split('.') {
        if label.is_empty() {
            return Err(format!("`{text}`: an empty part between dots (or a dot at an end)"));
        }
        if let Some(c) = label.chars().find(|c| !c.is_ascii_alphanumeric() && *c != '-') {
            return Err(format!(
                "`{text}`: `{c}` cannot be in a host name (letters, digits, `-` and dots; give an international name in its xn-- form)"
            ));
        }
        if label.len() > 63 {
            return Err(format!("`{text}`: `{label}` is longer than a part of a host name may be (63 characters)"));
        }
        if label.starts_with('-') || label.ends_with('-') {
            return Err(format!("`{text}`: `{label}` starts or ends with `-`"));
        }
    }
    if text.rsplit('.').next().is_some_and(|last| last.bytes().all(|b| b.is_ascii_digit())) {
        return Err(format!("`{text}` is not an IP address (four numbers of 0 to 255) nor a host name"));
    }
    Ok(text.to_ascii_lowercase())
}

/// The routes, answering to a Host of localhost, 127.0.0.1 or [::1], or one of `names` (addresses
/// and `--allow-host` names as [`host_of`] and [`allowed_host`] write them), each with `port`.
pub(crate) fn router(shared: Arc<Shared>, token: String, names: &[String], port: u16, timeouts: Timeouts) -> Router {
    let mut hosts = vec![format!("localhost:{port}"), format!("127.0.0.1:{port}"), format!("[::1]:{port}")];
    for name in names {
        let host = format!("{name}:{port}");
        if !hosts.contains(&host) {
            hosts.push(host);
        }
    }
    let origins = hosts.iter().map(|h| format!("http://{h}")).collect();
    let guard = Guard { shared, token, cookie: cookie_name(port), hosts, origins, timeouts };
    Router::new()
        .route("/", get(index))
        .route("/app.js", get(|| async { asset(SCRIPT, "text/javascript; charset=utf-8") }))
        .route("/app.css", get(|| async { asset(STYLE, "text/css; charset=utf-8") }))
        .route("/ws", get(socket))
        .route("/api/explain", get(explain).post(explain))
        .route("/api/scene.toml", get(download).post(download))
        .route("/api/save", axum::routing::post(save))
        .route("/api/encode", axum::routing::post(encode).layer(DefaultBodyLimit::max(ENCODE_LIMIT)))
        .layer(middleware::from_fn_with_state(guard.clone(), check))
        .layer(DefaultBodyLimit::max(LIMIT))
        .with_state(guard)
}

fn asset(text: &'static str, kind: &'static str) -> Response {
    ([(header::CONTENT_TYPE, kind), (header::CACHE_CONTROL, "no-store")], text).into_response()
}

/// Whether a cookie named `name` holds `token`, across every Cookie header and every pair in
/// each: `None` when no cookie has that name. Any one that matches is enough: cookies are not
/// kept apart by port, so a page on another port of this machine can set one of the same name,
/// which must not lock the user out. Read as bytes: one cookie that is not ASCII must not hide
/// the others sent in the same header.
fn cookie_holds(headers: &HeaderMap, name: &str, token: &str) -> Option<bool> {
    let mut found = None;
    for pair in headers.get_all(header::COOKIE).iter().flat_map(|v| v.as_bytes().split(|&b| b == b';')) {
        let Some(at) = pair.iter().position(|&b| b == b'=') else { continue };
        let (key, value) = (pair[..at].trim_ascii(), pair[at + 1..].trim_ascii());
        if key == name.as_bytes() {
            let matches = same(value, token.as_bytes());
            found = Some(matches || found == Some(true));
        }
    }
    found
}

/// Every request: a known Host, then the token (the cookie, or on `/` the launch URL's query,
/// which sets the cookie).
async fn check(Axum(g): Axum<Guard>, request: Request, next: Next) -> Response {
    let host = request.headers().get(header::HOST).and_then(|h| h.to_str().ok()).unwrap_or("");
    if !g.hosts.iter().any(|h| h.eq_ignore_ascii_case(host)) {
        return (
            StatusCode::FORBIDDEN,
            "unknown Host: the studio answers to the addresses lancer serve printed (name another with --allow-host)",
        )
            .into_response();
    }
    let from_query =
        request.uri().query().and_then(|q| q.split('&').find_map(|kv| kv.strip_prefix("token=")).map(str::to_owned));
    if request.uri().path() == "/" && from_query.as_deref().is_some_and(|t| same(t.as_bytes(), g.token.as_bytes())) {
        // Exchange the URL's token for a cookie, and drop it from the address bar.
        let cookie = format!("{}={}; HttpOnly; SameSite=Strict; Path=/", g.cookie, g.token);
        return Response::builder()
            .status(StatusCode::SEE_OTHER)
            .header(header::LOCATION, "/")
            .header(header::SET_COOKIE, cookie)
            .body(Body::empty())
            .expect("a redirect");
    }
    match cookie_holds(request.headers(), &g.cookie, &g.token) {
        Some(true) => {}
        Some(false) => return (StatusCode::FORBIDDEN, "wrong token").into_response(),
        None => {
            return (StatusCode::UNAUTHORIZED, "open the address `lancer serve` printed (it holds the token)")
                .into_response();
        }
    }
    let mut response = next.run(request).await;
    response.headers_mut().insert(header::CONTENT_SECURITY_POLICY, HeaderValue::from_static("default-src 'self'"));
    response.headers_mut().insert(header::X_CONTENT_TYPE_OPTIONS, HeaderValue::from_static("nosniff"));
    response.headers_mut().insert("x-frame-options", HeaderValue::from_static("DENY"));
    response
}

async fn index() -> Response {
    asset(INDEX, "text/html; charset=utf-8")
}

async fn socket(Axum(g): Axum<Guard>, headers: HeaderMap, ws: WebSocketUpgrade) -> Response {
    let origin = headers.get(header::ORIGIN).and_then(|o| o.to_str().ok()).unwrap_or("");
    if !g.origins.iter().any(|o| o.eq_ignore_ascii_case(origin)) {
        return (StatusCode::FORBIDDEN, "WebSocket from another origin").into_response();
    }
    ws.max_message_size(LIMIT).max_frame_size(LIMIT).on_upgrade(move |s| session(g.shared, s, g.timeouts))
}

/// Sends a frame's messages (its images the page has not been sent yet); `false` once the page
/// is gone.
async fn send_frame(ws: &mut WebSocket, sent: &mut Sent, frame: Option<crate::worker::SharedFrame>) -> bool {
    let Some(frame) = frame else { return true };
    // Comparing with the last frame and copying the floats out takes milliseconds a page: done
    // on tokio's blocking threads, not on the ones that serve every connection.
    let (page, f) = (sent.clone(), frame.clone());
    let Ok(messages) = tokio::task::spawn_blocking(move || page.messages(&f)).await else { return false };
    for m in messages {
        if ws.send(Message::Binary(m.into())).await.is_err() {
            return false;
        }
    }
    sent.sent(frame);
    true
}

/// One page's connection: the hello, then frames and events out, edits in, and a ping every
/// `timeouts.ping`; in a read-only studio the page's edits render for it alone. A page that is
/// heard from not at all (no edit, no pong) for `timeouts.idle` is gone (a closed laptop, a dead
/// network): its connection is closed, even when a send to it is stuck.
async fn session(shared: Arc<Shared>, mut ws: WebSocket, timeouts: Timeouts) {
    let start = tokio::time::Instant::now();
    // When the page was last heard from, in milliseconds since `start`.
    let heard = AtomicU64::new(0);
    let watchdog = async {
        loop {
            let deadline = start + Duration::from_millis(heard.load(Ordering::Relaxed)) + timeouts.idle;
            if tokio::time::Instant::now() >= deadline {
                return;
            }
            tokio::time::sleep_until(deadline).await;
        }
    };
    let idle = tokio::select! {
        () = talk(&shared, &mut ws, &heard, start, timeouts.ping) => false,
        () = watchdog => true,
    };
    if idle {
        // Best effort: the page may be gone for good.
        let close = Message::Close(Some(CloseFrame { code: 1001, reason: "nothing heard from the page".into() }));
        let _ = tokio::time::timeout(Duration::from_secs(1), ws.send(close)).await;
    }
}

async fn talk(
    shared: &Arc<Shared>,
    ws: &mut WebSocket,
    heard: &AtomicU64,
    start: tokio::time::Instant,
    ping: Duration,
) {
    let mut frames = shared.frames.subscribe();
    let mut events = shared.events.subscribe();
    // A read-only studio's page is a tab of its own: its edits, their frames and events.
    let (tab, mut own_events) = match shared.read_only {
        true => {
            let (tab, events) = shared.join();
            (Some(tab), Some(events))
        }
        false => (None, None),
    };
    if ws.send(Message::Text(shared.hello().into())).await.is_err() {
        return;
    }
    // What this page has been sent: the images of a newer frame that it already has are not sent again.
    let mut sent = Sent::default();
    let latest = frames.borrow_and_update().clone();
    if !send_frame(ws, &mut sent, latest).await {
        return;
    }
    let mut pings = tokio::time::interval_at(start + ping, ping);
    pings.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tokio::select! {
            incoming = ws.recv() => {
                let Some(Ok(message)) = incoming else { return };
                // Anything, a pong included, shows the page is there.
                let now = u64::try_from(start.elapsed().as_millis()).unwrap_or(u64::MAX);
                heard.store(now, Ordering::Relaxed);
                if let Message::Text(text) = message {
                    let error = match serde_json::from_str::<crate::State>(&text) {
                        Ok(state) => match &tab {
                            Some(t) => match shared.ask(t.id, state) {
                                Ok(queued) => {
                                    if queued {
                                        t.tab.own.store(true, Ordering::SeqCst);
                                    }
                                    None
                                }
                                // Only this page's edit: only this page is told.
                                Err(e) => Some(e),
                            },
                            None => {
                                if let Err(e) = shared.ask(EVERY_PAGE, state) {
                                    let m = serde_json::json!({"type": "error", "message": e});
                                    let _ = shared.events.send(m.to_string());
                                }
                                None
                            }
                        },
                        Err(e) => Some(format!("an edit the studio cannot read: {e}")),
                    };
                    if let Some(e) = error {
                        let m = serde_json::json!({"type": "error", "message": e});
                        if ws.send(Message::Text(m.to_string().into())).await.is_err() {
                            return;
                        }
                    }
                }
            }
            _ = pings.tick() => {
                if ws.send(Message::Ping(Default::default())).await.is_err() {
                    return;
                }
            }
            changed = frames.changed() => {
                if changed.is_err() {
                    return;
                }
                // Only the newest frame: a slow page skips the ones it could not take.
                let frame = frames.borrow_and_update().clone();
                // A tab showing its own edits is not shown the file's state.
                let own = tab.as_ref().is_some_and(|t| t.tab.own.load(Ordering::SeqCst));
                if !own && !send_frame(ws, &mut sent, frame).await {
                    return;
                }
            }
            () = async {
                match &tab {
                    Some(t) => t.tab.ready.notified().await,
                    None => std::future::pending().await,
                }
            } => {
                let frame = tab.as_ref().and_then(|t| t.tab.take());
                if frame.is_some() && !send_frame(ws, &mut sent, frame).await {
                    return;
                }
            }
            Some(text) = async {
                match &mut own_events {
                    Some(events) => events.recv().await,
                    None => std::future::pending().await,
                }
            } => {
                if ws.send(Message::Text(text.into())).await.is_err() {
                    return;
                }
            }
            event = events.recv() => {
                match event {
                    Ok(text) => if ws.send(Message::Text(text.into())).await.is_err() { return },
                    Err(tokio::sync::broadcast::error::RecvError::Lagged(_)) => {}
                    Err(_) => return,
                }
            }
        }
    }
}

#[derive(Deserialize)]
struct Pixel {
    x: u32,
    y: u32,
}

/// The state a request is about: the one its body holds (a read-only studio's page sends its
/// own), else the state every page shares (in a read-only studio, the file's).
fn state_of(shared: &Shared, body: &str) -> Result<crate::State, (StatusCode, String)> {
    if body.trim().is_empty() {
        return Ok(lock(&shared.current).clone());
    }
    let state: crate::State = serde_json::from_str(body)
        .map_err(|e| (StatusCode::BAD_REQUEST, format!("a state the studio cannot read: {e}")))?;
    if state.epoch != lock(&shared.slot).epoch {
        return Err((StatusCode::CONFLICT, "the scene was reloaded since: the page has been sent the new one".into()));
    }
    Ok(state)
}

/// The explanation of a pixel of the full image with the state posted (the page's own), or with
/// the current state.
async fn explain(Axum(g): Axum<Guard>, Query(p): Query<Pixel>, body: String) -> Response {
    let shared = g.shared.clone();
    let state = match state_of(&shared, &body) {
        Ok(s) => s,
        Err(e) => return e.into_response(),
    };
    let result = tokio::task::spawn_blocking(move || -> Result<String, String> {
        let (mut prepared, camera, image, name, objects, materials) = {
            let slot = lock(&shared.slot);
            let materials: Vec<String> = slot.loaded.materials.iter().map(|m| m.label.clone()).collect();
            (slot.prepared.clone(), slot.camera, slot.image, slot.name.clone(), slot.objects.clone(), materials)
        };
        if p.x >= image.width || p.y >= image.height {
            return Err(format!("pixel {},{} is outside the {}x{} image", p.x, p.y, image.width, image.height));
        }
        let pipeline = state.apply(&mut prepared, &shared.registry)?;
        // The full image's settings, as the render shown (the scene's adaptive sampling kept
        // while the samples are the scene's).
        let image = crate::state::image_for(&image, &state, false);
        let e = lancer_shading::explain_pixel(&prepared, &camera, &image, &pipeline, p.x, p.y);
        let report = lancer_output::Report {
            scene: &name,
            image: &image,
            pipeline: &pipeline,
            explanation: &e,
            objects: &objects,
            materials: &materials,
        };
        Ok(report.json())
    })
    .await;
    match result {
        Ok(Ok(json)) => ([(header::CONTENT_TYPE, "application/json")], json).into_response(),
        Ok(Err(e)) => (StatusCode::BAD_REQUEST, e).into_response(),
        Err(_) => (StatusCode::INTERNAL_SERVER_ERROR, "the explanation failed").into_response(),
    }
}

/// The scene file's text with the edits of the state posted (the page's own), or of the current
/// state, for the browser to download.
async fn download(Axum(g): Axum<Guard>, body: String) -> Response {
    let state = match state_of(&g.shared, &body) {
        Ok(s) => s,
        Err(e) => return e.into_response(),
    };
    let (text, name) = {
        let slot = lock(&g.shared.slot);
        let name = slot
            .path
            .as_ref()
            .and_then(|p| p.file_name())
            .map_or("scene.toml".into(), |n| n.to_string_lossy().into_owned());
        (crate::save::edited(&slot.source, &state, &slot.loaded), name)
    };
    match text {
        Ok(t) => (
            [
                (header::CONTENT_TYPE, "application/toml; charset=utf-8".to_owned()),
                (header::CONTENT_DISPOSITION, format!("attachment; filename=\"{}\"", name.replace('"', ""))),
            ],
            t,
        )
            .into_response(),
        Err(e) => (StatusCode::CONFLICT, e).into_response(),
    }
}

/// The most an image to encode may hold: 4096 x 4096 RGB floats.
const ENCODE_LIMIT: usize = 4096 * 4096 * 12;

#[derive(Deserialize)]
struct EncodeQuery {
    format: String,
    width: u32,
    height: u32,
}

/// A linear image the page holds (its body: little-endian RGB floats) as the bytes of a PNG or
/// EXR file, the bytes `lancer render` writes for the same pixels: the page's downloads.
async fn encode(Query(q): Query<EncodeQuery>, body: axum::body::Bytes) -> Response {
    let pixels = q.width as usize * q.height as usize;
    if body.len() != pixels * 12 {
        let message = format!("{} bytes are not {}x{} RGB floats", body.len(), q.width, q.height);
        return (StatusCode::BAD_REQUEST, message).into_response();
    }
    let floats: Vec<glam::Vec3> = body
        .chunks_exact(12)
        .map(|p| {
            let f = |k: usize| f32::from_le_bytes([p[k], p[k + 1], p[k + 2], p[k + 3]]);
            glam::Vec3::new(f(0), f(4), f(8))
        })
        .collect();
    let (bytes, kind) = match q.format.as_str() {
        "png" => (lancer_output::encode_png(q.width, q.height, &floats), "image/png"),
        "exr" => (lancer_output::encode_exr(q.width, q.height, &floats), "image/x-exr"),
        other => return (StatusCode::BAD_REQUEST, format!("no image format `{other}`: png or exr")).into_response(),
    };
    match bytes {
        Ok(b) => ([(header::CONTENT_TYPE, kind)], b).into_response(),
        Err(e) => (StatusCode::BAD_REQUEST, e.to_string()).into_response(),
    }
}

/// Writes the edits into the scene file, whole or not at all (`--allow-save` only).
async fn save(Axum(g): Axum<Guard>, headers: HeaderMap) -> Response {
    // A form or a fetch from another page (another port of this machine is the same site to
    // the cookie) carries another Origin.
    let origin = headers.get(header::ORIGIN).and_then(|o| o.to_str().ok()).unwrap_or("");
    if !g.origins.iter().any(|o| o.eq_ignore_ascii_case(origin)) {
        return (StatusCode::FORBIDDEN, "a save from another origin").into_response();
    }
    if g.shared.read_only {
        return (StatusCode::FORBIDDEN, READ_ONLY).into_response();
    }
    if !g.shared.allow_save {
        return (
            StatusCode::FORBIDDEN,
            "start lancer serve with --allow-save to write the scene file; Download works without",
        )
            .into_response();
    }
    let shared = g.shared.clone();
    let saved = tokio::task::spawn_blocking(move || -> Result<String, (StatusCode, String)> {
        let state = lock(&shared.current).clone();
        let (text, path, source, ours) = {
            let slot = lock(&shared.slot);
            (
                crate::save::edited(&slot.source, &state, &slot.loaded),
                slot.path.clone(),
                slot.source.clone(),
                slot.saved.clone(),
            )
        };
        let Some(path) = path else {
            return Err((StatusCode::CONFLICT, "the embedded scene has no file to save to".into()));
        };
        let text = text.map_err(|e| (StatusCode::CONFLICT, e))?;
        write_scene(&path, &source, ours.as_deref(), &text)?;
        let mut slot = lock(&shared.slot);
        // Unless the watcher has reloaded meanwhile (then the file's text is the slot's).
        if slot.source == source {
            slot.saved = Some(text);
        }
        Ok(format!("saved {}", path.display()))
    })
    .await;
    match saved {
        Ok(Ok(m)) => (StatusCode::OK, m).into_response(),
        Ok(Err(e)) => e.into_response(),
        Err(_) => (StatusCode::INTERNAL_SERVER_ERROR, "the save failed").into_response(),
    }
}

/// What Save answers in a read-only studio.
pub(crate) const READ_ONLY: &str =
    "the studio is read-only (lancer serve --read-only): Save is off; Download keeps your edits";

/// What Save answers when the scene file no longer holds the text the studio loaded.
pub(crate) const CHANGED_ON_DISK: &str = "the file changed on disk: reload, or Download your version";

/// Replaces the scene file at `path` with `text`, whole or not at all, if it still holds
/// `loaded` (the text the studio loaded: anything else is newer work, an edit made outside,
/// which is kept and answered with 409) or `ours` (what this studio saved there last).
///
/// The text goes through a temporary created exclusively, under a name no one can guess, in the
/// file's folder: a link planted there is never followed, and the rename leaves a regular file at
/// `path`. The temporary gets the file's permission bits and is synced before the rename.
pub(crate) fn write_scene(
    path: &Path,
    loaded: &str,
    ours: Option<&str>,
    text: &str,
) -> Result<(), (StatusCode, String)> {
    use std::io::{Read, Write};
    let failed = |what: &str, e: std::io::Error| {
        (StatusCode::INTERNAL_SERVER_ERROR, format!("saving {}: {what}: {e}", path.display()))
    };
    let changed = || (StatusCode::CONFLICT, CHANGED_ON_DISK.to_owned());
    // The path itself, not what a link there points to.
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_file() => {}
        Ok(_) => {
            return Err((
                StatusCode::CONFLICT,
                format!(
                    "{} is not a regular file (a link?): Save writes only a plain file; Download your version",
                    path.display()
                ),
            ));
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Err(changed()),
        Err(e) => return Err(failed("reading it", e)),
    }
    let mut file = std::fs::File::open(path).map_err(|e| failed("reading it", e))?;
    let meta = file.metadata().map_err(|e| failed("reading it", e))?;
    if !meta.is_file() {
        return Err(changed());
    }
    let mut now = Vec::new();
    file.read_to_end(&mut now).map_err(|e| failed("reading it", e))?;
    drop(file);
    if now != loaded.as_bytes() && ours.is_none_or(|o| now != o.as_bytes()) {
        return Err(changed());
    }
    let folder = match path.parent() {
        Some(f) if !f.as_os_str().is_empty() => f,
        _ => Path::new("."),
    };
    let name = path.file_name().map_or("scene".into(), |n| n.to_string_lossy().into_owned());
    let mut temporary = tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(".tmp")
        .tempfile_in(folder)
        .map_err(|e| failed("creating a temporary file beside it", e))?;
    temporary.write_all(text.as_bytes()).map_err(|e| failed("writing", e))?;
    #[cfg(unix)]
    let permissions = {
        use std::os::unix::fs::PermissionsExt;
        std::fs::Permissions::from_mode(meta.permissions().mode() & 0o777)
    };
    #[cfg(not(unix))]
    let permissions = meta.permissions();
    temporary.as_file().set_permissions(permissions).map_err(|e| failed("setting the permissions", e))?;
    temporary.as_file().sync_all().map_err(|e| failed("writing", e))?;
    // On failure the temporary is removed when dropped.
    temporary.persist(path).map_err(|e| failed("replacing it", e.error))?;
    // The rename itself on disk (where a folder can be opened and synced).
    #[cfg(unix)]
    if let Ok(f) = std::fs::File::open(folder) {
        let _ = f.sync_all();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::io::{Read, Write};
    use std::net::{Ipv4Addr, SocketAddr, TcpStream};
    use std::path::PathBuf;
    use std::time::Instant;

    use lancer_shading::Registry;

    use super::*;

    /// A small scene, as a hand would write it.
    const SCENE: &str = "# A test scene.\n[image]\nwidth = 8\nheight = 6\n\n[camera]\nfrom = [0, 1, -3]\nto = [0, 0, 0]\n\n[materials.red]\ncolor = [0.8, 0.1, 0.1]\ndiff = 0.7\n\n[[lights]]\nat = [-3, 5, -3]\n\n[[objects]]\nshape = \"sphere\"\nmaterial = \"red\"\n";

    /// The studio's own timeouts: tests of other things never wait on them.
    const LONG: Timeouts =
        Timeouts { header: Duration::from_secs(30), ping: Duration::from_secs(30), idle: Duration::from_secs(600) };

    struct Studio {
        addr: SocketAddr,
        token: String,
        shared: Arc<Shared>,
    }

    impl Studio {
        fn cookie(&self) -> String {
            format!("{}={}", cookie_name(self.addr.port()), self.token)
        }

        /// A request's raw text with the Host (and `more` headers); the connection closes after.
        fn request(&self, method: &str, path: &str, more: &str) -> Vec<u8> {
            let port = self.addr.port();
            format!("{method} {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n{more}Content-Length: 0\r\nConnection: close\r\n\r\n")
                .into_bytes()
        }

        /// Sends `request` and reads the whole answer.
        fn send(&self, request: &[u8]) -> String {
            let mut s = TcpStream::connect(self.addr).unwrap();
            s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
            s.write_all(request).unwrap();
            let mut out = Vec::new();
            s.read_to_end(&mut out).unwrap();
            String::from_utf8_lossy(&out).into_owned()
        }

        /// The status and body of a request from the studio's own page (with its cookie), with
        /// `body`.
        fn call(&self, method: &str, path: &str, body: &str) -> (u16, String) {
            let port = self.addr.port();
            let request = format!(
                "{method} {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nCookie: {}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
                self.cookie(),
                body.len()
            );
            let answer = self.send(request.as_bytes());
            let (_, text) = answer.split_once("\r\n\r\n").unwrap_or((&answer, ""));
            (status(&answer), text.to_owned())
        }

        /// The status and body of a POST to /api/save from the studio's own page.
        fn save(&self) -> (u16, String) {
            let more = format!("Origin: http://127.0.0.1:{}\r\nCookie: {}\r\n", self.addr.port(), self.cookie());
            let answer = self.send(&self.request("POST", "/api/save", &more));
            let (head, body) = answer.split_once("\r\n\r\n").unwrap();
            (head[9..12].parse().unwrap(), body.to_owned())
        }
    }

    fn status(answer: &str) -> u16 {
        answer.get(9..12).and_then(|s| s.parse().ok()).unwrap_or(0)
    }

    /// How a test's studio is started, besides its scene.
    #[derive(Default)]
    struct Setup {
        /// `--allow-host` names, as [`allowed_host`] gives them.
        allow_hosts: Vec<String>,
        /// `--read-only`.
        read_only: bool,
        /// Watch the scene's file and reload it when it changes (else nothing is watched: a
        /// test changes the file itself).
        watch: bool,
    }

    /// `source` loaded as the CLI's loader would (from `path`, watched if `watch`).
    fn loaded(source: &str, path: Option<PathBuf>, watch: bool) -> Result<crate::server::Loaded, String> {
        let registry = Registry::with_builtins();
        let l = lancer_scene::load_scene(source, "scene.toml", &registry).map_err(|e| e.to_string())?;
        let prepared = lancer_shading::prepare(&l.scene).map_err(|e| format!("{e:?}"))?;
        let objects = crate::session::object_labels(&prepared, &l.places);
        Ok(crate::server::Loaded {
            prepared,
            pipeline: l.pipeline,
            objects,
            labels: l.places.materials,
            warnings: Vec::new(),
            inputs: if watch { path.iter().cloned().collect() } else { Vec::new() },
            name: "scene.toml".into(),
            source: source.to_owned(),
            path,
            scene: l.scene,
        })
    }

    /// The studio serving `source` (from `path`), on a port of its own.
    fn studio(source: &str, path: Option<PathBuf>, timeouts: Timeouts) -> Studio {
        studio_with(source, path, timeouts, Setup::default())
    }

    /// The same, set up as `setup` says (Save allowed, which `--read-only` must override).
    fn studio_with(source: &str, path: Option<PathBuf>, timeouts: Timeouts, setup: Setup) -> Studio {
        let registry = Registry::with_builtins();
        let first = loaded(source, path.clone(), setup.watch).expect("the scene loads");
        let loader: crate::Loader = match (setup.watch, path) {
            (true, Some(path)) => Arc::new(move || {
                let text = std::fs::read_to_string(&path).map_err(|e| e.to_string())?;
                loaded(&text, Some(path.clone()), true)
            }),
            _ => Arc::new(|| Err("no reload in a test".into())),
        };
        let slot = crate::server::SceneSlot::new(first);
        let shared = crate::worker::start(registry, slot, loader, true, setup.read_only).unwrap();
        let mut names = vec!["127.0.0.1".to_owned()];
        names.extend(setup.allow_hosts);
        let token = new_token().unwrap();
        let (tx, rx) = std::sync::mpsc::channel();
        let (s, t) = (shared.clone(), token.clone());
        std::thread::spawn(move || {
            let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
            runtime.block_on(async move {
                let listener = tokio::net::TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).await.unwrap();
                let addr = listener.local_addr().unwrap();
                tx.send(addr).unwrap();
                let app = router(s, t, &names, addr.port(), timeouts);
                crate::server::run(listener, app, timeouts).await;
            });
        });
        Studio { addr: rx.recv().unwrap(), token, shared }
    }

    // --- D: the token cookie ------------------------------------------------------------

    #[test]
    fn a_cookie_planted_before_the_right_one_does_not_lock_the_user_out() {
        let s = studio(SCENE, None, LONG);
        let name = cookie_name(s.addr.port());
        let one = format!("Cookie: {name}=0123456789abcdef0123456789abcdef; {name}={}\r\n", s.token);
        assert_eq!(status(&s.send(&s.request("GET", "/app.js", &one))), 200);
        // In two headers (as HTTP/2 and some clients send them).
        let two = format!("Cookie: {name}=planted\r\nCookie: other=1; {name}={}\r\n", s.token);
        assert_eq!(status(&s.send(&s.request("GET", "/app.js", &two))), 200);
    }

    #[test]
    fn a_downloaded_image_is_encoded_to_the_bytes_lancer_render_writes() {
        let s = studio(SCENE, None, LONG);
        let pixels = [glam::Vec3::new(0.25, 1.5, 0.0), glam::Vec3::new(3.0, 0.125, 0.5)];
        let body: Vec<u8> = pixels.iter().flat_map(|p| p.to_array()).flat_map(f32::to_le_bytes).collect();
        let post = |path: &str, body: &[u8]| {
            let port = s.addr.port();
            let mut request = format!(
                "POST {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nCookie: {}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
                s.cookie(),
                body.len()
            )
            .into_bytes();
            request.extend_from_slice(body);
            let mut c = TcpStream::connect(s.addr).unwrap();
            c.write_all(&request).unwrap();
            let mut out = Vec::new();
            c.read_to_end(&mut out).unwrap();
            let at = out.windows(4).position(|w| w == b"\r\n\r\n").unwrap() + 4;
            (status(&String::from_utf8_lossy(&out[..at])), out[at..].to_vec())
        };
        for (format, want) in [
            ("exr", lancer_output::encode_exr(2, 1, &pixels).unwrap()),
            ("png", lancer_output::encode_png(2, 1, &pixels).unwrap()),
        ] {
            let (code, got) = post(&format!("/api/encode?format={format}&width=2&height=1"), &body);
            assert_eq!(code, 200, "{}", String::from_utf8_lossy(&got));
            assert!(got == want, "{format}: not the bytes lancer render writes");
        }
        let (code, got) = post("/api/encode?format=exr&width=3&height=1", &body);
        assert_eq!(code, 400);
        assert!(String::from_utf8_lossy(&got).contains("24 bytes are not 3x1 RGB floats"));
        let (code, _) = post("/api/encode?format=jpg&width=2&height=1", &body);
        assert_eq!(code, 400);
    }

    #[test]
    fn only_wrong_cookies_are_refused() {
        let s = studio(SCENE, None, LONG);
        let name = cookie_name(s.addr.port());
        let wrong = format!("Cookie: {name}=planted; {name}={}0\r\nCookie: {name}=\r\n", s.token);
        assert_eq!(status(&s.send(&s.request("GET", "/app.js", &wrong))), 403);
        let other = format!("Cookie: lancer_token_1={}\r\n", s.token);
        assert_eq!(status(&s.send(&s.request("GET", "/app.js", &other))), 401);
        let right = format!("Cookie: {}\r\n", s.cookie());
        assert_eq!(status(&s.send(&s.request("GET", "/app.js", &right))), 200);
    }

    #[test]
    fn a_cookie_that_is_not_ascii_does_not_hide_the_token() {
        let s = studio(SCENE, None, LONG);
        let mut more = b"Cookie: planted=\xc3\xa9t\xc3\xa9; ".to_vec();
        more.extend_from_slice(format!("{}\r\n", s.cookie()).as_bytes());
        let mut request = s.request("GET", "/app.js", "");
        let at = request.windows(2).position(|w| w == b"\r\n").unwrap() + 2;
        request.splice(at..at, more);
        assert_eq!(status(&s.send(&request)), 200);
    }

    // --- A and B: Save ------------------------------------------------------------------

    #[cfg(unix)]
    #[test]
    fn a_link_planted_at_the_old_or_a_likely_temporary_name_is_not_followed() {
        let folder = tempfile::tempdir().unwrap();
        let outside = tempfile::tempdir().unwrap();
        let victim = outside.path().join("victim");
        std::fs::write(&victim, "not yours").unwrap();
        let path = folder.path().join("scene.toml");
        std::fs::write(&path, SCENE).unwrap();
        let names =
            ["scene.toml.lancer-save", ".scene.toml.tmp", ".scene.toml..tmp", "scene.toml.tmp", ".scene.toml.swp"];
        for n in names {
            std::os::unix::fs::symlink(&victim, folder.path().join(n)).unwrap();
        }
        write_scene(&path, SCENE, None, "# saved\n").unwrap();
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "not yours");
        for n in names {
            assert_eq!(std::fs::read_link(folder.path().join(n)).unwrap(), victim, "{n}");
        }
        assert!(std::fs::symlink_metadata(&path).unwrap().file_type().is_file());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "# saved\n");
        // Nothing else left behind.
        assert_eq!(std::fs::read_dir(folder.path()).unwrap().count(), names.len() + 1);
    }

    #[cfg(unix)]
    #[test]
    fn a_link_at_the_scene_path_is_not_written_through() {
        let folder = tempfile::tempdir().unwrap();
        let target = folder.path().join("elsewhere.toml");
        std::fs::write(&target, SCENE).unwrap();
        let path = folder.path().join("scene.toml");
        std::os::unix::fs::symlink(&target, &path).unwrap();
        let (code, _) = write_scene(&path, SCENE, None, "# saved\n").unwrap_err();
        assert_eq!(code, StatusCode::CONFLICT);
        assert_eq!(std::fs::read_to_string(&target).unwrap(), SCENE);
        assert!(std::fs::symlink_metadata(&path).unwrap().file_type().is_symlink());
    }

    #[cfg(unix)]
    #[test]
    fn save_keeps_the_scene_files_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("scene.toml");
        std::fs::write(&path, SCENE).unwrap();
        for mode in [0o600, 0o640] {
            std::fs::set_permissions(&path, std::fs::Permissions::from_mode(mode)).unwrap();
            let now = std::fs::read_to_string(&path).unwrap();
            write_scene(&path, &now, None, &format!("# {mode:o}\n")).unwrap();
            assert_eq!(std::fs::metadata(&path).unwrap().permissions().mode() & 0o777, mode);
        }
    }

    #[test]
    fn a_file_changed_on_disk_after_loading_is_not_overwritten() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("scene.toml");
        std::fs::write(&path, SCENE).unwrap();
        // An edit outside (here with a typo the watcher would refuse to load).
        let outside = SCENE.replace("diff = 0.7", "diff = 0.7x");
        std::fs::write(&path, &outside).unwrap();
        let (code, message) = write_scene(&path, SCENE, None, "# saved\n").unwrap_err();
        assert_eq!((code, message.as_str()), (StatusCode::CONFLICT, CHANGED_ON_DISK));
        assert_eq!(std::fs::read(&path).unwrap(), outside.as_bytes());
        // The same through the route, with an edit made on the page.
        let s = studio(SCENE, Some(path.clone()), LONG);
        lock(&s.shared.current).materials[0].diff = 0.5;
        assert_eq!(s.save(), (409, CHANGED_ON_DISK.to_owned()));
        assert_eq!(std::fs::read(&path).unwrap(), outside.as_bytes());
    }

    #[test]
    fn a_second_save_before_the_reload_is_not_a_conflict() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("scene.toml");
        std::fs::write(&path, SCENE).unwrap();
        let s = studio(SCENE, Some(path.clone()), LONG);
        lock(&s.shared.current).materials[0].diff = 0.5;
        assert_eq!(s.save().0, 200);
        assert_eq!(std::fs::read_to_string(&path).unwrap(), SCENE.replace("diff = 0.7", "diff = 0.5"));
        lock(&s.shared.current).materials[0].diff = 0.25;
        assert_eq!(s.save().0, 200);
        assert_eq!(std::fs::read_to_string(&path).unwrap(), SCENE.replace("diff = 0.7", "diff = 0.25"));
    }

    // --- E: timeouts ----------------------------------------------------------------------

    const SHORT: Timeouts = Timeouts {
        header: Duration::from_millis(300),
        ping: Duration::from_millis(100),
        idle: Duration::from_millis(500),
    };

    /// Reads until the server closes the connection: how long that took (a failure if it does
    /// not within 20 s).
    fn closed_after(s: &mut TcpStream) -> (Duration, Vec<u8>) {
        let start = Instant::now();
        s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
        let mut out = Vec::new();
        s.read_to_end(&mut out).expect("the server closes the connection");
        (start.elapsed(), out)
    }

    #[test]
    fn a_connection_that_sends_nothing_is_closed() {
        let s = studio(SCENE, None, SHORT);
        let mut c = TcpStream::connect(s.addr).unwrap();
        let (after, _) = closed_after(&mut c);
        assert!(after >= Duration::from_millis(250), "{after:?}");
    }

    #[test]
    fn a_request_head_that_never_ends_is_dropped() {
        let s = studio(SCENE, None, SHORT);
        let mut c = TcpStream::connect(s.addr).unwrap();
        c.write_all(format!("GET / HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nX-Slow: ", s.addr.port()).as_bytes()).unwrap();
        closed_after(&mut c);
    }

    #[test]
    fn a_kept_alive_connection_that_goes_quiet_is_closed() {
        let s = studio(SCENE, None, SHORT);
        let mut c = TcpStream::connect(s.addr).unwrap();
        let request =
            format!("GET /app.js HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nCookie: {}\r\n\r\n", s.addr.port(), s.cookie());
        c.write_all(request.as_bytes()).unwrap();
        let (_, answer) = closed_after(&mut c);
        assert_eq!(status(&String::from_utf8_lossy(&answer)), 200);
    }

    /// What a page's WebSocket receives, frame by frame.
    #[derive(Debug, PartialEq)]
    enum Got {
        Ping,
        Close,
        /// A text message (the hello, an error, progress), parsed.
        Text(serde_json::Value),
        /// A binary message: one part of a rendered frame, its header.
        Frame(serde_json::Value),
        Other,
        Gone,
    }

    /// Asks for the WebSocket upgrade with `host` and `origin`: the connection and the status.
    fn upgrade(s: &Studio, host: &str, origin: &str) -> (TcpStream, u16) {
        let mut c = TcpStream::connect(s.addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
        let upgrade = format!(
            "GET /ws HTTP/1.1\r\nHost: {host}\r\nOrigin: {origin}\r\nCookie: {}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n",
            s.cookie()
        );
        c.write_all(upgrade.as_bytes()).unwrap();
        let mut head = Vec::new();
        while !head.ends_with(b"\r\n\r\n") {
            let mut b = [0u8];
            if c.read_exact(&mut b).is_err() {
                break;
            }
            head.push(b[0]);
        }
        c.set_read_timeout(None).unwrap();
        let code = status(&String::from_utf8_lossy(&head));
        (c, code)
    }

    /// Opens the studio's WebSocket; a thread reads its frames into the channel.
    fn websocket(s: &Studio) -> (TcpStream, std::sync::mpsc::Receiver<Got>) {
        let local = format!("127.0.0.1:{}", s.addr.port());
        let (c, code) = upgrade(s, &local, &format!("http://{local}"));
        assert_eq!(code, 101);
        let (tx, rx) = std::sync::mpsc::channel();
        let mut r = c.try_clone().unwrap();
        std::thread::spawn(move || {
            let mut read = || -> Option<Got> {
                let mut h = [0u8; 2];
                r.read_exact(&mut h).ok()?;
                let len = match h[1] & 0x7f {
                    126 => {
                        let mut n = [0u8; 2];
                        r.read_exact(&mut n).ok()?;
                        usize::from(u16::from_be_bytes(n))
                    }
                    127 => {
                        let mut n = [0u8; 8];
                        r.read_exact(&mut n).ok()?;
                        usize::try_from(u64::from_be_bytes(n)).ok()?
                    }
                    n => usize::from(n),
                };
                let mut payload = vec![0u8; len];
                r.read_exact(&mut payload).ok()?;
                Some(match h[0] & 0x0f {
                    0x9 => Got::Ping,
                    0x8 => Got::Close,
                    0x1 => Got::Text(serde_json::from_slice(&payload).ok()?),
                    0x2 => {
                        let n = u32::from_le_bytes(payload.get(..4)?.try_into().ok()?) as usize;
                        Got::Frame(serde_json::from_slice(payload.get(4..4 + n)?).ok()?)
                    }
                    _ => Got::Other,
                })
            };
            loop {
                let got = read().unwrap_or(Got::Gone);
                let gone = got == Got::Gone;
                if tx.send(got).is_err() || gone {
                    return;
                }
            }
        });
        (c, rx)
    }

    /// Sends a text message as a page does (masked).
    fn send_text(c: &mut TcpStream, text: &str) {
        let n = text.len();
        let mut frame = vec![0x81u8];
        if n < 126 {
            frame.push(0x80 | n as u8);
        } else {
            frame.push(0x80 | 126);
            frame.extend_from_slice(&u16::try_from(n).unwrap().to_be_bytes());
        }
        let mask = [7u8, 21, 42, 99];
        frame.extend_from_slice(&mask);
        frame.extend(text.bytes().enumerate().map(|(i, b)| b ^ mask[i % 4]));
        c.write_all(&frame).unwrap();
    }

    /// The hello a socket got first.
    fn hello(rx: &std::sync::mpsc::Receiver<Got>) -> serde_json::Value {
        loop {
            match rx.recv_timeout(Duration::from_secs(20)).expect("the hello") {
                Got::Text(m) if m["type"] == "hello" => return m,
                Got::Close | Got::Gone => panic!("the socket closed before its hello"),
                _ => {}
            }
        }
    }

    /// The header of the next full frame's last part a socket gets.
    fn full_frame(rx: &std::sync::mpsc::Receiver<Got>) -> serde_json::Value {
        loop {
            match rx.recv_timeout(Duration::from_secs(20)).expect("a full frame") {
                Got::Frame(h)
                    if h["coarse"] == false
                        && h["offset"].as_u64().zip(h["count"].as_u64()).map(|(o, c)| o + c) == h["total"].as_u64() =>
                {
                    return h;
                }
                Got::Close | Got::Gone => panic!("the socket closed before a full frame"),
                _ => {}
            }
        }
    }

    /// The first frame part a socket gets within `wait`, if any.
    fn any_frame(rx: &std::sync::mpsc::Receiver<Got>, wait: Duration) -> Option<serde_json::Value> {
        let end = Instant::now() + wait;
        while let Some(left) = end.checked_duration_since(Instant::now()) {
            match rx.recv_timeout(left) {
                Ok(Got::Frame(h)) => return Some(h),
                Ok(_) => {}
                Err(_) => return None,
            }
        }
        None
    }

    #[test]
    fn a_websocket_that_hears_nothing_from_the_page_is_closed() {
        let s = studio(SCENE, None, SHORT);
        let start = Instant::now();
        let (_c, rx) = websocket(&s);
        let mut pings = 0;
        loop {
            match rx.recv_timeout(Duration::from_secs(20)).expect("the studio closes the socket") {
                Got::Ping => pings += 1,
                Got::Close | Got::Gone => break,
                _ => {}
            }
        }
        assert!(start.elapsed() >= Duration::from_millis(450), "{:?}", start.elapsed());
        assert!(pings >= 2, "{pings} pings");
    }

    #[test]
    fn a_websocket_whose_page_answers_the_pings_stays_open() {
        let s = studio(SCENE, None, SHORT);
        let (mut c, rx) = websocket(&s);
        let end = Instant::now() + SHORT.idle * 4;
        while let Some(left) = end.checked_duration_since(Instant::now()) {
            match rx.recv_timeout(left) {
                // A pong, masked as a page's frames are (an empty one, as the ping was).
                Ok(Got::Ping) => c.write_all(&[0x8a, 0x80, 1, 2, 3, 4]).unwrap(),
                Ok(got @ (Got::Close | Got::Gone)) => panic!("the socket ended ({got:?}) though the page answered"),
                Ok(_) | Err(_) => {}
            }
        }
        let _ = c.shutdown(std::net::Shutdown::Both);
    }

    // --- F: sharing with a class: other names, read-only ----------------------------------

    #[test]
    fn allowed_host_takes_names_and_addresses_and_refuses_ports_paths_and_spaces() {
        assert_eq!(allowed_host("Lab-PC.local").unwrap(), "lab-pc.local");
        assert_eq!(allowed_host("studio").unwrap(), "studio");
        assert_eq!(allowed_host("192.168.1.20").unwrap(), "192.168.1.20");
        assert_eq!(allowed_host("fd00::2").unwrap(), "[fd00::2]");
        assert_eq!(allowed_host("[fd00::2]").unwrap(), "[fd00::2]");
        for (bad, says) in [
            ("", "empty"),
            ("lab pc", "space"),
            ("lab-pc.local:8470", "port"),
            ("http://lab-pc.local", "path"),
            ("lab-pc.local/", "path"),
            ("lab_pc.local", "`_`"),
            ("lab..local", "empty part"),
            ("lab-pc.local.", "empty part"),
            ("-lab.local", "`-`"),
            ("192.168.1.300", "not an IP address"),
            ("école.local", "xn--"),
        ] {
            let e = allowed_host(bad).expect_err(bad);
            assert!(e.contains(says), "{bad:?}: {e}");
        }
        assert!(allowed_host(&"a".repeat(64)).unwrap_err().contains("63"));
    }

    #[test]
    fn an_allowed_host_name_is_answered_and_other_names_are_not() {
        let setup = Setup { allow_hosts: vec![allowed_host("Lab-PC.local").unwrap()], ..Setup::default() };
        let s = studio_with(SCENE, None, LONG, setup);
        let port = s.addr.port();
        let get = |host: &str| {
            let request =
                format!("GET /app.js HTTP/1.1\r\nHost: {host}\r\nCookie: {}\r\nConnection: close\r\n\r\n", s.cookie());
            status(&s.send(request.as_bytes()))
        };
        assert_eq!(get(&format!("lab-pc.local:{port}")), 200);
        assert_eq!(get(&format!("LAB-PC.local:{port}")), 200, "a Host is read without case");
        assert_eq!(get(&format!("127.0.0.1:{port}")), 200);
        for other in [
            format!("other-pc.local:{port}"),
            format!("lab-pc.local.evil.example:{port}"),
            format!("lab-pc.local:{}", port.wrapping_add(1)),
            "lab-pc.local".to_owned(),
        ] {
            assert_eq!(get(&other), 403, "{other}");
        }
        // The page opened by that name opens its WebSocket from that origin.
        let lab = format!("lab-pc.local:{port}");
        assert_eq!(upgrade(&s, &lab, &format!("http://{lab}")).1, 101);
        assert_eq!(upgrade(&s, &lab, &format!("http://other-pc.local:{port}")).1, 403);
    }

    #[test]
    fn read_only_refuses_save_with_403_though_save_is_allowed() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("scene.toml");
        std::fs::write(&path, SCENE).unwrap();
        let s = studio_with(SCENE, Some(path.clone()), LONG, Setup { read_only: true, ..Setup::default() });
        lock(&s.shared.current).materials[0].diff = 0.5;
        assert_eq!(s.save(), (403, READ_ONLY.to_owned()));
        assert_eq!(std::fs::read_to_string(&path).unwrap(), SCENE);
        // The page is told so (its Save button is off).
        let (_c, rx) = websocket(&s);
        let h = hello(&rx);
        assert_eq!((h["read_only"].as_bool(), h["can_save"].as_bool()), (Some(true), Some(false)));
    }

    #[test]
    fn read_only_an_edit_renders_on_its_own_socket_and_not_on_another() {
        let s = studio_with(SCENE, None, LONG, Setup { read_only: true, ..Setup::default() });
        let (mut a, ra) = websocket(&s);
        let (mut b, rb) = websocket(&s);
        let mut state = hello(&ra)["state"].clone();
        hello(&rb);
        // Both show the file's image first.
        let file = full_frame(&ra)["generation"].as_u64().unwrap();
        assert_eq!(full_frame(&rb)["generation"].as_u64(), Some(file));
        state["materials"][0]["diff"] = serde_json::json!(0.25);
        send_text(&mut a, &state.to_string());
        let mine = full_frame(&ra)["generation"].as_u64().unwrap();
        assert!(mine > file, "{mine} after {file}");
        assert_eq!(any_frame(&rb, Duration::from_millis(600)), None, "a's edit reached b");
        // b's own edit renders for b, and not for a.
        state["materials"][0]["diff"] = serde_json::json!(0.5);
        send_text(&mut b, &state.to_string());
        assert!(full_frame(&rb)["generation"].as_u64().unwrap() > mine);
        assert_eq!(any_frame(&ra, Duration::from_millis(600)), None, "b's edit reached a");
        // A bad edit is told to its own page only.
        send_text(&mut a, "{\"materials\": 3}");
        loop {
            match ra.recv_timeout(Duration::from_secs(20)).expect("the error") {
                Got::Text(m) if m["type"] == "error" => break,
                Got::Close | Got::Gone => panic!("closed"),
                _ => {}
            }
        }
        let end = Instant::now() + Duration::from_millis(300);
        while let Some(left) = end.checked_duration_since(Instant::now()) {
            if let Ok(Got::Text(m)) = rb.recv_timeout(left) {
                assert_ne!(m["type"], "error", "a's error reached b");
            }
        }
    }

    #[test]
    fn read_only_a_reload_reaches_every_tab_even_one_showing_its_own_edit() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("scene.toml");
        std::fs::write(&path, SCENE).unwrap();
        let setup = Setup { read_only: true, watch: true, ..Setup::default() };
        let s = studio_with(SCENE, Some(path.clone()), LONG, setup);
        let (mut a, ra) = websocket(&s);
        let (_b, rb) = websocket(&s);
        let mut state = hello(&ra)["state"].clone();
        hello(&rb);
        full_frame(&ra);
        full_frame(&rb);
        state["materials"][0]["diff"] = serde_json::json!(0.25);
        send_text(&mut a, &state.to_string());
        let mine = full_frame(&ra)["generation"].as_u64().unwrap();
        // The file changes on disk: every page gets its state and its image, a's edit or not.
        std::fs::write(&path, SCENE.replace("diff = 0.7", "diff = 0.45")).unwrap();
        for rx in [&ra, &rb] {
            // The new hello and the new file's full image, in either order.
            let (mut told, mut shown) = (false, false);
            while !(told && shown) {
                match rx.recv_timeout(Duration::from_secs(20)).expect("the reload's hello and image") {
                    Got::Text(h) if h["type"] == "hello" => {
                        let diff = h["state"]["materials"][0]["diff"].as_f64().unwrap();
                        assert!((diff - 0.45).abs() < 1e-6, "{diff}");
                        told = true;
                    }
                    Got::Frame(f) if f["coarse"] == false => {
                        assert!(f["generation"].as_u64().unwrap() > mine);
                        shown = true;
                    }
                    Got::Close | Got::Gone => panic!("closed"),
                    _ => {}
                }
            }
        }
    }

    #[test]
    fn shared_studio_an_edit_from_one_socket_still_renders_on_every_socket() {
        let s = studio(SCENE, None, LONG);
        let (mut a, ra) = websocket(&s);
        let (_b, rb) = websocket(&s);
        let mut state = hello(&ra)["state"].clone();
        assert_eq!(hello(&rb)["read_only"].as_bool(), Some(false));
        let file = full_frame(&ra)["generation"].as_u64().unwrap();
        full_frame(&rb);
        state["materials"][0]["diff"] = serde_json::json!(0.25);
        send_text(&mut a, &state.to_string());
        assert_eq!(full_frame(&rb)["generation"].as_u64(), Some(file + 1));
        assert_eq!(full_frame(&ra)["generation"].as_u64(), Some(file + 1));
    }

    #[test]
    fn read_only_download_and_explain_use_the_state_the_page_posts() {
        let s = studio_with(SCENE, None, LONG, Setup { read_only: true, ..Setup::default() });
        let file = serde_json::to_value(lock(&s.shared.current).clone()).unwrap();
        let mut mine = file.clone();
        mine["materials"][0]["diff"] = serde_json::json!(0.25);
        let (code, text) = s.call("POST", "/api/scene.toml", &mine.to_string());
        assert_eq!((code, text.contains("diff = 0.25")), (200, true), "{text}");
        // Without a state, the file's (no page's edit is the studio's).
        let (code, text) = s.call("GET", "/api/scene.toml", "");
        assert_eq!((code, text.contains("diff = 0.7")), (200, true), "{text}");
        let explain = |method: &str, body: &str| s.call(method, "/api/explain?x=4&y=3", body);
        let (theirs, posted_file, posted_mine) =
            (explain("GET", ""), explain("POST", &file.to_string()), explain("POST", &mine.to_string()));
        assert_eq!(theirs.0, 200, "{}", theirs.1);
        assert_eq!(theirs, posted_file);
        assert_eq!(posted_mine.0, 200);
        assert_ne!(posted_mine.1, theirs.1, "the posted edit is explained");
        // A state of an older load of the scene, or none the studio can read, is refused.
        let mut old = mine.clone();
        old["epoch"] = serde_json::json!(7);
        assert_eq!(s.call("POST", "/api/scene.toml", &old.to_string()).0, 409);
        assert_eq!(explain("POST", "{").0, 400);
    }
}

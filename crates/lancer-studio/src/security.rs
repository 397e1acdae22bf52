//! The studio's routes and what guards them: a Host allow-list (against DNS rebinding), a
//! per-run token exchanged for a `SameSite=Strict` cookie, the Origin of WebSocket upgrades,
//! small body and message limits, a content security policy. No route reads a path a client
//! gives.

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
use crate::worker::{Shared, lock};

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

pub(crate) fn router(shared: Arc<Shared>, token: String, host: IpAddr, port: u16, timeouts: Timeouts) -> Router {
    let mut hosts = vec![format!("localhost:{port}"), format!("127.0.0.1:{port}"), format!("[::1]:{port}")];
    if !host.is_loopback() {
        hosts.push(match host {
            IpAddr::V4(a) => format!("{a}:{port}"),
            IpAddr::V6(a) => format!("[{a}]:{port}"),
        });
    }
    let origins = hosts.iter().map(|h| format!("http://{h}")).collect();
    let guard = Guard { shared, token, cookie: cookie_name(port), hosts, origins, timeouts };
    Router::new()
        .route("/", get(index))
        .route("/app.js", get(|| async { asset(SCRIPT, "text/javascript; charset=utf-8") }))
        .route("/app.css", get(|| async { asset(STYLE, "text/css; charset=utf-8") }))
        .route("/ws", get(socket))
        .route("/api/explain", get(explain))
        .route("/api/scene.toml", get(download))
        .route("/api/save", axum::routing::post(save))
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
    if !g.hosts.iter().any(|h| h == host) {
        return (StatusCode::FORBIDDEN, "unknown Host: the studio answers to localhost only").into_response();
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
    if !g.origins.iter().any(|o| o == origin) {
        return (StatusCode::FORBIDDEN, "WebSocket from another origin").into_response();
    }
    ws.max_message_size(LIMIT).max_frame_size(LIMIT).on_upgrade(move |s| session(g.shared, s, g.timeouts))
}

/// Sends a frame's messages; `false` once the page is gone.
async fn send_frame(ws: &mut WebSocket, frame: Option<crate::worker::FrameBytes>) -> bool {
    for m in frame.iter().flat_map(|f| f.iter()) {
        if ws.send(Message::Binary(m.clone().into())).await.is_err() {
            return false;
        }
    }
    true
}

/// One page's connection: the hello, then frames and events out, edits in, and a ping every
/// `timeouts.ping`. A page that is heard from not at all (no edit, no pong) for `timeouts.idle`
/// is gone (a closed laptop, a dead network): its connection is closed, even when a send to it
/// is stuck.
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

async fn talk(shared: &Shared, ws: &mut WebSocket, heard: &AtomicU64, start: tokio::time::Instant, ping: Duration) {
    let mut frames = shared.frames.subscribe();
    let mut events = shared.events.subscribe();
    if ws.send(Message::Text(shared.hello().into())).await.is_err() {
        return;
    }
    let latest = frames.borrow_and_update().clone();
    if !send_frame(ws, latest).await {
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
                    match serde_json::from_str::<crate::State>(&text) {
                        Ok(state) => shared.ask(state),
                        Err(e) => {
                            let m = serde_json::json!({"type": "error", "message": format!("an edit the studio cannot read: {e}")});
                            if ws.send(Message::Text(m.to_string().into())).await.is_err() {
                                return;
                            }
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
                if !send_frame(ws, frame).await {
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

/// The explanation of a pixel of the full image with the current state.
async fn explain(Axum(g): Axum<Guard>, Query(p): Query<Pixel>) -> Response {
    let shared = g.shared.clone();
    let result = tokio::task::spawn_blocking(move || -> Result<String, String> {
        let state = lock(&shared.current).clone();
        let (mut prepared, camera, mut image, name) = {
            let slot = lock(&shared.slot);
            (slot.prepared.clone(), slot.camera, slot.image, slot.name.clone())
        };
        if p.x >= image.width || p.y >= image.height {
            return Err(format!("pixel {},{} is outside the {}x{} image", p.x, p.y, image.width, image.height));
        }
        let pipeline = state.apply(&mut prepared, &shared.registry)?;
        image.samples = state.model.samples;
        let e = lancer_shading::explain_pixel(&prepared, &camera, &image, &pipeline, p.x, p.y);
        Ok(lancer_output::Report { scene: &name, image: &image, pipeline: &pipeline, explanation: &e }.json())
    })
    .await;
    match result {
        Ok(Ok(json)) => ([(header::CONTENT_TYPE, "application/json")], json).into_response(),
        Ok(Err(e)) => (StatusCode::BAD_REQUEST, e).into_response(),
        Err(_) => (StatusCode::INTERNAL_SERVER_ERROR, "the explanation failed").into_response(),
    }
}

/// The scene file's text with the current edits, for the browser to download.
async fn download(Axum(g): Axum<Guard>) -> Response {
    let state = lock(&g.shared.current).clone();
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

/// Writes the edits into the scene file, whole or not at all (`--allow-save` only).
async fn save(Axum(g): Axum<Guard>, headers: HeaderMap) -> Response {
    // A form or a fetch from another page (another port of this machine is the same site to
    // the cookie) carries another Origin.
    let origin = headers.get(header::ORIGIN).and_then(|o| o.to_str().ok()).unwrap_or("");
    if !g.origins.iter().any(|o| o == origin) {
        return (StatusCode::FORBIDDEN, "a save from another origin").into_response();
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

    /// The studio serving `source` (from `path`), on a port of its own.
    fn studio(source: &str, path: Option<PathBuf>, timeouts: Timeouts) -> Studio {
        let registry = Registry::with_builtins();
        let l = lancer_scene::load_scene(source, "scene.toml", &registry).expect("the scene loads");
        let prepared = lancer_shading::prepare(&l.scene).expect("the scene prepares");
        let loaded = crate::server::Loaded {
            prepared,
            pipeline: l.pipeline,
            labels: l.places.materials,
            warnings: Vec::new(),
            // Nothing to watch: the test changes the file itself.
            inputs: Vec::new(),
            name: "scene.toml".into(),
            source: source.to_owned(),
            path,
            scene: l.scene,
        };
        let loader: crate::Loader = Arc::new(|| Err("no reload in a test".into()));
        let shared = crate::worker::start(registry, crate::server::SceneSlot::new(loaded), loader, true).unwrap();
        let token = new_token().unwrap();
        let (tx, rx) = std::sync::mpsc::channel();
        let (s, t) = (shared.clone(), token.clone());
        std::thread::spawn(move || {
            let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
            runtime.block_on(async move {
                let listener = tokio::net::TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).await.unwrap();
                let addr = listener.local_addr().unwrap();
                tx.send(addr).unwrap();
                let app = router(s, t, IpAddr::V4(Ipv4Addr::LOCALHOST), addr.port(), timeouts);
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
        Other,
        Gone,
    }

    /// Opens the studio's WebSocket; a thread reads its frames into the channel.
    fn websocket(s: &Studio) -> (TcpStream, std::sync::mpsc::Receiver<Got>) {
        let mut c = TcpStream::connect(s.addr).unwrap();
        let port = s.addr.port();
        let upgrade = format!(
            "GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nOrigin: http://127.0.0.1:{port}\r\nCookie: {}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n",
            s.cookie()
        );
        c.write_all(upgrade.as_bytes()).unwrap();
        let mut head = Vec::new();
        while !head.ends_with(b"\r\n\r\n") {
            let mut b = [0u8];
            c.read_exact(&mut b).unwrap();
            head.push(b[0]);
        }
        assert_eq!(status(&String::from_utf8_lossy(&head)), 101);
        let (tx, rx) = std::sync::mpsc::channel();
        let mut r = c.try_clone().unwrap();
        std::thread::spawn(move || {
            loop {
                let mut h = [0u8; 2];
                if r.read_exact(&mut h).is_err() {
                    let _ = tx.send(Got::Gone);
                    return;
                }
                let len = match h[1] & 0x7f {
                    126 => {
                        let mut n = [0u8; 2];
                        r.read_exact(&mut n).unwrap();
                        u64::from(u16::from_be_bytes(n))
                    }
                    127 => {
                        let mut n = [0u8; 8];
                        r.read_exact(&mut n).unwrap();
                        u64::from_be_bytes(n)
                    }
                    n => u64::from(n),
                };
                std::io::copy(&mut (&mut r).take(len), &mut std::io::sink()).unwrap();
                let got = match h[0] & 0x0f {
                    0x9 => Got::Ping,
                    0x8 => Got::Close,
                    _ => Got::Other,
                };
                if tx.send(got).is_err() {
                    return;
                }
            }
        });
        (c, rx)
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
                Got::Other => {}
                Got::Close | Got::Gone => break,
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
                Ok(Got::Other) | Err(_) => {}
                Ok(got) => panic!("the socket ended ({got:?}) though the page answered"),
            }
        }
        let _ = c.shutdown(std::net::Shutdown::Both);
    }
}

//! The studio's routes and what guards them: a Host allow-list (against DNS rebinding), a
//! per-run token exchanged for a `SameSite=Strict` cookie, the Origin of WebSocket upgrades,
//! small body and message limits, a content security policy. No route reads a path a client
//! gives.

use std::net::IpAddr;
use std::sync::Arc;

use anyhow::{Context, Result};
use axum::Router;
use axum::body::Body;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{DefaultBodyLimit, Query, Request, State as Axum};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use serde::Deserialize;

use crate::worker::{Shared, lock};

const INDEX: &str = include_str!("page/index.html");
const SCRIPT: &str = include_str!("page/app.js");
const STYLE: &str = include_str!("page/app.css");

/// The most a request body or a WebSocket message may hold: an edit is a few kilobytes.
const LIMIT: usize = 256 * 1024;

/// The cookie's name, with the port: two studios on one machine keep their own.
fn cookie_name(port: u16) -> String {
    format!("lancer_token_{port}")
}

/// Equal, in a time that does not depend on where they differ.
fn same(a: &str, b: &str) -> bool {
    a.len() == b.len() && a.bytes().zip(b.bytes()).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
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
}

pub(crate) fn router(shared: Arc<Shared>, token: String, host: IpAddr, port: u16) -> Router {
    let mut hosts = vec![format!("localhost:{port}"), format!("127.0.0.1:{port}"), format!("[::1]:{port}")];
    if !host.is_loopback() {
        hosts.push(match host {
            IpAddr::V4(a) => format!("{a}:{port}"),
            IpAddr::V6(a) => format!("[{a}]:{port}"),
        });
    }
    let origins = hosts.iter().map(|h| format!("http://{h}")).collect();
    let guard = Guard { shared, token, cookie: cookie_name(port), hosts, origins };
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

fn cookie_token(headers: &HeaderMap, name: &str) -> Option<String> {
    headers.get_all(header::COOKIE).iter().filter_map(|v| v.to_str().ok()).flat_map(|v| v.split(';')).find_map(|c| {
        let (k, v) = c.trim().split_once('=')?;
        (k == name).then(|| v.to_owned())
    })
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
    if request.uri().path() == "/" && from_query.as_deref().is_some_and(|t| same(t, &g.token)) {
        // Exchange the URL's token for a cookie, and drop it from the address bar.
        let cookie = format!("{}={}; HttpOnly; SameSite=Strict; Path=/", g.cookie, g.token);
        return Response::builder()
            .status(StatusCode::SEE_OTHER)
            .header(header::LOCATION, "/")
            .header(header::SET_COOKIE, cookie)
            .body(Body::empty())
            .expect("a redirect");
    }
    match cookie_token(request.headers(), &g.cookie) {
        Some(t) if same(&t, &g.token) => {}
        Some(_) => return (StatusCode::FORBIDDEN, "wrong token").into_response(),
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
    ws.max_message_size(LIMIT).max_frame_size(LIMIT).on_upgrade(move |s| session(g.shared, s))
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

/// One page's connection: the hello, then frames and events out, edits in.
async fn session(shared: Arc<Shared>, mut ws: WebSocket) {
    let mut frames = shared.frames.subscribe();
    let mut events = shared.events.subscribe();
    if ws.send(Message::Text(shared.hello().into())).await.is_err() {
        return;
    }
    let latest = frames.borrow_and_update().clone();
    if !send_frame(&mut ws, latest).await {
        return;
    }
    loop {
        tokio::select! {
            incoming = ws.recv() => {
                let Some(Ok(message)) = incoming else { return };
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
            changed = frames.changed() => {
                if changed.is_err() {
                    return;
                }
                // Only the newest frame: a slow page skips the ones it could not take.
                let frame = frames.borrow_and_update().clone();
                if !send_frame(&mut ws, frame).await {
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
        Ok((shared.explainer)(&e, &name, &image, &pipeline))
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
    let state = lock(&g.shared.current).clone();
    let (text, path) = {
        let slot = lock(&g.shared.slot);
        (crate::save::edited(&slot.source, &state, &slot.loaded), slot.path.clone())
    };
    let Some(path) = path else {
        return (StatusCode::CONFLICT, "the embedded scene has no file to save to").into_response();
    };
    let text = match text {
        Ok(t) => t,
        Err(e) => return (StatusCode::CONFLICT, e).into_response(),
    };
    let temporary = path.with_extension("toml.lancer-save");
    let written = std::fs::write(&temporary, text).and_then(|()| std::fs::rename(&temporary, &path));
    match written {
        Ok(()) => (StatusCode::OK, format!("saved {}", path.display())).into_response(),
        Err(e) => {
            let _ = std::fs::remove_file(&temporary);
            (StatusCode::INTERNAL_SERVER_ERROR, format!("saving {}: {e}", path.display())).into_response()
        }
    }
}

//! `lancer serve`'s server: the scene slot the renders and the routes share, the options, and
//! the HTTP loop (with the header timeout).

use std::net::{IpAddr, SocketAddr};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, Result};
use lancer_core::{Camera, ImageSettings, Scene};
use lancer_shading::{Pipeline, Prepared, Registry};

use crate::{State, security, worker};

/// A scene as the studio needs it, loaded afresh from its files by the [`Loader`].
pub struct Loaded {
    /// The scene.
    pub scene: Scene,
    /// The scene prepared for rendering.
    pub prepared: Prepared,
    /// Its model (with the command line's changes).
    pub pipeline: Pipeline,
    /// A name for each prepared material, in order.
    pub labels: Vec<String>,
    /// What loading and checking warn about, one line each.
    pub warnings: Vec<String>,
    /// Every file read (scene, model, meshes, textures): what the studio watches.
    pub inputs: Vec<PathBuf>,
    /// How the scene is named.
    pub name: String,
    /// The scene file's text (what "Save" edits).
    pub source: String,
    /// The scene file, when there is one (the embedded showcase has none).
    pub path: Option<PathBuf>,
}

/// Loads the scene from its files (the same way each time): an error is the located message.
pub type Loader = Arc<dyn Fn() -> std::result::Result<Loaded, String> + Send + Sync>;

/// How to serve.
pub struct Options {
    /// The address to bind (127.0.0.1 unless `--host`).
    pub host: IpAddr,
    /// The port (0: any free one).
    pub port: u16,
    /// Open the page in the default browser.
    pub open: bool,
    /// Let the page write its edits back into the scene file (else it only downloads them).
    pub allow_save: bool,
}

/// What renders use besides the state: fixed for a loaded scene.
pub(crate) struct SceneSlot {
    pub prepared: Prepared,
    pub camera: Camera,
    pub image: ImageSettings,
    pub name: String,
    pub warnings: Vec<String>,
    pub inputs: Vec<PathBuf>,
    pub source: String,
    pub path: Option<PathBuf>,
    /// The state as the file has it.
    pub loaded: State,
    /// Counts the loads of the scene.
    pub epoch: u64,
    /// The text the studio itself last saved into the file since it was loaded: a second Save
    /// before the watcher has reloaded finds it there, which is no newer work to protect.
    pub saved: Option<String>,
}

impl SceneSlot {
    pub(crate) fn new(l: Loaded) -> SceneSlot {
        let prepared = l.prepared;
        let loaded = State::of(&prepared, &l.pipeline, &l.labels, l.scene.image.samples.clamp(1, 256));
        SceneSlot {
            prepared,
            camera: l.scene.camera,
            image: l.scene.image,
            name: l.name,
            warnings: l.warnings,
            inputs: l.inputs,
            source: l.source,
            path: l.path,
            loaded,
            epoch: 0,
            saved: None,
        }
    }
}

/// Serves the studio until the process is stopped (Ctrl-C). Prints the page's address (with its
/// token) on stdout and opens it unless told not to. A scene that does not load at the start is
/// an error; later, a broken save shows its error on the page and keeps the last image.
pub fn serve(registry: Registry, loader: Loader, options: Options) -> Result<()> {
    let first = loader().map_err(anyhow::Error::msg)?;
    let slot = SceneSlot::new(first);
    let token = security::new_token()?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("starting the server's runtime")?;
    runtime.block_on(async move {
        let listener = tokio::net::TcpListener::bind(SocketAddr::new(options.host, options.port))
            .await
            .with_context(|| format!("listening on {}:{}", options.host, options.port))?;
        let port = listener.local_addr()?.port();
        let shared = worker::start(registry, slot, loader, options.allow_save)?;
        let timeouts = Timeouts::default();
        let app = security::router(shared, token.clone(), options.host, port, timeouts);
        let shown = match options.host {
            IpAddr::V4(a) if a.is_loopback() => "127.0.0.1".to_owned(),
            IpAddr::V4(a) => a.to_string(),
            IpAddr::V6(a) => format!("[{a}]"),
        };
        let url = format!("http://{shown}:{port}/?token={token}");
        println!("Lancer studio: {url}");
        if options.open {
            // No browser is not an error: the address is printed.
            let _ = webbrowser::open(&url);
        }
        run(listener, app, timeouts).await;
        Ok(())
    })
}

/// How long the server waits on a client.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Timeouts {
    /// From the moment a connection waits for a request (just opened, or idle between two) to
    /// the end of the request's head: a client that sends none, or sends it slowly, is dropped.
    pub header: Duration,
    /// How often a WebSocket is pinged (a live page answers at once, even a hidden tab).
    pub ping: Duration,
    /// A WebSocket that receives nothing for this long (no edit, no answer to the pings), or
    /// whose sends are stuck that long, is closed. Renders need nothing from the page: a long
    /// render keeps its connection as long as the page answers the pings.
    pub idle: Duration,
}

impl Default for Timeouts {
    fn default() -> Timeouts {
        Timeouts { header: Duration::from_secs(30), ping: Duration::from_secs(30), idle: Duration::from_secs(600) }
    }
}

/// Serves `app` on `listener` over HTTP/1.1 (what browsers speak to an `http://` address), with
/// upgrades for the WebSocket, closing connections whose request head does not arrive within
/// `timeouts.header`. (`axum::serve` runs the same hyper connection but without a timer, so
/// hyper's header timeout never fired and an idle connection stayed open for ever.)
pub(crate) async fn run(listener: tokio::net::TcpListener, app: axum::Router, timeouts: Timeouts) {
    loop {
        let stream = match listener.accept().await {
            Ok((stream, _)) => stream,
            Err(e) => {
                // A connection that failed before it was accepted is the client's business; any
                // other error (too many open files) passes with time: wait, as axum::serve does.
                if !matches!(
                    e.kind(),
                    std::io::ErrorKind::ConnectionRefused
                        | std::io::ErrorKind::ConnectionAborted
                        | std::io::ErrorKind::ConnectionReset
                ) {
                    tokio::time::sleep(Duration::from_secs(1)).await;
                }
                continue;
            }
        };
        let _ = stream.set_nodelay(true);
        let service = hyper_util::service::TowerToHyperService::new(app.clone());
        tokio::spawn(async move {
            let mut builder = hyper::server::conn::http1::Builder::new();
            builder.timer(hyper_util::rt::TokioTimer::new()).header_read_timeout(timeouts.header);
            // A failed connection (a timeout, a client gone) ends only itself.
            let _ = builder.serve_connection(hyper_util::rt::TokioIo::new(stream), service).with_upgrades().await;
        });
    }
}

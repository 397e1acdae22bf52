//! `lancer serve`'s server: the scene slot the renders and the routes share, the options, the
//! addresses printed (every interface's, when bound to 0.0.0.0 or ::), and the HTTP loop (with
//! the header timeout).

use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr};
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
    /// A name for each prepared object, in order (`session::object_labels`).
    pub objects: Vec<String>,
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
    /// The address to bind (127.0.0.1 unless `--host`; 0.0.0.0 or :: for every interface).
    pub host: IpAddr,
    /// The port (0: any free one).
    pub port: u16,
    /// Open the page in the default browser.
    pub open: bool,
    /// Let the page write its edits back into the scene file (else it only downloads them).
    pub allow_save: bool,
    /// More names the page may be opened by (`--allow-host`), as [`crate::allowed_host`] gives
    /// them: the Host allow-list takes each with the port, and they are printed.
    pub allow_hosts: Vec<String>,
    /// Each page's edits render for that page alone and Save is off (`--read-only`, for a
    /// class); the file's own state and its reloads still reach every page.
    pub read_only: bool,
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
    /// How each object is named: `object 3 (sphere, glass.toml:45)`.
    pub objects: Vec<String>,
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
            objects: l.objects,
            loaded,
            epoch: 0,
            saved: None,
        }
    }
}

/// Serves the studio until the process is stopped (Ctrl-C). Prints the page's addresses (with
/// its token) on stdout, one a line, the first as `Lancer studio: URL` (127.0.0.1 whenever
/// loopback is reachable), the others as `  also: URL`, and opens the first unless told not to.
/// A scene that does not load at the start is an error; later, a broken save shows its error on
/// the page and keeps the last image.
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
        let names = hosts(&reachable(options.host, port).await, &options.allow_hosts);
        let shared = worker::start(registry, slot, loader, options.allow_save, options.read_only)?;
        let timeouts = Timeouts::default();
        let app = security::router(shared, token.clone(), &names, port, timeouts);
        let urls: Vec<String> = names.iter().map(|n| format!("http://{n}:{port}/?token={token}")).collect();
        for (i, url) in urls.iter().enumerate() {
            println!("{}{url}", if i == 0 { "Lancer studio: " } else { "  also: " });
        }
        if options.open {
            // No browser is not an error: the address is printed.
            let _ = webbrowser::open(&urls[0]);
        }
        run(listener, app, timeouts).await;
        Ok(())
    })
}

/// The addresses a listener bound to `host` on `port` is reached at: `host` itself, or for an
/// unspecified one (0.0.0.0, ::) loopback and every interface's address it takes, as
/// [`interface_addresses`] orders them.
async fn reachable(host: IpAddr, port: u16) -> Vec<IpAddr> {
    if !host.is_unspecified() {
        return vec![host];
    }
    let (v4, v6) = match host {
        IpAddr::V4(_) => (true, false),
        // A socket on :: takes IPv4 too where it is dual-stack (Linux's default, not Windows'):
        // seen by connecting to 127.0.0.1 on its port.
        IpAddr::V6(_) => {
            let probe = tokio::net::TcpStream::connect((Ipv4Addr::LOCALHOST, port));
            (matches!(tokio::time::timeout(Duration::from_millis(500), probe).await, Ok(Ok(_))), true)
        }
    };
    let listed = match if_addrs::get_if_addrs() {
        Ok(interfaces) => interfaces.iter().map(if_addrs::Interface::ip).collect(),
        Err(e) => {
            eprintln!(
                "warning: listing this machine's network interfaces: {e}; only loopback is printed (name the machine's address or name with --allow-host)"
            );
            Vec::new()
        }
    };
    interface_addresses(v4, v6, &listed)
}

/// Loopback first (127.0.0.1 if `v4`, then ::1 if `v6`), then each address of `listed` of a family
/// taken, IPv4 before IPv6, once each, in the order listed; other loopback, unspecified, multicast
/// and IPv6 link-local addresses (a URL would need the interface's zone) are left out.
fn interface_addresses(v4: bool, v6: bool, listed: &[IpAddr]) -> Vec<IpAddr> {
    let mut out: Vec<IpAddr> = Vec::new();
    if v4 {
        out.push(Ipv4Addr::LOCALHOST.into());
    }
    if v6 {
        out.push(Ipv6Addr::LOCALHOST.into());
    }
    let fours = listed.iter().filter(|a| v4 && a.is_ipv4());
    let sixes = listed.iter().filter(|a| v6 && a.is_ipv6());
    for &a in fours.chain(sixes) {
        let link_local = matches!(a, IpAddr::V6(b) if b.is_unicast_link_local());
        if a.is_loopback() || a.is_unspecified() || a.is_multicast() || link_local || out.contains(&a) {
            continue;
        }
        out.push(a);
    }
    out
}

/// The names the studio is printed and answers by: the `addresses` (IPv6 in brackets), then the
/// `--allow-host` names, once each.
fn hosts(addresses: &[IpAddr], allowed: &[String]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for name in addresses.iter().map(|a| security::host_of(*a)).chain(allowed.iter().cloned()) {
        if !names.contains(&name) {
            names.push(name);
        }
    }
    names
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

#[cfg(test)]
mod tests {
    use super::*;

    fn ip(text: &str) -> IpAddr {
        text.parse().unwrap()
    }

    #[test]
    fn regression_0_0_0_0_printed_itself_instead_of_loopback_and_the_lan_addresses() {
        let listed =
            [ip("127.0.0.1"), ip("192.168.1.20"), ip("::1"), ip("fd00::2"), ip("10.0.0.7"), ip("192.168.1.20")];
        let got = interface_addresses(true, false, &listed);
        assert_eq!(got, [ip("127.0.0.1"), ip("192.168.1.20"), ip("10.0.0.7")]);
        // The first line keeps its form (xtask studio-check reads it); the others follow.
        let names = hosts(&got, &["lab-pc.local".to_owned(), "10.0.0.7".to_owned()]);
        assert_eq!(names, ["127.0.0.1", "192.168.1.20", "10.0.0.7", "lab-pc.local"]);
    }

    #[test]
    fn a_dual_stack_unspecified_address_lists_both_families_loopback_first() {
        let listed = [ip("fe80::1"), ip("fd00::2"), ip("192.0.2.2"), ip("::1"), ip("127.0.0.1"), ip("ff02::1")];
        let both = interface_addresses(true, true, &listed);
        assert_eq!(both, [ip("127.0.0.1"), ip("::1"), ip("192.0.2.2"), ip("fd00::2")]);
        assert_eq!(hosts(&both, &[])[1..], ["[::1]", "192.0.2.2", "[fd00::2]"]);
        // IPv6 only: no IPv4 address is printed.
        assert_eq!(interface_addresses(false, true, &listed), [ip("::1"), ip("fd00::2")]);
    }

    #[test]
    fn a_specific_address_is_the_only_one_printed() {
        let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
        assert_eq!(runtime.block_on(reachable(ip("192.168.1.20"), 8470)), [ip("192.168.1.20")]);
        assert_eq!(runtime.block_on(reachable(ip("127.0.0.1"), 8470)), [ip("127.0.0.1")]);
        // On this machine, 0.0.0.0 starts with loopback.
        assert_eq!(runtime.block_on(reachable(ip("0.0.0.0"), 8470))[0], ip("127.0.0.1"));
    }
}

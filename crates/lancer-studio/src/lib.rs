//! The Lancer studio: one page (embedded: no CDN, no network) shows the beauty
//! image and every term's image, with sliders for the materials, the lights and the model; each
//! edit renders a coarse image at once, then the full one, and a newer edit cancels the render
//! in progress. A pixel click explains the pixel. The scene file is watched.
//!
//! The server binds 127.0.0.1 by default, answers only to the Host of an address it printed
//! (localhost; bound to 0.0.0.0 or ::, each interface's address) or of a name it was given
//! (`--allow-host`), wants a per-run token (from the launch URL, then a `SameSite=Strict`
//! cookie), checks the Origin of the WebSocket upgrade, limits request bodies and messages, and
//! reads no path a client names. A connection that sends no request head within 30 s is closed,
//! and so is a WebSocket that hears nothing (not even the answer to a ping) for 10 minutes.
//! Read-only (`--read-only`, for a class), each page's edits render for that page alone, pages
//! taking turns, and Save is off.

//!
//! The page is shared by two engines: `lancer serve` (the `server` feature, on by default: this
//! crate's HTTP server renders on the machine's threads) and the browser build (`lancer-wasm`,
//! which renders in Web Workers through a [`session::Session`] each). What both need, and that
//! builds for WebAssembly, is here without the feature: the page's state ([`State`]), a scene
//! loaded for the page ([`session`]), and the edits written back into the scene text.

mod save;
pub mod session;
mod state;

#[cfg(feature = "server")]
mod security;
#[cfg(feature = "server")]
mod server;
#[cfg(feature = "server")]
mod worker;

#[cfg(feature = "server")]
pub use security::allowed_host;
#[cfg(feature = "server")]
pub use server::{Loaded, Loader, Options, serve};
pub use state::{MaterialState, State, registry_json};

/// The page's files, by name: the same bytes whichever engine serves them.
pub const PAGE: [(&str, &str); 3] = [
    ("index.html", include_str!("page/index.html")),
    ("app.js", include_str!("page/app.js")),
    ("app.css", include_str!("page/app.css")),
];

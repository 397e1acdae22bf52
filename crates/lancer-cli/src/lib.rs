//! The `lancer` command as a library: [`main_with`] runs the whole command line with a registry
//! of your choosing (so your own terms get `render`, `--aov`, `--model`, `terms`...), plus image
//! encoding ([`output`]) and the `lancer terms` text ([`listing`]).

mod app;
mod explain;
pub mod listing;
pub mod output;
mod part;
mod pov;
mod stats;
mod watch;

pub use app::{DEFAULT_SCENE, main_with};

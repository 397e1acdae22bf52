//! The `lancer` command as a library: [`main_with`] runs the whole command line with a registry
//! of your choosing (so your own terms get `render`, `--aov`, `--model`, `terms`...), plus image
//! output ([`output`], the encoders from `lancer-output`), part files of a render cut in parts ([`part`]) and the `lancer terms`
//! text ([`listing`]), [`diagnose_layer`]: `lancer diagnose` on an image held in memory, and
//! [`embed`]: loading, rendering and writing as the command line does, for another program (the
//! Python package).

mod app;
mod diagnose;
mod diff;
pub mod embed;
pub mod listing;
pub mod output;
pub mod part;
mod pov;
mod sheet;
mod stats;
mod watch;

pub use app::{DEFAULT_SCENE, main_with};
pub use diagnose::{Diagnosis, diagnose_layer};

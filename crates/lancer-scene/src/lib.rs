//! Scene and model files: TOML text (docs/scene-format.md) → a [`lancer_core::Scene`] (a hecs World of
//! objects, materials and lights) and a [`lancer_shading::Pipeline`] built from the registry.
//! Every error names the file, line and column. No file system access: callers pass the text.

mod build;
mod check;
mod doc;
mod error;
mod obj;

pub use build::{Loaded, Places, Resolver, load_model, load_model_over, load_scene, load_scene_with};
pub use check::check;
pub use error::{LoadError, LoadErrorKind, Place, Warning};

#[cfg(test)]
mod tests;

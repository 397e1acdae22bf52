//! Scene and model files: TOML text (docs/scene-format.md) → a [`lancer_core::Scene`] (a hecs World of
//! objects, materials and lights) and a [`lancer_shading::Pipeline`] built from the registry.
//! Every error names the file, line and column. No file system access: callers pass the text.

mod build;
mod check;
mod doc;
mod error;
mod obj;
mod scan;
mod texture;

pub use build::{
    Limits, Loaded, MAX_TRIANGLES, Places, Resolver, load_model, load_model_over, load_scene, load_scene_with,
    load_scene_within, toml_error,
};
pub use check::check;
/// The largest colour channel and light intensity a scene may give (what edits are held to too).
pub use doc::{MAX_CHANNEL, MAX_LIGHT, MAX_SAMPLES};
pub use error::{LoadError, LoadErrorKind, Place, Warning};
pub use texture::MAX_TEXTURE_PIXELS;

#[cfg(test)]
mod tests;

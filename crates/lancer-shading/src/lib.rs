//! Shading: the illumination terms as registered systems over the per-tile ray world, the shadow
//! models, the registry that finds both by name, and the render loop that runs generations of
//! ray chunks through them.
//!
//! This crate knows nothing of TOML files or the command line: a model arrives as names and typed
//! parameters ([`Params`]), and a render returns a [`lancer_core::Frame`].

mod choice;
mod explain;
mod lanes;
mod params;
mod pattern;
mod prepare;
mod registry;
mod render;
mod shadow;
pub mod shadows;
mod term;
pub mod terms;
mod visibility;

pub use choice::Choice;
pub use explain::{HitNode, LightNode, PixelExplanation, RayNode, TermNode, explain_pixel};
pub use params::{ParamError, ParamSpec, ParamValue, Params};
pub use pattern::surface_color;
pub use prepare::{PrepareError, Prepared, prepare};
pub use registry::{
    MATERIAL_FIELDS, Mistake, ModelError, NAME_MAX, NamedShadow, NamedTerm, Pipeline, RESERVED, Registry,
    RegistryError, ShadowSpec, TermSpec, WEIGHT, is_name, is_term_name, nearest,
};
pub use render::{RenderOptions, Scratches, TILE, WAVE, part_bands, render, render_prepared};
pub use shadow::{HitBlock, ShadowContext, ShadowModel, aim};
pub use term::{Chunk, Note, NoteValue, ShadeContext, Term, TermOutput, lit_by, mirror_direction, sum_lights};

//! The built-in shadow models, one file each, and their ordered table.

pub mod hard;
pub mod none;
pub mod soft;
pub mod transmissive;

use crate::ShadowSpec;

/// The built-in shadow models, in the order `lancer terms` lists them. The first is not the
/// default: a model that names no shadow model gets `hard` (the handout's).
pub const BUILTIN: &[ShadowSpec] = &[none::SPEC, hard::SPEC, transmissive::SPEC, soft::SPEC];

/// The shadow model a model gets when it names none.
pub const DEFAULT: &str = "hard";

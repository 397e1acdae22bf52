//! The built-in illumination terms, one file each, and their ordered table.

pub mod ambient;
pub mod diffuse;
pub mod mirror;
pub mod refraction;
pub mod specular;

use crate::TermSpec;

/// The built-in terms, in the handout's order. Order is meaningful: a model without `terms`
/// gets all of them in this order, and golden images depend on the summation order.
pub const BUILTIN: &[TermSpec] = &[ambient::SPEC, diffuse::SPEC, specular::SPEC, mirror::SPEC, refraction::SPEC];

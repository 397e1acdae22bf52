//! The built-in illumination terms: a folder per term, a file per variant, and their ordered
//! table.

pub mod ambient;
pub mod diffuse;
pub mod mirror;
pub mod refraction;
pub mod specular;

use crate::TermSpec;

/// The built-in term variants. Order is meaningful: the first variant of each name is its
/// default, and a model without `terms` gets each name's default in the handout's order
/// (ambient, diffuse, specular, mirror, refraction), which golden images depend on.
pub const BUILTIN: &[TermSpec] = &[
    ambient::SPEC,
    diffuse::lambert::SPEC,
    diffuse::oren_nayar::SPEC,
    specular::phong::SPEC,
    specular::blinn::SPEC,
    specular::blinn_normalized::SPEC,
    mirror::constant::SPEC,
    mirror::schlick::SPEC,
    refraction::seed::SPEC,
    refraction::fresnel::SPEC,
];

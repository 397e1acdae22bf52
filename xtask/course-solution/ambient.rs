//! The solution of exercise 1, kept for `cargo xtask course-check` only (it replaces
//! course/starter/src/ambient.rs in a copy of the starter): `Col += ambi · Col_Ω`.

use glam::Vec3;

use crate::Hit;

/// What the ambient term adds at `hit`: `ambi · Col_Ω`.
pub fn ambient(hit: &Hit<'_>) -> Vec3 {
    hit.material.ambi * hit.col_omega
}

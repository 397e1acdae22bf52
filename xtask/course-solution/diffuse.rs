//! The solution of exercise 2, kept for `cargo xtask course-check` only (it replaces
//! course/starter/src/diffuse.rs in a copy of the starter):
//! `Col += diff · max(N·w, 0) · Col_Ω · Col_L` for each light.

use glam::Vec3;

use crate::Hit;

/// What the diffuse term adds at `hit`: `Σ_lights diff · max(N·w, 0) · Col_Ω · Col_L`.
pub fn diffuse(hit: &Hit<'_>) -> Vec3 {
    let mut col = Vec3::ZERO;
    for light in &hit.lights {
        let cos_phi = hit.n.dot(light.w).max(0.0);
        col += hit.material.diff * cos_phi * hit.col_omega * light.col_l;
    }
    col
}

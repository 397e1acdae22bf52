//! Exercise 3 (docs/course.md): the specular highlight (the handout's Phong form), yours to
//! write. Check it with `cargo test ex3` (and `cargo test ex4`, with shadows).
//!
//! A shiny surface sends the light mostly in one direction, `w_r`, the mirror image of `w`
//! about the normal: `w + w_r = 2 (N·w) N`. The ray `[A, u)` brings back the more of it the
//! closer `−u` is to `w_r`, and the highlight takes the light's colour. For each light in front
//! of the surface (`N·w > 0`):
//!
//! ```text
//! w_r = 2 (N·w) N − w
//! Col += spec · shine · max(−u·w_r, 0)^(1/(1−shine)) · Col_L
//! ```
//!
//! - `spec`: the material's specular weight, `hit.material.spec`;
//! - `shine`: its glossiness in [0, 1], `hit.material.shine`: the exponent `1/(1−shine)` is
//!   100 for shine 0.99, 5 for 0.8, 2 for 0.5 (the higher, the smaller and sharper the spot);
//! - `u`: the ray's unit direction, `hit.u` (it points *at* the surface, hence `−u`);
//! - `N`, `w`, `Col_L`: as for the diffuse term (`hit.n`, `light.w`, `light.col_l`).
//!
//! `shine = 1` would be an infinite exponent and `shine = 0` gives `spec · shine = 0`: in both
//! cases add nothing (the course's scenes have neither). `x.powf(e)` is `x^e`.

use glam::Vec3;

use crate::Hit;

/// What the specular term adds at `hit`:
/// `Σ_lights with N·w > 0 of spec · shine · max(−u·w_r, 0)^(1/(1−shine)) · Col_L`.
pub fn specular(hit: &Hit<'_>) -> Vec3 {
    let _ = hit;
    // Your turn: for each light with N·w > 0, w_r = 2 (N·w) N − w, then
    // spec · shine · max(−u·w_r, 0)^(1/(1−shine)) · Col_L, summed.
    Vec3::ZERO
}

//! Exercise 2 (docs/course.md): the diffuse term (Lambert), yours to write. Check it with
//! `cargo test ex2` (and `cargo test ex4`, with shadows).
//!
//! A matte surface sends the light it receives back in every direction, so what it records
//! does not depend on the viewpoint, only on the angle `φ` between the normal and the light:
//! `cos φ = N·w`, largest facing the light, zero from `φ = 90°` on (a light behind the
//! surface lights nothing). For each light:
//!
//! ```text
//! Col += diff · max(N·w, 0) · Col_Ω · Col_L
//! ```
//!
//! - `diff`: the material's diffuse weight, `hit.material.diff`;
//! - `N`: the unit normal at the hit, `hit.n`;
//! - `w`: the unit direction from the hit towards the light, `light.w`;
//! - `Col_Ω`: the object's colour at the hit, `hit.col_omega`;
//! - `Col_L`: the light arriving from that light, `light.col_l` (black where the shadow
//!   model says it is hidden).
//!
//! The lights: `for light in &hit.lights { ... }`. `a.dot(b)` is the dot product, `x.max(0.0)`
//! the larger of `x` and 0.

use glam::Vec3;

use crate::Hit;

/// What the diffuse term adds at `hit`: `Σ_lights diff · max(N·w, 0) · Col_Ω · Col_L`.
pub fn diffuse(hit: &Hit<'_>) -> Vec3 {
    let _ = hit;
    // Your turn: for each light, diff · max(N·w, 0) · Col_Ω · Col_L, summed.
    Vec3::ZERO
}

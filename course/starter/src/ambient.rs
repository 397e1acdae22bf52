//! Exercise 1 (docs/course.md): the ambient term, yours to write. Check it with `cargo test ex1`.
//!
//! The light the source sends round the scene by reflections we do not model bathes every
//! point uniformly: each hit records its object's colour weighted by its ambient fraction,
//! once per hit, whatever the lights:
//!
//! ```text
//! Col += ambi · Col_Ω
//! ```
//!
//! - `ambi`: the material's ambient fraction, `hit.material.ambi` (small, about 0.1);
//! - `Col_Ω`: the object's colour at the hit, `hit.col_omega` (linear RGB, a `Vec3`).
//!
//! `Vec3` is glam's: `a * v` scales a vector by a number, `v * w` multiplies two colours
//! channel by channel, `v + w` adds them.

use glam::Vec3;

use crate::Hit;

/// What the ambient term adds at `hit`: `ambi · Col_Ω`.
pub fn ambient(hit: &Hit<'_>) -> Vec3 {
    let _ = hit;
    // Your turn: ambi · Col_Ω.
    Vec3::ZERO
}

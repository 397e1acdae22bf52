//! Exercise 5 (docs/course.md): the mirror term, yours to write. Check it with `cargo test ex5`.
//!
//! A shiny object also reflects the rest of the scene: the light that comes back along the
//! ray `[A, u)` after a reflection at `I` arrives from the mirror direction `u_r`, the image of
//! `u` about the normal. The ray tracer becomes recursive: trace the reflected ray
//! `R_r = [I, u_r)`, and add what it brings back, weighted by `spec`:
//!
//! ```text
//! u_r = u − 2 (N·u) N
//! Col += spec · Col(R_r)
//! ```
//!
//! - `u`: the ray's unit direction, `hit.u`; `N`: the unit normal, `hit.n`;
//! - `spec`: the material's specular weight, `hit.material.spec` (the same as the highlight's);
//! - `R_r`: `hit.ray(u_r)`, the ray from `I` along `u_r` (it starts a hair off the surface).
//!
//! Return `Some(Child { ray: R_r, weight: spec })` and Lancer traces `R_r` (down to the scene's
//! `max_depth`) and adds `spec · Col(R_r)`; return `None` where there is nothing to reflect
//! (`spec = 0`).

use crate::{Child, Hit};

/// The reflected ray at `hit` and its weight: `R_r = [I, u − 2 (N·u) N)`, weight `spec`.
pub fn mirror(hit: &Hit<'_>) -> Option<Child> {
    let _ = hit;
    // Your turn: u_r = u − 2 (N·u) N, then Some(Child { ray: hit.ray(u_r), weight: spec }).
    None
}

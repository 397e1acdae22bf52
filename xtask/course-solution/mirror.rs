//! The solution of exercise 5, kept for `cargo xtask course-check` only (it replaces
//! course/starter/src/mirror.rs in a copy of the starter): `u_r = u − 2 (N·u) N`,
//! `Col += spec · Col(R_r)` with `R_r = [I, u_r)`.

use crate::{Child, Hit};

/// The reflected ray at `hit` and its weight.
pub fn mirror(hit: &Hit<'_>) -> Option<Child> {
    let spec = hit.material.spec;
    if spec <= 0.0 {
        return None;
    }
    let u_r = hit.u - 2.0 * hit.n.dot(hit.u) * hit.n;
    Some(Child { ray: hit.ray(u_r), weight: spec })
}

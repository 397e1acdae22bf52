//! Exercise 6 (docs/course.md): refraction through a transparent object, yours to write,
//! with `VctTransmis`. Check it with `cargo test ex6`.
//!
//! A ray that crosses from a medium of index `n1` into one of index `n2` bends (Snell:
//! `n1 sin θ = n2 sin θ_t`). With `δn = n1/n2` and `ps = N'·u`, the transmitted direction is
//!
//! ```text
//! VctTransmis(u, N', δn) = (√(1 − δn² (1 − ps²)) − δn · ps) · N' + δn · u
//! ```
//!
//! where `N'` is the unit normal on the side the ray goes to (`N'·u ≥ 0`): at the entry point
//! the outward normal points back at the ray (`N·u < 0`), so `N' = −N` there. Using the outward
//! normal at the entry is the course's classic trap: the ray comes back out like a mirror's.
//! When `1 − δn² (1 − ps²) < 0` there is no transmitted ray (total internal reflection).
//!
//! The whole passage, for an object of index `n` in air (`n1 = 1`):
//!
//! ```text
//! u_t = VctTransmis(u, −N, 1/n)          entering at I
//! J, N_j = where [I, u_t) leaves the object, and the outward normal there
//! v_t = VctTransmis(u_t, N_j, n)         leaving at J
//! Col += alpha · Col(R_t),  R_t = [J, v_t)
//! ```
//!
//! - `u`, `N`: `hit.u`, `hit.n` (outward: the course's rays come from outside);
//! - `n`: the object's refractive index, `hit.material.n`; `alpha`: its transparency,
//!   `hit.material.alpha`: nothing to do where it is 0;
//! - `J`, `N_j`: `hit.exit(u_t)` gives `Some(exit)` with `exit.j` and `exit.n_j` (the ray
//!   inside meets nothing else);
//! - `R_t`: `exit.ray(v_t)`, the ray from `J` along `v_t`.
//!
//! Return `Some(Child { ray: R_t, weight: alpha })` and Lancer traces `R_t` and adds
//! `alpha · Col(R_t)`. `x.sqrt()` is `√x`; `?` after an `Option` returns `None` for you when it
//! is `None`.

use glam::Vec3;

use crate::{Child, Hit};

/// `VctTransmis(u, N', δn)`: the direction of the ray `u` (unit) once it has crossed a surface
/// of unit normal `n_t` (on the side the ray goes to, `n_t·u ≥ 0`) from a medium of index `n1`
/// into one of index `n2`, `delta = n1/n2`; `None` on total internal reflection.
pub fn vct_transmis(u: Vec3, n_t: Vec3, delta: f32) -> Option<Vec3> {
    let _ = (u, n_t, delta);
    // Your turn: ps = N'·u, k = 1 − δn² (1 − ps²); None if k < 0, else
    // (√k − δn · ps) · N' + δn · u.
    None
}

/// The transmitted ray at `hit` and its weight: `R_t = [J, v_t)`, weight `alpha`.
pub fn refraction(hit: &Hit<'_>) -> Option<Child> {
    let _ = hit;
    // Your turn: nothing where alpha is 0; else u_t = VctTransmis(u, −N, 1/n), the exit J
    // (hit.exit(u_t)), v_t = VctTransmis(u_t, N_j, n), and Some(Child { ray: exit.ray(v_t),
    // weight: alpha }).
    None
}

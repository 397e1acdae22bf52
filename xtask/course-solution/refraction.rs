//! The solution of exercise 6, kept for `cargo xtask course-check` only (it replaces
//! course/starter/src/refraction.rs in a copy of the starter): `VctTransmis`, and the passage
//! `u_t = VctTransmis(u, −N, 1/n)`, exit `J`, `v_t = VctTransmis(u_t, N_j, n)`,
//! `Col += alpha · Col(R_t)` with `R_t = [J, v_t)`.

use glam::Vec3;

use crate::{Child, Hit};

/// `VctTransmis(u, N', δn)`, `N'` on the side the ray goes to; `None` on total internal
/// reflection.
pub fn vct_transmis(u: Vec3, n_t: Vec3, delta: f32) -> Option<Vec3> {
    let ps = n_t.dot(u);
    let k = 1.0 - delta * delta * (1.0 - ps * ps);
    if k < 0.0 {
        return None;
    }
    Some((k.sqrt() - delta * ps) * n_t + delta * u)
}

/// The transmitted ray at `hit` and its weight.
pub fn refraction(hit: &Hit<'_>) -> Option<Child> {
    let m = hit.material;
    if m.alpha <= 0.0 {
        return None;
    }
    let u_t = vct_transmis(hit.u, -hit.n, 1.0 / m.n)?;
    let exit = hit.exit(u_t)?;
    let v_t = vct_transmis(u_t, exit.n_j, m.n)?;
    Some(Child { ray: exit.ray(v_t), weight: m.alpha })
}

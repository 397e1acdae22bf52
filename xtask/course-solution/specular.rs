//! The solution of exercise 3, kept for `cargo xtask course-check` only (it replaces
//! course/starter/src/specular.rs in a copy of the starter): for each light with `N·w > 0`,
//! `w_r = 2 (N·w) N − w` and `Col += spec · shine · max(−u·w_r, 0)^(1/(1−shine)) · Col_L`.

use glam::Vec3;

use crate::Hit;

/// What the specular term adds at `hit`.
pub fn specular(hit: &Hit<'_>) -> Vec3 {
    let m = hit.material;
    if m.shine <= 0.0 || m.shine >= 1.0 {
        return Vec3::ZERO;
    }
    let mut col = Vec3::ZERO;
    for light in &hit.lights {
        let n_dot_w = hit.n.dot(light.w);
        if n_dot_w <= 0.0 {
            continue;
        }
        let w_r = 2.0 * n_dot_w * hit.n - light.w;
        let c = (-hit.u.dot(w_r)).max(0.0);
        col += m.spec * m.shine * c.powf(1.0 / (1.0 - m.shine)) * light.col_l;
    }
    col
}

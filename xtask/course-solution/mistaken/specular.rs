//! A mistaken solution of exercise 3, kept for `cargo xtask course-check` only: the exponent
//! `shine` where `1/(1−shine)` belongs, which the starter's test must name
//! (`verdict: specular:exponent-shine`).

use glam::Vec3;

use crate::Hit;

/// What this mistaken specular term adds at `hit`.
pub fn specular(hit: &Hit<'_>) -> Vec3 {
    let m = hit.material;
    let mut col = Vec3::ZERO;
    for light in &hit.lights {
        let n_dot_w = hit.n.dot(light.w);
        if n_dot_w <= 0.0 {
            continue;
        }
        let w_r = 2.0 * n_dot_w * hit.n - light.w;
        let c = (-hit.u.dot(w_r)).max(0.0);
        col += m.spec * m.shine * c.powf(m.shine) * light.col_l;
    }
    col
}

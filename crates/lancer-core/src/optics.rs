//! The handout's two direction formulas: mirror reflection and `VctTransmis` (Snell refraction).

use glam::Vec3;

/// Mirror reflection of the direction `u` about the unit normal `n`: `u - 2 (n·u) n`.
///
/// The side `n` faces does not matter: the formula is symmetric in the sign of `n`.
#[inline]
pub fn reflect(u: Vec3, n: Vec3) -> Vec3 {
    u - 2.0 * n.dot(u) * n
}

/// The handout's `VctTransmis(u, N', delta)` with `delta = n1 / n2`.
///
/// `n_t` is the unit normal on the **transmission side** (`n_t · u >= 0`); callers flip the
/// outward normal at an entry point (see docs/model.md, refraction). A normal that
/// still comes in on the wrong side (an interpolated mesh normal near a silhouette can) is turned
/// round rather than producing the trap's mirror-like direction. Returns `None` on total internal
/// reflection (`1 - delta² (1 - ps²) < 0`), never a NaN.
#[inline]
pub fn vct_transmis(u: Vec3, n_t: Vec3, delta: f32) -> Option<Vec3> {
    let n_t = if n_t.dot(u) < 0.0 { -n_t } else { n_t };
    let ps = n_t.dot(u).clamp(-1.0, 1.0);
    let k = 1.0 - delta * delta * (1.0 - ps * ps);
    if k < 0.0 {
        return None;
    }
    let t = (k.sqrt() - delta * ps) * n_t + delta * u;
    // The formula yields a unit vector for unit inputs; renormalise only to shed rounding.
    Some(t.try_normalize().unwrap_or(u))
}

/// The critical angle (radians) for leaving a medium of index `n_inside` into one of `n_outside`.
/// `None` when there is none (`n_inside <= n_outside`).
pub fn critical_angle(n_inside: f32, n_outside: f32) -> Option<f32> {
    (n_inside > n_outside).then(|| libm::asinf(n_outside / n_inside))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-5
    }

    #[test]
    fn reflection_flips_the_normal_component_only() {
        let n = Vec3::Y;
        let u = Vec3::new(1.0, -1.0, 0.0).normalize();
        assert!(close(reflect(u, n), Vec3::new(1.0, 1.0, 0.0).normalize()));
        // Either orientation of the normal gives the same mirror direction.
        assert!(close(reflect(u, -n), reflect(u, n)));
        // Normal incidence comes straight back.
        assert!(close(reflect(-Vec3::Y, n), Vec3::Y));
    }

    #[test]
    fn transmis_at_normal_incidence_goes_straight_through() {
        let u = -Vec3::Y;
        for delta in [1.0 / 1.5, 1.0, 1.5, 1.0 / 2.417] {
            // Entering from above: the transmission side is -N.
            let t = vct_transmis(u, -Vec3::Y, delta).unwrap();
            assert!(close(t, u), "delta {delta}: {t}");
        }
    }

    #[test]
    fn transmis_obeys_snell() {
        let theta = 40f32.to_radians();
        let u = Vec3::new(theta.sin(), -theta.cos(), 0.0);
        let (n1, n2) = (1.0, 1.52);
        let t = vct_transmis(u, -Vec3::Y, n1 / n2).unwrap();
        let sin_t = t.x.hypot(t.z);
        assert!((n1 * theta.sin() - n2 * sin_t).abs() < 1e-5);
        assert!(t.y < 0.0, "the ray keeps going down into the medium");
        assert!((t.length() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn ray_through_a_slab_leaves_parallel_to_itself() {
        let n = 1.7;
        for deg in [0.0f32, 10.0, 35.0, 60.0, 85.0] {
            let a = deg.to_radians();
            let u = Vec3::new(a.sin(), -a.cos(), 0.2 * a.sin()).normalize();
            // Top face (outward normal +y), entering: transmission side is -y.
            let inside = vct_transmis(u, -Vec3::Y, 1.0 / n).unwrap();
            // Bottom face (outward normal -y), leaving: the outward normal is on the transmission side.
            let out = vct_transmis(inside, -Vec3::Y, n).unwrap();
            assert!(close(out, u), "{deg}°: {u} -> {out}");
        }
    }

    #[test]
    fn a_normal_on_the_wrong_side_is_turned_round_not_a_mirror_direction() {
        // The handout's sign trap: given the outward normal at an entry point, the formula would
        // send the ray back up. `vct_transmis` turns such a normal round, so both give Snell's
        // direction, worked out by hand: sin θt = 0.6 / 1.5 = 0.4, cos θt = √0.84.
        let (u, delta) = (Vec3::new(0.6, -0.8, 0.0), 1.0 / 1.5);
        let right = vct_transmis(u, -Vec3::Y, delta).unwrap();
        assert!(close(right, Vec3::new(0.4, -(0.84f32).sqrt(), 0.0)), "{right}");
        assert!(close(vct_transmis(u, Vec3::Y, delta).unwrap(), right));
    }

    #[test]
    fn critical_angle_and_beyond_is_total_internal_reflection() {
        let n = 1.5f32;
        let crit = critical_angle(n, 1.0).unwrap();
        assert!((crit - 0.729_727_7).abs() < 1e-6, "asin(1/1.5) = 41.81°: {crit}");
        // Leaving through a face with outward normal +y (transmission side), from inside.
        let dir = |a: f32| Vec3::new(a.sin(), a.cos(), 0.0);
        let below = vct_transmis(dir(crit - 1e-3), Vec3::Y, n).unwrap();
        assert!(below.y > 0.0 && below.y < 0.1, "near grazing exit: {below}");
        assert!(!below.is_nan());
        for a in [crit + 1e-3, crit + 0.2, 1.5] {
            assert_eq!(vct_transmis(dir(a), Vec3::Y, n), None, "angle {a}");
        }
        assert_eq!(critical_angle(1.0, 1.5), None);
    }
}

/// Fresnel reflectance of unpolarised light at a smooth dielectric interface, going from index
/// `eta_i` into `eta_t`, with `cos_i` the cosine of the incidence angle (taken as its absolute
/// value). 1 on total internal reflection; `R` and `T = 1 − R` always in [0, 1].
pub fn fresnel_dielectric(cos_i: f32, eta_i: f32, eta_t: f32) -> f32 {
    let cos_i = cos_i.abs().min(1.0);
    let sin_t = eta_i / eta_t * (1.0 - cos_i * cos_i).max(0.0).sqrt();
    if sin_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t * sin_t).max(0.0).sqrt();
    let rs = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
    let rp = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
    // The denominators vanish only at grazing incidence with cos_t = 0 too, i.e. sin_t = 1: TIR.
    let r = 0.5 * (rs * rs + rp * rp);
    if r.is_finite() { r.clamp(0.0, 1.0) } else { 1.0 }
}

/// Schlick's approximation of Fresnel reflectance: `F0 + (1 − F0)(1 − cos θ)⁵`.
#[inline]
pub fn schlick(cos_i: f32, f0: f32) -> f32 {
    let m = (1.0 - cos_i.abs().min(1.0)).max(0.0);
    f0 + (1.0 - f0) * m * m * m * m * m
}

/// Reflectance at normal incidence between indices 1 and `n`: `((n − 1) / (n + 1))²`.
#[inline]
pub fn f0_from_index(n: f32) -> f32 {
    let r = (n - 1.0) / (n + 1.0);
    r * r
}

#[cfg(test)]
mod fresnel_tests {
    use super::*;

    #[test]
    fn schlick_and_exact_fresnel_agree_at_normal_incidence() {
        assert!((f0_from_index(1.5) - 0.04).abs() < 1e-7);
        assert!((schlick(1.0, f0_from_index(1.5)) - 0.04).abs() < 1e-7);
        assert!((fresnel_dielectric(1.0, 1.0, 1.5) - 0.04).abs() < 1e-6);
        assert!((fresnel_dielectric(1.0, 1.5, 1.0) - 0.04).abs() < 1e-6);
        assert!((schlick(0.0, 0.04) - 1.0).abs() < 1e-7, "grazing: everything reflects");
        assert_eq!(fresnel_dielectric(1.0, 1.0, 1.0), 0.0, "index-matched: nothing reflects");
    }

    #[test]
    fn exact_fresnel_is_total_past_the_critical_angle_and_never_nan() {
        let crit = critical_angle(1.5, 1.0).unwrap();
        assert_eq!(fresnel_dielectric((crit + 1e-3).cos(), 1.5, 1.0), 1.0);
        assert!(fresnel_dielectric((crit - 1e-2).cos(), 1.5, 1.0) < 1.0);
        for k in 0..=1000 {
            let c = k as f32 / 1000.0;
            for (a, b) in [(1.0, 1.5), (1.5, 1.0), (1.0, 2.4), (2.4, 1.0)] {
                let r = fresnel_dielectric(c, a, b);
                assert!(r.is_finite() && (0.0..=1.0).contains(&r), "cos {c}, {a} -> {b}: {r}");
            }
        }
        // At 45° from air into n = 1.5 (rs = −0.30335, rp = 0.09206, worked out by hand).
        assert!((fresnel_dielectric(std::f32::consts::FRAC_1_SQRT_2, 1.0, 1.5) - 0.050_240).abs() < 1e-5);
        // Brewster's angle: p-polarised reflection vanishes, so R = rs² / 2 there, with rs from
        // the sine form of the Fresnel equations, −sin(θi − θt) / sin(θi + θt).
        let (ti, tt) = (1.5f64.atan(), (1.5f64.atan().sin() / 1.5).asin());
        let rs = -(ti - tt).sin() / (ti + tt).sin();
        let r = fresnel_dielectric(ti.cos() as f32, 1.0, 1.5);
        assert!((r as f64 - rs * rs / 2.0).abs() < 1e-5, "{r} vs {}", rs * rs / 2.0);
    }
}

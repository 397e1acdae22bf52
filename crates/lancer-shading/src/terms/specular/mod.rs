//! The `specular` term's variants: the highlight of a shiny surface.
//!
//! | variant | lobe | strength |
//! |---|---|---|
//! | `phong` (default, the handout's) | `(−u·w_r)^(1/(1−shine))` | `spec · shine` |
//! | `blinn` | `(N·h)^e`, `h = normalize(w − u)` | `spec · shine` |
//! | `blinn-normalized` | `(e + 8)/(8π) · (N·h)^e · (N·w)` | `spec` |
//!
//! Classic mistakes of the course, kept as variants to show them (`lancer terms --mistakes`):
//! `exponent-shine` (the exponent `shine` instead of `1/(1−shine)`) and `sign`
//! (`max(u·w_r, 0)` instead of `max(−u·w_r, 0)`).

pub mod blinn;
pub mod blinn_normalized;
pub mod exponent_shine;
pub mod phong;
pub mod sign;

use glam::Vec3;

/// The Blinn exponent Lancer derives from `shine` when no `exponent` is given: `4 / (1 − shine)`,
/// four times the seed's Phong exponent. The half vector's angle to `N` is about half the
/// mirror direction's angle to the view, and `cos(x/2)^(4e) ≈ cos(x)^e` near the peak, so both
/// variants give highlights of about the same size. `None` (no highlight) for `shine ≥ 1`.
#[inline]
pub fn blinn_exponent(shine: f32) -> Option<f32> {
    (shine < 1.0).then(|| 4.0 / (1.0 - shine))
}

/// `(N·h)^e` with `h = normalize(w − u)`, guarded: 0 when the half vector is undefined (light
/// exactly behind the viewer's direction) or faces away.
#[inline]
pub fn half_vector_lobe(n: Vec3, w: Vec3, u: Vec3, e: f32) -> f32 {
    match (w - u).try_normalize() {
        Some(h) => lobe(n.dot(h).clamp(0.0, 1.0), e),
        None => 0.0,
    }
}

/// `c^e` for `c` in [0, 1]. An exponent that is a whole number but for the rounding of `shine`
/// in single precision (the handout's shine values give 5, 20, 40, 80, 100: 0.975 gives
/// 39.99994) is taken as that whole number and computed by repeated multiplication, much
/// cheaper than `powf`; any other exponent goes to `powf`.
#[inline]
pub fn lobe(c: f32, e: f32) -> f32 {
    match whole_power(e) {
        Some(whole) => c.powi(whole as i32),
        None => libm::powf(c, e),
    }
}

/// The whole number (at most 1024) the exponent `e` is but for the rounding of `shine`, which
/// [`lobe`] computes by repeated multiplication; `None` for any other exponent.
#[inline]
pub fn whole_power(e: f32) -> Option<u32> {
    let whole = e.round();
    ((e - whole).abs() <= 1e-4 * whole && whole <= 1024.0).then_some(whole as u32)
}

/// [`crate::Term::why_idle`] of a highlight whose exponent `formula` (`1/(1 − shine)`) comes
/// from `shine`: at `shine = 1` it is infinite and the highlight vanishes, whatever `spec` is.
pub(crate) fn infinite_exponent(material: &lancer_core::Material, formula: &str) -> Option<String> {
    (material.spec > 0.0 && material.shine >= 1.0).then(|| {
        format!(
            "`shine = 1` makes its exponent {formula} infinite, so the highlight shrinks to nothing (a shine \
             just below 1, such as 0.98, gives a small sharp one)"
        )
    })
}

/// The optional `exponent` parameter shared by both Blinn variants.
pub(crate) const EXPONENT: crate::ParamSpec = crate::ParamSpec {
    name: "exponent",
    default: "4/(1−shine) per material",
    doc: "fixed highlight exponent for every material, instead of one derived from shine",
};

pub(crate) fn read_exponent(p: &mut crate::Params) -> Result<Option<f32>, crate::ParamError> {
    let e = p.number(EXPONENT.name, 0.0, 0.0, 1e6)?;
    Ok((e > 0.0).then_some(e as f32))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_exponents_go_by_multiplication_and_agree_with_powf() {
        // 1/(1 − 0.975) is 39.99994 in f32: taken as 40, which c^40 by hand confirms.
        let e = 1.0 / (1.0 - 0.975f32);
        assert_ne!(e, 40.0);
        let c = 0.9f32;
        let by_hand = (0..40).fold(1.0f32, |acc, _| acc * c);
        assert!((lobe(c, e) - by_hand).abs() <= 1e-6 * by_hand, "{} vs {by_hand}", lobe(c, e));
        // A fractional exponent is left to powf: 0.25^1.5 = 0.125.
        assert!((lobe(0.25, 1.5) - 0.125).abs() < 1e-7);
        assert_eq!(lobe(0.0, 40.0), 0.0);
        assert_eq!(lobe(1.0, 100.0), 1.0);
    }

    #[test]
    fn blinn_peaks_where_phong_does_with_about_the_same_width() {
        // Viewer in the light's mirror direction: both lobes are 1.
        let n = Vec3::Y;
        let w = Vec3::new(1.0, 1.0, 0.0).normalize();
        let u = -Vec3::new(-1.0, 1.0, 0.0).normalize();
        let e = blinn_exponent(0.9).unwrap();
        let peak = half_vector_lobe(n, w, u, e);
        assert!((peak - 1.0).abs() < 1e-5, "peak {peak}");
        // 5° off the mirror direction: the Blinn lobe falls about as fast as Phong's.
        let off = 5f32.to_radians();
        let v = Vec3::new(-(45f32.to_radians() + off).sin(), (45f32.to_radians() + off).cos(), 0.0);
        let phong = off.cos().powf(1.0 / (1.0 - 0.9));
        let blinn = half_vector_lobe(n, w, -v, e);
        assert!((phong - blinn).abs() < 0.02, "phong {phong}, blinn {blinn}");
        assert_eq!(blinn_exponent(1.0), None);
        assert_eq!(half_vector_lobe(n, w, w, 8.0), 0.0, "undefined half vector");
    }
}

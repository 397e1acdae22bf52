//! Arithmetic on eight rays at once (eight f32 lanes, or two halves of four f64 lanes) with the
//! bits of glam's scalar operations: the building blocks the SIMD paths share, so each lane of
//! them gets what the scalar code gives it alone.

use glam::{Mat3A, Vec3};
use wide::{CmpGt, CmpLt, f32x8, f64x4};

/// Eight lanes of a vector, axis by axis.
pub(crate) type V3 = [f32x8; 3];
/// Four lanes of a vector in f64, axis by axis.
pub(crate) type D3 = [f64x4; 3];

/// `a · b` in glam's order: `(x x' + y y') + z z'`, for f32 or f64 lanes.
#[inline(always)]
pub(crate) fn dot<T: Copy + std::ops::Mul<Output = T> + std::ops::Add<Output = T>>(a: &[T; 3], b: &[T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `if a > b { a } else { b }` lane by lane: glam's `max_element` step, NaN included.
#[inline(always)]
pub(crate) fn gt_max(a: f32x8, b: f32x8) -> f32x8 {
    a.cmp_gt(b).blend(a, b)
}

/// glam's `max_element` of `|v|` lane by lane.
#[inline(always)]
pub(crate) fn reach(v: &V3) -> f32x8 {
    gt_max(v[0].abs(), gt_max(v[1].abs(), v[2].abs()))
}

/// `-x` as scalar code negates: the sign bit flipped (wide's `-x` is `0 − x`, which turns −0
/// into +0).
#[inline(always)]
pub(crate) fn neg(x: f32x8) -> f32x8 {
    x ^ f32x8::splat(-0.0)
}

/// [`neg`] in f64.
#[inline(always)]
pub(crate) fn neg64(x: f64x4) -> f64x4 {
    x ^ f64x4::splat(-0.0)
}

/// `v.normalize_or(fallback)` lane by lane (glam's: `v` times the reciprocal of its length
/// where that is finite and positive), in f32.
#[inline(always)]
pub(crate) fn unit_or(v: &V3, fallback: Vec3) -> V3 {
    let rcp = f32x8::ONE / dot(v, v).sqrt();
    let ok = rcp.abs().cmp_lt(f32x8::splat(f32::INFINITY)) & rcp.cmp_gt(f32x8::ZERO);
    std::array::from_fn(|a| ok.blend(v[a] * rcp, f32x8::splat(fallback[a])))
}

/// [`unit_or`] in f64.
#[inline(always)]
pub(crate) fn unit_or64(v: &D3, fallback: [f64; 3]) -> D3 {
    let rcp = f64x4::ONE / dot(v, v).sqrt();
    let ok = rcp.abs().cmp_lt(f64x4::splat(f64::INFINITY)) & rcp.cmp_gt(f64x4::ZERO);
    std::array::from_fn(|a| ok.blend(v[a] * rcp, f64x4::splat(fallback[a])))
}

/// `m v (+ translation)` lane by lane, in glam's order: `((x_axis v.x + y_axis v.y) + z_axis
/// v.z) + translation`.
#[inline(always)]
pub(crate) fn linear(m: &Mat3A, v: &V3, translation: Option<Vec3>) -> V3 {
    let col = |c: glam::Vec3A, a: usize| f32x8::splat(c[a]);
    std::array::from_fn(|a| {
        let sum = col(m.x_axis, a) * v[0] + col(m.y_axis, a) * v[1] + col(m.z_axis, a) * v[2];
        translation.map_or(sum, |t| sum + f32x8::splat(t[a]))
    })
}

/// Lanes `4 half .. 4 half + 4` of `v` in f64.
#[inline(always)]
pub(crate) fn half64(v: &[f32; 8], half: usize) -> f64x4 {
    f64x4::new(std::array::from_fn(|k| v[4 * half + k] as f64))
}

/// `o + t d` in f64 (`o.as_dvec3() + t as f64 * d.as_dvec3()`) for lanes `4 half ..`.
#[inline(always)]
pub(crate) fn on_line64(o: &[[f32; 8]; 3], d: &[[f32; 8]; 3], t: &[f32; 8], half: usize) -> D3 {
    let t = half64(t, half);
    std::array::from_fn(|a| half64(&o[a], half) + t * half64(&d[a], half))
}

/// Two halves of f64 lanes rounded into eight f32 lanes (`as_vec3`).
#[inline(always)]
pub(crate) fn to_f32(halves: [D3; 2]) -> V3 {
    std::array::from_fn(|a| {
        let (lo, hi) = (halves[0][a].to_array(), halves[1][a].to_array());
        f32x8::new(std::array::from_fn(|k| if k < 4 { lo[k] as f32 } else { hi[k - 4] as f32 }))
    })
}

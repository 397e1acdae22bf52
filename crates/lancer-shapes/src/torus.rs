//! The torus around y (major radius 1, tube radius `minor`): ray intersection by a quartic in
//! f64, set up from a point near the torus so the coefficients stay small, and Newton-polished.

use glam::Vec3;

use crate::quartic::{Roots, least_root, least_root_from, polish4, quartic_roots, sorted_rough_roots};

/// The outward unit normal of the torus at a point on it.
pub fn normal(p: Vec3) -> Vec3 {
    let rho = (p.x * p.x + p.z * p.z).sqrt();
    if rho == 0.0 {
        return Vec3::Y;
    }
    // From the tube's centre circle (radius 1 in the xz-plane) to the point.
    let centre = Vec3::new(p.x / rho, 0.0, p.z / rho);
    (p - centre).normalize_or(Vec3::Y)
}

/// Every crossing of the torus surface by the line `o + t d`, ascending, with outward normals:
/// an even number (0, 2 or 4), entering and leaving in turn.
pub fn roots(minor: f32, o: Vec3, d: Vec3) -> Vec<(f32, Vec3)> {
    let (ts, n) = crossings(minor, o, d, f32::NEG_INFINITY, f32::INFINITY);
    ts[..n].iter().map(|&t| (t, normal(o + t * d))).collect()
}

/// The distances of every crossing of the torus surface by the line `o + t d`, ascending: an
/// even number (0, 2 or 4), entering and leaving in turn. No allocation, no normals. When the
/// part of the line that can meet the torus lies outside `(tmin, tmax)`, or misses the slab
/// `|y| ≤ minor` the torus lies in, the quartic is not solved and there are none.
pub fn crossings(minor: f32, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> ([f32; 4], usize) {
    let mut out = [0.0f32; 4];
    let Some(q) = Quartic::of(minor, o, d, tmin, tmax) else {
        return (out, 0);
    };
    let [a3, a2, a1, a0] = q.coefficients;
    let mut ss = quartic_roots(a3, a2, a1, a0);
    pair_up(&mut ss, |x: f64| (((4.0 * x + 3.0 * a3) * x + 2.0 * a2) * x + a1).abs());
    for (slot, s) in out.iter_mut().zip(ss.iter()) {
        *slot = q.t(*s);
    }
    (out, ss.len())
}

/// The quartic in `s` whose roots are where a line meets the torus, `s` measured from a point
/// near the torus along the unit direction: its coefficients, and what maps a root back to the
/// line's `t`.
struct Quartic {
    coefficients: [f64; 4],
    shift: f64,
    len: f64,
}

impl Quartic {
    /// The distance along the caller's line of the root `s`.
    #[inline]
    fn t(&self, s: f64) -> f32 {
        ((s + self.shift) / self.len) as f32
    }

    /// The distance along the caller's line of the least root with `tmin < t < tmax`.
    #[inline]
    fn least_t(&self, tmin: f32, tmax: f32) -> Option<f32> {
        let [a3, a2, a1, a0] = self.coefficients;
        least_root(a3, a2, a1, a0, self.within(tmin, tmax)).map(|s| self.t(s))
    }

    /// [`Quartic::least_t`] from the quartic's rough roots (ascending) and the first of them
    /// already polished ([`least_root_from`]).
    #[inline]
    fn least_t_from(&self, rough: &[f64], first: Option<f64>, tmin: f32, tmax: f32) -> Option<f32> {
        let [a3, a2, a1, a0] = self.coefficients;
        least_root_from(rough, first, a3, a2, a1, a0, self.within(tmin, tmax)).map(|s| self.t(s))
    }

    /// Whether the root `s` is within `tmin < t < tmax` along the caller's line.
    #[inline]
    fn within(&self, tmin: f32, tmax: f32) -> impl Fn(f64) -> bool + '_ {
        move |s| {
            let t = self.t(s);
            t > tmin && t < tmax
        }
    }

    /// The quartic of the line `o + t d` and the torus of tube radius `minor`; `None` when the
    /// part of the line that can meet the torus lies outside `(tmin, tmax)`, or misses the slab
    /// `|y| ≤ minor` the torus lies in, or stays in its hole.
    #[inline]
    fn of(minor: f32, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<Quartic> {
        // The direction is made unit in f64: normalised in f32 it is unit only to 1e-7, and the
        // bounding-sphere step below would lose |o|² · 1e-7 (pinholes from far away).
        let (od, dd) = (o.as_dvec3(), d.as_dvec3());
        let len = dd.length();
        if len == 0.0 || !len.is_finite() {
            return None;
        }
        let dd = dd / len;
        let r = minor as f64;
        // Start from the point of the line nearest the bounding sphere's entry (radius 1 + r),
        // which keeps the quartic's coefficients near 1 however far the origin is.
        let bound = 1.0 + r;
        let b = od.dot(dd);
        // b² − c as bound² − |q|², q the line's point nearest the centre: no cancellation.
        let q = od - b * dd;
        let disc = bound * bound - q.dot(q);
        if disc < 0.0 {
            return None;
        }
        let shift = -b - disc.sqrt();
        let chord = 2.0 * disc.sqrt();
        // The bounding sphere's chord, in the caller's units of t, against the range asked for.
        let (t_in, t_out) = (shift / len, (shift + chord) / len);
        if t_out <= tmin as f64 || t_in >= tmax as f64 {
            return None;
        }
        let p = od + shift * dd;
        // The torus lies in the slab |y| ≤ r: the chord must cross it.
        if dd.y == 0.0 {
            if p.y.abs() > r {
                return None;
            }
        } else {
            let (s0, s1) = ((-r - p.y) / dd.y, (r - p.y) / dd.y);
            let (lo, hi) = (s0.min(s1).max(0.0), s0.max(s1).min(chord));
            if lo > hi {
                return None;
            }
            // Within the slab, a line that stays inside the hole (distance to the axis below
            // 1 − r at both ends, so all along: the squared distance is convex) misses the tube.
            let rho2 = |s: f64| {
                let q = p + s * dd;
                q.x * q.x + q.z * q.z
            };
            let hole = (1.0 - r) * (1.0 - r);
            if rho2(lo) < hole && rho2(hi) < hole {
                return None;
            }
        }
        Some(Quartic { coefficients: coefficients(p, dd, r), shift, len })
    }
}

/// The coefficients `[a3, a2, a1, a0]` of the monic quartic in `s` whose roots are where the
/// line `p + s d` (`|d| = 1`) crosses the torus of tube radius `r`: `|p + s d|² + 1 − r²`
/// squared, minus 4 (x² + z²).
#[inline]
fn coefficients(p: glam::DVec3, d: glam::DVec3, r: f64) -> [f64; 4] {
    let g = p.dot(p) + 1.0 - r * r;
    let h = p.dot(d);
    let horiz_dd = d.x * d.x + d.z * d.z;
    let horiz_pd = p.x * d.x + p.z * d.z;
    let horiz_pp = p.x * p.x + p.z * p.z;
    [4.0 * h, 4.0 * h * h + 2.0 * g - 4.0 * horiz_dd, 4.0 * h * g - 8.0 * horiz_pd, g * g - 4.0 * horiz_pp]
}

/// Whether the ray from `o` along `d` surely meets the torus nowhere ahead (`t > 0`), without
/// solving the quartic: the quartic of the distance along the ray from `o` itself (a point near
/// the torus: within its bounding sphere) has every coefficient clearly positive, so by
/// Descartes' rule of signs it has no positive root. This is the usual case of a ray leaving
/// the torus's surface (a shadow or mirror ray from it) that does not come back to it, about
/// half the torus tests of a scene that shows one. Any doubt (a coefficient near zero, or a
/// farther origin, where the coefficients lose digits) says `false`.
#[inline]
fn never_ahead(minor: f32, o: Vec3, d: Vec3) -> bool {
    let (od, dd) = (o.as_dvec3(), d.as_dvec3());
    let r = minor as f64;
    let bound = 1.0 + r;
    let len = dd.length();
    // (A tube radius of 1 or more, which scenes cannot give, would void the bound on the terms
    // below: the full solve decides.)
    if !(0.0..1.0).contains(&r) || od.length_squared() > bound * bound || len == 0.0 || !len.is_finite() {
        return false;
    }
    // The coefficients of `crossings`, taken at `o`. Every term of them is at most 40 in size
    // (|o| ≤ 1 + r < 2, |d| = 1, r < 1): rounding moves a coefficient by less than 1e-13, far
    // below this margin.
    const CLEAR: f64 = 1e-10;
    coefficients(od, dd / len, r).iter().all(|&a| a > CLEAR)
}

/// A grazing double root may come out of the solver once: with an odd number of roots, the one
/// where the polynomial's `slope` is smallest is doubled, so entering and leaving still alternate.
fn pair_up(roots: &mut Roots, slope: impl Fn(f64) -> f64) {
    if roots.len() % 2 == 1 {
        let i = (0..roots.len()).min_by(|&i, &j| slope(roots[i]).total_cmp(&slope(roots[j]))).unwrap_or(0);
        roots.insert(i, roots[i]);
    }
}

/// The first crossing of the torus surface by `o + t d` with `tmin < t < tmax`, and the
/// outward normal there.
#[cfg(test)]
fn first_hit(minor: f32, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, Vec3)> {
    first_t(minor, o, d, tmin, tmax).map(|t| (t, normal(o + t * d)))
}

/// The distance of the first crossing of the torus surface by `o + t d` with `tmin < t < tmax`.
#[inline]
pub fn first_t(minor: f32, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<f32> {
    if tmin >= 0.0 && never_ahead(minor, o, d) {
        return None;
    }
    // The least root within range, as `crossings` would find it among all of them.
    Quartic::of(minor, o, d, tmin, tmax)?.least_t(tmin, tmax)
}

/// [`first_t`] with `tmin = 0` for up to four lines at once (`n` of them; `o`, `d` in the
/// torus's own space): the checks before the quartic (the sign test of [`never_ahead`], then
/// [`Quartic::of`]'s bounding sphere, range, slab and hole), the quartic's coefficients and the
/// first polish of each quartic's least rough root made four lanes at a time in f64, with the
/// same operations in the same order, so each line gets the bits it gets alone; the rough roots,
/// and the rest of each solve, lane by lane. When a line has a coordinate that is not finite,
/// all of them are left to [`first_t`] (where `min` and `max` meet a NaN).
pub fn first_t4(minor: f32, o: &[Vec3; 4], d: &[Vec3; 4], tmax: &[f32; 4], n: usize) -> [Option<f32>; 4] {
    use wide::{CmpEq, CmpGe, CmpGt, CmpLe, CmpLt, f64x4};
    let mut out = [None; 4];
    if !(0..n).all(|k| o[k].is_finite() && d[k].is_finite()) {
        for k in 0..n {
            out[k] = first_t(minor, o[k], d[k], 0.0, tmax[k]);
        }
        return out;
    }
    // Lanes past `n` repeat the first line; their answers are dropped.
    let lane = |k: usize| if k < n { k } else { 0 };
    let axis = |v: &[Vec3; 4], a: usize| f64x4::new(std::array::from_fn(|k| v[lane(k)][a] as f64));
    let (od, dd) = ([0, 1, 2].map(|a| axis(o, a)), [0, 1, 2].map(|a| axis(d, a)));
    let dot = crate::lanes::dot::<f64x4>;
    let r = minor as f64;
    let bound = 1.0 + r;
    let len = dot(&dd, &dd).sqrt();
    let finite = |x: f64x4| x.abs().cmp_lt(f64x4::splat(f64::INFINITY));
    // `dd / len` (the lanes where `len` is zero or not finite are dropped below).
    let u = dd.map(|c| c / len);
    let usable = !len.cmp_eq(f64x4::ZERO) & finite(len);
    // `never_ahead`: from within the bounding sphere, every coefficient of the quartic taken
    // at the origin clearly positive.
    let never = if (0.0..1.0).contains(&r) {
        let within = dot(&od, &od).cmp_le(f64x4::splat(bound * bound)) & usable;
        let clear = f64x4::splat(1e-10);
        let c = coefficients4(&od, &u, r);
        within & c[0].cmp_gt(clear) & c[1].cmp_gt(clear) & c[2].cmp_gt(clear) & c[3].cmp_gt(clear)
    } else {
        f64x4::ZERO
    };
    // `Quartic::of`: the bounding sphere's chord, from the point nearest its entry.
    let b = dot(&od, &u);
    let q: [f64x4; 3] = std::array::from_fn(|a| od[a] - b * u[a]);
    let disc = f64x4::splat(bound * bound) - dot(&q, &q);
    let root = disc.sqrt();
    let shift = crate::lanes::neg64(b) - root;
    let chord = f64x4::splat(2.0) * root;
    let (t_in, t_out) = (shift / len, (shift + chord) / len);
    let limit = f64x4::new(std::array::from_fn(|k| tmax[lane(k)] as f64));
    let ahead = !t_out.cmp_le(f64x4::ZERO) & !t_in.cmp_ge(limit);
    let mut live = usable & !never & !disc.cmp_lt(f64x4::ZERO) & ahead;
    let p: [f64x4; 3] = std::array::from_fn(|a| od[a] + shift * u[a]);
    // The slab |y| ≤ r: a level line must lie in it; any other must cross it within the chord,
    // and not stay inside the hole there.
    let rr = f64x4::splat(r);
    let level = u[1].cmp_eq(f64x4::ZERO);
    let (s0, s1) = ((f64x4::splat(-r) - p[1]) / u[1], (rr - p[1]) / u[1]);
    let (lo, hi) = (s0.min(s1).max(f64x4::ZERO), s0.max(s1).min(chord));
    let rho2 = |s: f64x4| {
        let (x, z) = (p[0] + s * u[0], p[2] + s * u[2]);
        x * x + z * z
    };
    let hole = f64x4::splat((1.0 - r) * (1.0 - r));
    let in_hole = rho2(lo).cmp_lt(hole) & rho2(hi).cmp_lt(hole);
    let crossing = !lo.cmp_gt(hi) & !in_hole;
    live &= level.blend(!p[1].abs().cmp_gt(rr), crossing);
    let live = live.move_mask();
    if live == 0 {
        return out;
    }
    let c4 = coefficients4(&p, &u, r);
    let c = c4.map(f64x4::to_array);
    let (shift, len) = (shift.to_array(), len.to_array());
    // The rough roots lane by lane; the least of each polished four lanes at a time, the rest
    // (where the least is not taken) lane by lane.
    let mut rough = [Roots::default(); 4];
    let mut starts = [0.0f64; 4];
    for k in (0..n).filter(|k| live >> k & 1 == 1) {
        rough[k] = sorted_rough_roots(c[0][k], c[1][k], c[2][k], c[3][k]);
        if let Some(&y) = rough[k].first() {
            starts[k] = y - c[0][k] / 4.0;
        }
    }
    let first = polish4(f64x4::new(starts), c4[0], c4[1], c4[2], c4[3]).to_array();
    for k in (0..n).filter(|k| live >> k & 1 == 1) {
        let q = Quartic { coefficients: [c[0][k], c[1][k], c[2][k], c[3][k]], shift: shift[k], len: len[k] };
        let polished = (!rough[k].is_empty()).then_some(first[k]);
        out[k] = q.least_t_from(&rough[k], polished, 0.0, tmax[k]);
    }
    out
}

/// [`coefficients`] four lanes at a time, in the same order.
#[inline(always)]
fn coefficients4(p: &[wide::f64x4; 3], d: &[wide::f64x4; 3], r: f64) -> [wide::f64x4; 4] {
    use wide::f64x4;
    let s = f64x4::splat;
    let g = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) + s(1.0) - s(r * r);
    let h = p[0] * d[0] + p[1] * d[1] + p[2] * d[2];
    let horiz_dd = d[0] * d[0] + d[2] * d[2];
    let horiz_pd = p[0] * d[0] + p[2] * d[2];
    let horiz_pp = p[0] * p[0] + p[2] * p[2];
    [
        s(4.0) * h,
        s(4.0) * h * h + s(2.0) * g - s(4.0) * horiz_dd,
        s(4.0) * h * g - s(8.0) * horiz_pd,
        g * g - s(4.0) * horiz_pp,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_lines_at_once_get_the_first_crossing_each_gets_alone() {
        // Lines from on and near the tube (leaving it, as shadow and mirror rays do), from
        // inside the bounding sphere, from far away, level with the torus's plane, grazing it,
        // with short limits, and a NaN origin; one to four at a time: each the bits `first_t`
        // gives it alone.
        let mut f = crate::testing::uniform(0xD1B5_4A32_D192_ED03);
        let (mut hits, mut cases) = (0, 0);
        for case in 0..40_000 {
            let minor = [0.05, 0.25, 0.278, 0.6][case % 4];
            let n = 1 + case % 4;
            let mut o = [Vec3::ZERO; 4];
            let mut d = [Vec3::ZERO; 4];
            let mut tmax = [f32::INFINITY; 4];
            for k in 0..4 {
                let (a, b) = (f(0.0, std::f32::consts::TAU), f(0.0, std::f32::consts::TAU));
                let (around, across) =
                    (Vec3::new(a.cos(), 0.0, a.sin()), Vec3::new(a.cos() * b.cos(), b.sin(), a.sin() * b.cos()));
                o[k] = match (case / 4 + k) % 5 {
                    0 => around + across * minor * (1.0 + 1e-5),
                    1 => around + across * minor * f(0.9, 1.3),
                    2 => Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)) * (1.0 + minor),
                    3 => Vec3::new(f(-1.0, 1.0), f(-0.1, 0.1), f(-1.0, 1.0)) * 4e3,
                    _ => Vec3::new(f(-5.0, 5.0), f(-5.0, 5.0), f(-5.0, 5.0)),
                };
                let aim = around * f(0.6, 1.4) + Vec3::Y * f(-minor, minor) * 1.2;
                d[k] = match (case + k) % 6 {
                    0 => Vec3::new(f(-1.0, 1.0), 0.0, f(-1.0, 1.0)) * f(0.1, 10.0),
                    1 => Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)) * f(0.1, 10.0),
                    _ => (aim - o[k]) * f(0.01, 3.0),
                };
                if case % 3 == 0 {
                    tmax[k] = f(0.0, 2.0) * (aim - o[k]).length() / d[k].length().max(1e-30);
                }
                if case % 997 == 0 && k == 1 {
                    o[k].x = f32::NAN;
                }
            }
            let got = first_t4(minor, &o, &d, &tmax, n);
            for k in 0..n {
                let want = first_t(minor, o[k], d[k], 0.0, tmax[k]);
                assert_eq!(got[k].map(f32::to_bits), want.map(f32::to_bits), "{minor} {} {} {}", o[k], d[k], tmax[k]);
                (hits, cases) = (hits + usize::from(want.is_some()), cases + 1);
            }
            assert!(got[n..].iter().all(Option::is_none));
        }
        assert!(hits > cases / 5 && hits < cases * 4 / 5, "{hits} of {cases}");
    }

    #[test]
    fn hits_the_tube_where_expected() {
        // Down the y axis from above at x = 1: the tube's top at y = minor.
        let (t, n) = first_hit(0.25, Vec3::new(1.0, 5.0, 0.0), -Vec3::Y, 0.0, f32::INFINITY).unwrap();
        assert!((t - 4.75).abs() < 1e-5 && (n - Vec3::Y).length() < 1e-5);
        // Through the hole: no hit.
        assert!(first_hit(0.25, Vec3::new(0.0, 5.0, 0.0), -Vec3::Y, 0.0, f32::INFINITY).is_none());
        // Along x through the middle: outer wall at x = -1.25 first.
        let (t, n) = first_hit(0.25, Vec3::new(-5.0, 0.0, 0.0), Vec3::X, 0.0, f32::INFINITY).unwrap();
        assert!((t - 3.75).abs() < 1e-5 && (n + Vec3::X).length() < 1e-5);
        // From inside the tube, the next crossing: the inner wall at x = -0.75.
        let (t, _) = first_hit(0.25, Vec3::new(-1.0, 0.0, 0.0), Vec3::X, 0.0, f32::INFINITY).unwrap();
        assert!((t - 0.25).abs() < 1e-5);
    }

    #[test]
    fn regression_an_odd_root_count_is_repaired_by_doubling_the_grazing_root() {
        // Roots 0, 1 (a double root that came out once: slope 0) and 2: the repair keeps all
        // three and doubles the middle one (before the fix it removed two roots).
        let mut roots = Roots::default();
        [0.0, 1.0, 2.0].into_iter().for_each(|x| roots.push(x));
        pair_up(&mut roots, |x| (x - 1.0).abs());
        assert_eq!(&roots[..], [0.0, 1.0, 1.0, 2.0]);
        // An even count is left alone.
        let mut even = Roots::default();
        [0.0, 2.0].into_iter().for_each(|x| even.push(x));
        pair_up(&mut even, |x| (x - 1.0).abs());
        assert_eq!(&even[..], [0.0, 2.0]);
    }

    #[test]
    fn regression_no_pinholes_from_20000_units() {
        // Rays from 20,000 units away aimed across the tube's top must all hit it (before the
        // fix, the f32-normalised direction made b² − c lose 20000² · 1e-7 ≈ 40).
        let target_count = 200;
        let mut missed = 0;
        for k in 0..target_count {
            let a = k as f32 / target_count as f32 * std::f32::consts::TAU;
            let target = Vec3::new(a.cos(), 0.1, a.sin()) * Vec3::new(1.1, 1.0, 1.1);
            let o = Vec3::new(3.0, 16_000.0, -12_000.0);
            if first_hit(0.3, o, target - o, 0.0, f32::INFINITY).is_none() {
                missed += 1;
            }
        }
        assert_eq!(missed, 0);
    }

    #[test]
    fn a_ray_said_never_to_come_back_has_no_crossing_ahead() {
        // Rays from points on and near the tube (as shadow and mirror rays leave it) and from
        // anywhere in the bounding sphere, in every direction, for thin and fat tubes.
        let mut f = crate::testing::uniform(0x9E37_79B9_7F4A_7C15);
        let (mut pruned, mut cases) = (0, 0);
        for case in 0..200_000 {
            let minor = [0.05, 0.25, 0.278, 0.6, 0.95][case % 5];
            let (a, b) = (f(0.0, std::f32::consts::TAU), f(0.0, std::f32::consts::TAU));
            let (around, across) =
                (Vec3::new(a.cos(), 0.0, a.sin()), Vec3::new(a.cos() * b.cos(), b.sin(), a.sin() * b.cos()));
            let o = match case % 3 {
                // On the surface, a hair outside as a spawned ray starts.
                0 => around + across * minor * (1.0 + 1e-5),
                // Near it.
                1 => around + across * minor * f(0.9, 1.3),
                // Anywhere within the bounding sphere.
                _ => Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)) * (1.0 + minor) * 0.577,
            };
            let d = if case % 7 == 0 {
                // Grazing the tube where it leaves: along the surface, tilted a hair outward.
                let tangent = across.cross(Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0))).normalize_or(Vec3::Y);
                (tangent + across * f(0.0, 1e-3)) * f(0.1, 10.0)
            } else {
                Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)) * f(0.1, 10.0)
            };
            cases += 1;
            if never_ahead(minor, o, d) {
                pruned += 1;
                let (ts, n) = crossings(minor, o, d, f32::NEG_INFINITY, f32::INFINITY);
                assert!(
                    ts[..n].iter().all(|&t| t <= 0.0),
                    "case {case}: {o} + t {d}, minor {minor}: crossings {:?}",
                    &ts[..n]
                );
            }
        }
        // The shortcut does cut solving: about a fifth of these rays (random directions; most
        // rays leaving a lit torus do not come back).
        assert!(pruned * 10 > cases, "{pruned} of {cases}");
    }

    #[test]
    fn a_ray_leaving_the_top_of_the_tube_upwards_skips_the_quartic_and_one_across_the_hole_does_not() {
        let top = Vec3::new(1.0, 0.25 * (1.0 + 1e-5), 0.0);
        assert!(never_ahead(0.25, top, Vec3::new(0.1, 1.0, 0.2)));
        // From the inner wall across the hole: it meets the far side of the tube.
        let inner = Vec3::new(0.75 * (1.0 - 1e-5), 0.0, 0.0);
        assert!(!never_ahead(0.25, inner, -Vec3::X));
        assert!(first_t(0.25, inner, -Vec3::X, 0.0, f32::INFINITY).is_some_and(|t| (t - 1.5).abs() < 1e-4));
    }

    #[test]
    fn regression_a_ray_nearly_level_with_the_middle_plane_hits_the_tube() {
        // Through one side of the tube, almost in the torus's plane (before the fix the
        // resolvent cubic's root, tiny and unpolished, lost both crossings).
        for (y0, slope) in [(0.0, 1e-7), (0.0, 1e-6), (0.0, 1.6e-5), (0.05, 1e-12), (0.1, 2e-8)] {
            let (o, d) = (Vec3::new(-5.0, y0, 1.1), Vec3::new(1.0, slope, 0.0));
            let (ts, n) = crossings(0.25, o, d, f32::NEG_INFINITY, f32::INFINITY);
            assert_eq!(n, 2, "y0 {y0}, slope {slope}: {:?}", &ts[..n]);
            let (first, _) = first_hit(0.25, o, d, 0.0, f32::INFINITY).expect("a hit");
            // At z = 1.1 the line passes beside the hole, inside the tube from one side of its
            // outer wall to the other: x² + 1.1² = ρ², ρ = 1 + √(0.25² − y0²), t = 5 ∓ x.
            let rho = 1.0 + (0.25f32 * 0.25 - y0 * y0).sqrt();
            let x = (rho * rho - 1.1 * 1.1).sqrt();
            assert!((ts[0] - (5.0 - x)).abs() < 1e-4 && (ts[1] - (5.0 + x)).abs() < 1e-4, "{:?}", &ts[..n]);
            assert_eq!(first, ts[0]);
        }
        // Slopes from 1e-12 to 1e-4, a little off the plane or on it, beside the hole (two
        // crossings) and across it (four).
        for k in 0..=32 {
            let slope = 10f32.powf(-12.0 + k as f32 * 0.25);
            for y0 in [0.0, 0.05, -0.07, 0.1] {
                for (z, count) in [(1.1, 2), (0.5, 4)] {
                    let (ts, n) =
                        crossings(0.25, Vec3::new(-5.0, y0, z), Vec3::new(1.0, slope, 0.0), f32::MIN, f32::MAX);
                    assert_eq!(n, count, "slope {slope}, y0 {y0}, z {z}: {:?}", &ts[..n]);
                }
            }
        }
    }

    #[test]
    fn a_far_grazing_ray_is_still_accurate() {
        // Tangent to the top of the tube from 1000 units away: the hit stays on the surface.
        let o = Vec3::new(-1000.0, 0.2499, 0.0);
        let (t, _) = first_hit(0.25, o, Vec3::X, 0.0, f32::INFINITY).unwrap();
        let p = o + t * Vec3::X;
        let rho = (p.x * p.x + p.z * p.z).sqrt();
        let dist = ((rho - 1.0).powi(2) + p.y * p.y).sqrt();
        assert!((dist - 0.25).abs() < 1e-4, "{p}: {dist}");
    }
}

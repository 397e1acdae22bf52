//! The torus around y (major radius 1, tube radius `minor`): ray intersection by a quartic in
//! f64, set up from a point near the torus so the coefficients stay small, and Newton-polished.

use glam::Vec3;

use crate::quartic::{Roots, least_root, quartic_roots};

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
    let q = Quartic::of(minor, o, d, tmin, tmax)?;
    let [a3, a2, a1, a0] = q.coefficients;
    let within = |s: f64| {
        let t = q.t(s);
        t > tmin && t < tmax
    };
    least_root(a3, a2, a1, a0, within).map(|s| q.t(s))
}

#[cfg(test)]
mod tests {
    use super::*;

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

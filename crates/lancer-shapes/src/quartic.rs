//! Real roots of polynomials up to degree four, in f64, polished by Newton's method: the torus
//! needs a quartic solver that stays accurate at grazing angles (no speckles).

/// Up to four real roots, kept on the stack (the torus test runs for every ray near a torus).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Roots {
    v: [f64; 4],
    n: usize,
}

impl Roots {
    /// Appends a root (at most four are kept).
    pub fn push(&mut self, x: f64) {
        if self.n < 4 {
            self.v[self.n] = x;
            self.n += 1;
        }
    }

    /// Inserts `x` at `i` (at most four are kept).
    pub fn insert(&mut self, i: usize, x: f64) {
        if self.n < 4 {
            self.v.copy_within(i..self.n, i + 1);
            self.v[i] = x;
            self.n += 1;
        }
    }
}

impl std::ops::Deref for Roots {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        &self.v[..self.n]
    }
}

impl std::ops::DerefMut for Roots {
    fn deref_mut(&mut self) -> &mut [f64] {
        &mut self.v[..self.n]
    }
}

/// Real roots of `x² + b x + c = 0`, by the cancellation-free formula.
fn quadratic(b: f64, c: f64, out: &mut Roots) {
    let disc = b * b - 4.0 * c;
    if disc < 0.0 {
        // A double root pushed below zero by rounding is still a (grazing) root.
        if disc > -1e-12 * (b * b).max(1.0) {
            out.push(-b / 2.0);
        }
        return;
    }
    let q = -0.5 * (b + disc.sqrt().copysign(b));
    if q == 0.0 {
        out.push(0.0);
        return;
    }
    out.push(q);
    out.push(c / q);
}

/// The largest real root of the monic cubic `x³ + a x² + b x + c = 0`.
fn largest_cubic_root(a: f64, b: f64, c: f64) -> f64 {
    const THIRD: f64 = 1.0 / 3.0;
    // Depressed: x = y − a/3, y³ + p y + q = 0. (Products by 1/3 and 1/27, not divisions: the
    // divisions' latency was most of this function's.)
    let a3 = a * THIRD;
    let p = b - a * a3;
    let q = (2.0 / 27.0) * a * a * a - a3 * b + c;
    let (half_q2, third_p3) = (0.25 * q * q, (1.0 / 27.0) * p * p * p);
    let disc = half_q2 + third_p3;
    let y = if disc > 0.0 {
        // One real root (Cardano): u + v with u³ the larger of −q/2 ± √disc (no cancellation)
        // and v from u v = −p/3: one cube root instead of two.
        let s = disc.sqrt();
        let u = libm::cbrt(if q > 0.0 { -0.5 * q - s } else { -0.5 * q + s });
        if u == 0.0 { 0.0 } else { u - p * THIRD / u }
    } else if p == 0.0 {
        0.0
    } else {
        // Three real roots (trigonometric form); k = 0 gives the largest.
        let m = 2.0 * (-p * THIRD).sqrt();
        let arg = (3.0 * q / (p * m)).clamp(-1.0, 1.0);
        m * libm::cos(libm::acos(arg) * THIRD)
    };
    let mut x = y - a3;
    // The trigonometric and Cardano forms lose digits near a multiple root (`disc` near zero
    // against its terms), and the root loses them when it comes out much smaller than the
    // cubic's scale (`a/3` and `√|p|`: terms that cancelled, as for a nearly even quartic whose
    // resolvent root is tiny): polished then, by Newton's method. (Elsewhere a polish moved no
    // root of the benchmark scene's 196k torus tests by a bit of the final f32 distance.)
    if disc.abs() > 1e-6 * (half_q2 + third_p3.abs()) && x * x > 1e-6 * (a3 * a3 + p.abs()) {
        return x;
    }
    // A step that leaves `x` as it is would be repeated as it is: the rest is skipped.
    for _ in 0..3 {
        let f = ((x + a) * x + b) * x + c;
        let df = (3.0 * x + 2.0 * a) * x + b;
        if df == 0.0 {
            break;
        }
        let next = x - f / df;
        if next == x {
            break;
        }
        x = next;
    }
    x
}

/// Real roots of the monic quartic `x⁴ + a x³ + b x² + c x + d = 0`, ascending, each polished
/// by Newton's method on the quartic itself. Double roots may appear once or twice.
pub fn quartic_roots(a: f64, b: f64, c: f64, d: f64) -> Roots {
    let mut xs = Roots::default();
    for &y in rough_roots(a, b, c, d).iter() {
        let x = polish(y - a / 4.0, a, b, c, d);
        if x.is_finite() {
            xs.push(x);
        }
    }
    xs.sort_by(f64::total_cmp);
    xs
}

/// The least of the roots [`quartic_roots`] gives that `accept` takes, with the same bits, the
/// others mostly left unpolished: the rough roots are polished in ascending order, and one
/// that starts well past the least accepted so far is not polished at all (polishing moves a
/// root by far less). The exception is an exact double root, whose Newton steps may fling a
/// rough root far from where it started: such a stray root is not taken here, so the answer
/// is then nearer a true root than `quartic_roots`' least.
pub fn least_root(a: f64, b: f64, c: f64, d: f64, accept: impl Fn(f64) -> bool) -> Option<f64> {
    let rough = sorted_rough_roots(a, b, c, d);
    let first = rough.first().map(|&y| polish(y - a / 4.0, a, b, c, d));
    least_root_from(&rough, first, a, b, c, d, accept)
}

/// The rough roots [`least_root`] starts from, ascending.
#[inline]
pub(crate) fn sorted_rough_roots(a: f64, b: f64, c: f64, d: f64) -> Roots {
    let mut rough = rough_roots(a, b, c, d);
    rough.sort_by(f64::total_cmp);
    rough
}

/// [`least_root`] from its rough roots (`rough`, ascending) and the first of them already
/// polished (`first`, `None` when there is none).
#[inline]
pub(crate) fn least_root_from(
    rough: &[f64],
    first: Option<f64>,
    a: f64,
    b: f64,
    c: f64,
    d: f64,
    accept: impl Fn(f64) -> bool,
) -> Option<f64> {
    let mut best: Option<f64> = None;
    for (k, &y) in rough.iter().enumerate() {
        let start = y - a / 4.0;
        if best.is_some_and(|b| start > b + 1e-6 * b.abs().max(1.0)) {
            break;
        }
        let x = match (k, first) {
            (0, Some(x)) => x,
            _ => polish(start, a, b, c, d),
        };
        if x.is_finite() && accept(x) && best.is_none_or(|b| x < b) {
            best = Some(x);
        }
    }
    best
}

/// [`polish`] of four starts at once, each with its own quartic (the coefficients four lanes
/// at a time): the same steps lane by lane, each lane stopping where it stops alone, so the
/// same bits.
#[inline]
pub(crate) fn polish4(x: wide::f64x4, a: wide::f64x4, b: wide::f64x4, c: wide::f64x4, d: wide::f64x4) -> wide::f64x4 {
    use wide::{CmpEq, CmpLe, f64x4};
    let s = f64x4::splat;
    let (mut x, mut going) = (x, f64x4::from(f64::from_bits(u64::MAX)));
    for _ in 0..4 {
        let f = (((x + a) * x + b) * x + c) * x + d;
        let df = ((s(4.0) * x + s(3.0) * a) * x + s(2.0) * b) * x + c;
        let flat = df.cmp_eq(f64x4::ZERO);
        let step = f / df;
        let moved = x - step;
        let on = going & !flat;
        x = on.blend(moved, x);
        let close = step.abs().cmp_le(s(1e-14) * x.abs().max(s(1.0)));
        going = on & !close;
        if going.move_mask() == 0 {
            break;
        }
    }
    x
}

/// The roots of the depressed quartic (`x = y − a/4`) of `x⁴ + a x³ + b x² + c x + d`, before
/// any polish, in no particular order.
#[inline]
fn rough_roots(a: f64, b: f64, c: f64, d: f64) -> Roots {
    // Depressed: x = y − a/4, y⁴ + p y² + q y + r = 0.
    let a2 = a * a;
    let p = b - 3.0 * a2 / 8.0;
    let q = c - a * b / 2.0 + a2 * a / 8.0;
    let r = d - a * c / 4.0 + a2 * b / 16.0 - 3.0 * a2 * a2 / 256.0;
    let mut ys = Roots::default();
    let scale = p.abs().max(r.abs().sqrt()).max(1e-300);
    if q.abs() <= 1e-12 * scale * scale.sqrt() {
        // Biquadratic: y² = z with z² + p z + r = 0.
        let mut zs = Roots::default();
        quadratic(p, r, &mut zs);
        for &z in zs.iter() {
            if z >= 0.0 {
                let s = z.sqrt();
                ys.push(s);
                ys.push(-s);
            }
        }
    } else {
        // Ferrari: with m > 0 a root of 8m³ + 8p m² + (2p² − 8r) m − q² = 0,
        // y⁴ + p y² + q y + r = (y² + p/2 + m)² − (√(2m) y − q / (2√(2m)))².
        let m = largest_cubic_root(p, p * p / 4.0 - r, -q * q / 8.0).max(1e-300);
        let s = (2.0 * m).sqrt();
        quadratic(s, p / 2.0 + m - q / (2.0 * s), &mut ys);
        quadratic(-s, p / 2.0 + m + q / (2.0 * s), &mut ys);
    }
    ys
}

/// A root of `x⁴ + a x³ + b x² + c x + d` polished by Newton's method from `x`.
#[inline]
fn polish(mut x: f64, a: f64, b: f64, c: f64, d: f64) -> f64 {
    for _ in 0..4 {
        let f = (((x + a) * x + b) * x + c) * x + d;
        let df = ((4.0 * x + 3.0 * a) * x + 2.0 * b) * x + c;
        if df == 0.0 {
            break;
        }
        let step = f / df;
        x -= step;
        if step.abs() <= 1e-14 * x.abs().max(1.0) {
            break;
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    fn expand(roots: [f64; 4]) -> (f64, f64, f64, f64) {
        let [r1, r2, r3, r4] = roots;
        let a = -(r1 + r2 + r3 + r4);
        let b = r1 * r2 + r1 * r3 + r1 * r4 + r2 * r3 + r2 * r4 + r3 * r4;
        let c = -(r1 * r2 * r3 + r1 * r2 * r4 + r1 * r3 * r4 + r2 * r3 * r4);
        let d = r1 * r2 * r3 * r4;
        (a, b, c, d)
    }

    #[test]
    fn four_polishes_at_once_have_the_bits_of_each_alone() {
        // Starts near roots, far from them, at a flat point of the quartic (a zero slope stops
        // the steps at once), on a double root and at NaN; four quartics side by side.
        let mut f = crate::testing::uniform(0x5851_F42D_4C95_7F2D);
        let mut moved = 0;
        for round in 0..20_000 {
            let quartic = |_| -> [f64; 4] {
                let r: [f64; 4] = std::array::from_fn(|_| f(-3.0, 3.0) as f64);
                // (x - r0)(x - r1)(x - r2)(x - r3), or x⁴ + 1 (no real root, flat at 0).
                if round % 11 == 0 {
                    return [0.0, 0.0, 0.0, 1.0];
                }
                let (s1, s2) = (r[0] + r[1], r[0] * r[1]);
                let (t1, t2) = (r[2] + r[3], r[2] * r[3]);
                [-(s1 + t1), s2 + t2 + s1 * t1, -(s1 * t2 + s2 * t1), s2 * t2]
            };
            let qs: [[f64; 4]; 4] = std::array::from_fn(quartic);
            let starts: [f64; 4] = std::array::from_fn(|k| match (round + k) % 7 {
                0 => 0.0,
                1 if round % 13 == 0 => f64::NAN,
                _ => f(-4.0, 4.0) as f64,
            });
            let lane = |i: usize| wide::f64x4::new(std::array::from_fn(|k| qs[k][i]));
            let got = polish4(wide::f64x4::new(starts), lane(0), lane(1), lane(2), lane(3)).to_array();
            for k in 0..4 {
                let [a, b, c, d] = qs[k];
                let want = polish(starts[k], a, b, c, d);
                assert_eq!(got[k].to_bits(), want.to_bits(), "{:?} from {}", qs[k], starts[k]);
                moved += usize::from(want != starts[k]);
            }
        }
        assert!(moved > 60_000, "{moved}");
    }

    #[test]
    fn recovers_four_known_roots() {
        for roots in [[-3.0, -1.0, 2.0, 5.0], [0.1, 0.2, 0.3, 0.4], [-10.0, 1e-3, 2.0, 7.5], [1.0, 1.0, 3.0, 4.0]] {
            let (a, b, c, d) = expand(roots);
            let got = quartic_roots(a, b, c, d);
            for r in roots {
                assert!(got.iter().any(|g| (g - r).abs() < 1e-6), "{roots:?}: {got:?}");
            }
        }
    }

    #[test]
    fn the_largest_root_of_a_cubic_with_one_real_root_either_sign() {
        // (x − r)(x² + b x + c) with x² + b x + c > 0 everywhere: Cardano's branch, both signs
        // of its q, and p of both signs.
        for (r, b, c) in [(2.0, 2.0, 3.0), (-2.0, 2.0, 3.0), (0.5, 0.0, 1.0), (-7.5, -1.0, 9.0), (1e-3, 0.1, 0.01)] {
            let (a2, a1, a0) = (b - r, c - r * b, -r * c);
            let x = largest_cubic_root(a2, a1, a0);
            assert!((x - r).abs() <= 1e-12 * r.abs().max(1.0), "root {r}: got {x}");
        }
    }

    #[test]
    fn the_largest_cubic_root_stays_accurate_near_a_double_root() {
        // (x − 1)²(x + 2) and neighbours whose two largest roots are 1e-9 to 1e-3 apart: where
        // the closed forms lose digits, the polish must bring the root back.
        for gap in [0.0, 1e-9, 1e-6, 1e-3] {
            for sign in [1.0, -1.0] {
                let (r1, r2, r3) = (1.0 + sign * gap, 1.0, -2.0);
                let (a, b, c) = (-(r1 + r2 + r3), r1 * r2 + r1 * r3 + r2 * r3, -(r1 * r2 * r3));
                let x = largest_cubic_root(a, b, c);
                let f = ((x + a) * x + b) * x + c;
                // (Rounding may make the close pair complex: the root found is then −2.)
                let near = [r1, r2, r3].iter().any(|r| (x - r).abs() < 1e-6);
                assert!(f.abs() < 1e-14 && near, "gap {gap}: {x}, f {f}");
            }
        }
    }

    #[test]
    fn the_least_accepted_root_is_the_one_every_root_polished_gives() {
        // Random quartics (four real roots, two close ones, a double one, two real and two
        // complex) and random ranges: `least_root` picks, to the bit, the least root of
        // `quartic_roots` in range, but for an exact double root (see below).
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let mut f = move |lo: f64, hi: f64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            lo + (hi - lo) * (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut found, mut flung) = (0, 0);
        for case in 0..20_000 {
            let r = [f(-3.0, 3.0), f(-3.0, 3.0), f(-3.0, 3.0), f(-3.0, 3.0)];
            let (roots, real) = match case % 4 {
                0 => (r, 4),
                1 => ([r[0], r[0] + f(0.0, 1e-4), r[2], r[3]], 4),
                2 => ([r[0], r[0], r[2], r[3]], 4),
                _ => ([r[0], r[1], 0.0, 0.0], 2),
            };
            let (a, b, c, d) = if real == 2 {
                // (x − r0)(x − r1)(x² + u x + v), v > u²/4: two complex roots.
                let (u, v) = (f(-1.0, 1.0), f(1.0, 3.0));
                let (p, q) = (-(roots[0] + roots[1]), roots[0] * roots[1]);
                (p + u, q + p * u + v, p * v + q * u, q * v)
            } else {
                expand(roots)
            };
            let (lo, hi) = (f(-4.0, 2.0), f(-1.0, 4.0));
            let accept = |x: f64| x > lo && x < hi;
            let want = quartic_roots(a, b, c, d).iter().copied().find(|&x| accept(x));
            let got = least_root(a, b, c, d, accept);
            if case % 4 != 2 {
                assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "case {case}: {roots:?} in ({lo}, {hi})");
            } else {
                // An exact double root, where Newton's method converges slowly and a step from
                // a rough root may fling it far (both solvers then miss it by up to 1e-1): a
                // root in range, never farther from a true one than `quartic_roots`' is.
                let miss = |x: f64| roots[..real].iter().map(|r| (x - r).abs()).fold(f64::INFINITY, f64::min);
                let fine = match (got, want) {
                    (Some(x), Some(w)) => accept(x) && miss(x) <= miss(w) + 1e-12,
                    (got, want) => got == want,
                };
                assert!(fine, "case {case}: {roots:?} in ({lo}, {hi}): {got:?}, {want:?}");
                flung += usize::from(got != want);
            }
            found += usize::from(want.is_some());
        }
        assert!(found > 10_000 && flung < 500, "{found} found, {flung} flung");
    }

    #[test]
    fn regression_a_nearly_even_quartic_keeps_its_real_roots() {
        // y⁴ + 3y² + q y − 4 = (y² + 4)(y² − 1) + q y: roots near ±1 and a complex pair. With q
        // tiny the resolvent's largest root is tiny too, left by cancellation from the closed
        // form (before the fix, unpolished there, it sent the rough roots to 1e69: no root).
        for q in [1e-11, 1e-9, 1e-7, -1e-8] {
            let got = quartic_roots(0.0, 3.0, q, -4.0);
            assert_eq!(got.len(), 2, "q {q}: {got:?}");
            assert!((got[0] + 1.0).abs() < 1e-6 && (got[1] - 1.0).abs() < 1e-6, "q {q}: {got:?}");
        }
    }

    #[test]
    fn two_real_roots_and_none() {
        // (x² + 1)(x − 2)(x + 3): only 2 and −3 are real.
        let got = quartic_roots(1.0, -5.0, 1.0, -6.0);
        assert_eq!(got.len(), 2, "{got:?}");
        assert!((got[0] + 3.0).abs() < 1e-9 && (got[1] - 2.0).abs() < 1e-9);
        // (x² + 1)(x² + 4): no real root.
        assert!(quartic_roots(0.0, 5.0, 0.0, 4.0).is_empty());
    }
}

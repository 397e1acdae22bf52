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
    // Depressed: x = y − a/3, y³ + p y + q = 0.
    let p = b - a * a / 3.0;
    let q = 2.0 * a * a * a / 27.0 - a * b / 3.0 + c;
    let shift = -a / 3.0;
    let disc = q * q / 4.0 + p * p * p / 27.0;
    let y = if disc > 0.0 {
        // One real root (Cardano): u + v with u³ the larger of −q/2 ± √disc (no cancellation)
        // and v from u v = −p/3: one cube root instead of two.
        let s = disc.sqrt();
        let u = if q > 0.0 { -q / 2.0 - s } else { -q / 2.0 + s }.cbrt();
        if u == 0.0 { 0.0 } else { u - p / (3.0 * u) }
    } else if p == 0.0 {
        0.0
    } else {
        // Three real roots (trigonometric form); k = 0 gives the largest.
        let m = 2.0 * (-p / 3.0).sqrt();
        let arg = (3.0 * q / (p * m)).clamp(-1.0, 1.0);
        m * (arg.acos() / 3.0).cos()
    };
    let mut x = y + shift;
    // Polish: the trigonometric and Cardano forms lose digits near multiple roots. A step that
    // leaves `x` as it is would be repeated as it is: the rest of the loop is skipped.
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
    let mut xs = Roots::default();
    for &y in ys.iter() {
        let x = {
            let mut x = y - a / 4.0;
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
        };
        if x.is_finite() {
            xs.push(x);
        }
    }
    xs.sort_by(f64::total_cmp);
    xs
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
    fn two_real_roots_and_none() {
        // (x² + 1)(x − 2)(x + 3): only 2 and −3 are real.
        let got = quartic_roots(1.0, -5.0, 1.0, -6.0);
        assert_eq!(got.len(), 2, "{got:?}");
        assert!((got[0] + 3.0).abs() < 1e-9 && (got[1] - 2.0).abs() < 1e-9);
        // (x² + 1)(x² + 4): no real root.
        assert!(quartic_roots(0.0, 5.0, 0.0, 4.0).is_empty());
    }
}

//! The usual mismatches between a renderer's image and the reference, named instead of only
//! scored: rows upside down (or columns mirrored), the sRGB curve missing or applied twice, a
//! constant factor in linear values, channels in another order, and a shift by half a pixel or a
//! whole one.
//!
//! Each is a candidate transform of one image; the pair is compared again with it applied (in
//! the display domain, as the raw comparison). A candidate **explains** the difference when
//! that comparison reaches [`EXPLAINS_DB`] and beats the raw one by [`BETTER_BY_DB`]: a small
//! improvement, or a good score on images that were close already, names nothing.

use glam::Vec3;
use lancer_core::srgb_decode;

use super::metrics::psnr;
use super::read::Image;
use crate::output::srgb_encode;

/// The PSNR (dB) a transformed comparison must reach to explain the difference.
pub(crate) const EXPLAINS_DB: f64 = 40.0;
/// How much better (dB) than the raw comparison it must be.
pub(crate) const BETTER_BY_DB: f64 = 10.0;

/// A mismatch that explains the difference of a pair.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Finding {
    /// A stable name for scripts: `upside_down`, `mirrored`, `srgb_missing`, `srgb_twice`,
    /// `factor`, `channels`, `shift`, `half_pixel_shift`.
    pub(crate) kind: &'static str,
    /// What it looks like, in a few words: "the rows are upside down".
    pub(crate) what: String,
    /// More on it: "B is A flipped vertically (the first row written at the bottom?)".
    pub(crate) detail: String,
    /// How the comparison was made to match: "once flipped".
    pub(crate) undo: String,
    /// The PSNR once undone (infinite: identical).
    pub(crate) psnr: f64,
    /// For a constant factor: B ≈ factor · A in linear values.
    pub(crate) factor: Option<f64>,
}

/// The mean squared errors (display domain, every channel) over the pixels of `cols` × `rows`:
/// of the pairs `pair(x, y)` gives, and of `a` and `b` as they are over the same pixels (what
/// the candidate must beat: a shift compares fewer pixels than the whole images).
fn mse(
    a: &Image,
    b: &Image,
    cols: std::ops::Range<u32>,
    rows: std::ops::Range<u32>,
    pair: impl Fn(u32, u32) -> (Vec3, Vec3),
) -> (f64, f64) {
    let (mut sum, mut raw) = (0.0f64, 0.0f64);
    let mut n = 0usize;
    for y in rows {
        for x in cols.clone() {
            let (p, q) = pair(x, y);
            let (d, r) = (p - q, a.at(x, y) - b.at(x, y));
            sum += f64::from(d.dot(d));
            raw += f64::from(r.dot(r));
            n += 3;
        }
    }
    if n == 0 { (f64::INFINITY, 0.0) } else { (sum / n as f64, raw / n as f64) }
}

/// Each channel through `f`.
fn each(p: Vec3, f: impl Fn(f32) -> f32) -> Vec3 {
    Vec3::new(f(p.x), f(p.y), f(p.z))
}

/// The linear factor k that best takes `a` to `b` (least squares, b ≈ k·a), from the channels
/// neither clipped (at 1 in the display domain) nor black in `a`; none when there are none.
fn factor(a: &Image, b: &Image) -> Option<f64> {
    let (mut ab, mut aa) = (0.0f64, 0.0f64);
    for i in 0..a.linear.len() {
        for c in 0..3 {
            let (da, db) = (a.display[i][c], b.display[i][c]);
            if da > 0.0 && da < 0.999 && db < 0.999 {
                let (la, lb) = (f64::from(a.linear[i][c]), f64::from(b.linear[i][c]));
                ab += la * lb;
                aa += la * la;
            }
        }
    }
    (aa > 0.0).then(|| ab / aa).filter(|k| k.is_finite() && *k > 0.0)
}

/// Where a shift by (dx, dy) moves the picture, in words: B(x, y) = A(x + dx, y + dy) shows A's
/// picture moved by (−dx, −dy).
fn direction(dx: f32, dy: f32) -> String {
    let h = if dx > 0.0 {
        Some("left")
    } else if dx < 0.0 {
        Some("right")
    } else {
        None
    };
    let v = if dy > 0.0 {
        Some("up")
    } else if dy < 0.0 {
        Some("down")
    } else {
        None
    };
    match (v, h) {
        (Some(v), Some(h)) => format!("{v} and to the {h}"),
        (None, Some(h)) => format!("to the {h}"),
        (Some(v), None) => v.to_owned(),
        (None, None) => "nowhere".to_owned(),
    }
}

/// `x + d` as a formula: `x`, `x + 1`, `y - 0.5`.
fn plus(axis: &str, d: f32) -> String {
    if d == 0.0 {
        axis.to_owned()
    } else if d > 0.0 {
        format!("{axis} + {d}")
    } else {
        format!("{axis} - {}", -d)
    }
}

/// Every candidate that explains the difference of `b` from `a` (one size), best first. `raw`
/// is the raw comparison's PSNR; a candidate that compares fewer pixels (a shift) must also beat
/// the raw comparison of those pixels alone.
pub(crate) fn explain(a: &Image, b: &Image, raw: f64) -> Vec<Finding> {
    let (w, h) = (a.width, a.height);
    let all = || (0..w, 0..h);
    let da = |x: u32, y: u32| a.at(x, y);
    let db = |x: u32, y: u32| b.at(x, y);
    let la = |x: u32, y: u32| a.linear[(y * w + x) as usize];
    let mut candidates: Vec<Candidate> = Vec::new();
    let mut add = |kind, what: String, detail: String, undo: &str, (mse, raw): (f64, f64), factor| {
        candidates.push(Candidate {
            finding: Finding { kind, what, detail, undo: undo.to_owned(), psnr: psnr(mse), factor },
            raw: psnr(raw),
        });
    };

    if h >= 2 {
        let (cols, rows) = all();
        add(
            "upside_down",
            "the rows are upside down".into(),
            "B is A flipped vertically (the first row written at the bottom?)".into(),
            "once flipped",
            mse(a, b, cols, rows, |x, y| (da(x, y), db(x, h - 1 - y))),
            None,
        );
    }
    if w >= 2 {
        let (cols, rows) = all();
        add(
            "mirrored",
            "the columns are mirrored".into(),
            "B is A flipped left to right".into(),
            "once mirrored",
            mse(a, b, cols, rows, |x, y| (da(x, y), db(w - 1 - x, y))),
            None,
        );
    }
    let (cols, rows) = all();
    add(
        "srgb_missing",
        "the sRGB curve is missing".into(),
        "B holds A's linear values unencoded (written to PNG or PPM without the curve?)".into(),
        "once B is encoded",
        mse(a, b, cols, rows, |x, y| (da(x, y), each(db(x, y), srgb_encode))),
        None,
    );
    let (cols, rows) = all();
    add(
        "srgb_twice",
        "the sRGB curve is applied once too often".into(),
        "B's linear values are A's encoded ones (encoded twice, or encoded values saved as linear?)".into(),
        "once B is decoded",
        mse(a, b, cols, rows, |x, y| (da(x, y), each(db(x, y), srgb_decode))),
        None,
    );
    if let Some(k) = factor(a, b).filter(|k| (k - 1.0).abs() > 0.01) {
        let (cols, rows) = all();
        let kf = k as f32;
        add(
            "factor",
            format!("B is A times {k:.3} in linear values"),
            "a light, an exposure or a colour off by a constant factor?".into(),
            &format!("once A is scaled by {k:.3}"),
            mse(a, b, cols, rows, |x, y| (each(la(x, y) * kf, srgb_encode), db(x, y))),
            Some(k),
        );
    }
    // B's channel i holds A's channel order[i].
    for (order, name, how) in [
        ([2, 1, 0], "BGR", "red and blue swapped"),
        ([0, 2, 1], "RBG", "green and blue swapped"),
        ([1, 0, 2], "GRB", "red and green swapped"),
        ([1, 2, 0], "GBR", "every channel one place on"),
        ([2, 0, 1], "BRG", "every channel one place back"),
    ] {
        let (cols, rows) = all();
        let mut back = [0usize; 3];
        for (i, &o) in order.iter().enumerate() {
            back[o] = i;
        }
        add(
            "channels",
            format!("the channels are in {name} order"),
            how.into(),
            "once reordered",
            mse(a, b, cols, rows, |x, y| {
                let q = db(x, y);
                (da(x, y), Vec3::new(q[back[0]], q[back[1]], q[back[2]]))
            }),
            None,
        );
    }
    // Shifts: B(x, y) = A(x + dx, y + dy), over the pixels where that is inside A.
    for (dx, dy) in [(1i32, 0i32), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, -1), (1, -1), (-1, 1)] {
        let cols = (-dx).max(0) as u32..(w as i32 - dx.max(0)).max(0) as u32;
        let rows = (-dy).max(0) as u32..(h as i32 - dy.max(0)).max(0) as u32;
        let (fx, fy) = (dx as f32, dy as f32);
        add(
            "shift",
            format!("B is A moved one pixel {}", direction(fx, fy)),
            format!("B(x, y) = A({}, {})", plus("x", fx), plus("y", fy)),
            "once moved back",
            mse(a, b, cols, rows, |x, y| (da((x as i32 + dx) as u32, (y as i32 + dy) as u32), db(x, y))),
            None,
        );
    }
    // Half a pixel: B(x, y) ≈ A(x + dx/2, y + dy/2), the mean (in linear values) of the one,
    // two or four pixels around that point.
    for (dx, dy) in [(1i32, 0i32), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, -1), (1, -1), (-1, 1)] {
        let cols = (-dx).max(0) as u32..(w as i32 - dx.max(0)).max(0) as u32;
        let rows = (-dy).max(0) as u32..(h as i32 - dy.max(0)).max(0) as u32;
        let (fx, fy) = (dx as f32 * 0.5, dy as f32 * 0.5);
        let xs = |x: u32| [x, (x as i32 + dx) as u32];
        let ys = |y: u32| [y, (y as i32 + dy) as u32];
        let corner = if dx != 0 && dy != 0 { " (rays through a pixel's corner instead of its centre?)" } else { "" };
        add(
            "half_pixel_shift",
            format!("B is A shifted half a pixel {}", direction(fx, fy)),
            format!("each pixel the mean of its neighbours, B(x, y) ≈ A({}, {}){corner}", plus("x", fx), plus("y", fy)),
            "once A is shifted likewise",
            mse(a, b, cols, rows, |x, y| {
                let mut sum = Vec3::ZERO;
                for sx in xs(x) {
                    for sy in ys(y) {
                        sum += la(sx, sy);
                    }
                }
                (each(sum / 4.0, srgb_encode), db(x, y))
            }),
            None,
        );
    }

    let mut found: Vec<Finding> = candidates
        .into_iter()
        // The raw comparison over the candidate's pixels must show a difference to explain (a
        // shift leaves out a border, where the whole difference may lie).
        .filter(|c| {
            let p = c.finding.psnr;
            p >= EXPLAINS_DB && c.raw.is_finite() && p >= c.raw.max(raw) + BETTER_BY_DB
        })
        .map(|c| c.finding)
        .collect();
    found.sort_by(|p, q| q.psnr.total_cmp(&p.psnr));
    found
}

/// A transform tried: what it would mean, and the raw PSNR over the pixels it compares.
struct Candidate {
    finding: Finding,
    raw: f64,
}

/// What two sizes that differ suggest, when they are related: one an exact multiple of the
/// other, the same aspect ratio, or width and height swapped.
pub(crate) fn size_hint(a: (u32, u32), b: (u32, u32)) -> Option<String> {
    let multiple = |big: (u32, u32), small: (u32, u32)| {
        let k = big.0 / small.0.max(1);
        (k >= 2 && small.0 * k == big.0 && small.1 * k == big.1).then_some(k)
    };
    if let Some(k) = multiple(b, a) {
        return Some(format!("B is exactly {k} times A's size each way (rendered at another --width?)"));
    }
    if let Some(k) = multiple(a, b) {
        return Some(format!("B is exactly 1/{k} of A's size each way (rendered at another --width?)"));
    }
    if (b.0, b.1) == (a.1, a.0) {
        return Some("B's width and height are A's swapped".to_owned());
    }
    if u64::from(a.0) * u64::from(b.1) == u64::from(b.0) * u64::from(a.1) {
        return Some("B has A's aspect ratio at another size (rendered at another --width?)".to_owned());
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diff::metrics::measure;

    /// Noise in linear values, 8-bit sRGB as a PNG would hold it (so every candidate meets the
    /// rounding a real file has).
    fn noise(w: u32, h: u32, seed: u32) -> Vec<Vec3> {
        let mut s = seed.wrapping_mul(0x9E37_79B9) | 1;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            (s >> 8) as f32 / (1 << 24) as f32
        };
        (0..w * h).map(|_| Vec3::new(next(), next(), next())).collect()
    }

    /// An image whose linear values are `linear`, as an 8-bit sRGB file stores them.
    fn as_png(w: u32, h: u32, linear: &[Vec3]) -> Image {
        let bytes: Vec<u16> = crate::output::to_srgb8(linear).into_iter().map(u16::from).collect();
        Image::from_encoded(w, h, 3, 255, &bytes)
    }

    fn findings(a: &Image, b: &Image) -> Vec<Finding> {
        explain(a, b, psnr(measure(a, b, 0.0).mse))
    }

    /// The best finding's kind and words (what, then detail).
    fn first_kind(a: &Image, b: &Image) -> (&'static str, String) {
        let f = findings(a, b);
        assert!(!f.is_empty(), "nothing found");
        (f[0].kind, if f[0].kind == "channels" { f[0].what.clone() } else { format!("{}: {}", f[0].what, f[0].detail) })
    }

    const W: u32 = 24;
    const H: u32 = 16;

    /// A W × H image of `f(x, y)`.
    fn grid(f: impl Fn(u32, u32) -> Vec3) -> Vec<Vec3> {
        (0..H).flat_map(|y| (0..W).map(move |x| (x, y))).map(|(x, y)| f(x, y)).collect()
    }

    #[test]
    fn rows_upside_down_are_named() {
        let lin = noise(W, H, 1);
        let b = grid(|x, y| lin[((H - 1 - y) * W + x) as usize]);
        let (kind, what) = first_kind(&as_png(W, H, &lin), &as_png(W, H, &b));
        assert_eq!(kind, "upside_down", "{what}");
        assert!(what.starts_with("the rows are upside down: B is A flipped vertically"), "{what}");
    }

    #[test]
    fn a_missing_or_doubled_srgb_curve_is_named() {
        let lin = noise(W, H, 2);
        let a = as_png(W, H, &lin);
        // Linear values written as they are: B's stored values are A's linear ones.
        let missing = Image::from_encoded(
            W,
            H,
            3,
            65535,
            &lin.iter().flat_map(|p| p.to_array()).map(|c| (c * 65535.0).round() as u16).collect::<Vec<_>>(),
        );
        assert_eq!(first_kind(&a, &missing).0, "srgb_missing");
        // Encoded twice.
        let twice = a.display.clone();
        assert_eq!(first_kind(&a, &as_png(W, H, &twice)).0, "srgb_twice");
    }

    #[test]
    fn a_constant_factor_is_named_with_its_value() {
        let lin: Vec<Vec3> = noise(W, H, 3).into_iter().map(|p| p * 0.4).collect();
        let b: Vec<Vec3> = lin.iter().map(|p| *p * 2.0).collect();
        let f = findings(&as_png(W, H, &lin), &as_png(W, H, &b));
        assert_eq!(f[0].kind, "factor", "{f:?}");
        let k = f[0].factor.unwrap();
        assert!((k - 2.0).abs() < 0.02, "{k}");
        assert!(f[0].what.starts_with("B is A times 2.0"), "{}", f[0].what);
    }

    #[test]
    fn swapped_channels_are_named_by_their_order() {
        let lin = noise(W, H, 4);
        let bgr: Vec<Vec3> = lin.iter().map(|p| Vec3::new(p.z, p.y, p.x)).collect();
        let (kind, what) = first_kind(&as_png(W, H, &lin), &as_png(W, H, &bgr));
        assert_eq!((kind, what.as_str()), ("channels", "the channels are in BGR order"));
        // B's channels are A's (G, B, R).
        let gbr: Vec<Vec3> = lin.iter().map(|p| Vec3::new(p.y, p.z, p.x)).collect();
        let (_, what) = first_kind(&as_png(W, H, &lin), &as_png(W, H, &gbr));
        assert!(what.contains("GBR order"), "{what}");
    }

    #[test]
    fn whole_and_half_pixel_shifts_are_named_with_their_direction() {
        let lin = noise(W, H, 5);
        let a = as_png(W, H, &lin);
        let at = |x: u32, y: u32| lin[(y.min(H - 1) * W + x.min(W - 1)) as usize];
        // B(x, y) = A(x + 1, y): the picture moved one pixel to the left.
        let moved = grid(|x, y| at(x + 1, y));
        let (kind, what) = first_kind(&a, &as_png(W, H, &moved));
        assert_eq!(kind, "shift");
        assert_eq!(what, "B is A moved one pixel to the left: B(x, y) = A(x + 1, y)");
        // B(x, y) = A(x, y + 1/2): the mean of each pixel and the one below.
        let half = grid(|x, y| (at(x, y) + at(x, y + 1)) * 0.5);
        let (kind, what) = first_kind(&a, &as_png(W, H, &half));
        assert_eq!(kind, "half_pixel_shift", "{what}");
        assert!(what.starts_with("B is A shifted half a pixel up") && what.contains("A(x, y + 0.5)"), "{what}");
        // Both ways at once: rays through the corner.
        let corner = grid(|x, y| {
            let (x0, y0) = (x.saturating_sub(1), y.saturating_sub(1));
            (at(x0, y0) + at(x, y0) + at(x0, y) + at(x, y)) * 0.25
        });
        let (kind, what) = first_kind(&a, &as_png(W, H, &corner));
        assert_eq!(kind, "half_pixel_shift");
        assert!(what.contains("down and to the right") && what.contains("corner"), "{what}");
    }

    #[test]
    fn unrelated_differences_and_small_ones_name_nothing() {
        let (a, b) = (as_png(W, H, &noise(W, H, 6)), as_png(W, H, &noise(W, H, 7)));
        assert_eq!(findings(&a, &b), []);
        // A few pixels changed on a smooth image: the raw comparison is good already.
        let smooth: Vec<Vec3> = (0..W * H).map(|i| Vec3::splat((i % W) as f32 / W as f32)).collect();
        let mut touched = smooth.clone();
        touched[17] = Vec3::ONE;
        assert_eq!(findings(&as_png(W, H, &smooth), &as_png(W, H, &touched)), []);
    }

    #[test]
    fn related_sizes_are_described() {
        assert!(size_hint((64, 36), (128, 72)).unwrap().contains("exactly 2 times"));
        assert!(size_hint((128, 72), (64, 36)).unwrap().contains("exactly 1/2"));
        assert!(size_hint((64, 36), (36, 64)).unwrap().contains("swapped"));
        assert!(size_hint((64, 36), (96, 54)).unwrap().contains("aspect ratio"));
        assert_eq!(size_hint((64, 36), (64, 37)), None);
    }
}

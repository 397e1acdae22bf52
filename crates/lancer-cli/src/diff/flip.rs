//! ꟻLIP, the perceptual difference of two images, as LDR-FLIP is described in Andersson,
//! Nilsson, Akenine-Möller, Oskarsson, Åström and Fairchild, "FLIP: A Difference Evaluator for
//! Alternating Images", Proc. ACM Comput. Graph. Interact. Tech. 3(2), 2020 (HPG 2020).
//!
//! The paper's algorithm has two pipelines whose results are combined per pixel; each step below
//! names the part of the paper it follows:
//!
//! * the **colour pipeline** — *spatial filtering*: both images, sRGB → linear RGB → XYZ →
//!   YCxCz (the opponent space of Zhang and Wandell's S-CIELAB, a linearised L\*a\*b\*), each
//!   channel filtered by its contrast sensitivity function, a sum of Gaussians over visual angle
//!   ([`Csf`]), for the pixels per degree the images are seen at; then back to linear RGB,
//!   clamped to the unit cube; *perceptually uniform colour space*: L\*a\*b\*, its chroma scaled
//!   by 0.01·L\* for the Hunt effect ([`hunt_lab`]); *colour metric*: the HyAB distance
//!   (|ΔL| plus the Euclidean distance in a, b; [`hyab`]) raised to q_c = 0.7 and compressed
//!   into [0, 1] against the largest distance, green to blue, with p_c = 0.4 and p_t = 0.95
//!   ([`compress`]): ΔE_c;
//! * the **feature pipeline** — the achromatic channel (YCxCz's Y normalised to [0, 1], not
//!   filtered) searched for edges and points by the first and second derivatives of a Gaussian
//!   whose peak-to-trough width is w = 0.082° ([`Features`]); the larger of the two differences
//!   in feature strength, over √2, raised to q_f = 0.5: ΔE_f;
//! * the **final difference map**: ΔE = ΔE_c^(1 − ΔE_f), in [0, 1].
//!
//! Every filter is separable (a 2-D Gaussian is a product of two 1-D ones, and the derivative
//! filters' signs depend on one axis only, so their normalisation, positive weights to 1 and
//! negative ones to −1, carries over), and is applied along rows then columns with the image's
//! edge pixels repeated beyond it.

use glam::{Mat3, Vec3};
use lancer_core::srgb_decode;
use rayon::prelude::*;

/// The pixels per degree of visual angle of the paper's default viewing: a 0.7 m wide 4K
/// monitor seen from 0.7 m (3840 pixels over 2·atan(0.5) ≈ 53° is about 67).
pub(crate) const DEFAULT_PPD: f32 = 67.0;

/// The colour pipeline's exponent of the HyAB distance (q_c).
const QC: f32 = 0.7;
/// The feature pipeline's exponent (q_f).
const QF: f32 = 0.5;
/// The share of the largest colour distance below which errors are spread over [0, p_t] (p_c).
const PC: f32 = 0.4;
/// Where the compressed colour errors from p_c·c_max upwards start (p_t).
const PT: f32 = 0.95;
/// The peak-to-trough width of the edge detector, in degrees (w).
const FEATURE_WIDTH: f64 = 0.082;

/// Linear sRGB to CIE XYZ (D65), by rows.
const RGB_TO_XYZ: [[f32; 3]; 3] = [
    [0.412_456_4, 0.357_576_1, 0.180_437_5],
    [0.212_672_9, 0.715_152_2, 0.072_175],
    [0.019_333_9, 0.119_192, 0.950_304_1],
];

/// The colour transforms of both pipelines: linear RGB ↔ XYZ, and the reference white (the XYZ
/// of linear RGB (1, 1, 1), D65).
struct Colour {
    to_xyz: Mat3,
    to_rgb: Mat3,
    white: Vec3,
}

impl Colour {
    fn new() -> Colour {
        let to_xyz = Mat3::from_cols_array_2d(&RGB_TO_XYZ).transpose();
        Colour { to_xyz, to_rgb: to_xyz.inverse(), white: to_xyz * Vec3::ONE }
    }

    /// Linear RGB to YCxCz: Y = 116·y − 16, Cx = 500·(x − y), Cz = 200·(y − z), with x, y, z
    /// the XYZ over the white's.
    fn ycxcz(&self, rgb: Vec3) -> Vec3 {
        let n = self.to_xyz * rgb / self.white;
        Vec3::new(116.0 * n.y - 16.0, 500.0 * (n.x - n.y), 200.0 * (n.y - n.z))
    }

    /// YCxCz back to linear RGB.
    fn rgb_of_ycxcz(&self, c: Vec3) -> Vec3 {
        let y = (c.x + 16.0) / 116.0;
        self.to_rgb * (Vec3::new(y + c.y / 500.0, y, y - c.z / 200.0) * self.white)
    }

    /// Linear RGB to CIE L\*a\*b\*.
    fn lab(&self, rgb: Vec3) -> Vec3 {
        const DELTA: f32 = 6.0 / 29.0;
        let f = |t: f32| if t > DELTA * DELTA * DELTA { t.cbrt() } else { t / (3.0 * DELTA * DELTA) + 4.0 / 29.0 };
        let n = self.to_xyz * rgb / self.white;
        let (fx, fy, fz) = (f(n.x), f(n.y), f(n.z));
        Vec3::new(116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz))
    }

    /// Linear RGB to the Hunt-adjusted L\*a\*b\* of the colour pipeline: a\* and b\* scaled by
    /// 0.01·L\* (colours look less colourful the darker they are).
    fn hunt_lab(&self, rgb: Vec3) -> Vec3 {
        let lab = self.lab(rgb);
        Vec3::new(lab.x, 0.01 * lab.x * lab.y, 0.01 * lab.x * lab.z)
    }
}

/// The HyAB distance of two (Hunt-adjusted) L\*a\*b\* colours: city-block in lightness,
/// Euclidean in chroma.
fn hyab(p: Vec3, q: Vec3) -> f32 {
    let d = p - q;
    d.x.abs() + (d.y * d.y + d.z * d.z).sqrt()
}

/// A colour error (a HyAB distance raised to q_c) in [0, 1]: linearly to p_t up to p_c·c_max,
/// then the rest up to c_max into (p_t, 1].
fn compress(e: f32, cmax: f32) -> f32 {
    let knee = PC * cmax;
    let c = if e < knee { PT / knee * e } else { PT + (e - knee) / (cmax - knee) * (1.0 - PT) };
    c.clamp(0.0, 1.0)
}

/// One channel of an image, row after row.
type Plane = Vec<f32>;

/// `src` (`width` wide) filtered along its rows by `taps` (from −r to r), with its edge
/// pixels repeated past the edges.
fn along_rows(src: &[f32], width: usize, taps: &[f32]) -> Plane {
    let r = taps.len() / 2;
    let mut out = vec![0.0; src.len()];
    out.par_chunks_mut(width).zip(src.par_chunks(width)).for_each(|(out, row)| {
        for (x, o) in out.iter_mut().enumerate() {
            *o = taps.iter().enumerate().map(|(j, t)| t * row[(x + j).saturating_sub(r).min(width - 1)]).sum();
        }
    });
    out
}

/// `src` (`width` wide) filtered along its columns by `taps`, edges repeated.
fn along_columns(src: &[f32], width: usize, taps: &[f32]) -> Plane {
    let r = taps.len() / 2;
    let height = src.len() / width;
    let mut out = vec![0.0; src.len()];
    out.par_chunks_mut(width).enumerate().for_each(|(y, out)| {
        for (j, t) in taps.iter().enumerate() {
            let row = &src[(y + j).saturating_sub(r).min(height - 1) * width..][..width];
            for (o, s) in out.iter_mut().zip(row) {
                *o += t * s;
            }
        }
    });
    out
}

/// A channel's contrast sensitivity function as a spatial filter (the colour pipeline's
/// spatial filtering): s(x) = Σᵢ aᵢ·√(π/bᵢ)·exp(−π²·x²/bᵢ), x in degrees, normalised to sum
/// to 1 over the filter's square, kept as its Gaussians: `(weight, 1-D taps)`.
struct Csf {
    terms: Vec<(f32, Vec<f32>)>,
}

impl Csf {
    /// The achromatic, red-green and blue-yellow filters at `ppd` pixels per degree. Their
    /// radius is the paper's: three standard deviations of the widest Gaussian of the three.
    fn channels(ppd: f64) -> [Csf; 3] {
        // (a1, b1, a2, b2) of each channel: A, RG, BY (a2 = 0: one Gaussian).
        let params = [(1.0, 0.0047, 0.0, 1.0), (1.0, 0.0053, 0.0, 1.0), (34.1, 0.04, 13.5, 0.025)];
        let widest: f64 = 0.04;
        let r = (3.0 * (widest / (2.0 * std::f64::consts::PI.powi(2))).sqrt() * ppd).ceil() as i64;
        params.map(|(a1, b1, a2, b2)| {
            let mut terms: Vec<(f64, Vec<f64>)> = Vec::new();
            for (a, b) in [(a1, b1), (a2, b2)] {
                if a > 0.0 {
                    let taps = (-r..=r)
                        .map(|x| {
                            let d = x as f64 / ppd;
                            (-std::f64::consts::PI.powi(2) * d * d / b).exp()
                        })
                        .collect();
                    terms.push((a * (std::f64::consts::PI / b).sqrt(), taps));
                }
            }
            let total: f64 = terms.iter().map(|(w, taps)| w * taps.iter().sum::<f64>().powi(2)).sum();
            Csf {
                terms: terms
                    .into_iter()
                    .map(|(w, taps)| ((w / total) as f32, taps.into_iter().map(|t| t as f32).collect()))
                    .collect(),
            }
        })
    }

    fn apply(&self, plane: &[f32], width: usize) -> Plane {
        let mut out = vec![0.0; plane.len()];
        for (w, taps) in &self.terms {
            let filtered = along_columns(&along_rows(plane, width, taps), width, taps);
            out.iter_mut().zip(filtered).for_each(|(o, f)| *o += w * f);
        }
        out
    }
}

/// The feature pipeline's detectors, one axis of each: the first derivative of a Gaussian
/// (edges) and the second (points), each with its positive weights summing to 1 and its
/// negative ones to −1, and the Gaussian itself (summing to 1) across the other axis. The
/// standard deviation is half the detector's peak-to-trough width w, in pixels; the radius
/// three standard deviations.
struct Features {
    edge: Vec<f32>,
    point: Vec<f32>,
    smooth: Vec<f32>,
}

impl Features {
    fn new(ppd: f64) -> Features {
        let sd = 0.5 * FEATURE_WIDTH * ppd;
        let r = (3.0 * sd).ceil() as i64;
        let gauss: Vec<f64> = (-r..=r).map(|x| (-((x * x) as f64) / (2.0 * sd * sd)).exp()).collect();
        let xs = || (-r..=r).map(|x| x as f64);
        let edge: Vec<f64> = xs().zip(&gauss).map(|(x, g)| -x * g).collect();
        let point: Vec<f64> = xs().zip(&gauss).map(|(x, g)| (x * x / (sd * sd) - 1.0) * g).collect();
        let balanced = |k: Vec<f64>| {
            let pos: f64 = k.iter().filter(|v| **v > 0.0).sum();
            let neg: f64 = -k.iter().filter(|v| **v < 0.0).sum::<f64>();
            // At a very low resolution a side can vanish (underflow): it stays zero.
            let scale = |v: f64, s: f64| if s > 0.0 { v / s } else { 0.0 };
            k.into_iter().map(|v| (if v > 0.0 { scale(v, pos) } else { scale(v, neg) }) as f32).collect()
        };
        let sum: f64 = gauss.iter().sum();
        Features {
            edge: balanced(edge),
            point: balanced(point),
            smooth: gauss.iter().map(|g| (g / sum) as f32).collect(),
        }
    }

    /// The strength of the edges and of the points at each pixel of the achromatic plane: the
    /// length of the detector's answer along x and along y.
    fn strengths(&self, grey: &[f32], width: usize) -> (Plane, Plane) {
        let length = |k: &[f32]| {
            let dx = along_columns(&along_rows(grey, width, k), width, &self.smooth);
            let dy = along_rows(&along_columns(grey, width, k), width, &self.smooth);
            dx.iter().zip(&dy).map(|(x, y)| (x * x + y * y).sqrt()).collect::<Plane>()
        };
        (length(&self.edge), length(&self.point))
    }
}

/// What each image brings to the comparison: its filtered Hunt-adjusted L\*a\*b\* colours and
/// its edge and point strengths.
struct Prepared {
    lab: Vec<Vec3>,
    edges: Plane,
    points: Plane,
}

fn prepare(srgb: &[Vec3], width: usize, colour: &Colour, csf: &[Csf; 3], features: &Features) -> Prepared {
    let opponent: Vec<Vec3> = srgb
        .par_iter()
        .map(|p| colour.ycxcz(Vec3::from_array(p.to_array().map(|c| srgb_decode(c.clamp(0.0, 1.0))))))
        .collect();
    let plane = |k: usize| opponent.iter().map(|p| p[k]).collect::<Plane>();
    let filtered: Vec<Plane> = (0..3).map(|k| csf[k].apply(&plane(k), width)).collect();
    let lab = (0..srgb.len())
        .into_par_iter()
        .map(|i| {
            let rgb = colour.rgb_of_ycxcz(Vec3::new(filtered[0][i], filtered[1][i], filtered[2][i]));
            colour.hunt_lab(rgb.clamp(Vec3::ZERO, Vec3::ONE))
        })
        .collect();
    let grey: Plane = opponent.iter().map(|p| (p.x + 16.0) / 116.0).collect();
    let (edges, points) = features.strengths(&grey, width);
    Prepared { lab, edges, points }
}

/// The ꟻLIP error of every pixel of `test` against `reference` (both sRGB-encoded, `width`
/// wide, row after row), seen at `ppd` pixels per degree: each in [0, 1], 0 where nothing
/// differs.
pub(crate) fn flip_map(reference: &[Vec3], test: &[Vec3], width: usize, ppd: f32) -> Vec<f32> {
    assert_eq!(reference.len(), test.len(), "images of one size");
    if reference.is_empty() {
        return Vec::new();
    }
    let colour = Colour::new();
    let (csf, features) = (Csf::channels(f64::from(ppd)), Features::new(f64::from(ppd)));
    let (r, t) = rayon::join(
        || prepare(reference, width, &colour, &csf, &features),
        || prepare(test, width, &colour, &csf, &features),
    );
    let cmax = hyab(colour.hunt_lab(Vec3::Y), colour.hunt_lab(Vec3::Z)).powf(QC);
    (0..reference.len())
        .into_par_iter()
        .map(|i| {
            let colour_error = compress(hyab(r.lab[i], t.lab[i]).powf(QC), cmax);
            let feature = (r.edges[i] - t.edges[i]).abs().max((r.points[i] - t.points[i]).abs());
            let feature_error = (feature / std::f32::consts::SQRT_2).powf(QF).clamp(0.0, 1.0);
            colour_error.powf(1.0 - feature_error)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reproducible image of noise in [0, 1].
    fn noise(n: usize, seed: u32) -> Vec<Vec3> {
        let mut s = seed.wrapping_mul(0x9E37_79B9) | 1;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            (s >> 8) as f32 / (1 << 24) as f32
        };
        (0..n).map(|_| Vec3::new(next(), next(), next())).collect()
    }

    fn mean(v: &[f32]) -> f32 {
        v.iter().sum::<f32>() / v.len() as f32
    }

    #[test]
    fn identical_images_have_no_error_anywhere() {
        let a = noise(40 * 30, 1);
        assert!(flip_map(&a, &a, 40, DEFAULT_PPD).iter().all(|&e| e == 0.0));
    }

    #[test]
    fn every_error_is_in_the_unit_interval() {
        for seed in 0..4 {
            let (a, b) = (noise(32 * 24, seed), noise(32 * 24, seed + 100));
            for ppd in [5.0, DEFAULT_PPD, 300.0] {
                let map = flip_map(&a, &b, 32, ppd);
                assert!(map.iter().all(|e| (0.0..=1.0).contains(e)), "seed {seed}, ppd {ppd}");
            }
        }
    }

    #[test]
    fn black_against_white_is_the_colour_error_of_lightness_100_near_1() {
        // Uniform images have no features: the error is the colour pipeline's alone. Worked out
        // here from published L*a*b* values of sRGB green and blue (D65), not from this file's
        // transforms: HyAB(black, white) = 100.
        let hunt = |l: f32, a: f32, b: f32| Vec3::new(l, 0.01 * l * a, 0.01 * l * b);
        let (green, blue) = (hunt(87.7347, -86.1827, 83.1793), hunt(32.2970, 79.1875, -107.8602));
        let cmax = hyab(green, blue).powf(QC);
        let expected = PT + (100f32.powf(QC) - PC * cmax) / (cmax - PC * cmax) * (1.0 - PT);
        let (black, white) = (vec![Vec3::ZERO; 24 * 24], vec![Vec3::ONE; 24 * 24]);
        let map = flip_map(&black, &white, 24, DEFAULT_PPD);
        assert!(map.iter().all(|e| (e - expected).abs() < 1e-3), "{} against {expected}", map[0]);
        assert!(expected > 0.96, "{expected}");
    }

    #[test]
    fn one_pixel_changed_is_a_small_mean_error_with_its_peak_there() {
        let (w, h) = (64usize, 64usize);
        let a = vec![Vec3::splat(0.5); w * h];
        let mut b = a.clone();
        b[20 * w + 30] = Vec3::ONE;
        let map = flip_map(&a, &b, w, DEFAULT_PPD);
        let peak = map.iter().enumerate().max_by(|x, y| x.1.total_cmp(y.1)).unwrap();
        assert_eq!(peak.0, 20 * w + 30, "the worst pixel is the changed one");
        assert!(*peak.1 > 0.2, "a white dot on grey is visible: {}", peak.1);
        assert!(mean(&map) < 0.01, "but it is one pixel in 4096: {}", mean(&map));
        // Far from it, nothing.
        assert_eq!(map[60 * w + 2], 0.0);
    }

    #[test]
    fn the_error_is_the_same_either_way_round() {
        let (a, b) = (noise(30 * 20, 7), noise(30 * 20, 8));
        let (ab, ba) = (flip_map(&a, &b, 30, DEFAULT_PPD), flip_map(&b, &a, 30, DEFAULT_PPD));
        assert!(ab.iter().zip(&ba).all(|(x, y)| (x - y).abs() < 1e-5));
    }

    #[test]
    fn a_larger_change_is_a_larger_error() {
        let grey = |v: f32| vec![Vec3::splat(v); 16 * 16];
        let small = mean(&flip_map(&grey(0.5), &grey(0.52), 16, DEFAULT_PPD));
        let large = mean(&flip_map(&grey(0.5), &grey(0.7), 16, DEFAULT_PPD));
        assert!(0.0 < small && small < large, "{small} {large}");
    }

    #[test]
    fn a_fine_checkerboard_is_harder_to_tell_from_grey_seen_from_further_away() {
        // Against its own mean, a one-pixel checkerboard: the filters blur it away as the pixels
        // per degree grow.
        let w = 48;
        let board: Vec<Vec3> = (0..w * w).map(|i| Vec3::splat(((i % w + i / w) % 2) as f32)).collect();
        let grey = vec![Vec3::splat(crate::output::srgb_encode(0.5)); w * w];
        let near = mean(&flip_map(&board, &grey, w, 10.0));
        let far = mean(&flip_map(&board, &grey, w, 200.0));
        assert!(far < near * 0.5, "near {near}, far {far}");
    }

    #[test]
    fn the_filters_sum_to_one_and_the_detectors_balance() {
        for ppd in [1.0, 67.0, 500.0] {
            for csf in Csf::channels(ppd) {
                let total: f32 = csf.terms.iter().map(|(w, t)| w * t.iter().sum::<f32>().powi(2)).sum();
                assert!((total - 1.0).abs() < 1e-5, "ppd {ppd}: {total}");
            }
            let f = Features::new(ppd);
            for k in [&f.edge, &f.point] {
                let pos: f32 = k.iter().filter(|v| **v > 0.0).sum();
                let neg: f32 = k.iter().filter(|v| **v < 0.0).sum();
                assert!((pos - 1.0).abs() < 1e-5 && (neg + 1.0).abs() < 1e-5, "ppd {ppd}: {pos} {neg}");
            }
        }
        // The paper's default viewing: filters of radius 10 (colour) and 9 (features).
        assert_eq!(Csf::channels(67.0)[0].terms[0].1.len(), 21);
        assert_eq!(Features::new(67.0).edge.len(), 19);
    }
}

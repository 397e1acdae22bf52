//! The plain measures of `lancer diff`, all in the display domain (sRGB-encoded values clamped
//! to [0, 1], what a viewer shows): PSNR, the mean and largest absolute errors, the pixels off
//! by more than a tolerance, and the block where an error map is worst.

use super::read::Image;

/// How much more than the tolerance a channel must be off to count: a millionth, so that at a
/// tolerance of 1/255 a value one 8-bit step away (whose difference, in floats, may come out a
/// hair over 1/255) is not counted.
pub(crate) const SLACK: f64 = 1e-6;

/// The measures of one pair of images of one size.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Measures {
    /// The mean squared error over every channel of every pixel.
    pub(crate) mse: f64,
    /// The mean absolute error over every channel of every pixel.
    pub(crate) mean_abs: f64,
    /// The largest absolute error of any channel.
    pub(crate) max_abs: f64,
    /// The pixel (column, row) where it is (the first such, row by row).
    pub(crate) max_at: (u32, u32),
    /// The pixels with a channel off by more than the tolerance.
    pub(crate) over: usize,
    /// The largest absolute difference of the linear values (which, above 1, the display
    /// domain does not see).
    pub(crate) linear_max_abs: f64,
}

/// PSNR in dB of a mean squared error of values in [0, 1]; infinite for none.
pub(crate) fn psnr(mse: f64) -> f64 {
    if mse == 0.0 { f64::INFINITY } else { 10.0 * (1.0 / mse).log10() }
}

/// The measures of `b` against `a` (of one size), a pixel counting as off when a channel is off
/// by more than `tolerance`.
pub(crate) fn measure(a: &Image, b: &Image, tolerance: f64) -> Measures {
    let (mut sq, mut abs, mut max_abs, mut max_at, mut over, mut linear_max_abs) = (0.0, 0.0, 0.0, 0, 0, 0.0f64);
    for (i, (p, q)) in a.display.iter().zip(&b.display).enumerate() {
        let mut worst = 0.0f64;
        for c in 0..3 {
            let d = (f64::from(p[c]) - f64::from(q[c])).abs();
            sq += d * d;
            abs += d;
            worst = worst.max(d);
        }
        if worst > max_abs {
            (max_abs, max_at) = (worst, i);
        }
        over += usize::from(worst > tolerance + SLACK);
    }
    for (p, q) in a.linear.iter().zip(&b.linear) {
        linear_max_abs = linear_max_abs.max(f64::from((*p - *q).abs().max_element()));
    }
    let n = (a.display.len() * 3).max(1) as f64;
    let w = a.width.max(1) as usize;
    Measures {
        mse: sq / n,
        mean_abs: abs / n,
        max_abs,
        max_at: ((max_at % w) as u32, (max_at / w) as u32),
        over,
        linear_max_abs,
    }
}

/// The largest absolute error of each pixel's channels: the map `--heatmap-of abs` draws.
pub(crate) fn abs_map(a: &Image, b: &Image) -> Vec<f32> {
    a.display.iter().zip(&b.display).map(|(p, q)| (*p - *q).abs().max_element()).collect()
}

/// The block of an error map whose mean error is largest.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Block {
    /// Its top-left pixel (column, row).
    pub(crate) x: u32,
    /// Its top row.
    pub(crate) y: u32,
    /// Its width (less than the block size at the image's right edge).
    pub(crate) width: u32,
    /// Its height (less at the bottom edge).
    pub(crate) height: u32,
    /// Its mean error.
    pub(crate) mean: f32,
    /// Its worst pixel (column, row): the one to ask `lancer explain` about.
    pub(crate) pixel: (u32, u32),
    /// That pixel's error.
    pub(crate) value: f32,
}

/// The `size`×`size` block (counted from the top-left corner) of `map` (`width` × `height`)
/// with the largest mean, the first of equals row by row; none if the map is all zero.
pub(crate) fn worst_block(map: &[f32], width: u32, height: u32, size: u32) -> Option<Block> {
    let mut best: Option<Block> = None;
    for by in (0..height).step_by(size as usize) {
        for bx in (0..width).step_by(size as usize) {
            let (bw, bh) = (size.min(width - bx), size.min(height - by));
            let (mut sum, mut pixel, mut value) = (0.0f64, (bx, by), f32::NEG_INFINITY);
            for y in by..by + bh {
                for x in bx..bx + bw {
                    let e = map[(y * width + x) as usize];
                    sum += f64::from(e);
                    if e > value {
                        (pixel, value) = ((x, y), e);
                    }
                }
            }
            let mean = (sum / f64::from(bw * bh)) as f32;
            if mean > 0.0 && best.as_ref().is_none_or(|b| mean > b.mean) {
                best = Some(Block { x: bx, y: by, width: bw, height: bh, mean, pixel, value });
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn image(w: u32, h: u32, f: impl Fn(u32, u32) -> Vec3) -> Image {
        let px: Vec<Vec3> = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| f(x, y)).collect();
        Image { width: w, height: h, format: String::new(), display: px.clone(), linear: px, notes: Vec::new() }
    }

    #[test]
    fn psnr_of_a_known_error_and_of_none() {
        assert_eq!(psnr(0.0), f64::INFINITY);
        assert!((psnr(0.01) - 20.0).abs() < 1e-12);
        // Every channel off by 0.1: MSE 0.01, 20 dB.
        let (a, b) = (image(4, 3, |_, _| Vec3::splat(0.5)), image(4, 3, |_, _| Vec3::splat(0.6)));
        let m = measure(&a, &b, 1.0 / 255.0);
        assert!((psnr(m.mse) - 20.0).abs() < 1e-5 && (m.mean_abs - 0.1).abs() < 1e-6);
        assert_eq!(m.over, 12);
    }

    #[test]
    fn the_largest_error_is_found_where_it_is_and_one_8_bit_step_is_within_1_over_255() {
        let a = image(5, 4, |_, _| Vec3::splat(100.0 / 255.0));
        let b = image(5, 4, |x, y| match (x, y) {
            (3, 2) => Vec3::new(100.0, 100.0, 180.0) / 255.0,
            (0, 0) => Vec3::splat(101.0 / 255.0),
            (1, 0) => Vec3::splat(102.0 / 255.0),
            _ => Vec3::splat(100.0 / 255.0),
        });
        let m = measure(&a, &b, 1.0 / 255.0);
        assert_eq!(m.max_at, (3, 2));
        assert!((m.max_abs - 80.0 / 255.0).abs() < 1e-6);
        assert_eq!(m.over, 2, "one step is not over 1/255; two steps and the blue one are");
    }

    #[test]
    fn the_worst_block_is_the_one_with_the_largest_mean_and_names_its_worst_pixel() {
        let (w, h) = (40u32, 20u32);
        let mut map = vec![0.0f32; (w * h) as usize];
        // One bright pixel in the first block, a dimmer but wide patch in the third.
        map[(3 * w + 3) as usize] = 1.0;
        for y in 0..16 {
            for x in 32..40 {
                map[(y * w + x) as usize] = 0.1 + if (x, y) == (35, 9) { 0.5 } else { 0.0 };
            }
        }
        let b = worst_block(&map, w, h, 16).unwrap();
        assert_eq!((b.x, b.y, b.width, b.height), (32, 0, 8, 16), "the partial block at the right edge");
        assert_eq!(b.pixel, (35, 9));
        assert!(worst_block(&[0.0; 16], 4, 4, 16).is_none());
    }
}

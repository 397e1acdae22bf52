//! The heatmap `lancer diff --heatmap` writes: each pixel's error in the magma colour map (dark
//! for none, pale yellow for the top of the scale), and under the image a legend: the colour bar
//! with ticks at 0, ¼, ½, ¾ and the top of the scale, their values, and what is shown, drawn
//! with a 3×5 bitmap font of its own, scaled up.

use anyhow::{Context, Result};
use image::{Rgb, RgbImage};

/// The magma colour map (matplotlib's, as ꟻLIP's tools show their error maps) at 0, 1/8, …, 1,
/// sRGB-encoded; read between the points linearly.
const MAGMA: [[f32; 3]; 9] = [
    [0.001_462, 0.000_466, 0.013_866],
    [0.113_094, 0.065_492, 0.276_784],
    [0.316_654, 0.071_690, 0.485_380],
    [0.512_831, 0.148_179, 0.507_648],
    [0.716_387, 0.214_982, 0.475_290],
    [0.904_281, 0.319_610, 0.388_137],
    [0.986_700, 0.535_582, 0.382_210],
    [0.996_898, 0.769_591, 0.534_892],
    [0.987_053, 0.991_438, 0.749_504],
];

/// The colour of `t` in [0, 1] (clamped; NaN as 0).
pub(crate) fn magma(t: f32) -> Rgb<u8> {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) } * (MAGMA.len() - 1) as f32;
    let k = (t.floor() as usize).min(MAGMA.len() - 2);
    let f = t - k as f32;
    let (p, q) = (MAGMA[k], MAGMA[k + 1]);
    Rgb(std::array::from_fn(|c| ((p[c] + (q[c] - p[c]) * f) * 255.0).round() as u8))
}

/// The glyphs of the legend, 3 pixels wide and 5 high: a row a byte, its three low bits from
/// left (4) to right (1).
fn glyph(c: char) -> [u8; 5] {
    match c {
        '0' => [0b111, 0b101, 0b101, 0b101, 0b111],
        '1' => [0b010, 0b110, 0b010, 0b010, 0b111],
        '2' => [0b111, 0b001, 0b111, 0b100, 0b111],
        '3' => [0b111, 0b001, 0b111, 0b001, 0b111],
        '4' => [0b101, 0b101, 0b111, 0b001, 0b001],
        '5' => [0b111, 0b100, 0b111, 0b001, 0b111],
        '6' => [0b111, 0b100, 0b111, 0b101, 0b111],
        '7' => [0b111, 0b001, 0b001, 0b001, 0b001],
        '8' => [0b111, 0b101, 0b111, 0b101, 0b111],
        '9' => [0b111, 0b101, 0b111, 0b001, 0b111],
        '.' => [0b000, 0b000, 0b000, 0b000, 0b010],
        '-' => [0b000, 0b000, 0b111, 0b000, 0b000],
        'A' => [0b010, 0b101, 0b111, 0b101, 0b101],
        'B' => [0b110, 0b101, 0b110, 0b101, 0b110],
        'E' => [0b111, 0b100, 0b110, 0b100, 0b111],
        'F' => [0b111, 0b100, 0b110, 0b100, 0b100],
        'I' => [0b111, 0b010, 0b010, 0b010, 0b111],
        'L' => [0b100, 0b100, 0b100, 0b100, 0b111],
        'O' => [0b010, 0b101, 0b101, 0b101, 0b010],
        'P' => [0b110, 0b101, 0b110, 0b100, 0b100],
        'R' => [0b110, 0b101, 0b110, 0b101, 0b101],
        'S' => [0b011, 0b100, 0b010, 0b001, 0b110],
        _ => [0; 5],
    }
}

/// How wide `text` is drawn at `scale` (a glyph and a one-pixel gap each, the last gap left off).
fn text_width(text: &str, scale: u32) -> u32 {
    (text.chars().count() as u32 * 4).saturating_sub(1) * scale
}

/// Draws `text` with its top-left corner at (`x`, `y`), each font pixel `scale` pixels square
/// (clipped to the image).
fn draw_text(img: &mut RgbImage, text: &str, x: u32, y: u32, scale: u32, colour: Rgb<u8>) {
    for (i, c) in text.chars().enumerate() {
        for (row, bits) in glyph(c).iter().enumerate() {
            for col in 0..3u32 {
                if bits & (0b100 >> col) != 0 {
                    let (px, py) = (x + (i as u32 * 4 + col) * scale, y + row as u32 * scale);
                    fill(img, px, py, scale, scale, colour);
                }
            }
        }
    }
}

/// Fills the rectangle at (`x`, `y`), `w` × `h`, clipped to the image.
fn fill(img: &mut RgbImage, x: u32, y: u32, w: u32, h: u32, colour: Rgb<u8>) {
    for py in y..(y + h).min(img.height()) {
        for px in x..(x + w).min(img.width()) {
            img.put_pixel(px, py, colour);
        }
    }
}

/// A value of the scale as the legend writes it: at most six decimals, no trailing zeros.
fn label(v: f32) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s.is_empty() { "0".to_owned() } else { s.to_owned() }
}

/// The smallest of 1, 2 or 5 times a power of ten at or above `v` (1 for nothing above 0): the
/// top of a scale whose quarter ticks read well.
pub(crate) fn nice_top(v: f32) -> f32 {
    if v.is_nan() || v <= 0.0 {
        return 1.0;
    }
    let v = f64::from(v);
    let decade = v.log10().floor() as i32;
    let top = [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * 10f64.powi(decade)).find(|t| *t >= v * (1.0 - 1e-6));
    top.unwrap_or(10f64.powi(decade + 1)) as f32
}

/// The background around the image and legend.
const BACKGROUND: Rgb<u8> = Rgb([24, 24, 24]);
/// The legend's text and ticks.
const INK: Rgb<u8> = Rgb([235, 235, 235]);
/// The narrowest heatmap drawn: room for the legend under a small image.
const MIN_WIDTH: u32 = 200;

/// The heatmap of `map` (`width` × `height`, each pixel's error, 0 to `top`), with its legend
/// naming the scale `title` (capitals and digits: `FLIP`, `ABS ERROR`).
pub(crate) fn draw(map: &[f32], width: u32, height: u32, top: f32, title: &str) -> RgbImage {
    let canvas = width.max(MIN_WIDTH);
    let scale = (canvas / 200).clamp(2, 8);
    let ticks: Vec<String> = (0..=4).map(|k| label(top * k as f32 / 4.0)).collect();
    let widest = ticks.iter().map(|t| text_width(t, scale)).max().unwrap_or(0);
    // Room for half the widest number past each end of the bar.
    let margin = widest / 2 + 2 * scale;
    let (gap, bar, tick) = (4 * scale, 5 * scale, 2 * scale);
    let (bar_y, text_y) = (height + gap, height + gap + bar + tick + scale);
    let title_y = text_y + 5 * scale + 2 * scale;
    let total = title_y + 5 * scale + 2 * scale;
    let mut img = RgbImage::from_pixel(canvas, total, BACKGROUND);
    let left = (canvas - width) / 2;
    for y in 0..height {
        for x in 0..width {
            let e = map[(y * width + x) as usize];
            img.put_pixel(left + x, y, magma(e / top));
        }
    }
    let (bar_x, bar_w) = (margin, canvas.saturating_sub(2 * margin).max(2));
    for x in 0..bar_w {
        fill(&mut img, bar_x + x, bar_y, 1, bar, magma(x as f32 / (bar_w - 1) as f32));
    }
    for (k, t) in ticks.iter().enumerate() {
        let at = bar_x + (bar_w - 1) * k as u32 / 4;
        fill(&mut img, at.saturating_sub(scale / 2), bar_y + bar, scale.max(1), tick, INK);
        draw_text(&mut img, t, at.saturating_sub(text_width(t, scale) / 2), text_y, scale, INK);
    }
    draw_text(&mut img, title, canvas.saturating_sub(text_width(title, scale)) / 2, title_y, scale, INK);
    img
}

/// The heatmap's PNG file.
pub(crate) fn encode(img: &RgbImage) -> Result<Vec<u8>> {
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).context("encoding the heatmap")?;
    Ok(out.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_colour_map_runs_from_black_to_pale_yellow() {
        assert_eq!(magma(0.0), Rgb([0, 0, 4]));
        assert_eq!(magma(1.0), Rgb([252, 253, 191]));
        assert_eq!(magma(-1.0), magma(0.0));
        assert_eq!(magma(f32::NAN), magma(0.0));
        // Brighter all along (by the sum of channels).
        let sums: Vec<u32> = (0..=64).map(|k| magma(k as f32 / 64.0).0.iter().map(|&c| u32::from(c)).sum()).collect();
        assert!(sums.windows(2).all(|w| w[0] <= w[1]), "{sums:?}");
    }

    #[test]
    fn digits_are_drawn_from_the_font() {
        let mut img = RgbImage::from_pixel(16, 6, BACKGROUND);
        draw_text(&mut img, "10", 0, 0, 1, INK);
        let row = |y: u32| (0..7).map(|x| if img.get_pixel(x, y) == &INK { '#' } else { '.' }).collect::<String>();
        let drawn: Vec<String> = (0..5).map(row).collect();
        assert_eq!(drawn, [".#..###", "##..#.#", ".#..#.#", ".#..#.#", "###.###"]);
    }

    #[test]
    fn scale_labels_and_tops_read_well() {
        assert_eq!([label(0.0), label(0.25), label(1.0), label(0.0125)], ["0", "0.25", "1", "0.0125"]);
        assert_eq!([nice_top(0.3), nice_top(0.02), nice_top(0.021), nice_top(0.0)], [0.5, 0.02, 0.05, 1.0]);
    }

    #[test]
    fn the_legend_lies_under_the_image_even_for_a_tiny_one() {
        let map = [0.0, 0.5, 1.0, 0.25];
        let img = draw(&map, 2, 2, 1.0, "FLIP");
        assert_eq!(img.width(), MIN_WIDTH);
        assert!(img.height() > 30, "room for the bar, the numbers and the title");
        let left = (MIN_WIDTH - 2) / 2;
        assert_eq!(*img.get_pixel(left, 0), magma(0.0));
        assert_eq!(*img.get_pixel(left + 1, 0), magma(0.5));
        assert_eq!(*img.get_pixel(left, 1), magma(1.0));
        // The bar: from the bottom of the colour map at its left end to the top at its right.
        let bar_y = 2 + 8;
        let row: Vec<Rgb<u8>> = (0..MIN_WIDTH).map(|x| *img.get_pixel(x, bar_y)).filter(|p| *p != BACKGROUND).collect();
        assert_eq!((row.first(), row.last()), (Some(&magma(0.0)), Some(&magma(1.0))));
        // Text below the bar.
        assert!((bar_y + 10..img.height()).any(|y| (0..MIN_WIDTH).any(|x| *img.get_pixel(x, y) == INK)));
    }
}

//! Reading the images `lancer diff` compares: PNG (8 and 16 bit, grey or RGB, with or without
//! alpha) and OpenEXR through the `image` crate, PPM and PGM (P3, P6, P2, P5; maximum values up to
//! 65535, `#` comments in the header) by a small reader of its own whose errors name the byte.
//!
//! PNG, PPM and PGM values are taken as sRGB-encoded (what a C course's renderer writes, and what
//! Lancer's PNGs hold); EXR values as linear. Every image is kept both ways: its display values
//! (sRGB-encoded, clamped to [0, 1], what the comparison is made on) and its linear ones (what
//! the named mismatches reason about).

use std::path::Path;

use anyhow::{Context, Result, bail};
use glam::Vec3;
use lancer_core::srgb_decode;

use crate::output::srgb_encode;

/// The most pixels an image compared may have (8192 × 8192, as many as Lancer renders).
pub(crate) const MAX_PIXELS: u64 = 1 << 26;

/// The widest or tallest image read (a PPM header naming more is refused at once).
const MAX_SIDE: u32 = 65535;

/// An image read for comparison: row 0 at the top, pixels row after row.
#[derive(Clone, Debug)]
pub(crate) struct Image {
    /// Columns.
    pub(crate) width: u32,
    /// Rows.
    pub(crate) height: u32,
    /// What the file is, for the report: `PNG 8-bit RGB`, `OpenEXR float RGB`, `PPM P6, maximum 255`.
    pub(crate) format: String,
    /// Display-domain values: sRGB-encoded, in [0, 1]. A PNG's or PPM's stored values exactly
    /// (sample / maximum); an EXR's linear values encoded by the sRGB curve and clamped.
    pub(crate) display: Vec<Vec3>,
    /// Linear values: a PNG's or PPM's decoded by the sRGB curve; an EXR's as stored (a NaN or
    /// infinite value as 0).
    pub(crate) linear: Vec<Vec3>,
    /// What the report should mention about the file: alpha ignored, non-finite values.
    pub(crate) notes: Vec<String>,
}

impl Image {
    /// An image of integer samples that are sRGB-encoded: `channels` (1, grey, or 3) a pixel,
    /// each from 0 to `max`.
    pub(crate) fn from_encoded(width: u32, height: u32, channels: usize, max: u32, samples: &[u16]) -> Image {
        // One decode per possible value, not per sample.
        let display_of: Vec<f32> = (0..=max).map(|k| k as f32 / max as f32).collect();
        let linear_of: Vec<f32> = display_of.iter().map(|&c| srgb_decode(c)).collect();
        let pixel = |table: &[f32], p: &[u16]| match channels {
            1 => Vec3::splat(table[p[0] as usize]),
            _ => Vec3::new(table[p[0] as usize], table[p[1] as usize], table[p[2] as usize]),
        };
        let display = samples.chunks_exact(channels).map(|p| pixel(&display_of, p)).collect();
        let linear = samples.chunks_exact(channels).map(|p| pixel(&linear_of, p)).collect();
        Image { width, height, format: String::new(), display, linear, notes: Vec::new() }
    }

    /// An image of linear values (an EXR's): NaN and infinite values are taken as 0 (and
    /// counted in a note).
    pub(crate) fn from_linear(width: u32, height: u32, values: Vec<Vec3>) -> Image {
        let mut bad = 0usize;
        let linear: Vec<Vec3> = values
            .into_iter()
            .map(|p| {
                let fixed = Vec3::from_array(p.to_array().map(|c| if c.is_finite() { c } else { 0.0 }));
                bad += usize::from(fixed != p);
                fixed
            })
            .collect();
        let display = linear.iter().map(|p| Vec3::from_array(p.to_array().map(srgb_encode))).collect();
        let mut notes = Vec::new();
        if bad > 0 {
            notes.push(format!("{bad} pixels hold NaN or infinite values (compared as 0)"));
        }
        Image { width, height, format: String::new(), display, linear, notes }
    }

    /// The pixel at column `x`, row `y` (display domain).
    #[inline]
    pub(crate) fn at(&self, x: u32, y: u32) -> Vec3 {
        self.display[(y * self.width + x) as usize]
    }
}

/// Reads the image file `path` (at most `max_mb` MB), whatever its name says: the format is told
/// by its first bytes.
pub(crate) fn read(path: &Path, max_mb: u64) -> Result<Image> {
    let bytes = crate::app::read_bytes(path, "image", max_mb).map_err(anyhow::Error::msg)?;
    decode(&bytes).with_context(|| path.display().to_string())
}

/// An image from a file's bytes; the error says what was expected (the caller adds the name).
pub(crate) fn decode(bytes: &[u8]) -> Result<Image> {
    const PNG: &[u8] = b"\x89PNG\r\n\x1a\n";
    const EXR: &[u8] = &[0x76, 0x2f, 0x31, 0x01];
    if bytes.starts_with(PNG) {
        return by_image_crate(bytes, image::ImageFormat::Png, "PNG");
    }
    if bytes.starts_with(EXR) {
        return by_image_crate(bytes, image::ImageFormat::OpenExr, "OpenEXR");
    }
    match bytes {
        [b'P', b'2' | b'3' | b'5' | b'6', ..] => pnm(bytes).map_err(anyhow::Error::msg),
        [b'P', b'1' | b'4', ..] => bail!("a PBM bitmap (P1, P4) is not read: expected a PPM (P3, P6) or PGM (P2, P5)"),
        [b'P', b'7', ..] => bail!("a PAM file (P7) is not read: expected a PPM (P3, P6) or PGM (P2, P5)"),
        [] => bail!("the file is empty: expected a PNG, OpenEXR, PPM (P3, P6) or PGM (P2, P5) image"),
        _ => bail!(
            "unknown image format (the file starts with `{}`): expected a PNG, OpenEXR, PPM (P3, P6) or PGM (P2, P5) image",
            bytes.iter().take(8).copied().flat_map(std::ascii::escape_default).map(char::from).collect::<String>()
        ),
    }
}

/// A PNG or EXR decoded by the `image` crate, within the pixel budget.
fn by_image_crate(bytes: &[u8], format: image::ImageFormat, name: &str) -> Result<Image> {
    use image::ColorType;
    let mut reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_SIDE);
    limits.max_image_height = Some(MAX_SIDE);
    // Four float channels a pixel, at most.
    limits.max_alloc = Some(MAX_PIXELS * 16);
    reader.limits(limits);
    let img = reader.decode().with_context(|| format!("not a readable {name} file"))?;
    let (width, height) = (img.width(), img.height());
    check_size(width, height).map_err(anyhow::Error::msg)?;
    let color = img.color();
    let (alpha, grey) = (color.has_alpha(), !color.has_color());
    let layout = match (grey, alpha) {
        (true, false) => "grey",
        (true, true) => "grey+alpha",
        (false, false) => "RGB",
        (false, true) => "RGBA",
    };
    let mut image = match color {
        ColorType::Rgb32F | ColorType::Rgba32F => {
            let rgb = img.into_rgb32f();
            let mut image = Image::from_linear(width, height, rgb.pixels().map(|p| Vec3::from_array(p.0)).collect());
            image.format = format!("{name} float {layout}, linear");
            image
        }
        ColorType::L8 | ColorType::La8 | ColorType::Rgb8 | ColorType::Rgba8 => {
            let (channels, samples): (usize, Vec<u16>) = if grey {
                (1, img.into_luma8().into_raw().into_iter().map(u16::from).collect())
            } else {
                (3, img.into_rgb8().into_raw().into_iter().map(u16::from).collect())
            };
            let mut image = Image::from_encoded(width, height, channels, 255, &samples);
            image.format = format!("{name} 8-bit {layout}");
            image
        }
        _ => {
            let (channels, samples) =
                if grey { (1, img.into_luma16().into_raw()) } else { (3, img.into_rgb16().into_raw()) };
            let mut image = Image::from_encoded(width, height, channels, 65535, &samples);
            image.format = format!("{name} 16-bit {layout}");
            image
        }
    };
    if alpha {
        image.notes.push("its alpha channel is ignored".to_owned());
    }
    Ok(image)
}

/// The image's size within the budget, or why not.
fn check_size(width: u32, height: u32) -> Result<(), String> {
    let pixels = u64::from(width) * u64::from(height);
    if pixels > MAX_PIXELS {
        return Err(format!(
            "the image is {width}x{height} = {pixels} pixels, more than the {MAX_PIXELS} `lancer diff` reads"
        ));
    }
    Ok(())
}

/// A reader of a PPM or PGM header and pixels, its place kept as a byte offset (from 0, as a hex
/// dump counts) for the errors.
struct Scan<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Scan<'_> {
    /// Past whitespace and `#` comments (to the end of their line).
    fn skip_blanks(&mut self) {
        while let Some(&b) = self.bytes.get(self.at) {
            if b == b'#' {
                while self.bytes.get(self.at).is_some_and(|&c| c != b'\n' && c != b'\r') {
                    self.at += 1;
                }
            } else if is_blank(b) {
                self.at += 1;
            } else {
                return;
            }
        }
    }

    /// A whole number from `lo` to `hi` after blanks and comments, ended by a blank, a comment
    /// or the end of the file; else an error at its first byte saying `what` was expected.
    fn number(&mut self, lo: u32, hi: u32, what: &dyn Fn() -> String) -> Result<u32, String> {
        self.skip_blanks();
        let start = self.at;
        let mut value = 0u64;
        while let Some(&d) = self.bytes.get(self.at).filter(|d| d.is_ascii_digit()) {
            // Saturating: a number past the limit is an error anyway.
            value = (value * 10 + u64::from(d - b'0')).min(1 << 40);
            self.at += 1;
        }
        let ended = self.bytes.get(self.at).is_none_or(|&b| is_blank(b) || b == b'#');
        if self.at == start || !ended || value < u64::from(lo) || value > u64::from(hi) {
            return Err(format!(
                "byte {start}: expected {}, a number from {lo} to {hi}, found {}",
                what(),
                self.token(start)
            ));
        }
        Ok(value as u32)
    }

    /// The text from `start` to the next blank (shortened), for an error; or "the end of the file".
    fn token(&self, start: usize) -> String {
        let rest = self.bytes.get(start..).unwrap_or_default();
        if rest.is_empty() {
            return "the end of the file".to_owned();
        }
        let word: Vec<u8> = rest.iter().copied().take_while(|&b| !is_blank(b)).take(12).collect();
        let text: String = word.iter().copied().flat_map(std::ascii::escape_default).map(char::from).collect();
        format!("`{text}`")
    }
}

/// Netpbm's whitespace: space, tab, line feed, vertical tab, form feed, carriage return.
fn is_blank(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | 0x0b | 0x0c | b'\r')
}

/// A PPM (P3 ASCII, P6 binary) or PGM (P2 ASCII, P5 binary) image: the first in the file (a
/// binary file may hold more, one after the other; the rest is not read).
fn pnm(bytes: &[u8]) -> Result<Image, String> {
    let magic = bytes[1];
    let (kind, channels, ascii) = match magic {
        b'2' => ("PGM", 1usize, true),
        b'3' => ("PPM", 3, true),
        b'5' => ("PGM", 1, false),
        _ => ("PPM", 3, false),
    };
    let mut scan = Scan { bytes, at: 2 };
    if scan.bytes.get(2).is_some_and(|&b| !is_blank(b) && b != b'#') {
        return Err(format!("byte 2: expected whitespace after the magic number P{}", magic as char));
    }
    let width = scan.number(1, MAX_SIDE, &|| "the width".to_owned())?;
    let height = scan.number(1, MAX_SIDE, &|| "the height".to_owned())?;
    let max = scan.number(1, 65535, &|| "the maximum value".to_owned())?;
    check_size(width, height).map_err(|e| format!("byte {}: {e}", scan.at))?;
    let count = width as usize * height as usize * channels;
    let mut samples = Vec::new();
    if ascii {
        // Every sample takes a digit and all but the last a blank after it: a header claiming
        // more than the file can hold is refused before anything is sized by it.
        let left = bytes.len() - scan.at;
        if left < 2 * count - 1 {
            return Err(format!(
                "byte {}: the pixels end early: a {width}x{height} {kind} holds {count} samples, at least {} bytes as text, and only {left} bytes are left",
                bytes.len(),
                2 * count - 1
            ));
        }
        samples.reserve(count);
        for k in 0..count {
            let what = || format!("sample {} of {count}", k + 1);
            samples.push(scan.number(0, max, &what)? as u16);
        }
    } else {
        // Exactly one whitespace byte between the maximum value and the pixels.
        if !scan.bytes.get(scan.at).is_some_and(|&b| is_blank(b)) {
            return Err(format!(
                "byte {}: expected one whitespace byte after the maximum value, then the pixels, found {}",
                scan.at,
                scan.token(scan.at)
            ));
        }
        scan.at += 1;
        let size = if max < 256 { 1 } else { 2 };
        let pixels = &bytes[scan.at..];
        if pixels.len() < count * size {
            return Err(format!(
                "byte {}: the pixels end early (the file is truncated): a {width}x{height} {kind} with maximum value {max} holds {} bytes of pixels, the file has {}",
                bytes.len(),
                count * size,
                pixels.len()
            ));
        }
        samples.reserve(count);
        for (k, s) in pixels.chunks_exact(size).take(count).enumerate() {
            let v = if size == 1 { u16::from(s[0]) } else { u16::from_be_bytes([s[0], s[1]]) };
            if u32::from(v) > max {
                return Err(format!(
                    "byte {}: sample {} of {count} is {v}, over the maximum value {max}",
                    scan.at + k * size,
                    k + 1
                ));
            }
            samples.push(v);
        }
    }
    let mut image = Image::from_encoded(width, height, channels, max, &samples);
    image.format = format!("{kind} P{}, maximum {max}", magic as char);
    Ok(image)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(bytes: &[u8]) -> String {
        format!("{:#}", decode(bytes).expect_err("an error"))
    }

    #[test]
    fn p3_with_comments_reads_its_values_over_its_maximum() {
        let text = b"P3 # a comment after the magic\n# and a line of its own\n2 1\n15\n0 5 15   # mid-row\n 15 10 3\n";
        let img = decode(text).unwrap();
        assert_eq!((img.width, img.height), (2, 1));
        assert_eq!(img.display, [Vec3::new(0.0, 5.0 / 15.0, 1.0), Vec3::new(1.0, 10.0 / 15.0, 3.0 / 15.0)]);
        assert_eq!(img.linear[0], Vec3::new(0.0, srgb_decode(5.0 / 15.0), 1.0));
        assert_eq!(img.format, "PPM P3, maximum 15");
    }

    #[test]
    fn p6_reads_one_and_two_byte_samples() {
        let mut eight = b"P6\n2 1 255\n".to_vec();
        eight.extend([0, 128, 255, 10, 20, 30]);
        let img = decode(&eight).unwrap();
        assert_eq!(img.display[0], Vec3::new(0.0, 128.0 / 255.0, 1.0));
        assert_eq!(img.display[1], Vec3::new(10.0, 20.0, 30.0) / 255.0);
        // 16 bits, big-endian, as Netpbm says.
        let mut deep = b"P6 1 1 65535\n".to_vec();
        deep.extend([0x12, 0x34, 0xff, 0xff, 0x00, 0x01]);
        let img = decode(&deep).unwrap();
        assert_eq!(img.display[0], Vec3::new(0x1234 as f32 / 65535.0, 1.0, 1.0 / 65535.0));
        // A maximum of 1000 takes two bytes a sample too.
        let mut odd = b"P5 2 1 1000\n".to_vec();
        odd.extend([0x01, 0xf4, 0x03, 0xe8]);
        let img = decode(&odd).unwrap();
        assert_eq!(img.display, [Vec3::splat(0.5), Vec3::ONE]);
        assert_eq!(img.format, "PGM P5, maximum 1000");
    }

    #[test]
    fn p2_grey_is_grey_in_every_channel() {
        let img = decode(b"P2\n3 1\n4\n0 2 4").unwrap();
        assert_eq!(img.display, [Vec3::ZERO, Vec3::splat(0.5), Vec3::ONE]);
    }

    #[test]
    fn ppm_errors_name_the_byte_and_what_was_expected() {
        // The maximum value starts at byte 17.
        assert_eq!(
            err(b"P6\n# by hand\n2 2 70000\n"),
            "byte 17: expected the maximum value, a number from 1 to 65535, found `70000`"
        );
        assert_eq!(err(b"P3\n2 x 255\n"), "byte 5: expected the height, a number from 1 to 65535, found `x`");
        assert_eq!(err(b"P3\n0 2 255\n"), "byte 3: expected the width, a number from 1 to 65535, found `0`");
        assert_eq!(
            err(b"P3\n2 2"),
            "byte 6: expected the maximum value, a number from 1 to 65535, found the end of the file"
        );
        assert_eq!(err(b"P612 2 255\n"), "byte 2: expected whitespace after the magic number P6");
        assert_eq!(err(b"P3 1 1 255\n1 2 300"), "byte 15: expected sample 3 of 3, a number from 0 to 255, found `300`");
        assert_eq!(
            err(b"P3 1 2 255\n1 2 3 4 5   "),
            "byte 23: expected sample 6 of 6, a number from 0 to 255, found the end of the file"
        );
        let truncated = err(b"P6 2 2 255\n\x01\x02\x03\x04\x05\x06\x07");
        assert!(truncated.starts_with("byte 18: the pixels end early (the file is truncated)"), "{truncated}");
        assert!(truncated.contains("holds 12 bytes of pixels, the file has 7"), "{truncated}");
        assert_eq!(err(b"P5 1 1 100\n\x65"), "byte 11: sample 1 of 1 is 101, over the maximum value 100");
        assert_eq!(
            err(b"P6 1 1 255"),
            "byte 10: expected one whitespace byte after the maximum value, then the pixels, found the end of the file"
        );
        // A header claiming a huge image in a small file is refused before anything is sized.
        let huge = err(b"P3 8000 8000 255\n0 0 0");
        assert!(huge.contains("the pixels end early") && huge.contains("192000000 samples"), "{huge}");
        let over = err(b"P6 65535 65535 255\n");
        assert!(over.contains("more than the 67108864"), "{over}");
    }

    #[test]
    fn unknown_and_unsupported_formats_say_what_is_read() {
        let jpeg = err(b"\xff\xd8\xff\xe0JFIF");
        assert!(jpeg.starts_with("unknown image format (the file starts with `\\xff\\xd8\\xff\\xe0JFIF`)"), "{jpeg}");
        assert!(jpeg.contains("expected a PNG, OpenEXR, PPM (P3, P6) or PGM (P2, P5) image"), "{jpeg}");
        assert!(err(b"P1 1 1 0").contains("PBM bitmap"));
        assert!(err(b"").contains("empty"));
        assert!(err(b"\x89PNG\r\n\x1a\nrest").starts_with("not a readable PNG file"));
    }

    #[test]
    fn sixteen_bit_png_and_exr_read_as_written() {
        let mut png = Vec::new();
        let values: Vec<u16> = vec![0, 1000, 65535, 32768, 12345, 54321];
        let buf = image::ImageBuffer::<image::Rgb<u16>, _>::from_raw(2, 1, values.clone()).unwrap();
        buf.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
        let img = decode(&png).unwrap();
        assert_eq!(img.format, "PNG 16-bit RGB");
        let expected: Vec<f32> = values.iter().map(|&v| v as f32 / 65535.0).collect();
        assert_eq!(img.display.iter().flat_map(|p| p.to_array()).collect::<Vec<_>>(), expected);
        // Grey with alpha: grey in every channel, alpha ignored and said so.
        let mut la = Vec::new();
        let buf = image::ImageBuffer::<image::LumaA<u8>, _>::from_raw(1, 1, vec![51u8, 7]).unwrap();
        buf.write_to(&mut std::io::Cursor::new(&mut la), image::ImageFormat::Png).unwrap();
        let img = decode(&la).unwrap();
        assert_eq!(img.display, [Vec3::splat(0.2)]);
        assert_eq!(img.notes, ["its alpha channel is ignored"]);
        // EXR: linear as stored, encoded for the display domain, NaN taken as 0.
        let exr =
            crate::output::encode_exr(2, 1, &[Vec3::new(0.214, 2.0, 0.0), Vec3::new(f32::NAN, 0.5, 1.0)]).unwrap();
        let img = decode(&exr).unwrap();
        assert_eq!(img.linear, [Vec3::new(0.214, 2.0, 0.0), Vec3::new(0.0, 0.5, 1.0)]);
        assert!((img.display[0].x - 0.5).abs() < 2e-3 && (img.display[0].y - 1.0).abs() < 1e-6, "{:?}", img.display);
        assert_eq!(img.notes, ["1 pixels hold NaN or infinite values (compared as 0)"]);
    }
}

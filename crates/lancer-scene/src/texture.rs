//! Texture files decoded at a bounded cost: the size read from the header and held to a pixel
//! budget before anything is decoded, the decoder's allocations limited to what that size
//! costs, and the samples kept as decoded (8-bit sRGB stays 8-bit, grey one channel).

use std::io::Cursor;
use std::sync::{Arc, OnceLock};

use image::{DynamicImage, ImageBuffer, ImageDecoder, ImageReader, Limits, Luma, LumaA, Rgb, Rgba};
use lancer_core::{Texels, Texture, Vec3, srgb_decode};

/// The most pixels all of a scene's textures may hold together unless raised: 8192 × 8192
/// (64 MB as 8-bit grey, 192 MB as 8-bit colour).
pub const MAX_TEXTURE_PIXELS: u64 = 8192 * 8192;

/// What a decoder may allocate beyond its image buffer (rows, compression windows).
const SLACK: u64 = 16 << 20;

/// Decodes an image file's bytes into a texture, refusing from its header alone one whose pixels
/// with the `used` pixels of the scene's other textures would be more than `budget`.
pub(crate) fn decode(bytes: &[u8], used: u64, budget: u64) -> Result<Texture, String> {
    let reader =
        || ImageReader::new(Cursor::new(bytes)).with_guessed_format().map_err(|e| format!("reading the image: {e}"));
    let decoder = reader()?.into_decoder().map_err(|e| e.to_string())?;
    let (width, height) = decoder.dimensions();
    let pixels = width as u64 * height as u64;
    if used.saturating_add(pixels) > budget {
        let others = if used > 0 { format!(" with the scene's other textures' {used}") } else { String::new() };
        return Err(format!(
            "the image is {width}x{height}, {pixels} pixels{others}: over the {budget}-pixel budget for a scene's textures (raise it with --max-texture-pixels)"
        ));
    }
    let mut limits = Limits::default();
    limits.max_image_width = Some(width);
    limits.max_image_height = Some(height);
    limits.max_alloc = Some(decoder.total_bytes().saturating_add(SLACK));
    let mut reader = reader()?;
    reader.limits(limits);
    let img = reader.decode().map_err(|e| e.to_string())?;
    Ok(compact(img))
}

/// Every `step`-th sample of `samples`, the first `keep` of each group.
fn channels<T: Copy>(samples: &[T], step: usize, keep: usize) -> Vec<T> {
    samples.chunks_exact(step).flat_map(|p| p[..keep].iter().copied()).collect()
}

/// The linear value of each sample of one pixel layout: every sample value through the image
/// crate's own conversion to floats, then the sRGB curve undone. The conversion's arithmetic
/// differs between layouts in the last bit (a product with `1 / 255` for grey, a quotient for
/// RGBA), so a table made this way gives each texel the very bits the decoded image converted
/// to floats would.
fn table_of(image: DynamicImage) -> Arc<[f32]> {
    image.into_rgb32f().pixels().map(|p| srgb_decode(p[0])).collect()
}

/// The tables of the eight integer layouts, each made once.
fn table(layout: usize, make: impl FnOnce() -> DynamicImage) -> Arc<[f32]> {
    static TABLES: [OnceLock<Arc<[f32]>>; 8] = [const { OnceLock::new() }; 8];
    TABLES[layout].get_or_init(|| table_of(make())).clone()
}

fn every8<P: image::Pixel<Subpixel = u8>>(pixel: fn(u8) -> P) -> ImageBuffer<P, Vec<u8>> {
    ImageBuffer::from_fn(256, 1, |x, _| pixel(x as u8))
}

fn every16<P: image::Pixel<Subpixel = u16>>(pixel: fn(u16) -> P) -> ImageBuffer<P, Vec<u16>> {
    ImageBuffer::from_fn(65536, 1, |x, _| pixel(x as u16))
}

/// The decoded image kept compactly: alpha dropped, integers kept as integers.
fn compact(img: DynamicImage) -> Texture {
    let (width, height) = (img.width(), img.height());
    let srgb8 = |channels, samples, layout, make: fn() -> DynamicImage| Texels::Srgb8 {
        channels,
        samples,
        table: table(layout, make),
    };
    let srgb16 = |channels, samples, layout, make: fn() -> DynamicImage| Texels::Srgb16 {
        channels,
        samples,
        table: table(layout, make),
    };
    let texels = match img {
        DynamicImage::ImageLuma8(b) => srgb8(1, b.into_raw(), 0, || every8(|s| Luma([s])).into()),
        DynamicImage::ImageLumaA8(b) => srgb8(1, channels(b.as_raw(), 2, 1), 1, || every8(|s| LumaA([s, 255])).into()),
        DynamicImage::ImageRgb8(b) => srgb8(3, b.into_raw(), 2, || every8(|s| Rgb([s, s, s])).into()),
        DynamicImage::ImageRgba8(b) => {
            srgb8(3, channels(b.as_raw(), 4, 3), 3, || every8(|s| Rgba([s, s, s, 255])).into())
        }
        DynamicImage::ImageLuma16(b) => srgb16(1, b.into_raw(), 4, || every16(|s| Luma([s])).into()),
        DynamicImage::ImageLumaA16(b) => {
            srgb16(1, channels(b.as_raw(), 2, 1), 5, || every16(|s| LumaA([s, 65535])).into())
        }
        DynamicImage::ImageRgb16(b) => srgb16(3, b.into_raw(), 6, || every16(|s| Rgb([s, s, s])).into()),
        DynamicImage::ImageRgba16(b) => {
            srgb16(3, channels(b.as_raw(), 4, 3), 7, || every16(|s| Rgba([s, s, s, 65535])).into())
        }
        // Float images (EXR) are linear already.
        img @ (DynamicImage::ImageRgb32F(_) | DynamicImage::ImageRgba32F(_)) => {
            Texels::Linear(img.into_rgb32f().pixels().map(|p| Vec3::new(p[0], p[1], p[2])).collect())
        }
        // Any other layout a later decoder gives: sRGB-encoded, as floats.
        other => Texels::Linear(
            other
                .into_rgb32f()
                .pixels()
                .map(|p| Vec3::new(srgb_decode(p[0]), srgb_decode(p[1]), srgb_decode(p[2])))
                .collect(),
        ),
    };
    Texture { width, height, texels }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png(img: DynamicImage) -> Vec<u8> {
        let mut out = Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png).unwrap();
        out.into_inner()
    }

    #[test]
    fn every_layout_reads_as_the_float_conversion_made_linear() {
        // What loading did before textures were kept compact: every image to 32-bit floats,
        // then the sRGB curve undone. The compact forms must give the same bits.
        let rgba = image::RgbaImage::from_fn(7, 5, |x, y| image::Rgba([(x * 37) as u8, (y * 51) as u8, 200, 9]));
        let deep = image::ImageBuffer::<image::Rgb<u16>, _>::from_fn(7, 5, |x, y| {
            image::Rgb([(x * 9000) as u16, (y * 13001) as u16, 65535])
        });
        let rgba = DynamicImage::ImageRgba8(rgba);
        let deep = DynamicImage::ImageRgb16(deep);
        for img in [
            rgba.clone(),
            rgba.to_rgb8().into(),
            rgba.to_luma8().into(),
            rgba.to_luma_alpha8().into(),
            deep.clone(),
            deep.to_rgba16().into(),
            deep.to_luma16().into(),
            deep.to_luma_alpha16().into(),
        ] {
            let t = decode(&png(img.clone()), 0, MAX_TEXTURE_PIXELS).unwrap();
            let floats = img.into_rgb32f();
            for (i, p) in floats.pixels().enumerate() {
                let want = Vec3::new(srgb_decode(p[0]), srgb_decode(p[1]), srgb_decode(p[2]));
                assert_eq!(t.texel(i), want, "pixel {i}");
            }
        }
    }

    #[test]
    fn regression_a_huge_grey_png_is_refused_from_its_header_and_a_large_one_stays_one_byte_a_pixel() {
        // Found in review: a 62 KB PNG of 8000 x 8000 grey peaked at 1.5 GB (decoded, then 24
        // bytes a pixel); a 23000 x 23000 one panicked.
        let grey = png(image::GrayImage::from_pixel(3000, 3000, image::Luma([128])).into());
        assert!(grey.len() < 64 * 1024, "the file is small: {} bytes", grey.len());
        let t = decode(&grey, 0, MAX_TEXTURE_PIXELS).unwrap();
        assert_eq!(t.bytes(), 3000 * 3000, "one byte a pixel");
        let e = decode(&grey, 0, 1000 * 1000).unwrap_err();
        assert!(e.contains("3000x3000, 9000000 pixels: over the 1000000-pixel budget"), "{e}");
        assert!(e.contains("--max-texture-pixels"), "{e}");
    }

    #[test]
    fn regression_one_file_named_three_ways_is_decoded_once_and_the_budget_counts_all_textures() {
        // Found in review: `a.png`, `./a.png` and `.//a.png` were decoded three times.
        let bytes = png(image::GrayImage::from_pixel(40, 30, image::Luma([90])).into());
        let other = png(image::GrayImage::from_pixel(40, 30, image::Luma([91])).into());
        let read = std::cell::Cell::new(0);
        let resolve = |p: &str| {
            read.set(read.get() + 1);
            Ok(if p == "b.png" { other.clone() } else { bytes.clone() })
        };
        let camera = "[camera]\nfrom = [0, 0, 5]\nto = [0, 0, 0]\n";
        let mut src = camera.to_owned();
        for (k, path) in ["a.png", "./a.png", ".//a.png", "b.png"].iter().enumerate() {
            src += &format!("[materials.m{k}]\ncolor = {{ pattern = \"image\", path = \"{path}\" }}\n");
            src += &format!("[[objects]]\nshape = \"sphere\"\nmaterial = \"m{k}\"\n");
        }
        let registry = lancer_shading::Registry::with_builtins();
        let l = crate::load_scene_with(&src, "s.toml", &registry, &resolve).unwrap();
        assert_eq!(l.scene.textures.len(), 2, "a.png decoded once, b.png once");
        assert_eq!(read.get(), 4);
        // Two textures of 1200 pixels: a budget of 2000 takes the first only.
        let limits = crate::Limits { max_texture_pixels: 2000, ..Default::default() };
        let e = match crate::load_scene_within(&src, "s.toml", &registry, &resolve, &limits) {
            Err(e) => e,
            Ok(_) => panic!("over the budget"),
        };
        let text = e.to_string();
        assert!(text.contains("texture `b.png`: the image is 40x30, 1200 pixels with the scene's other textures' 1200: over the 2000-pixel budget"), "{text}");
        assert_eq!(e.line, src.lines().position(|l| l.contains("b.png")).unwrap() + 1, "{text}");
    }

    #[test]
    fn a_header_lying_about_its_size_is_an_error_not_a_panic() {
        let mut bytes = png(image::GrayImage::from_pixel(16, 16, image::Luma([7])).into());
        // The IHDR's width (bytes 16..20) claims 23000 x 23000: the data is far too short.
        bytes[16..20].copy_from_slice(&23000u32.to_be_bytes());
        bytes[20..24].copy_from_slice(&23000u32.to_be_bytes());
        assert!(decode(&bytes, 0, u64::MAX).is_err());
        assert!(decode(b"not an image", 0, MAX_TEXTURE_PIXELS).is_err());
    }
}

//! Texture images kept as they were decoded: 8- and 16-bit sRGB samples stay integers (grey
//! images one channel) and are made linear as they are read, through a table, so an 8-bit grey
//! image costs one byte a pixel, not twelve; float images (EXR) are linear already.

use std::sync::Arc;

use glam::Vec3;

pub use crate::srgb::srgb_decode;

/// A texture's samples, row 0 at the top, channels interleaved.
#[derive(Clone, Debug, PartialEq)]
pub enum Texels {
    /// 8-bit sRGB-encoded samples, one channel (grey) or three (RGB) a pixel.
    Srgb8 {
        /// 1 or 3.
        channels: u8,
        /// `width * height * channels` samples.
        samples: Vec<u8>,
        /// The linear value of each sample (256 of them; shared between textures).
        table: Arc<[f32]>,
    },
    /// 16-bit sRGB-encoded samples, one channel (grey) or three (RGB) a pixel.
    Srgb16 {
        /// 1 or 3.
        channels: u8,
        /// `width * height * channels` samples.
        samples: Vec<u16>,
        /// The linear value of each sample (65536 of them; shared between textures).
        table: Arc<[f32]>,
    },
    /// Linear colours (float images).
    Linear(Vec<Vec3>),
}

/// A texture image, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The samples, as decoded.
    pub texels: Texels,
}

impl Texture {
    /// A texture of linear colours, `width * height` of them.
    pub fn linear(width: u32, height: u32, pixels: Vec<Vec3>) -> Texture {
        assert_eq!(pixels.len() as u64, width as u64 * height as u64, "one colour a pixel");
        Texture { width, height, texels: Texels::Linear(pixels) }
    }

    /// Pixel `index` (row by row from the top left) as a linear colour.
    #[inline]
    pub fn texel(&self, index: usize) -> Vec3 {
        fn read<T: Copy + Into<usize>>(channels: u8, samples: &[T], table: &[f32], index: usize) -> Vec3 {
            match channels {
                1 => Vec3::splat(table[samples[index].into()]),
                _ => {
                    let s = &samples[3 * index..3 * index + 3];
                    Vec3::new(table[s[0].into()], table[s[1].into()], table[s[2].into()])
                }
            }
        }
        match &self.texels {
            Texels::Linear(p) => p[index],
            Texels::Srgb8 { channels, samples, table } => read(*channels, samples, table, index),
            Texels::Srgb16 { channels, samples, table } => read(*channels, samples, table, index),
        }
    }

    /// Every pixel as a linear colour (for writing the image out).
    pub fn linear_pixels(&self) -> Vec<Vec3> {
        (0..self.width as usize * self.height as usize).map(|i| self.texel(i)).collect()
    }

    /// The bytes its samples take.
    pub fn bytes(&self) -> usize {
        match &self.texels {
            Texels::Linear(p) => std::mem::size_of_val(p.as_slice()),
            Texels::Srgb8 { samples, .. } => samples.len(),
            Texels::Srgb16 { samples, .. } => 2 * samples.len(),
        }
    }

    /// Bilinear lookup at `(u, v)`, wrapping around; `v = 0` is the image's bottom row.
    pub fn sample(&self, u: f32, v: f32) -> Vec3 {
        let (w, h) = (self.width as i64, self.height as i64);
        let x = u.rem_euclid(1.0) * w as f32 - 0.5;
        let y = (1.0 - v.rem_euclid(1.0)) * h as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let at = |i: i64, j: i64| self.texel((j.rem_euclid(h) * w + i.rem_euclid(w)) as usize);
        let (i, j) = (x0 as i64, y0 as i64);
        let top = at(i, j).lerp(at(i + 1, j), fx);
        let bottom = at(i, j + 1).lerp(at(i + 1, j + 1), fx);
        top.lerp(bottom, fy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grey_and_rgb_samples_read_as_the_same_colours_through_their_table() {
        let table: Arc<[f32]> = (0..256).map(|s| srgb_decode(s as f32 / 255.0)).collect();
        let deep: Arc<[f32]> = (0..65536).map(|s| srgb_decode(s as f32 / 65535.0)).collect();
        let grey = Texture {
            width: 2,
            height: 1,
            texels: Texels::Srgb8 { channels: 1, samples: vec![0, 188], table: table.clone() },
        };
        let rgb = Texture {
            width: 2,
            height: 1,
            texels: Texels::Srgb8 { channels: 3, samples: vec![0, 0, 0, 188, 188, 188], table },
        };
        let wide = Texture {
            width: 2,
            height: 1,
            texels: Texels::Srgb16 {
                channels: 3,
                samples: vec![0, 0, 0, 188 * 257, 188 * 257, 188 * 257],
                table: deep,
            },
        };
        for i in 0..2 {
            assert_eq!(grey.texel(i), rgb.texel(i));
            assert!((wide.texel(i) - rgb.texel(i)).abs().max_element() < 1e-6, "188 * 257 / 65535 = 188 / 255");
        }
        assert!((grey.texel(1).x - 0.5029).abs() < 1e-3);
        assert_eq!((grey.bytes(), rgb.bytes(), wide.bytes()), (2, 6, 12));
        assert_eq!(grey.linear_pixels(), rgb.linear_pixels());
        assert_eq!(srgb_decode(1.0), 1.0);
        assert_eq!(srgb_decode(0.0), 0.0);
    }
}

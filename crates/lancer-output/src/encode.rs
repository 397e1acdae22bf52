//! Image files as bytes: the sRGB curve, 8-bit sRGB PNG and linear float OpenEXR encoders (the
//! same bytes for the same pixels, on every platform: the CLI writes them to files, the browser
//! build hands them to downloads).

use std::io::{Cursor, Seek, Write};

use glam::Vec3;

/// Why an image could not be encoded.
#[derive(Debug, thiserror::Error)]
pub enum EncodeError {
    /// The pixels are not `width` x `height` of them.
    #[error("the image buffer holds {got} pixels, not {width}x{height}")]
    Size {
        /// The width asked for.
        width: u32,
        /// The height asked for.
        height: u32,
        /// The pixels given.
        got: usize,
    },
    /// The PNG encoder failed (a write failed).
    #[error("encoding PNG: {0}")]
    Png(#[from] image::ImageError),
    /// The OpenEXR encoder failed (a write failed).
    #[error("encoding EXR: {0}")]
    Exr(#[from] exr::error::Error),
}

type Result<T> = std::result::Result<T, EncodeError>;
pub use lancer_core::srgb::srgb_encode;
use lancer_core::srgb::srgb8;

/// 8-bit sRGB pixels of a linear image, row-major RGB: [`srgb8`] for every channel, by its
/// thresholds (a bucket of the float's bits, then one comparison) instead of a power per
/// channel: the same bytes.
pub fn to_srgb8(pixels: &[Vec3]) -> Vec<u8> {
    pixels.iter().flat_map(|p| p.to_array()).map(srgb8).collect()
}

/// A PNG file's bytes: the linear image sRGB-encoded to 8 bits per channel.
pub fn encode_png(width: u32, height: u32, pixels: &[Vec3]) -> Result<Vec<u8>> {
    let mut out = Cursor::new(Vec::new());
    write_png(&mut out, width, height, pixels)?;
    Ok(out.into_inner())
}

/// The image encoded straight to `out` as an 8-bit sRGB PNG.
pub fn write_png(out: &mut (impl Write + Seek), width: u32, height: u32, pixels: &[Vec3]) -> Result<()> {
    let size = EncodeError::Size { width, height, got: pixels.len() };
    let img = image::RgbImage::from_raw(width, height, to_srgb8(pixels)).ok_or(size)?;
    Ok(img.write_to(out, image::ImageFormat::Png)?)
}

/// An OpenEXR file's bytes: the linear image as 32-bit floats.
pub fn encode_exr(width: u32, height: u32, pixels: &[Vec3]) -> Result<Vec<u8>> {
    let mut out = Cursor::new(Vec::new());
    write_exr(&mut out, width, height, pixels)?;
    Ok(out.into_inner())
}

/// The image encoded straight to `out` as OpenEXR: R, G and B as 32-bit floats, RLE-compressed
/// scan lines in increasing order, on the calling thread (the files of `--aov` are written side
/// by side already), so the same pixels always give the same bytes.
///
/// The `exr` crate writes the header and offset tables; each scan line is laid out and
/// compressed here ([`RleLine::compress`], [`rle_pack`]), straight from the row: the crate's
/// per-pixel interface took 12 ns a pixel, and its RLE packing, byte by byte, a fifth more time
/// than this one (`--aov` writing 0.099 against 0.082 s on the benchmark scene).
pub fn write_exr(out: &mut (impl Write + Seek), width: u32, height: u32, pixels: &[Vec3]) -> Result<()> {
    use exr::block::chunk::{Chunk, CompressedBlock, CompressedScanLineBlock};
    use exr::block::writer::ChunksWriter;
    use exr::meta::BlockDescription;
    use exr::meta::attribute::{ChannelDescription, LineOrder, SampleType};
    use exr::meta::header::Header;
    let (w, h) = (width as usize, height as usize);
    if pixels.len() != w * h {
        return Err(EncodeError::Size { width, height, got: pixels.len() });
    }
    // Channels in the file's order, by name: B, G, R.
    let channels = ["B", "G", "R"].map(|name| ChannelDescription::named(name, SampleType::F32));
    let header = Header::new("".into(), (w, h), exr::prelude::SmallVec::from_vec(channels.to_vec())).with_encoding(
        exr::compression::Compression::RLE,
        BlockDescription::ScanLines,
        LineOrder::Increasing,
    );
    exr::block::writer::write_chunks_with(out, exr::prelude::SmallVec::from_vec(vec![header]), true, |_, chunks| {
        let mut line = RleLine::default();
        for (y, row) in pixels.chunks_exact(w.max(1)).enumerate().take(h) {
            let compressed_pixels_le = line.compress(row);
            let y_coordinate = i32::try_from(y).map_err(|_| exr::error::Error::Invalid("image height".into()))?;
            let block = CompressedBlock::ScanLine(CompressedScanLineBlock { y_coordinate, compressed_pixels_le });
            chunks.write_chunk(y, Chunk { layer_index: 0, compressed_block: block })?;
        }
        Ok(())
    })?;
    Ok(())
}

/// One scan line of an OpenEXR file with RLE compression, and the buffers it is made in (kept
/// from line to line).
#[derive(Default)]
struct RleLine {
    split: Vec<u8>,
    delta: Vec<u8>,
    triple: Vec<u8>,
}

impl RleLine {
    /// The bytes of `row` as an RLE block: its samples laid out channel after channel (B, G, R,
    /// little-endian f32), their bytes split into even and odd halves, each byte replaced by its
    /// difference to the one before (plus 128), then packed into runs and literals by the
    /// OpenEXR reference's rules ([`rle_pack`]); the raw samples when that is no smaller, as
    /// the format asks.
    fn compress(&mut self, row: &[Vec3]) -> Vec<u8> {
        let RleLine { split, delta, triple } = self;
        let n = row.len() * 12;
        // A sample starts at an even offset: its bytes 0 and 2 go to the even half, 1 and 3 to
        // the odd one.
        split.clear();
        split.resize(n, 0);
        let (even, odd) = split.split_at_mut(n / 2);
        let w = row.len() * 2;
        for (c, axis) in [2, 1, 0].into_iter().enumerate() {
            let (e, o) = (&mut even[c * w..(c + 1) * w], &mut odd[c * w..(c + 1) * w]);
            for ((e, o), p) in e.chunks_exact_mut(2).zip(o.chunks_exact_mut(2)).zip(row) {
                let b = p[axis].to_le_bytes();
                (e[0], e[1], o[0], o[1]) = (b[0], b[2], b[1], b[3]);
            }
        }
        delta.clear();
        delta.extend(split.first().copied());
        delta.extend(
            split.iter().zip(split.get(1..).unwrap_or_default()).map(|(a, b)| b.wrapping_sub(*a).wrapping_add(128)),
        );
        let packed = rle_pack(delta, triple);
        if packed.len() < n {
            return packed;
        }
        let mut raw = vec![0; n];
        for (c, axis) in [2, 1, 0].into_iter().enumerate() {
            for (bytes, p) in raw[c * w * 2..(c + 1) * w * 2].chunks_exact_mut(4).zip(row) {
                bytes.copy_from_slice(&p[axis].to_le_bytes());
            }
        }
        raw
    }
}

/// The OpenEXR reference's RLE packing of `data` (`ImfRle.cpp`): a run of 3 to 128 equal bytes
/// as its length minus one and the byte; anything else as literals, up to 127 at a time, as
/// minus their count and the bytes, ended where a run of three equal bytes starts. `triple` is
/// scratch space: for each byte, whether it and the next two are equal (found for the whole
/// line at once, so the literal scan reads the flags eight at a time).
fn rle_pack(data: &[u8], triple: &mut Vec<u8>) -> Vec<u8> {
    const MIN_RUN: usize = 3;
    const MAX_RUN: usize = 127;
    let n = data.len();
    triple.clear();
    let after = |k: usize| data.get(k..).unwrap_or_default();
    triple.extend(data.iter().zip(after(1)).zip(after(2)).map(|((a, b), c)| u8::from((a == b) & (b == c))));
    triple.resize(n, 0);
    let mut out = Vec::with_capacity(n + n / 64 + 2);
    let (mut start, mut end) = (0, 1);
    while start < n {
        // The run of bytes equal to the first (at most 128), eight at a time.
        let (byte, cap) = (data[start], n.min(start + MAX_RUN + 1));
        let pattern = u64::from_ne_bytes([byte; 8]);
        while end + 8 <= cap {
            let v = u64::from_le_bytes(data[end..end + 8].try_into().expect("eight bytes"));
            let differ = v ^ pattern;
            if differ != 0 {
                end += differ.trailing_zeros() as usize / 8;
                break;
            }
            end += 8;
        }
        while end < cap && data[end] == byte {
            end += 1;
        }
        if end - start >= MIN_RUN {
            out.push((end - start - 1) as u8);
            out.push(data[start]);
            start = end;
        } else {
            // Literals up to where three equal bytes start (or 127 of them).
            let limit = n.min(start + MAX_RUN);
            if end < limit {
                end = first_set(&triple[end..limit]).map_or(limit, |k| end + k);
            }
            out.push((start as isize - end as isize) as u8);
            out.extend_from_slice(&data[start..end]);
            start = end;
            end += 1;
        }
    }
    out
}

/// The index of the first non-zero byte of `flags`, eight bytes at a time.
fn first_set(flags: &[u8]) -> Option<usize> {
    let mut words = flags.chunks_exact(8);
    for (k, word) in words.by_ref().enumerate() {
        let v = u64::from_le_bytes(word.try_into().expect("eight bytes"));
        if v != 0 {
            return Some(k * 8 + v.trailing_zeros() as usize / 8);
        }
    }
    let rest = words.remainder();
    rest.iter().position(|&f| f != 0).map(|k| flags.len() - rest.len() + k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_curve_endpoints_and_midpoint() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        // Linear 0.214 is sRGB ~0.5 (the familiar "middle grey" pair).
        assert!((srgb_encode(0.214) - 0.5).abs() < 2e-3);
        assert_eq!(srgb_encode(f32::NAN), 0.0);
        assert_eq!(srgb_encode(7.0), srgb_encode(1.0));
        assert_eq!(to_srgb8(&[Vec3::new(0.0, 1.0, 2.0)]), [0, 255, 255]);
    }

    #[test]
    fn exr_round_trips_linear_floats() {
        let px = vec![Vec3::new(0.25, 1.5, 0.0), Vec3::new(3.0, 0.125, 0.5)];
        let bytes = encode_exr(2, 1, &px).unwrap();
        let back = image::load_from_memory(&bytes).unwrap().into_rgb32f();
        assert_eq!(back.as_raw(), &[0.25, 1.5, 0.0, 3.0, 0.125, 0.5]);
        // Many rows and columns of distinct values in each channel (runs of equal values too,
        // which RLE packs), read back bit for bit by the `image` crate's decoder.
        let (w, h) = (37u32, 23u32);
        let px: Vec<Vec3> = (0..w * h)
            .map(|i| {
                let run = (i / 5) as f32;
                Vec3::new(i as f32 * 0.37 - 50.0, run * 1e-3, if i % 7 == 0 { 1e30 } else { -(i as f32).sqrt() })
            })
            .collect();
        let back = image::load_from_memory(&encode_exr(w, h, &px).unwrap()).unwrap().into_rgb32f();
        assert_eq!((back.width(), back.height()), (w, h));
        let expected: Vec<u32> = px.iter().flat_map(|p| p.to_array()).map(f32::to_bits).collect();
        assert_eq!(back.as_raw().iter().map(|v| v.to_bits()).collect::<Vec<_>>(), expected);
    }

    /// The file the `exr` crate writes itself for the same header and lines: its own layout and
    /// RLE compression of each block, the reference `write_exr`'s lines must match.
    fn exr_by_the_crate(width: u32, height: u32, pixels: &[Vec3]) -> Vec<u8> {
        use exr::block::writer::ChunksWriter;
        use exr::meta::BlockDescription;
        use exr::meta::attribute::{ChannelDescription, LineOrder, SampleType};
        use exr::meta::header::Header;
        let (w, h) = (width as usize, height as usize);
        let channels = ["B", "G", "R"].map(|name| ChannelDescription::named(name, SampleType::F32));
        let header = Header::new("".into(), (w, h), exr::prelude::SmallVec::from_vec(channels.to_vec())).with_encoding(
            exr::compression::Compression::RLE,
            BlockDescription::ScanLines,
            LineOrder::Increasing,
        );
        let mut out = Cursor::new(Vec::new());
        exr::block::write(&mut out, exr::prelude::SmallVec::from_vec(vec![header]), true, |meta, chunks| {
            let blocks = meta.collect_ordered_block_data(|block| {
                let (top, lines) = (block.pixel_position.y(), block.pixel_size.height());
                let mut data = Vec::new();
                for row in pixels[top * w..(top + lines) * w].chunks_exact(w) {
                    for axis in [2, 1, 0] {
                        data.extend(row.iter().flat_map(|p| p[axis].to_ne_bytes()));
                    }
                }
                data
            });
            let mut compressor = chunks.sequential_blocks_compressor(&meta);
            for (index, block) in blocks {
                compressor.compress_block(index, block)?;
            }
            Ok(())
        })
        .unwrap();
        out.into_inner()
    }

    #[test]
    fn exr_lines_are_packed_to_the_bytes_the_exr_crate_writes() {
        // Noise (no run: the raw line is kept), black (runs longer than 128), runs of every
        // length up to 300, repeated pairs, and a mix, at widths from 1 to 300.
        let mut state = 0x9E37_79B9u32;
        let mut noise = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            f32::from_bits(state >> 2)
        };
        for (w, h) in [(1u32, 3u32), (2, 2), (3, 5), (37, 23), (300, 4)] {
            let n = (w * h) as usize;
            let patterns: Vec<Vec<Vec3>> = vec![
                (0..n).map(|_| Vec3::new(noise(), noise(), noise())).collect(),
                vec![Vec3::ZERO; n],
                (0..n).map(|i| Vec3::splat((i / (1 + i % 300)) as f32 * 0.5)).collect(),
                (0..n).map(|i| if (i / 2) % 2 == 0 { Vec3::ONE } else { Vec3::new(0.25, noise(), 0.0) }).collect(),
                (0..n).map(|i| if i % 11 < 6 { Vec3::ZERO } else { Vec3::new(noise(), 1.0, noise()) }).collect(),
            ];
            for (k, px) in patterns.iter().enumerate() {
                let ours = encode_exr(w, h, px).unwrap();
                assert!(ours == exr_by_the_crate(w, h, px), "{w}x{h}, pattern {k}: the files differ");
            }
        }
    }
}

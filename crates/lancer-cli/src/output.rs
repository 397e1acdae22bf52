//! Image encoding and atomic file output.

use std::io::{BufWriter, Cursor, Seek, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use glam::Vec3;

/// The sRGB transfer function of one linear channel, clamped to [0, 1].
#[inline]
pub fn srgb_encode(linear: f32) -> f32 {
    let c = if linear.is_nan() { 0.0 } else { linear.clamp(0.0, 1.0) };
    if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }
}

/// One linear channel as an 8-bit sRGB value: the encoded value rounded to the nearest step.
#[inline]
fn srgb8_of(linear: f32) -> u8 {
    (srgb_encode(linear) * 255.0 + 0.5) as u8
}

/// For each 8-bit value `k` from 1 to 255, the smallest linear value in [0, 1] that
/// [`srgb8_of`] takes to `k` or more: the byte of a channel is the number of thresholds at or
/// below it. [`srgb8_of`] never decreases as its input grows, so a search over the bits of the
/// non-negative floats (ordered as their values) finds each threshold exactly.
fn srgb8_thresholds() -> &'static [f32; 255] {
    static TABLE: std::sync::OnceLock<[f32; 255]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|k| {
            let k = k as u8 + 1;
            let (mut lo, mut hi) = (0u32, 1.0f32.to_bits());
            // Invariant: srgb8_of(lo) < k <= srgb8_of(hi).
            while hi - lo > 1 {
                let mid = lo + (hi - lo) / 2;
                if srgb8_of(f32::from_bits(mid)) >= k { hi = mid } else { lo = mid }
            }
            f32::from_bits(hi)
        })
    })
}

/// How many low bits of a float in [0, 1) its bucket of [`Buckets`] drops: the buckets are
/// about 2⁻⁷ of their value wide, narrower than the gap between two thresholds anywhere in
/// [0, 1), so a bucket holds at most one threshold (a test checks every bucket).
const BUCKET_SHIFT: u32 = 16;

/// The thresholds of [`srgb8_thresholds`] by bucket of float bits: for each bucket, the byte of
/// its lowest float and the one threshold inside it (infinity if none).
struct Buckets {
    base: Vec<u8>,
    next: Vec<f32>,
}

fn srgb8_buckets() -> &'static Buckets {
    static TABLE: std::sync::OnceLock<Buckets> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let thresholds = srgb8_thresholds();
        let count = (1.0f32.to_bits() >> BUCKET_SHIFT) as usize;
        let (mut base, mut next) = (Vec::with_capacity(count), Vec::with_capacity(count));
        for b in 0..count as u32 {
            let (lo, hi) = (f32::from_bits(b << BUCKET_SHIFT), f32::from_bits(((b + 1) << BUCKET_SHIFT) - 1));
            let below = thresholds.partition_point(|&t| t <= lo);
            base.push(below as u8);
            next.push(thresholds.get(below).copied().filter(|&t| t <= hi).unwrap_or(f32::INFINITY));
        }
        Buckets { base, next }
    })
}

/// [`srgb8_of`] of one channel: the number of thresholds at or below it, found in its bucket.
#[inline]
fn srgb8_fast(c: f32, buckets: &Buckets) -> u8 {
    if c >= 1.0 {
        return 255;
    }
    // NaN and everything at or below 0 (no threshold is) give 0, as `srgb_encode` takes them.
    if c.is_nan() || c <= 0.0 {
        return 0;
    }
    let b = (c.to_bits() >> BUCKET_SHIFT) as usize;
    buckets.base[b] + u8::from(c >= buckets.next[b])
}

/// 8-bit sRGB pixels of a linear image, row-major RGB: [`srgb8_of`] for every channel, by its
/// thresholds (a bucket of the float's bits, then one comparison) instead of a power per
/// channel: the same bytes.
pub fn to_srgb8(pixels: &[Vec3]) -> Vec<u8> {
    let buckets = srgb8_buckets();
    pixels.iter().flat_map(|p| p.to_array()).map(|c| srgb8_fast(c, buckets)).collect()
}

/// A PNG file's bytes: the linear image sRGB-encoded to 8 bits per channel.
pub fn encode_png(width: u32, height: u32, pixels: &[Vec3]) -> Result<Vec<u8>> {
    let mut out = Cursor::new(Vec::new());
    write_png(&mut out, width, height, pixels)?;
    Ok(out.into_inner())
}

fn write_png(out: &mut (impl Write + Seek), width: u32, height: u32, pixels: &[Vec3]) -> Result<()> {
    let img = image::RgbImage::from_raw(width, height, to_srgb8(pixels)).context("image buffer has the wrong size")?;
    img.write_to(out, image::ImageFormat::Png).context("encoding PNG")
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
fn write_exr(out: &mut (impl Write + Seek), width: u32, height: u32, pixels: &[Vec3]) -> Result<()> {
    use exr::block::chunk::{Chunk, CompressedBlock, CompressedScanLineBlock};
    use exr::block::writer::ChunksWriter;
    use exr::meta::BlockDescription;
    use exr::meta::attribute::{ChannelDescription, LineOrder, SampleType};
    use exr::meta::header::Header;
    let (w, h) = (width as usize, height as usize);
    anyhow::ensure!(pixels.len() == w * h, "image buffer has the wrong size");
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
    })
    .context("encoding EXR")
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

/// The image formats `lancer` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// sRGB 8-bit PNG.
    Png,
    /// Linear float OpenEXR.
    Exr,
}

impl Format {
    /// The format a path's extension asks for.
    pub fn of(path: &Path) -> Result<Format> {
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("png") => Ok(Format::Png),
            Some("exr") => Ok(Format::Exr),
            _ => bail!("output {} must end in .png (sRGB 8-bit) or .exr (linear float)", path.display()),
        }
    }

    /// Encodes a linear image in this format.
    pub fn encode(self, width: u32, height: u32, pixels: &[Vec3]) -> Result<Vec<u8>> {
        match self {
            Format::Png => encode_png(width, height, pixels),
            Format::Exr => encode_exr(width, height, pixels),
        }
    }

    /// Writes a linear image in this format to `path`, whole or not at all, encoding straight
    /// into the file (no copy of the encoded image in memory).
    pub fn write(self, path: &Path, width: u32, height: u32, pixels: &[Vec3]) -> Result<()> {
        self.begin_write(path, width, height, pixels)?.finish()
    }

    /// The first half of [`Format::write`]: the image encoded into a temporary file beside
    /// `path`, which [`Pending::finish`] puts in place.
    pub fn begin_write(self, path: &Path, width: u32, height: u32, pixels: &[Vec3]) -> Result<Pending> {
        Pending::begin(path, |file| {
            let mut out = BufWriter::new(file);
            match self {
                Format::Png => write_png(&mut out, width, height, pixels)?,
                Format::Exr => write_exr(&mut out, width, height, pixels)?,
            }
            out.flush()?;
            Ok(())
        })
    }
}

/// Writes `bytes` to `path` whole or not at all: into a temporary file beside it, then renamed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    atomically(path, |f| Ok(f.write_all(bytes)?))
}

/// The temporary files being written now, removed by [`remove_temporaries`] when the program
/// is interrupted or stopped.
static TEMPORARIES: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Folders this run created for its output, with the files it put in them: removed, files and
/// folder, when the program is interrupted or stopped (the folder's other files, if another
/// program wrote any meanwhile, keep it).
static CREATED_DIRS: std::sync::Mutex<Vec<(PathBuf, Vec<PathBuf>)>> = std::sync::Mutex::new(Vec::new());

fn lock<T>(m: &std::sync::Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Creates the folder `dir` for output (and its parents), remembering it if it is new, so an
/// interrupt leaves no folder of this run's behind.
pub fn create_output_dir(dir: &Path) -> Result<()> {
    let new = std::fs::symlink_metadata(dir).is_err();
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    if new {
        lock(&CREATED_DIRS).push((dir.to_path_buf(), Vec::new()));
    }
    Ok(())
}

/// Every output of a run is in place: the folders it created are no longer its to remove if it
/// is stopped now (`watch` goes on after its renders; Ctrl-C must not take their images).
pub fn outputs_done() {
    lock(&CREATED_DIRS).clear();
}

/// Removes every temporary file being written, and every output folder this run created with the
/// files it wrote there (for an interrupt or a stop: no partial output is left).
pub fn remove_temporaries() {
    remove_under(Path::new(""));
}

/// [`remove_temporaries`] for the files and folders under `root` only (everything for `""`).
fn remove_under(root: &Path) {
    for tmp in lock(&TEMPORARIES).iter().filter(|t| t.starts_with(root)) {
        let _ = std::fs::remove_file(tmp);
    }
    for (dir, files) in lock(&CREATED_DIRS).iter().filter(|(d, _)| d.starts_with(root)) {
        for f in files {
            let _ = std::fs::remove_file(f);
        }
        let _ = std::fs::remove_dir(dir);
    }
}

/// Runs `fill` on a temporary file beside `path`, flushes it to disk and renames it to `path`;
/// on any error the temporary file is removed and `path` is untouched.
fn atomically(path: &Path, fill: impl FnOnce(&mut std::fs::File) -> Result<()>) -> Result<()> {
    Pending::begin(path, fill)?.finish()
}

/// A file written in full to a temporary file beside its path, not yet flushed to disk nor
/// renamed into place: [`Pending::finish`] does both (and can run on another thread, so that
/// waiting for the disk does not hold up encoding the next file). Dropped unfinished, it
/// removes its temporary file and leaves the path untouched.
///
/// The temporary file is created exclusively (`O_EXCL`) under an unpredictable name in the
/// path's folder, so a symlink or file planted there is never followed nor overwritten; it takes
/// the permissions of the file it replaces (or a new file's usual ones); the rename replaces the
/// path itself, so a symlink planted at the path is replaced, never its target.
pub struct Pending {
    file: Option<tempfile::NamedTempFile>,
    /// The temporary file's path, as registered for [`remove_temporaries`].
    tmp: PathBuf,
    path: PathBuf,
}

/// A new temporary file in `path`'s folder, to be renamed to `path`: created exclusively under an
/// unpredictable name, with the permissions of the file at `path` when that is a regular file.
pub fn temporary_for(path: &Path) -> Result<tempfile::NamedTempFile> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name().with_context(|| format!("{} is not a file path", path.display()))?;
    let existing = std::fs::symlink_metadata(path).ok().filter(|m| m.is_file()).map(|m| m.permissions());
    let prefix = format!(".{}.", name.to_string_lossy());
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    // A new file's usual permissions (0666 less the umask), not the temporary's private 0600.
    #[cfg(unix)]
    let new_file = <std::fs::Permissions as std::os::unix::fs::PermissionsExt>::from_mode(0o666);
    #[cfg(unix)]
    builder.permissions(new_file);
    let tmp = builder.tempfile_in(dir).with_context(|| format!("creating a temporary file in {}", dir.display()))?;
    if let Some(p) = existing {
        // Exactly the replaced file's mode (the umask would narrow it at creation).
        tmp.as_file().set_permissions(p).with_context(|| format!("keeping the permissions of {}", path.display()))?;
    }
    Ok(tmp)
}

impl Pending {
    /// Runs `fill` on a new temporary file beside `path`.
    fn begin(path: &Path, fill: impl FnOnce(&mut std::fs::File) -> Result<()>) -> Result<Pending> {
        // Created and registered under the registry's lock, so a stop in between (whose cleanup
        // takes the lock) cannot miss it.
        let (file, tmp) = {
            let mut registry = lock(&TEMPORARIES);
            let file = temporary_for(path).with_context(|| format!("writing {}", path.display()))?;
            let tmp = file.path().to_path_buf();
            registry.push(tmp.clone());
            (file, tmp)
        };
        // From here on, dropping `pending` (on an error) removes the temporary file.
        let mut pending = Pending { file: Some(file), tmp, path: path.to_path_buf() };
        let f = pending.file.as_mut().expect("just set").as_file_mut();
        fill(f).with_context(|| format!("writing {}", path.display()))?;
        Ok(pending)
    }

    /// Flushes the file to disk and renames it to its path.
    pub fn finish(mut self) -> Result<()> {
        let file = self.file.take().expect("a pending file is filled");
        let result = file
            .as_file()
            .sync_all()
            .map_err(anyhow::Error::from)
            .and_then(|()| file.persist(&self.path).map(drop).map_err(|e| anyhow::Error::from(e.error)));
        // Whatever happened, the temporary is no longer ours to remove: persisted, or removed by
        // the failed persist's drop.
        self.untrack();
        self.tmp = PathBuf::new();
        result.with_context(|| format!("writing {}", self.path.display()))?;
        // A file in a folder this run created goes with the folder if the run is stopped.
        let dir = self.path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        if let Some((_, files)) = lock(&CREATED_DIRS).iter_mut().find(|(d, _)| d == dir) {
            files.push(self.path.clone());
        }
        Ok(())
    }

    fn untrack(&self) {
        lock(&TEMPORARIES).retain(|p| *p != self.tmp);
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        if !self.tmp.as_os_str().is_empty() {
            // The temporary file removes itself when dropped.
            self.file = None;
            self.untrack();
        }
    }
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
    fn the_threshold_search_gives_the_bytes_of_the_curve() {
        // Every float near a threshold (where a mistake would show), a sweep through all the
        // floats in [0, 1] and beyond, and the special values: the same byte as encoding it.
        let mut values: Vec<f32> = vec![0.0, -0.0, 1.0, -1.0, 2.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e-45];
        for &t in srgb8_thresholds() {
            let bits = t.to_bits();
            values.extend((bits.saturating_sub(64)..bits + 64).map(f32::from_bits));
        }
        values.extend((0..=1.5f32.to_bits()).step_by(997).map(f32::from_bits));
        let bytes = to_srgb8(&values.iter().map(|&v| Vec3::splat(v)).collect::<Vec<_>>());
        for (v, got) in values.iter().zip(bytes.chunks(3)) {
            assert_eq!(got, [srgb8_of(*v); 3], "{v} ({:#x})", v.to_bits());
        }
        // Every byte is reached.
        let reached: std::collections::BTreeSet<u8> = bytes.iter().copied().collect();
        assert_eq!(reached.len(), 256);
    }

    #[test]
    fn every_bucket_holds_at_most_one_threshold() {
        // What the bucket lookup relies on: a second threshold in a bucket would be missed.
        let thresholds = srgb8_thresholds();
        let mut per_bucket = std::collections::BTreeMap::new();
        for t in thresholds {
            *per_bucket.entry(t.to_bits() >> BUCKET_SHIFT).or_insert(0) += 1;
        }
        assert!(per_bucket.values().all(|&n| n == 1), "{per_bucket:?}");
        assert_eq!(per_bucket.len(), 255);
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

    #[test]
    fn a_pending_file_appears_only_when_finished_and_leaves_nothing_when_dropped() {
        let folder = tempfile::tempdir().unwrap();
        let dir = folder.path();
        let listing = || {
            let mut names: Vec<String> = std::fs::read_dir(dir)
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            names.sort();
            names
        };
        let path = dir.join("a.bin");
        let pending = Pending::begin(&path, |f| Ok(f.write_all(b"abc")?)).unwrap();
        assert!(!path.exists(), "not in place before finish");
        assert_eq!(listing().len(), 1, "one temporary file: {:?}", listing());
        pending.finish().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"abc");
        assert_eq!(listing(), ["a.bin"]);
        // Dropped unfinished: the old file stays, the temporary goes.
        drop(Pending::begin(&path, |f| Ok(f.write_all(b"new")?)).unwrap());
        assert_eq!(std::fs::read(&path).unwrap(), b"abc");
        assert_eq!(listing(), ["a.bin"]);
        // Two writers of one path at once: a temporary file each, the last finished wins.
        let (one, two) = (
            Pending::begin(&path, |f| Ok(f.write_all(b"one")?)).unwrap(),
            Pending::begin(&path, |f| Ok(f.write_all(b"two")?)).unwrap(),
        );
        assert_eq!(listing().len(), 3, "{:?}", listing());
        one.finish().unwrap();
        two.finish().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"two");
        assert_eq!(listing(), ["a.bin"]);
        // A failing fill: an error naming the file, nothing left behind.
        let err = Pending::begin(&dir.join("b.bin"), |_| bail!("no room")).err().unwrap();
        assert!(format!("{err:#}").contains("b.bin") && format!("{err:#}").contains("no room"), "{err:#}");
        assert_eq!(listing(), ["a.bin"]);
        assert!(TEMPORARIES.lock().unwrap().iter().all(|t| !t.starts_with(dir)), "none still tracked");
    }

    #[cfg(unix)]
    #[test]
    fn regression_symlinks_planted_at_temporary_names_or_the_output_are_never_followed() {
        // Found in review: temporaries were `.NAME.PID.K.tmp`, opened with create-or-truncate:
        // a symlink planted at that name had its target outside the folder overwritten, and the
        // output path became a symlink to it.
        use std::os::unix::fs::{PermissionsExt, symlink};
        let folder = tempfile::tempdir().unwrap();
        let outside = tempfile::tempdir().unwrap();
        let target = outside.path().join("precious");
        std::fs::write(&target, b"keep me").unwrap();
        let dir = folder.path();
        let path = dir.join("out.png");
        // Every name the old scheme could have picked in this process, and a few more.
        for k in 0..256 {
            symlink(&target, dir.join(format!(".out.png.{}.{k}.tmp", std::process::id()))).unwrap();
        }
        write_atomic(&path, b"image").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"keep me");
        assert!(std::fs::symlink_metadata(&path).unwrap().is_file());
        // The output path itself a symlink out of the folder: replaced, its target untouched.
        let linked = dir.join("linked.png");
        symlink(&target, &linked).unwrap();
        write_atomic(&linked, b"image").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"keep me");
        let meta = std::fs::symlink_metadata(&linked).unwrap();
        assert!(meta.is_file() && !meta.file_type().is_symlink());
        assert_eq!(std::fs::read(&linked).unwrap(), b"image");
        // An existing file keeps its permissions; a new one gets a new file's usual ones.
        let private = dir.join("private.exr");
        std::fs::write(&private, b"old").unwrap();
        std::fs::set_permissions(&private, std::fs::Permissions::from_mode(0o600)).unwrap();
        write_atomic(&private, b"new").unwrap();
        assert_eq!(std::fs::metadata(&private).unwrap().permissions().mode() & 0o777, 0o600);
        let shared = dir.join("shared.exr");
        std::fs::write(&shared, b"old").unwrap();
        std::fs::set_permissions(&shared, std::fs::Permissions::from_mode(0o664)).unwrap();
        write_atomic(&shared, b"new").unwrap();
        assert_eq!(std::fs::metadata(&shared).unwrap().permissions().mode() & 0o777, 0o664);
        let usual = std::fs::File::create(dir.join("usual")).unwrap().metadata().unwrap().permissions().mode();
        write_atomic(&dir.join("fresh.exr"), b"new").unwrap();
        assert_eq!(std::fs::metadata(dir.join("fresh.exr")).unwrap().permissions().mode(), usual);
    }

    #[test]
    fn regression_a_stop_removes_the_output_folder_it_created_with_the_files_written_there() {
        // Found in review: a stop while the per-term images were being written left the new
        // `--aov` folder with some of them (only an empty folder was removed).
        let folder = tempfile::tempdir().unwrap();
        let existing = folder.path().join("existing");
        std::fs::create_dir(&existing).unwrap();
        std::fs::write(existing.join("mine.txt"), b"not Lancer's").unwrap();
        create_output_dir(&existing).unwrap();
        write_atomic(&existing.join("beauty.png"), b"x").unwrap();
        let created = folder.path().join("aov");
        create_output_dir(&created).unwrap();
        write_atomic(&created.join("ambient.exr"), b"x").unwrap();
        write_atomic(&created.join("beauty.exr"), b"x").unwrap();
        let unfinished = Pending::begin(&created.join("diffuse.exr"), |f| Ok(f.write_all(b"half")?)).unwrap();
        remove_under(folder.path());
        assert!(!created.exists(), "the folder this run created is gone with its files");
        assert!(existing.join("mine.txt").exists() && existing.join("beauty.png").exists(), "an existing folder stays");
        drop(unfinished);
        // Once a run's outputs are all in place, a stop takes nothing (a watch's earlier image).
        let kept = folder.path().join("kept");
        create_output_dir(&kept).unwrap();
        write_atomic(&kept.join("beauty.exr"), b"x").unwrap();
        outputs_done();
        remove_under(folder.path());
        assert!(kept.join("beauty.exr").exists(), "a finished run's folder stays");
    }

    #[test]
    fn unknown_extension_is_refused() {
        assert!(Format::of(Path::new("x.jpg")).unwrap_err().to_string().contains(".png"));
        assert_eq!(Format::of(Path::new("x.EXR")).unwrap(), Format::Exr);
    }
}

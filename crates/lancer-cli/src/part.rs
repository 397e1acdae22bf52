//! Parts of a render (`lancer render --tile I/N`) and putting them back together (`lancer
//! merge`). A part file holds the linear float rows of its bands for every layer, after a header
//! that records where they belong and what render they come from, so the merged frame is the
//! whole render's, bit for bit.
//!
//! Layout: the line `LANCER-PART 1`, one line of JSON (the [`Header`]), then for each band of the
//! part in increasing order, for each layer in frame order, the band's rows as little-endian
//! `f32` RGB triples, row by row from the left.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use lancer_core::{Frame, Layer, RenderStats};
use serde::{Deserialize, Serialize};

const MAGIC: &[u8] = b"LANCER-PART 1\n";

/// What a part file says about itself.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// A fingerprint of the render (scene, files, model, settings, Lancer's version), in hex:
    /// parts of one render share it.
    pub identity: String,
    /// How the scene was named where the part was rendered.
    pub scene: String,
    /// The whole image's width.
    pub width: u32,
    /// The whole image's height.
    pub height: u32,
    /// Samples per pixel.
    pub samples: u32,
    /// The effective model, in words.
    pub model: String,
    /// This part's index, from 0.
    pub index: u32,
    /// How many parts the render was cut into.
    pub count: u32,
    /// Rows per band.
    pub band_rows: u32,
    /// The layers, in frame order.
    pub layers: Vec<String>,
    /// Rays traced for this part: camera, secondary, shadow.
    pub rays: [u64; 3],
    /// This part's render time in seconds.
    pub seconds: f64,
}

/// `I/N` with `0 <= I < N`.
pub fn parse_tile(s: &str) -> Result<(u32, u32), String> {
    let expected = || format!("expected I/N (part I of N, I from 0), e.g. 0/4; got `{s}`");
    let (i, n) = s.split_once('/').ok_or_else(expected)?;
    let (i, n): (u32, u32) = (i.trim().parse().map_err(|_| expected())?, n.trim().parse().map_err(|_| expected())?);
    if n == 0 || i >= n {
        return Err(format!("part {i} of {n} does not exist: I goes from 0 to N - 1"));
    }
    Ok((i, n))
}

/// The byte range of `band`'s rows in a layer of `width` pixels and `height` rows.
fn band_pixels(band: u32, width: u32, height: u32, rows: u32) -> std::ops::Range<usize> {
    let (band, width, height, rows) = (band as usize, width as usize, height as usize, rows as usize);
    let first = (band * rows).min(height);
    let last = ((band + 1) * rows).min(height);
    first * width..last * width
}

/// Writes part `header.index` of `frame` (rendered with only that part's bands) to `path`,
/// whole or not at all.
pub fn write(path: &Path, header: &Header, frame: &Frame) -> Result<()> {
    let mut bytes = MAGIC.to_vec();
    serde_json::to_writer(&mut bytes, header).context("encoding the part's header")?;
    bytes.push(b'\n');
    for band in lancer_shading::part_bands(frame.height, header.index, header.count) {
        let range = band_pixels(band, frame.width, frame.height, header.band_rows);
        for layer in &frame.layers {
            bytes.extend_from_slice(bytemuck::cast_slice(&layer.pixels[range.clone()]));
        }
    }
    crate::output::write_atomic(path, &bytes).with_context(|| format!("writing part {}", path.display()))
}

/// One part file, read and checked against its own header.
struct Part {
    path: PathBuf,
    header: Header,
    data: Vec<u8>,
}

fn read(path: &Path, limit: u64) -> Result<Part> {
    let bytes = crate::app::read_bytes(path, "part", limit).map_err(anyhow::Error::msg)?;
    let bad = |what: &str| anyhow::anyhow!("{}: not a Lancer part file ({what})", path.display());
    let rest = bytes.strip_prefix(MAGIC).ok_or_else(|| bad("it does not start with `LANCER-PART 1`"))?;
    let end = rest.iter().position(|&b| b == b'\n').ok_or_else(|| bad("no header line"))?;
    let header: Header =
        serde_json::from_slice(&rest[..end]).map_err(|e| bad(&format!("its header does not read: {e}")))?;
    let data = rest[end + 1..].to_vec();
    // A hostile or damaged header must not size anything: every figure is checked first.
    let side = 1..=16384u32;
    let bands = header.height.div_ceil(lancer_shading::TILE);
    if header.count == 0
        || header.index >= header.count
        || header.count > bands
        || header.band_rows != lancer_shading::TILE
        || !side.contains(&header.width)
        || !side.contains(&header.height)
        || header.layers.is_empty()
        || header.layers.len() > 256
    {
        return Err(bad("its header names no valid part of a render"));
    }
    let pixels: usize = lancer_shading::part_bands(header.height, header.index, header.count)
        .map(|b| band_pixels(b, header.width, header.height, header.band_rows).len())
        .sum();
    let want = pixels * header.layers.len() * 12;
    if data.len() != want {
        return Err(bad(&format!("{} bytes of pixels where its header says {want}: cut short?", data.len())));
    }
    Ok(Part { path: path.to_path_buf(), header, data })
}

/// Reads `paths` and puts them together: the frame, with the rays of all parts and the sum of
/// their render times. Every part must come from the same render (the same fingerprint, size,
/// layers and number of parts) and each part must be there exactly once.
pub fn merge(paths: &[PathBuf], limit: u64) -> Result<(Frame, f64, String)> {
    if paths.is_empty() {
        bail!("no part files given");
    }
    let parts: Vec<Part> = paths.iter().map(|p| read(p, limit)).collect::<Result<_>>()?;
    let first = &parts[0].header;
    for p in &parts[1..] {
        let h = &p.header;
        let differs = if h.identity != first.identity {
            Some(format!(
                "comes from another render (scene `{}`, {}; the first part: scene `{}`, {})",
                h.scene, h.model, first.scene, first.model
            ))
        } else if (h.width, h.height, h.samples, h.count, &h.layers)
            != (first.width, first.height, first.samples, first.count, &first.layers)
        {
            Some(format!(
                "is part of {}x{} cut in {}, the first part of {}x{} cut in {}",
                h.width, h.height, h.count, first.width, first.height, first.count
            ))
        } else {
            None
        };
        if let Some(why) = differs {
            bail!("{} {why}; nothing written", p.path.display());
        }
    }
    let mut seen: Vec<Option<&Path>> = vec![None; first.count as usize];
    for p in &parts {
        if let Some(other) = seen[p.header.index as usize] {
            bail!(
                "part {} of {} is given twice ({} and {}); nothing written",
                p.header.index,
                first.count,
                other.display(),
                p.path.display()
            );
        }
        seen[p.header.index as usize] = Some(&p.path);
    }
    let missing: Vec<String> =
        seen.iter().enumerate().filter(|(_, s)| s.is_none()).map(|(i, _)| i.to_string()).collect();
    if !missing.is_empty() {
        bail!("part(s) {} of {} missing; nothing written", missing.join(", "), first.count);
    }
    let (w, h) = (first.width, first.height);
    let mut layers: Vec<Layer> = first
        .layers
        .iter()
        .map(|name| Layer { name: name.clone(), pixels: bytemuck::zeroed_vec(w as usize * h as usize) })
        .collect();
    let mut stats = RenderStats::default();
    let mut seconds = 0.0;
    for p in &parts {
        let mut at = 0;
        for band in lancer_shading::part_bands(h, p.header.index, p.header.count) {
            let range = band_pixels(band, w, h, first.band_rows);
            for layer in &mut layers {
                let len = range.len() * 12;
                let target: &mut [u8] = bytemuck::cast_slice_mut(&mut layer.pixels[range.clone()]);
                target.copy_from_slice(&p.data[at..at + len]);
                at += len;
            }
        }
        let [camera, secondary, shadow] = p.header.rays;
        stats +=
            RenderStats { camera_rays: camera, secondary_rays: secondary, shadow_rays: shadow, ..Default::default() };
        seconds += p.header.seconds;
    }
    let described = format!("{} ({}x{}, {}, {} parts)", first.scene, w, h, first.model, first.count);
    Ok((Frame::from_layers(w, h, layers, stats), seconds, described))
}

//! Parts of a render (`lancer render --tile I/N`) and putting them back together (`lancer
//! merge`). A part file holds the linear float rows of its bands for every layer, after a header
//! that records where they belong and what render they come from, so the merged frame is the
//! whole render's, bit for bit.
//!
//! Layout: the line `LANCER-PART 2`, one line of JSON (the [`Header`]), then for each band of the
//! part in increasing order, for each layer in frame order, the band's rows as little-endian
//! `f32` RGB triples, row by row from the left.
//!
//! A part file is untrusted input (the scale-out recipes share a parts folder every node can
//! write): every header field is checked when the part is read, before anything is sized or
//! written, and a layer's name becomes a file name only when it is a term name by the
//! registry's grammar.

use std::hash::Hasher;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use lancer_core::frame::BACKGROUND;
use lancer_core::{Frame, Layer, RenderStats};
use serde::{Deserialize, Serialize};

const MAGIC: &[u8] = b"LANCER-PART 2\n";
/// The first line of the earlier format, refused with a word on what to do.
const MAGIC_1: &[u8] = b"LANCER-PART 1\n";

/// The fingerprint of some bytes, in hex (FNV-1a, 64 bits: it tells renders apart, it is not
/// a signature).
pub fn digest(bytes: &[u8]) -> String {
    let mut f = fnv::FnvHasher::default();
    f.write(bytes);
    format!("{:016x}", f.finish())
}

/// What a render depends on, each as a fingerprint: parts of one render share all of them, and
/// when two parts differ these say what differs.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sources {
    /// The scene file's text.
    pub scene: String,
    /// The `--model` file's text, when one was given.
    pub model_file: Option<String>,
    /// Each file the scene reads (meshes, textures), as the scene names it, with its contents'.
    pub files: Vec<(String, String)>,
    /// The effective model (terms, variants, parameters, shadows, depth).
    pub model: String,
    /// The image settings: size, samples per pixel, background.
    pub image: String,
    /// Lancer's version.
    pub version: String,
}

impl Sources {
    /// The fingerprint of all of them together.
    pub fn fingerprint(&self) -> String {
        digest(serde_json::to_string(self).expect("plain data serialises").as_bytes())
    }

    /// What differs between these and `other`'s, in words (none when they are the same).
    fn differences(&self, other: &Sources) -> Vec<String> {
        let mut out = Vec::new();
        if self.version != other.version {
            out.push(format!("Lancer's version ({} here, {} there)", self.version, other.version));
        }
        if self.scene != other.scene {
            out.push("the scene file's text".to_owned());
        }
        match (&self.model_file, &other.model_file) {
            (Some(a), Some(b)) if a != b => out.push("the --model file's text".to_owned()),
            (Some(_), None) | (None, Some(_)) => out.push("whether a --model file was given".to_owned()),
            _ => {}
        }
        for (name, d) in &self.files {
            match other.files.iter().find(|(n, _)| n == name) {
                Some((_, e)) if e != d => out.push(format!("the contents of `{name}`")),
                None => out.push(format!("`{name}` is read by one part only")),
                _ => {}
            }
        }
        for (name, _) in other.files.iter().filter(|(n, _)| !self.files.iter().any(|(m, _)| m == n)) {
            out.push(format!("`{name}` is read by one part only"));
        }
        if self.model != other.model {
            out.push("the effective model".to_owned());
        }
        if self.image != other.image {
            out.push("the image's size, samples or background".to_owned());
        }
        out
    }
}

/// What a part file says about itself.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Header {
    /// The fingerprint of [`Header::sources`], in hex: parts of one render share it.
    pub identity: String,
    /// What the render depends on, one fingerprint each.
    pub sources: Sources,
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
    let bytes = encode(header, frame)?;
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
    parse(path, bytes)
}

/// A part file's bytes (named `path` in messages), read and checked against its own header.
fn parse(path: &Path, bytes: Vec<u8>) -> Result<Part> {
    let bad = |what: &str| anyhow::anyhow!("{}: not a Lancer part file ({what})", path.display());
    if bytes.starts_with(MAGIC_1) {
        return Err(bad("it is in the format of an earlier Lancer: render the part again"));
    }
    let rest = bytes.strip_prefix(MAGIC).ok_or_else(|| bad("it does not start with `LANCER-PART 2`"))?;
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
    check_header(&header).map_err(|why| bad(&format!("its header {why}")))?;
    let pixels: usize = lancer_shading::part_bands(header.height, header.index, header.count)
        .map(|b| band_pixels(b, header.width, header.height, header.band_rows).len())
        .sum();
    let want = pixels * header.layers.len() * 12;
    if data.len() != want {
        return Err(bad(&format!("{} bytes of pixels where its header says {want}: cut short?", data.len())));
    }
    Ok(Part { path: path.to_path_buf(), header, data })
}

/// Text from a header that is printed in messages: short, one line, no control characters (a
/// terminal's escape sequences among them).
fn printable(s: &str, max: usize) -> bool {
    s.len() <= max && !s.chars().any(char::is_control)
}

fn is_hex_digest(s: &str) -> bool {
    s.len() == 16 && s.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
}

/// Every field of a header that the figures' check in [`read`] does not cover: the layers (each
/// a term's name by the registry's grammar, or the background; each once), the texts printed in
/// messages, the fingerprints and the figures summed over parts.
fn check_header(h: &Header) -> Result<(), String> {
    for (i, name) in h.layers.iter().enumerate() {
        let last = i + 1 == h.layers.len();
        if !(lancer_shading::is_term_name(name) || (last && name == BACKGROUND)) {
            let shown: String = name.chars().flat_map(char::escape_debug).take(80).collect();
            return Err(format!(
                "names a layer `{shown}`: a layer is a term's name (a lowercase letter, then lowercase letters, digits, `-` or `_`; not `beauty` or `manifest`), or `background` last"
            ));
        }
        if h.layers[..i].contains(name) {
            return Err(format!("names the layer `{name}` twice"));
        }
    }
    let s = &h.sources;
    let digests_ok = is_hex_digest(&h.identity)
        && is_hex_digest(&s.scene)
        && is_hex_digest(&s.model)
        && is_hex_digest(&s.image)
        && s.model_file.as_deref().is_none_or(is_hex_digest)
        && s.files.len() <= 4096
        && s.files.iter().all(|(n, d)| printable(n, 4096) && is_hex_digest(d));
    if !digests_ok || !printable(&s.version, 64) {
        return Err("has malformed fingerprints".to_owned());
    }
    if h.identity != s.fingerprint() {
        return Err("has a fingerprint that is not its sources' (the file was edited or damaged)".to_owned());
    }
    if !printable(&h.scene, 4096) || !printable(&h.model, 4096) {
        return Err("names its scene or model with control characters or at great length".to_owned());
    }
    if !(1..=1 << 20).contains(&h.samples) {
        return Err(format!("says {} samples per pixel", h.samples));
    }
    if !(h.seconds.is_finite() && h.seconds >= 0.0) || h.rays.iter().any(|&r| r > 1 << 53) {
        return Err("has impossible statistics".to_owned());
    }
    Ok(())
}

/// Reads `paths` and puts them together: the frame, with the rays of all parts and the sum of
/// their render times. Every part must come from the same render (the same fingerprint, size,
/// layers and number of parts) and each part must be there exactly once.
pub fn merge(paths: &[PathBuf], limit: u64) -> Result<(Frame, f64, String)> {
    if paths.is_empty() {
        bail!("no part files given");
    }
    let parts: Vec<Part> = paths.iter().map(|p| read(p, limit)).collect::<Result<_>>()?;
    merge_parts(parts)
}

/// [`merge`] of part files given as their names and bytes, reading no file: what `cargo xtask
/// fuzz` feeds mutated headers to.
pub fn merge_bytes(parts: Vec<(PathBuf, Vec<u8>)>) -> Result<(Frame, f64, String)> {
    if parts.is_empty() {
        bail!("no part files given");
    }
    merge_parts(parts.into_iter().map(|(p, b)| parse(&p, b)).collect::<Result<_>>()?)
}

/// A part file's bytes: `header` (its index and count saying which bands of `frame`, rendered
/// with only that part's bands, are written) and the pixels.
pub fn encode(header: &Header, frame: &Frame) -> Result<Vec<u8>> {
    let mut bytes = MAGIC.to_vec();
    serde_json::to_writer(&mut bytes, header).context("encoding the part's header")?;
    bytes.push(b'\n');
    for band in lancer_shading::part_bands(frame.height, header.index, header.count) {
        let range = band_pixels(band, frame.width, frame.height, header.band_rows);
        for layer in &frame.layers {
            bytes.extend_from_slice(bytemuck::cast_slice(&layer.pixels[range.clone()]));
        }
    }
    Ok(bytes)
}

fn merge_parts(parts: Vec<Part>) -> Result<(Frame, f64, String)> {
    let first = &parts[0].header;
    for p in &parts[1..] {
        let h = &p.header;
        let differs = if h.identity != first.identity {
            let what = first.sources.differences(&h.sources).join(", ");
            Some(format!(
                "comes from another render than {} (they differ in {what}; this part: scene `{}`, {}; that one: scene `{}`, {})",
                parts[0].path.display(),
                h.scene,
                h.model,
                first.scene,
                first.model
            ))
        } else if h.layers != first.layers {
            Some(format!(
                "has the layers {} where {} has {}",
                h.layers.join(", "),
                parts[0].path.display(),
                first.layers.join(", ")
            ))
        } else if (h.width, h.height, h.samples, h.count) != (first.width, first.height, first.samples, first.count) {
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

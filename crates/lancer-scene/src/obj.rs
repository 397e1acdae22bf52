//! A lean Wavefront OBJ reader for meshes: positions, normals, texture coordinates and faces
//! (fan-triangulated), read in parallel chunks of lines straight into the arrays a mesh keeps.
//!
//! Why not a general OBJ crate: tobj, tried first, keeps every face of an object as a record of
//! nine machine words before exporting it, so a million-triangle file peaked at about 136 bytes a
//! triangle on top of the text; this reader stores 12 bytes per triangle and index kind as it
//! goes, and reads the lines of a large file on every thread. Materials (`mtllib`, `usemtl`),
//! groups, smoothing groups, points, lines and curves are left out: the scene gives materials.
//!
//! Memory is bounded by the input and a triangle budget: the counting pass (already needed to
//! number each chunk's elements) counts each face's triangles too, so a file past the budget is
//! refused before anything is stored; a face's corners are fanned as they are read (no list of
//! a line's corners), and each chunk's arrays are reserved at their exact size.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// What a mesh needs from an OBJ file.
#[derive(Debug, Default, PartialEq)]
pub(crate) struct Obj {
    /// `v` lines.
    pub positions: Vec<Vec3>,
    /// `vn` lines.
    pub normals: Vec<Vec3>,
    /// `vt` lines.
    pub uvs: Vec<Vec2>,
    /// Each triangle's three position indices (from 0).
    pub triangles: Vec<[u32; 3]>,
    /// Each triangle's normal indices, when every face corner gives one; else empty.
    pub normal_triangles: Vec<[u32; 3]>,
    /// Each triangle's texture-coordinate indices, when every face corner gives them; else empty.
    pub uv_triangles: Vec<[u32; 3]>,
    /// The first line (from 1) whose face corners are indexed differently (`v`, `v/vt`,
    /// `v//vn`, `v/vt/vn`) from the first face's. Normals and texture coordinates are then left
    /// out for the whole mesh.
    pub mixed: Option<usize>,
    /// How many `vn` and `vt` lines gave numbers that are not finite (replaced by zero: such a
    /// normal counts for nothing where it is interpolated).
    pub replaced: usize,
}

/// Why an OBJ file cannot be read: the line (from 1) and what was expected there.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct ObjError {
    pub line: usize,
    /// The column (from 1, in characters) for an error about a place in the line: the corner
    /// that goes past the triangle budget.
    pub column: Option<usize>,
    pub message: String,
}

impl ObjError {
    fn at(line: usize, message: String) -> ObjError {
        ObjError { line, column: None, message }
    }
}

/// How many triangles a file may fan into: the scene's `limit`, of which `earlier` meshes took
/// some.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Budget {
    pub limit: usize,
    pub earlier: usize,
}

impl Budget {
    /// No bound but the 32-bit indices'.
    #[cfg(test)]
    const NONE: Budget = Budget { limit: usize::MAX, earlier: 0 };

    /// The triangles left for this file.
    fn left(&self) -> usize {
        self.limit.saturating_sub(self.earlier)
    }
}

/// A line's statement, as far as meshes care.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Statement {
    Position,
    Normal,
    Uv,
    Face,
    Other,
}

/// The statement of a line and the rest of it after the keyword.
fn statement(line: &[u8]) -> (Statement, &[u8]) {
    let line = line.trim_ascii_start();
    let end = line.iter().position(|b| b.is_ascii_whitespace()).unwrap_or(line.len());
    let s = match &line[..end] {
        b"v" => Statement::Position,
        b"vn" => Statement::Normal,
        b"vt" => Statement::Uv,
        b"f" => Statement::Face,
        _ => Statement::Other,
    };
    (s, &line[end..])
}

/// The pieces of a chunk between newlines, as `chunk.split(|&b| b == b'\n')` gives them (an
/// empty piece after a final newline), each without its comment (from a `#` on): each newline
/// found by SIMD search, and the `#`s by one search over the chunk and one after each comment
/// (a line is never searched for a `#` of its own).
struct Lines<'a> {
    chunk: &'a [u8],
    /// Where the next line starts; past the end once the last is given.
    at: usize,
    /// Where the first `#` at or after `at` is (the chunk's length if there is none).
    hash: usize,
}

/// The lines of `chunk`, comments cut off (see [`Lines`]).
fn lines(chunk: &[u8]) -> Lines<'_> {
    Lines { chunk, at: 0, hash: memchr::memchr(b'#', chunk).unwrap_or(chunk.len()) }
}

impl<'a> Iterator for Lines<'a> {
    type Item = &'a [u8];

    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        let start = self.at;
        let rest = self.chunk.get(start..)?;
        let end = match memchr::memchr(b'\n', rest) {
            Some(k) => start + k,
            None => self.chunk.len(),
        };
        self.at = end + 1;
        if self.hash >= end {
            return Some(&rest[..end - start]);
        }
        // This line's comment: the line stops there, and the next `#` is looked for after it.
        let cut = self.hash;
        self.hash =
            self.chunk.get(self.at..).and_then(|r| memchr::memchr(b'#', r)).map_or(self.chunk.len(), |k| self.at + k);
        Some(&rest[..cut - start])
    }
}

/// Counts of each kind of element: before a chunk, or in it.
#[derive(Clone, Copy, Default)]
struct Counts {
    lines: usize,
    positions: usize,
    normals: usize,
    uvs: usize,
    /// Triangles its faces fan into (a face of k ≥ 3 corners is k - 2), if its corners are
    /// good.
    triangles: usize,
}

impl Counts {
    fn add(self, o: Counts) -> Counts {
        Counts {
            lines: self.lines + o.lines,
            positions: self.positions + o.positions,
            normals: self.normals + o.normals,
            uvs: self.uvs + o.uvs,
            triangles: self.triangles + o.triangles,
        }
    }
}

/// The words of a line after its keyword (a face's corners, a vertex's numbers): the runs of
/// bytes between ASCII whitespace, as `split(u8::is_ascii_whitespace)` gives them with the empty
/// pieces left out.
fn words(rest: &[u8]) -> Words<'_> {
    Words { rest }
}

/// The iterator of [`words`].
struct Words<'a> {
    rest: &'a [u8],
}

impl<'a> Iterator for Words<'a> {
    type Item = &'a [u8];

    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        let start = self.rest.iter().position(|b| !b.is_ascii_whitespace())?;
        let word = &self.rest[start..];
        let end = word.iter().position(|b| b.is_ascii_whitespace()).unwrap_or(word.len());
        self.rest = &word[end..];
        Some(&word[..end])
    }
}

/// The powers of ten an `f32` holds exactly (5¹⁰ < 2²⁴).
const EXACT_TENS: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];

/// A plain decimal (`-` or no sign, digits, at most one `.`) read at once where that is exact:
/// at most 2²⁴ units of 10⁻ᵏ with k ≤ 10, so that the units and the power of ten are both exact
/// `f32`s and their one division rounds the number once, to the nearest, as `str::parse::<f32>`
/// does (the fast path of Clinger's algorithm, which the parse itself takes for such numbers).
/// `None` for anything else (a `+`, an exponent, `inf`, more digits, no digit at all), which
/// the full parse reads.
#[inline]
fn short_decimal(word: &[u8]) -> Option<f32> {
    let (negative, digits) = match word.split_first()? {
        (b'-', rest) => (true, rest),
        _ => (false, word),
    };
    let (mut units, mut any, mut point, mut decimals) = (0u32, false, false, 0usize);
    for &b in digits {
        match b {
            b'0'..=b'9' => {
                units = units.checked_mul(10)?.checked_add(u32::from(b - b'0'))?;
                any = true;
                decimals += point as usize;
            }
            b'.' if !point => point = true,
            _ => return None,
        }
    }
    if !any || units > 1 << 24 || decimals >= EXACT_TENS.len() {
        return None;
    }
    let value = units as f32 / EXACT_TENS[decimals];
    Some(if negative { -value } else { value })
}

/// The triangles a face whose words after `f` are `rest` fans into.
fn face_triangles(rest: &[u8]) -> usize {
    // The words counted by where they start (`words(rest).count()`, without cutting them out).
    let mut gap = true;
    let mut starts = 0;
    for b in rest {
        let space = b.is_ascii_whitespace();
        starts += (gap && !space) as usize;
        gap = space;
    }
    starts.saturating_sub(2)
}

/// Splits `bytes` into about `parts` runs of whole lines.
fn chunks(bytes: &[u8], parts: usize) -> Vec<&[u8]> {
    let target = bytes.len().div_ceil(parts.max(1)).max(1);
    let mut out = Vec::with_capacity(parts + 1);
    let mut rest = bytes;
    while !rest.is_empty() {
        let cut = if rest.len() <= target {
            rest.len()
        } else {
            memchr::memchr(b'\n', &rest[target..]).map_or(rest.len(), |k| target + k + 1)
        };
        let (head, tail) = rest.split_at(cut);
        out.push(head);
        rest = tail;
    }
    out
}

/// The elements a chunk holds (counted, not read): where the next chunk's numbering starts.
fn count(chunk: &[u8]) -> Counts {
    let mut c = Counts::default();
    for line in lines(chunk) {
        c.lines += 1;
        match statement(line) {
            (Statement::Position, _) => c.positions += 1,
            (Statement::Normal, _) => c.normals += 1,
            (Statement::Uv, _) => c.uvs += 1,
            (Statement::Face, rest) => c.triangles += face_triangles(rest),
            (Statement::Other, _) => {}
        }
    }
    // `lines` yields one piece after a final newline: not a line of the file.
    if chunk.ends_with(b"\n") {
        c.lines -= 1;
    }
    c
}

/// How a face corner is indexed: whether it gives texture coordinates, and a normal.
type Kind = (bool, bool);

/// What one chunk read.
#[derive(Default)]
struct Part {
    /// Its triangles' normal and texture-coordinate indices, where its faces give them.
    normal_triangles: Vec<[u32; 3]>,
    uv_triangles: Vec<[u32; 3]>,
    /// The first face's corner kind and line.
    first: Option<(Kind, usize)>,
    /// The first line whose corners differ from the chunk's first face's (or among themselves).
    mixed: Option<usize>,
    /// Normals and texture coordinates that were not finite numbers, replaced by zero.
    replaced: usize,
}

/// Reads the numbers after a keyword: at least `min`, the first `N` kept (more are ignored, as
/// vertex colours after a position), and how many words there were.
fn numbers<const N: usize>(rest: &[u8], min: usize, what: &str) -> Result<([f32; N], usize), String> {
    let mut out = [0.0; N];
    let mut n = 0;
    let mut given = 0;
    for token in words(rest) {
        given += 1;
        if n == N {
            continue;
        }
        if let Some(value) = short_decimal(token) {
            out[n] = value;
            n += 1;
            continue;
        }
        let text = std::str::from_utf8(token).unwrap_or("");
        if token == b"\\" {
            return Err("line continuations (`\\` at the end of a line) are not supported: join the lines".into());
        }
        out[n] = text
            .parse()
            .map_err(|_| format!("expected a number in `{what}`, found `{}`", String::from_utf8_lossy(token)))?;
        n += 1;
    }
    if n < min {
        let s = if min == 1 { "" } else { "s" };
        return Err(format!("`{what}` needs {min} number{s}, found {n}"));
    }
    Ok((out, given))
}

/// A whole number written in ASCII digits with an optional sign (`None` for anything else, or
/// past ±10¹⁸): faces hold most of a file's words, and this is their only parse.
fn integer(field: &[u8]) -> Option<i64> {
    let (negative, digits) = match field.split_first()? {
        (b'-', rest) => (true, rest),
        (b'+', rest) => (false, rest),
        _ => (false, field),
    };
    if digits.is_empty() || digits.len() > 18 {
        return None;
    }
    let mut value = 0i64;
    for &d in digits {
        if !d.is_ascii_digit() {
            return None;
        }
        value = value * 10 + (d - b'0') as i64;
    }
    Some(if negative { -value } else { value })
}

/// A face corner's fields between `/`s (`v`, `v/vt`, `v//vn`, `v/vt/vn`), the missing ones
/// empty, as `split(b'/')` gives them; `None` for more than three.
#[inline]
fn corner_fields(word: &[u8]) -> Option<[&[u8]; 3]> {
    let mut fields = [&word[..0]; 3];
    let mut rest = word;
    for (k, field) in fields.iter_mut().enumerate() {
        match rest.iter().position(|&b| b == b'/') {
            Some(at) if k < 2 => {
                *field = &rest[..at];
                rest = &rest[at + 1..];
            }
            Some(_) => return None,
            None => {
                *field = rest;
                return Some(fields);
            }
        }
    }
    Some(fields)
}

/// One index of a corner: from 1, or negative counting back from the last element before the
/// line (`before`), checked against the `total` in the file. `None` for an empty field.
#[inline]
fn index(field: &[u8], before: usize, total: usize, what: &str) -> Result<Option<u32>, String> {
    if field.is_empty() {
        return Ok(None);
    }
    let i =
        integer(field).ok_or_else(|| format!("expected a {what} index, found `{}`", String::from_utf8_lossy(field)))?;
    let at = match i {
        0 => return Err(format!("{what} indices start at 1 (or count back from -1), found 0")),
        i if i > 0 => i - 1,
        i => before as i64 + i,
    };
    if i < 0 && at < 0 {
        let given = if before == 1 { "is 1".to_owned() } else { format!("are {before}") };
        return Err(format!("the face names {what} {i}, but there {given} before this line"));
    }
    if at >= total as i64 {
        let given = if total == 1 { "is 1".to_owned() } else { format!("are {total}") };
        return Err(format!("the face names {what} {i}, but there {given} in the file"));
    }
    Ok(Some(at as u32))
}

/// Where the file whose chunks hold `counts` (their first elements numbered `starts`) goes past
/// `budget`: the line and the column of the corner that makes one triangle too many.
fn over_budget(pieces: &[&[u8]], counts: &[Counts], starts: &[Counts], budget: Budget) -> ObjError {
    let left = budget.left();
    let k = (0..counts.len()).find(|&k| starts[k].triangles + counts[k].triangles > left).unwrap_or(counts.len() - 1);
    let mut before = starts[k].triangles;
    let mut line = starts[k].lines;
    let mut column = None;
    for (j, raw) in lines(pieces[k]).enumerate() {
        line = starts[k].lines + j + 1;
        let (what, rest) = statement(raw);
        let triangles = if what == Statement::Face { face_triangles(rest) } else { 0 };
        if before + triangles > left {
            // Its corners after the keyword: corner `left - before + 2` (from 0) closes the
            // triangle one past the budget.
            let corner = words(rest).nth(left - before + 2);
            let offset = corner.map_or(0, |c| c.as_ptr() as usize - raw.as_ptr() as usize);
            column = Some(raw[..offset].iter().filter(|&&b| (b & 0xC0) != 0x80).count() + 1);
            break;
        }
        before += triangles;
    }
    let earlier = if budget.earlier > 0 {
        format!(" (the meshes before this one have {})", budget.earlier)
    } else {
        String::new()
    };
    ObjError {
        line,
        column,
        message: format!(
            "too many triangles: the face's corner here makes triangle {} of the scene's meshes{earlier}: expected at \
             most {} triangles; raise it with --max-triangles",
            budget.limit.saturating_add(1),
            budget.limit
        ),
    }
}

/// Where one chunk's elements go: its stretch of each of the file's arrays, as long as it
/// counted (so each is filled exactly by a chunk read without error).
struct Slots<'a> {
    positions: &'a mut [Vec3],
    normals: &'a mut [Vec3],
    uvs: &'a mut [Vec2],
    triangles: &'a mut [[u32; 3]],
}

impl<'a> Slots<'a> {
    /// The file's arrays cut into each chunk's stretch, in order, by the chunks' `counts`.
    fn cut(obj: &'a mut Obj, counts: &[Counts]) -> Vec<Slots<'a>> {
        let (mut positions, mut normals, mut uvs, mut triangles) =
            (&mut obj.positions[..], &mut obj.normals[..], &mut obj.uvs[..], &mut obj.triangles[..]);
        counts
            .iter()
            .map(|c| Slots {
                positions: take(&mut positions, c.positions),
                normals: take(&mut normals, c.normals),
                uvs: take(&mut uvs, c.uvs),
                triangles: take(&mut triangles, c.triangles),
            })
            .collect()
    }
}

/// The first `n` of `rest`, which keeps what is after them.
fn take<'a, T>(rest: &mut &'a mut [T], n: usize) -> &'a mut [T] {
    let (head, tail) = std::mem::take(rest).split_at_mut(n);
    *rest = tail;
    head
}

/// Reads one chunk whose first line is line `at.lines + 1` of the file and whose elements are
/// numbered from `at` into its `slots`; `mine` is its own counts, `total` the whole file's.
fn read(chunk: &[u8], at: Counts, mine: Counts, total: Counts, slots: Slots<'_>) -> Result<Part, ObjError> {
    let mut part = Part::default();
    // How many of each it has read (the next slot of each).
    let (mut read_positions, mut read_normals, mut read_uvs, mut read_triangles) = (0, 0, 0, 0);
    let (mut positions, mut normals, mut uvs) = (at.positions, at.normals, at.uvs);
    for (k, raw) in lines(chunk).enumerate() {
        let line = at.lines + k + 1;
        let fail = |message: String| ObjError::at(line, message);
        let (what, rest) = statement(raw);
        match what {
            Statement::Position => {
                let ([x, y, z, w], n) = numbers(rest, 3, "v").map_err(fail)?;
                // Four numbers are homogeneous coordinates; six or seven are a position and a
                // vertex colour (left out).
                let p = if n == 4 {
                    if w == 0.0 || !w.is_finite() {
                        return Err(fail(format!(
                            "`v` has a weight `w` of {w}: expected a finite number other than 0"
                        )));
                    }
                    Vec3::new(x / w, y / w, z / w)
                } else {
                    Vec3::new(x, y, z)
                };
                if !p.is_finite() {
                    return Err(fail("`v` has a coordinate that is not a finite number".into()));
                }
                slots.positions[read_positions] = p;
                read_positions += 1;
                positions += 1;
            }
            Statement::Normal => {
                let ([x, y, z], _) = numbers(rest, 3, "vn").map_err(fail)?;
                let n = Vec3::new(x, y, z);
                // Exporters write `nan` normals for faces with no area: such a normal counts for
                // nothing in the interpolation (the face's own normal takes over).
                slots.normals[read_normals] = if n.is_finite() { n } else { Vec3::ZERO };
                read_normals += 1;
                part.replaced += !n.is_finite() as usize;
                normals += 1;
            }
            Statement::Uv => {
                let ([u, v], _) = numbers(rest, 1, "vt").map_err(fail)?;
                let t = Vec2::new(u, v);
                slots.uvs[read_uvs] = if t.is_finite() { t } else { Vec2::ZERO };
                read_uvs += 1;
                part.replaced += !t.is_finite() as usize;
                uvs += 1;
            }
            Statement::Face => {
                // A fan from the first corner (convex polygons, as exporters write them), made
                // as the corners are read: the first, the one before and the kind to compare.
                let mut first: Option<([u32; 3], Kind)> = None;
                let mut previous = [0u32; 3];
                let mut corners = 0usize;
                let mut differs = false;
                for token in words(rest) {
                    let corner = || String::from_utf8_lossy(token);
                    if token == b"\\" {
                        let message =
                            "line continuations (`\\` at the end of a line) are not supported: join the lines";
                        return Err(fail(message.into()));
                    }
                    let Some([pf, tf, nf]) = corner_fields(token) else {
                        return Err(fail(format!(
                            "a face corner has at most three indices (`v/vt/vn`), found `{}`",
                            corner()
                        )));
                    };
                    if pf.is_empty() {
                        return Err(fail(format!("a face corner needs a vertex index, found `{}`", corner())));
                    }
                    let p = index(pf, positions, total.positions, "vertex").map_err(fail)?.unwrap_or(0);
                    let t = index(tf, uvs, total.uvs, "texture coordinate").map_err(fail)?;
                    let n = index(nf, normals, total.normals, "normal").map_err(fail)?;
                    let corner = [p, t.unwrap_or(0), n.unwrap_or(0)];
                    let kind = (t.is_some(), n.is_some());
                    // The kind every corner is compared with: the chunk's first face's, or this
                    // face's first corner's when this is the first face.
                    let (c0, kind0) = *first.get_or_insert((corner, kind));
                    differs |= kind != part.first.map_or(kind0, |(k, _)| k);
                    corners += 1;
                    if corners >= 3 {
                        slots.triangles[read_triangles] = [c0[0], previous[0], p];
                        read_triangles += 1;
                        if kind0.0 {
                            if part.uv_triangles.capacity() == 0 {
                                part.uv_triangles.reserve_exact(mine.triangles);
                            }
                            part.uv_triangles.push([c0[1], previous[1], corner[1]]);
                        }
                        if kind0.1 {
                            if part.normal_triangles.capacity() == 0 {
                                part.normal_triangles.reserve_exact(mine.triangles);
                            }
                            part.normal_triangles.push([c0[2], previous[2], corner[2]]);
                        }
                    }
                    previous = corner;
                }
                // Points and lines written as faces have no area: left out, as other renderers do.
                if corners < 3 {
                    continue;
                }
                let kind0 = first.map(|(_, k)| k).unwrap_or_default();
                part.first.get_or_insert((kind0, line));
                if part.mixed.is_none() && differs {
                    part.mixed = Some(line);
                }
            }
            Statement::Other => {}
        }
    }
    debug_assert_eq!(
        [read_positions, read_normals, read_uvs, read_triangles],
        [mine.positions, mine.normals, mine.uvs, mine.triangles],
        "a chunk reads what it counted"
    );
    Ok(part)
}

/// Reads an OBJ file. Chunks of lines are read on every thread; the result does not depend on
/// how the file is cut (the same arrays, and the error of the earliest bad line).
/// A file whose faces fan into more triangles than `budget` leaves is refused at the corner
/// that goes past it, before any is stored.
pub(crate) fn parse(bytes: &[u8], budget: Budget) -> Result<Obj, ObjError> {
    // About four chunks a thread for balance, none under 256 KiB.
    parse_in(bytes, (bytes.len() / (256 << 10)).clamp(1, 4 * rayon::current_num_threads()), budget)
}

/// [`parse`] with the file cut into about `parts` chunks.
fn parse_in(bytes: &[u8], parts: usize, budget: Budget) -> Result<Obj, ObjError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    if !bytes.contains(&b'\n') && bytes.contains(&b'\r') {
        let message = "the lines end with a carriage return alone (old Mac OS): save the file with LF or CRLF endings";
        return Err(ObjError::at(1, message.into()));
    }
    let pieces = chunks(bytes, parts);
    let counts: Vec<Counts> = pieces.par_iter().map(|c| count(c)).collect();
    let mut starts = Vec::with_capacity(counts.len());
    let mut total = Counts::default();
    for c in &counts {
        starts.push(total);
        total = total.add(*c);
    }
    // Indices are 32-bit: a file with more elements than that is refused before reading.
    if [total.positions, total.normals, total.uvs].iter().any(|&n| n >= u32::MAX as usize) {
        return Err(ObjError::at(total.lines, "more than 4 billion vertices: too many to index".into()));
    }
    if total.triangles > budget.left() {
        return Err(over_budget(&pieces, &counts, &starts, budget));
    }
    if total.triangles >= u32::MAX as usize {
        return Err(ObjError::at(total.lines, "more than 4 billion triangles: too many to index".into()));
    }
    // The file's arrays at their counted sizes, each chunk reading into its own stretch (no
    // copy after; zeroed by the system as their pages are first written, on the thread that
    // writes them).
    let mut obj = Obj {
        positions: bytemuck::zeroed_vec(total.positions),
        normals: bytemuck::zeroed_vec(total.normals),
        uvs: bytemuck::zeroed_vec(total.uvs),
        triangles: bytemuck::zeroed_vec(total.triangles),
        ..Obj::default()
    };
    let slots = Slots::cut(&mut obj, &counts);
    let read: Vec<Result<Part, ObjError>> = pieces
        .into_par_iter()
        .zip(starts.into_par_iter().zip(counts.into_par_iter()))
        .zip(slots)
        .map(|((chunk, (at, mine)), slots)| read(chunk, at, mine, total, slots))
        .collect();
    // Each chunk stops at its own first bad line, so the first failing chunk has the file's.
    let parts = read.into_iter().collect::<Result<Vec<Part>, ObjError>>()?;
    // The first face's kind is the file's; a chunk whose faces begin otherwise is mixed there.
    let kind = parts.iter().find_map(|p| p.first.map(|(k, _)| k));
    obj.mixed = parts.iter().find_map(|p| match p.first {
        Some((k, line)) if Some(k) != kind => Some(line),
        _ => p.mixed,
    });
    obj.replaced = parts.iter().map(|p| p.replaced).sum();
    let mixed = obj.mixed;
    // Normal and texture-coordinate indices are kept only if every triangle has them.
    let join = |of: fn(&Part) -> &[[u32; 3]]| {
        let complete = mixed.is_none() && parts.iter().map(|p| of(p).len()).sum::<usize>() == total.triangles;
        let mut all = Vec::with_capacity(if complete { total.triangles } else { 0 });
        if complete {
            parts.iter().for_each(|p| all.extend_from_slice(of(p)));
        }
        all
    };
    obj.normal_triangles = join(|p| &p.normal_triangles);
    obj.uv_triangles = join(|p| &p.uv_triangles);
    Ok(obj)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_the_pieces_between_newlines_as_a_split_gives_them() {
        let long = "v 1 2 3 # a comment longer than a SIMD block of bytes\n".repeat(5);
        let long = long.as_str();
        for text in [
            "",
            "\n",
            "\n\n",
            "f 1 2 3",
            "f 1 2 3\n",
            "v 1 2 3\r\nf 1 2 3\r\n",
            "\nv 0 0 0\n\nx",
            long,
            // Comments: alone, at the start and the end, two on a line, one on the last line
            // with no newline after it, a `#` as the last byte, lines of nothing but `#`.
            "#",
            "#\n#\n",
            "# top\nv 0 0 0\nf 1 1 1 # x # y\nv 1 1 1\n#",
            "v 1 2 3\n\n# a\n\nv 4 5 6 #tail",
            "##\n#\n\n#v\nv 0 0 0#",
        ] {
            let bytes = text.as_bytes();
            // Each without its comment, as it was cut line by line before.
            fn uncommented(line: &[u8]) -> &[u8] {
                line.iter().position(|&b| b == b'#').map_or(line, |k| &line[..k])
            }
            let split: Vec<&[u8]> = bytes.split(|&b| b == b'\n').map(uncommented).collect();
            assert_eq!(lines(bytes).collect::<Vec<_>>(), split, "{text:?}");
        }
    }

    /// A small file with every kind of line: comments, groups, negative indices, a quad, a
    /// polygon, a point and a line, CRLF endings, no newline at the end.
    const SAMPLE: &str = "# a comment\r\nmtllib x.mtl\r\no thing\r\nv 0 0 0\r\nv 1 0 0 0.5 0.5 0.5\r\nv 1 1 0\r\n\
        v 0 1 0 # trailing comment\r\nvt 0 0\r\nvt 1\r\nvt 1 1 0\r\nvt 0 1\r\nvn 0 0 1\r\nusemtl red\r\ns 1\r\n\
        f 1/1/1 2/2/1 3/3/1 4/4/1\r\nf -4/-4/-1 -2/-2/-1 -1/-1/-1\r\nv 2 0 0\r\nv 2 1 0\r\nvt 1 0\r\n\
        f 2/2/1 5/5/1 6/5/1 3/3/1 1/1/1\r\nf 1/1/1\r\nl 1 2";

    #[test]
    fn every_kind_of_line_is_read_as_other_renderers_read_it() {
        let o = parse(SAMPLE.as_bytes(), Budget::NONE).unwrap();
        assert_eq!(o.positions.len(), 6);
        assert_eq!(o.positions[1], Vec3::new(1.0, 0.0, 0.0), "vertex colours ignored");
        assert_eq!(o.uvs[1], Vec2::new(1.0, 0.0), "a missing v is 0");
        assert_eq!(o.normals, [Vec3::Z]);
        // The quad fans into two triangles, the pentagon into three; the one-corner face is left out.
        assert_eq!(o.triangles, [[0, 1, 2], [0, 2, 3], [0, 2, 3], [1, 4, 5], [1, 5, 2], [1, 2, 0]]);
        assert_eq!(o.uv_triangles[2], [0, 2, 3], "negative indices count back from the line");
        assert_eq!(o.uv_triangles[3], [1, 4, 4]);
        assert_eq!(o.normal_triangles.len(), 6);
        assert!(o.normal_triangles.iter().all(|t| *t == [0, 0, 0]));
        assert_eq!((o.mixed, o.replaced), (None, 0));
    }

    #[test]
    fn the_result_does_not_depend_on_where_the_file_is_cut() {
        // Every cut of the sample into up to 40 chunks gives the same arrays as one chunk, and a
        // file with bad lines in several chunks always reports the first.
        let whole = parse_in(SAMPLE.as_bytes(), 1, Budget::NONE).unwrap();
        for parts in 1..40 {
            assert_eq!(chunks(SAMPLE.as_bytes(), parts).concat(), SAMPLE.as_bytes());
            assert_eq!(parse_in(SAMPLE.as_bytes(), parts, Budget::NONE).unwrap(), whole, "{parts} parts");
        }
        let bad =
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".repeat(50) + "v 0 0 x\n" + &"f 1 2 3\n".repeat(50) + "v 0 y 0\n";
        for parts in 1..40 {
            let e = parse_in(bad.as_bytes(), parts, Budget::NONE).unwrap_err();
            assert_eq!((e.line, e.message.contains("found `x`")), (201, true), "{parts} parts: {e:?}");
        }
        let mixed = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\n".to_owned()
            + &"f 1//1 2//1 3//1\n".repeat(30)
            + &"f 1 2 3\n".repeat(30);
        for parts in 1..40 {
            assert_eq!(parse_in(mixed.as_bytes(), parts, Budget::NONE).unwrap().mixed, Some(35), "{parts} parts");
        }
    }

    #[test]
    fn bad_lines_are_named_with_what_was_expected() {
        for (text, line, message) in [
            ("v 0 0 zero\nf 1 2 3\n", 1, "expected a number in `v`, found `zero`"),
            ("v 0 0\n", 1, "`v` needs 3 numbers, found 2"),
            ("v 0 0 0\nv 1 0 nan\n", 2, "not a finite number"),
            ("v 0 0 1e39\n", 1, "not a finite number"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", 4, "the face names vertex 4, but there are 3 in the file"),
            ("v 0 0 0\nf 0 1 1\n", 2, "vertex indices start at 1"),
            ("v 0 0 0\nf -2 1 1\n", 2, "the face names vertex -2, but there is 1 before this line"),
            ("v 0 0 0 0\n", 1, "a weight `w` of 0"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 \\\n 3\n", 4, "line continuations"),
            ("v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r", 1, "carriage return alone"),
            ("vt 0\nvt\n", 2, "`vt` needs 1 number, found 0"),
            ("v 0 0 0\nf 1/x 1 1\n", 2, "expected a texture coordinate index, found `x`"),
            ("v 0 0 0\nvt 0 0\nvn 0 0 1\nf 1/1/1/1 1 1\n", 4, "at most three indices"),
            ("v 0 0 0\nf /1 1 1\n", 2, "needs a vertex index"),
            ("v 0 0 0\nvt 0 0\nf 1/2 1/1 1/1\n", 3, "texture coordinate 2, but there is 1"),
        ] {
            let e = parse(text.as_bytes(), Budget::NONE).unwrap_err();
            assert_eq!(e.line, line, "{text:?}: {e:?}");
            assert!(e.message.contains(message), "{text:?}: {}", e.message);
        }
    }

    #[test]
    fn regression_a_face_past_the_triangle_budget_is_refused_at_its_corner_however_the_file_is_cut() {
        // 300 quads (600 triangles), then a pentagon (3): with 601 allowed, its second triangle
        // (closed by its fourth corner, at column 11) is one too many.
        let file = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n".to_owned() + &"f 1 2 3 4\n".repeat(300) + "  f 1 2 3 4 1\n";
        for parts in 1..40 {
            let e = parse_in(file.as_bytes(), parts, Budget { limit: 601, earlier: 0 }).unwrap_err();
            assert_eq!((e.line, e.column), (305, Some(11)), "{parts} parts: {e:?}");
            assert!(e.message.contains("makes triangle 602 of the scene's meshes: expected at most 601"), "{e:?}");
            // Earlier meshes take their share; what is left is exactly enough.
            let e = parse_in(file.as_bytes(), parts, Budget { limit: 603, earlier: 2 }).unwrap_err();
            assert_eq!((e.line, e.column), (305, Some(11)), "{parts} parts: {e:?}");
            assert!(e.message.contains("(the meshes before this one have 2)"), "{e:?}");
            let o = parse_in(file.as_bytes(), parts, Budget { limit: 605, earlier: 2 }).unwrap();
            assert_eq!(o.triangles.len(), 603);
            assert_eq!(o.triangles.capacity(), 603, "reserved at its exact size");
        }
        // A bad line before the face is not what a file over the budget is refused for: the
        // budget is checked before the numbers are read (as the 4-billion bound).
        let e = parse(b"v 0 0 0\nv 1 0 x\nv 0 1 0\nf 1 2 3 1 2\n", Budget { limit: 2, earlier: 0 }).unwrap_err();
        assert_eq!((e.line, e.column), (4, Some(11)));
    }

    /// Every string of `alphabet` up to `longest` bytes.
    fn strings(alphabet: &[u8], longest: usize) -> impl Iterator<Item = Vec<u8>> + '_ {
        (0..=longest).flat_map(move |len| {
            (0..alphabet.len().pow(len as u32)).map(move |mut k| {
                (0..len)
                    .map(|_| {
                        let b = alphabet[k % alphabet.len()];
                        k /= alphabet.len();
                        b
                    })
                    .collect()
            })
        })
    }

    #[test]
    fn words_fields_and_triangle_counts_are_what_splitting_gives() {
        // Every string of up to seven bytes of whitespace (each kind), digits, slashes and a
        // letter: the words as a split on whitespace without its empty pieces, the triangles as
        // that many words less two, and each word's corner fields as a split on `/`.
        let mut cornered = 0;
        for text in strings(b" \t\r\x0c1/f", 7) {
            let split: Vec<&[u8]> = text.split(u8::is_ascii_whitespace).filter(|w| !w.is_empty()).collect();
            assert_eq!(words(&text).collect::<Vec<_>>(), split, "{text:?}");
            assert_eq!(face_triangles(&text), split.len().saturating_sub(2), "{text:?}");
            for word in split {
                let fields: Vec<&[u8]> = word.split(|&b| b == b'/').collect();
                let expected = (fields.len() <= 3).then(|| [0, 1, 2].map(|k| fields.get(k).copied().unwrap_or(b"")));
                assert_eq!(corner_fields(word), expected, "{word:?}");
                cornered += expected.is_some() as usize;
            }
        }
        assert!(cornered > 100_000, "{cornered} words had corner fields");
    }

    #[test]
    fn short_decimals_are_read_to_the_bit_as_rust_reads_them() {
        let std = |text: &str| text.parse::<f32>().ok().map(f32::to_bits);
        // Every number of decimals the shortcut takes and one past, each with units through the
        // whole range it takes (a stride, and its ends and one past), with and without a sign.
        let units = (0..=(1u32 << 24) + 1).step_by(9_973).chain([1, 9, 10, (1 << 24) - 1, 1 << 24, (1 << 24) + 1]);
        let mut read = 0;
        for u in units {
            for decimals in 0..=11usize {
                let digits = format!("{u:0width$}", width = decimals + 1);
                let (whole, fraction) = digits.split_at(digits.len() - decimals);
                for sign in ["", "-"] {
                    let text =
                        if decimals == 0 { format!("{sign}{whole}") } else { format!("{sign}{whole}.{fraction}") };
                    let got = short_decimal(text.as_bytes());
                    if u <= 1 << 24 && decimals <= 10 {
                        assert_eq!(got.map(f32::to_bits), std(&text), "{text}");
                        read += 1;
                    } else {
                        assert_eq!(got, None, "{text} is left to the full parse");
                    }
                }
            }
        }
        assert!(read > 35_000, "{read}");
        // Other forms: read as Rust reads them, or left to the full parse (never another value).
        for text in [
            ".5",
            "5.",
            "-.5",
            "-0",
            "-0.0",
            "0.0",
            "007.250",
            "-10.00000",
            "0.75313",
            "16777216",
            "16777217",
            "+1",
            "1e3",
            "1E-2",
            "inf",
            "-inf",
            "nan",
            "NaN",
            "1.2.3",
            ".",
            "-",
            "",
            "--1",
            "-+1",
            "1-",
            "0x10",
            " 1",
            "0.00000000001",
            "99999999999999999999",
        ] {
            if let Some(v) = short_decimal(text.as_bytes()) {
                assert_eq!(Some(v.to_bits()), std(text), "{text}");
            }
        }
        for text in ["1.2.3", ".", "-", "", "--1", "+1", "1e3", "inf", "nan", "1-"] {
            assert_eq!(short_decimal(text.as_bytes()), None, "{text}");
        }
        // And every string of digits, points and signs up to six bytes.
        for text in strings(b"-.0159", 6) {
            let text = String::from_utf8(text).expect("ASCII");
            if let Some(v) = short_decimal(text.as_bytes()) {
                assert_eq!(Some(v.to_bits()), std(&text), "{text}");
            }
        }
    }

    #[test]
    fn integers_are_read_as_rust_reads_them() {
        for text in ["0", "7", "-3", "+12", "000042", "123456789012345678", "-1"] {
            assert_eq!(integer(text.as_bytes()), text.parse::<i64>().ok(), "{text}");
        }
        for text in ["", "-", "+", "1.5", "1e3", "x", "--1", "1234567890123456789", " 1"] {
            assert_eq!(integer(text.as_bytes()), None, "{text}");
        }
    }

    #[test]
    fn quirks_of_real_files_are_read_as_meant() {
        // A UTF-8 byte-order mark, homogeneous coordinates, vertex colours, `nan` normals.
        let o = parse(
            b"\xEF\xBB\xBFv 2 4 6 2\nv 1 0 0 0.1 0.2 0.3\nv 0 1 0\nvn nan nan nan\nvt 0 inf\nf 1 2 3\n",
            Budget::NONE,
        )
        .unwrap();
        assert_eq!(o.positions, [Vec3::new(1.0, 2.0, 3.0), Vec3::X, Vec3::Y]);
        assert_eq!((o.normals[0], o.uvs[0], o.replaced), (Vec3::ZERO, Vec2::ZERO, 2));
        assert_eq!(o.triangles, [[0, 1, 2]]);
    }

    #[test]
    fn faces_indexed_differently_from_the_first_are_found_and_drop_normals() {
        let o = parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nf 1 2 3\n", Budget::NONE).unwrap();
        assert_eq!(o.mixed, Some(6));
        assert!(o.normal_triangles.is_empty() && o.triangles.len() == 2);
        let o = parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2 3//1\n", Budget::NONE).unwrap();
        assert_eq!(o.mixed, Some(5), "corners of one face differing");
    }
}

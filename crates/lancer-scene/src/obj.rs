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

/// The line without a trailing comment.
fn uncommented(line: &[u8]) -> &[u8] {
    match memchr::memchr(b'#', line) {
        Some(k) => &line[..k],
        None => line,
    }
}

/// The pieces of a chunk between newlines, as `chunk.split(|&b| b == b'\n')` gives them (an
/// empty piece after a final newline), each newline found by SIMD search.
struct Lines<'a> {
    rest: Option<&'a [u8]>,
}

/// The lines of `chunk` (see [`Lines`]).
fn lines(chunk: &[u8]) -> Lines<'_> {
    Lines { rest: Some(chunk) }
}

impl<'a> Iterator for Lines<'a> {
    type Item = &'a [u8];

    fn next(&mut self) -> Option<&'a [u8]> {
        let rest = self.rest?;
        match memchr::memchr(b'\n', rest) {
            Some(k) => {
                self.rest = Some(&rest[k + 1..]);
                Some(&rest[..k])
            }
            None => {
                self.rest = None;
                Some(rest)
            }
        }
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

/// The words of a line after its keyword: a face's corners.
fn words(rest: &[u8]) -> impl Iterator<Item = &[u8]> {
    rest.split(|b| b.is_ascii_whitespace()).filter(|t| !t.is_empty())
}

/// The triangles a face whose words after `f` are `rest` fans into.
fn face_triangles(rest: &[u8]) -> usize {
    words(rest).count().saturating_sub(2)
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
        match statement(uncommented(line)) {
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
    obj: Obj,
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
    for token in rest.split(|b| b.is_ascii_whitespace()).filter(|t| !t.is_empty()) {
        given += 1;
        if n == N {
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

/// One index of a corner: from 1, or negative counting back from the last element before the
/// line (`before`), checked against the `total` in the file. `None` for an empty field.
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
        let (what, rest) = statement(uncommented(raw));
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

/// Reads one chunk whose first line is line `at.lines + 1` of the file and whose elements are
/// numbered from `at`; `mine` is its own counts, `total` the whole file's.
fn read(chunk: &[u8], at: Counts, mine: Counts, total: Counts) -> Result<Part, ObjError> {
    let mut part = Part::default();
    let o = &mut part.obj;
    o.positions.reserve_exact(mine.positions);
    o.normals.reserve_exact(mine.normals);
    o.uvs.reserve_exact(mine.uvs);
    o.triangles.reserve_exact(mine.triangles);
    let (mut positions, mut normals, mut uvs) = (at.positions, at.normals, at.uvs);
    for (k, raw) in lines(chunk).enumerate() {
        let line = at.lines + k + 1;
        let fail = |message: String| ObjError::at(line, message);
        let (what, rest) = statement(uncommented(raw));
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
                o.positions.push(p);
                positions += 1;
            }
            Statement::Normal => {
                let ([x, y, z], _) = numbers(rest, 3, "vn").map_err(fail)?;
                let n = Vec3::new(x, y, z);
                // Exporters write `nan` normals for faces with no area: such a normal counts for
                // nothing in the interpolation (the face's own normal takes over).
                o.normals.push(if n.is_finite() { n } else { Vec3::ZERO });
                part.replaced += !n.is_finite() as usize;
                normals += 1;
            }
            Statement::Uv => {
                let ([u, v], _) = numbers(rest, 1, "vt").map_err(fail)?;
                let t = Vec2::new(u, v);
                o.uvs.push(if t.is_finite() { t } else { Vec2::ZERO });
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
                    let mut fields = token.split(|&b| b == b'/');
                    let [pf, tf, nf] = [(); 3].map(|_| fields.next().unwrap_or(b""));
                    if pf.is_empty() {
                        return Err(fail(format!("a face corner needs a vertex index, found `{}`", corner())));
                    }
                    if fields.next().is_some() {
                        return Err(fail(format!(
                            "a face corner has at most three indices (`v/vt/vn`), found `{}`",
                            corner()
                        )));
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
                        o.triangles.push([c0[0], previous[0], p]);
                        if kind0.0 {
                            if o.uv_triangles.capacity() == 0 {
                                o.uv_triangles.reserve_exact(mine.triangles);
                            }
                            o.uv_triangles.push([c0[1], previous[1], corner[1]]);
                        }
                        if kind0.1 {
                            if o.normal_triangles.capacity() == 0 {
                                o.normal_triangles.reserve_exact(mine.triangles);
                            }
                            o.normal_triangles.push([c0[2], previous[2], corner[2]]);
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
    let read: Vec<Result<Part, ObjError>> = pieces
        .par_iter()
        .zip(starts.par_iter().zip(counts.par_iter()))
        .map(|(chunk, (&at, &mine))| read(chunk, at, mine, total))
        .collect();
    // Each chunk stops at its own first bad line, so the first failing chunk has the file's.
    let parts = read.into_iter().collect::<Result<Vec<Part>, ObjError>>()?;
    let triangles: usize = parts.iter().map(|p| p.obj.triangles.len()).sum();
    if triangles >= u32::MAX as usize {
        return Err(ObjError::at(total.lines, "more than 4 billion triangles: too many to index".into()));
    }
    // The first face's kind is the file's; a chunk whose faces begin otherwise is mixed there.
    let kind = parts.iter().find_map(|p| p.first.map(|(k, _)| k));
    let mixed = parts.iter().find_map(|p| match p.first {
        Some((k, line)) if Some(k) != kind => Some(line),
        _ => p.mixed,
    });
    let sum = |f: fn(&Obj) -> usize| parts.iter().map(|p| f(&p.obj)).sum::<usize>();
    let replaced = parts.iter().map(|p| p.replaced).sum();
    let mut obj = Obj {
        positions: Vec::with_capacity(total.positions),
        normals: Vec::with_capacity(total.normals),
        uvs: Vec::with_capacity(total.uvs),
        triangles: Vec::with_capacity(sum(|o| o.triangles.len())),
        normal_triangles: Vec::with_capacity(sum(|o| o.normal_triangles.len())),
        uv_triangles: Vec::with_capacity(sum(|o| o.uv_triangles.len())),
        mixed,
        replaced,
    };
    // Each chunk's arrays are freed as soon as they are copied: the peak holds the result and
    // one chunk.
    for p in parts {
        let Obj { positions, normals, uvs, triangles, normal_triangles, uv_triangles, .. } = p.obj;
        obj.positions.extend(positions);
        obj.normals.extend(normals);
        obj.uvs.extend(uvs);
        obj.triangles.extend(triangles);
        obj.normal_triangles.extend(normal_triangles);
        obj.uv_triangles.extend(uv_triangles);
    }
    if mixed.is_some() || obj.normal_triangles.len() != obj.triangles.len() {
        obj.normal_triangles = Vec::new();
    }
    if mixed.is_some() || obj.uv_triangles.len() != obj.triangles.len() {
        obj.uv_triangles = Vec::new();
    }
    Ok(obj)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_the_pieces_between_newlines_as_a_split_gives_them() {
        let long = "v 1 2 3 # a comment longer than a SIMD block of bytes\n".repeat(5);
        for text in
            ["", "\n", "\n\n", "f 1 2 3", "f 1 2 3\n", "v 1 2 3\r\nf 1 2 3\r\n", "\nv 0 0 0\n\nx", long.as_str()]
        {
            let bytes = text.as_bytes();
            assert_eq!(lines(bytes).collect::<Vec<_>>(), bytes.split(|&b| b == b'\n').collect::<Vec<_>>(), "{text:?}");
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

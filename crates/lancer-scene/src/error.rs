//! Load errors located by file, line and column, shown with the offending source line.

use std::ops::Range;

use lancer_shading::ModelError;

/// What went wrong while loading a scene or model file.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LoadErrorKind {
    /// TOML syntax, an unknown key, a missing key, a wrong type or a value out of range.
    #[error("{0}")]
    Syntax(String),
    /// An object names a material that `[materials]` does not define.
    #[error("unknown material `{name}`{}; defined materials: {}", hint(nearest), list(known))]
    UnknownMaterial {
        /// The name used.
        name: String,
        /// The closest defined name.
        nearest: Option<String>,
        /// The defined names.
        known: Vec<String>,
    },
    /// An object's `shape` is not a known shape.
    #[error("unknown shape `{name}`{}; known shapes: {}", hint(nearest), known.join(", "))]
    UnknownShape {
        /// The shape named.
        name: String,
        /// The closest known shape.
        nearest: Option<String>,
        /// The known shapes.
        known: Vec<String>,
    },
    /// The camera cannot be built.
    #[error("bad camera: {0}")]
    Camera(String),
    /// A term, variant, shadow model or parameter the registry rejects.
    #[error("{0}")]
    Model(#[from] ModelError),
}

fn hint(nearest: &Option<String>) -> String {
    nearest.as_ref().map(|n| format!(" (did you mean `{n}`?)")).unwrap_or_default()
}

fn list(known: &[String]) -> String {
    if known.is_empty() { "none".to_owned() } else { known.join(", ") }
}

/// An error in a scene or model file, with its location.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LoadError {
    /// The file as the caller named it.
    pub file: String,
    /// 1-based line.
    pub line: usize,
    /// 1-based column, in characters.
    pub column: usize,
    /// The source line, for display: the part around the place when the line is long.
    pub source_line: String,
    /// The column of `source_line`'s first character: 1 unless a long line was cut.
    pub source_column: usize,
    /// How many characters to underline from `column`.
    pub width: usize,
    /// What went wrong (boxed: errors travel through `Result`s on every path).
    pub kind: Box<LoadErrorKind>,
    /// The file's other errors after this one, in file order, when loading found several: at
    /// most [`MAX_ERRORS`] shown in all, this one included.
    pub more: Vec<LoadError>,
    /// How many errors past [`MAX_ERRORS`] were found but are not shown ("and N more").
    pub unshown: usize,
}

/// The most errors of one file shown together; the rest are counted.
pub const MAX_ERRORS: usize = 10;

/// A place in a scene or model file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Place {
    /// The file as the caller named it.
    pub file: String,
    /// 1-based line.
    pub line: usize,
    /// 1-based column, in characters.
    pub column: usize,
}

/// Bytes between two counts of characters in [`Lines`]: a column costs at most twice this many
/// bytes counted, however long its line.
const CHARS_EVERY: usize = 128;

/// Where the lines of one text start, and how many characters come before every
/// [`CHARS_EVERY`]-th byte: built once per text (one pass), so each place is a binary search and
/// a short count, not a scan from the start of the file (which made loading quadratic in the
/// number of objects).
pub(crate) struct Lines {
    /// The byte offset of each line's first byte (the first is 0).
    starts: Vec<usize>,
    /// `chars[k]`: the characters in the first `k * CHARS_EVERY` bytes.
    chars: Vec<usize>,
}

impl Lines {
    pub(crate) fn new(src: &str) -> Lines {
        let bytes = src.as_bytes();
        let mut starts = vec![0];
        starts.extend(bytes.iter().enumerate().filter(|&(_, &b)| b == b'\n').map(|(i, _)| i + 1));
        let mut chars = Vec::with_capacity(bytes.len() / CHARS_EVERY + 1);
        let mut total = 0;
        chars.push(0);
        for block in bytes.chunks(CHARS_EVERY) {
            total += char_starts(block);
            chars.push(total);
        }
        Lines { starts, chars }
    }

    /// The 1-based line and the byte offset of the start of the line holding byte `at`.
    fn line_of(&self, at: usize) -> (usize, usize) {
        let line = self.starts.partition_point(|&s| s <= at);
        (line, self.starts[line - 1])
    }

    /// Where line `line` (1-based) of `src` ends: its newline, or the end of the text.
    fn line_end(&self, src: &str, line: usize) -> usize {
        self.starts.get(line).map_or(src.len(), |next| next - 1)
    }

    /// The characters in the first `at` bytes of `src` (`at` on a character boundary).
    fn chars_before(&self, src: &str, at: usize) -> usize {
        let block = at / CHARS_EVERY;
        self.chars[block] + char_starts(&src.as_bytes()[block * CHARS_EVERY..at])
    }

    /// Where byte `at` of `src` (the text this table was built from) is: the same line and
    /// column (in characters) as counting from the start of the file.
    pub(crate) fn place(&self, file: &str, src: &str, at: usize) -> Place {
        let at = at.min(src.len());
        let (line, line_start) = self.line_of(at);
        Place {
            file: file.to_owned(),
            line,
            column: self.chars_before(src, at) - self.chars_before(src, line_start) + 1,
        }
    }
}

/// Bytes of a long source line kept on each side of an error's place: more than the characters
/// shown around it take (four bytes at most each), so what is shown is the same.
const KEPT: usize = 1024;

/// The character boundary of `s` at or before `at`.
fn floor_boundary(s: &str, mut at: usize) -> usize {
    while !s.is_char_boundary(at) {
        at -= 1;
    }
    at
}

/// The character boundary of `s` at or after `at`.
fn ceil_boundary(s: &str, mut at: usize) -> usize {
    while !s.is_char_boundary(at) {
        at += 1;
    }
    at
}

/// The characters that start in `bytes` (every byte but UTF-8 continuation bytes).
fn char_starts(bytes: &[u8]) -> usize {
    bytes.iter().filter(|&&b| (b & 0xC0) != 0x80).count()
}

impl std::fmt::Display for Place {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}:{}", self.file, self.line, self.column)
    }
}

/// Something a scene is allowed to do but its author probably did not mean (an unused
/// material, a light inside an object...), with the place it is about when there is one.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Warning {
    /// Where in the file.
    pub place: Option<Place>,
    /// What is wrong, and what to do.
    pub message: String,
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.place {
            Some(p) => write!(f, "warning: {p}: {}", self.message),
            None => write!(f, "warning: {}", self.message),
        }
    }
}

impl LoadError {
    /// An error at byte range `span` of `src`, the text of `file` (the start of the file when
    /// `None`): for other TOML files that report their errors as scene files do (`lancer
    /// sheet`'s sheet files).
    pub fn at(file: &str, src: &str, span: Option<Range<usize>>, kind: LoadErrorKind) -> LoadError {
        LoadError::located(file, src, &Lines::new(src), span, kind)
    }

    /// An error at byte range `span` of `src` (the start of the file when `None`), placed
    /// through `lines`, the text's line table.
    pub(crate) fn located(
        file: &str,
        src: &str,
        lines: &Lines,
        span: Option<Range<usize>>,
        kind: LoadErrorKind,
    ) -> LoadError {
        let span = span.unwrap_or(0..0);
        let start = span.start.min(src.len());
        let place = lines.place(file, src, start);
        let (line, line_start) = lines.line_of(start);
        let line_end = lines.line_end(src, line);
        // A long line is kept around the place only: each error of a file of one huge line
        // (generated, or hostile) costs the same as on a short one.
        let from = floor_boundary(src, start.saturating_sub(KEPT).max(line_start));
        let to = ceil_boundary(src, (start + KEPT).min(line_end));
        let mut source_line = &src[from..to];
        if to == line_end {
            source_line = source_line.trim_end_matches('\r');
        }
        let end = span.end.clamp(start, to);
        LoadError {
            file: place.file,
            line: place.line,
            column: place.column,
            width: src[start..end].chars().count().max(1),
            source_line: source_line.to_owned(),
            source_column: lines.chars_before(src, from) - lines.chars_before(src, line_start) + 1,
            kind: Box::new(kind),
            more: Vec::new(),
            unshown: 0,
        }
    }

    /// This error and the others it carries, in file order.
    pub fn all(&self) -> impl Iterator<Item = &LoadError> {
        std::iter::once(self).chain(&self.more)
    }
}

/// The errors found in one file so far: the first [`MAX_ERRORS`] in file order kept, the others
/// counted (a file of a million bad objects holds ten).
#[derive(Default)]
pub(crate) struct Errors {
    kept: Vec<LoadError>,
    unshown: usize,
}

impl Errors {
    /// Adds `e` (and the errors it carries).
    pub(crate) fn push(&mut self, mut e: LoadError) {
        let more = std::mem::take(&mut e.more);
        self.unshown += std::mem::take(&mut e.unshown);
        for e in std::iter::once(e).chain(more) {
            self.kept.push(e);
            if self.kept.len() > MAX_ERRORS {
                // The last in file order goes (of two at one place, the one found later).
                let key = |i: usize| (self.kept[i].line, self.kept[i].column, i);
                let last = (0..self.kept.len()).max_by_key(|&i| key(i)).expect("more than one");
                self.kept.remove(last);
                self.unshown += 1;
            }
        }
    }

    /// `result`'s value, or `None` with its error added.
    pub(crate) fn keep<T>(&mut self, result: Result<T, LoadError>) -> Option<T> {
        result.map_err(|e| self.push(e)).ok()
    }

    /// The errors as one: the first in file order, carrying the others. `None` when there are
    /// none.
    pub(crate) fn into_error(mut self) -> Option<LoadError> {
        // Stable: two errors at one place keep the order they were found in.
        self.kept.sort_by_key(|e| (e.line, e.column));
        let mut kept = self.kept.into_iter();
        let mut first = kept.next()?;
        first.more = kept.collect();
        first.unshown = self.unshown;
        Some(first)
    }

    /// `Err` with the errors when there are any, else `Ok(value)`.
    pub(crate) fn or<T>(self, value: T) -> Result<T, LoadError> {
        match self.into_error() {
            Some(e) => Err(e),
            None => Ok(value),
        }
    }
}

impl std::fmt::Display for LoadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}:{}: {}", self.file, self.line, self.column, self.kind)?;
        if !self.source_line.is_empty() {
            // A long line (a generated file's, a hostile one's) is shown around the place only.
            const AROUND: usize = 60;
            let (at, width) = (self.column - self.source_column, self.width.min(80));
            let from = at.saturating_sub(AROUND);
            let to = at + width + AROUND;
            let (before, after) = (from + self.source_column > 1, self.source_line.chars().nth(to).is_some());
            let shown: String = self.source_line.chars().skip(from).take(to - from).collect();
            let gutter = self.line.to_string().len();
            write!(
                f,
                "\n{:gutter$} |\n{} | {}{shown}{}\n{:gutter$} | {}{}",
                "",
                self.line,
                if before { "…" } else { "" },
                if after { "…" } else { "" },
                "",
                " ".repeat(at - from + usize::from(before)),
                "^".repeat(width)
            )?;
        }
        // The file's other errors, each as it would be shown alone, a blank line between.
        for e in &self.more {
            write!(f, "\n\n{e}")?;
        }
        if self.unshown > 0 {
            let s = if self.unshown == 1 { "" } else { "s" };
            write!(f, "\n\nand {} more error{s} (the first {MAX_ERRORS} are shown)", self.unshown)?;
        }
        Ok(())
    }
}

impl std::error::Error for LoadError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regression_an_error_on_a_megabyte_line_shows_the_line_around_its_place_only() {
        // Found in review: a 2 MB dotted key's error printed all 2 MB of its line.
        let src = format!("{}= 1 oops\n", "a.".repeat(1_000_000));
        let at = src.find("oops").unwrap();
        let lines = Lines::new(&src);
        let e = LoadError::located("s.toml", &src, &lines, Some(at..at + 4), LoadErrorKind::Syntax("bad".into()));
        let text = e.to_string();
        assert!(text.len() < 400, "{} bytes", text.len());
        let rows: Vec<&str> = text.lines().collect();
        let (code, marks) = (rows[2], rows[3]);
        assert!(code.starts_with("1 | …") && code.ends_with("= 1 oops"), "{code}");
        // The carets stand under `oops`.
        let caret = marks.find('^').unwrap();
        assert_eq!(code.chars().skip(caret).take(4).collect::<String>(), "oops", "{code}\n{marks}");
        // A short line is shown whole.
        let short = "x = oops\n";
        let e =
            LoadError::located("s.toml", short, &Lines::new(short), Some(4..8), LoadErrorKind::Syntax("bad".into()));
        assert!(e.to_string().ends_with("1 | x = oops\n  |     ^^^^"), "{e}");
    }

    /// How places were found before the line table: counting from the start of the file.
    fn place_by_scanning(file: &str, src: &str, at: usize) -> Place {
        let start = at.min(src.len());
        let line_start = src[..start].rfind('\n').map_or(0, |i| i + 1);
        Place {
            file: file.to_owned(),
            line: src[..start].matches('\n').count() + 1,
            column: src[line_start..start].chars().count() + 1,
        }
    }

    #[test]
    fn regression_quadratic_loading_the_line_table_places_every_offset_as_scanning_did() {
        // Multi-byte characters (2, 3 and 4 bytes), CRLF and LF endings, an empty line, a line
        // longer than the table's character blocks, and a last line with no newline.
        let long = "é".repeat(150) + "x" + &"a".repeat(300);
        let texts = [
            format!("a = 1\r\n# é ✓ 𝄞\r\n\r\nkey = \"日本語\"\n{long}\r\nlast = \"ß\""),
            String::new(),
            "\n".into(),
            "no newline at all é".into(),
            "\r\n\r\n𝄞".into(),
        ];
        for src in &texts {
            let lines = Lines::new(src);
            // Every offset on a character boundary (slicing elsewhere is not a place), and past the end.
            for at in (0..=src.len() + 2).filter(|&at| at > src.len() || src.is_char_boundary(at)) {
                assert_eq!(lines.place("f", src, at), place_by_scanning("f", src, at), "{src:?} at {at}");
            }
        }
    }

    #[test]
    fn regression_quadratic_loading_errors_read_the_same_through_the_table() {
        let src = "a = 1\r\n# é\r\nbad = [1, 2]\r\nlast";
        let at = src.find("[1").unwrap();
        let kind = || LoadErrorKind::Syntax("oops".into());
        let e = LoadError::located("s.toml", src, &Lines::new(src), Some(at..at + 6), kind());
        assert_eq!(e.to_string(), "s.toml:3:7: oops\n  |\n3 | bad = [1, 2]\n  |       ^^^^^^");
        assert_eq!(e, LoadError::at("s.toml", src, Some(at..at + 6), kind()));
        let e = LoadError::at("s.toml", src, Some(src.len()..src.len()), kind());
        assert_eq!((e.line, e.column, e.source_line.as_str()), (4, 5, "last"));
    }

    #[test]
    fn locates_line_and_column_in_characters() {
        let src = "a = 1\n# é\nbad = [1, 2]\n";
        let at = src.find("[1").unwrap();
        let e = LoadError::at("s.toml", src, Some(at..at + 6), LoadErrorKind::Syntax("oops".into()));
        assert_eq!((e.line, e.column, e.width), (3, 7, 6));
        assert_eq!(e.to_string(), "s.toml:3:7: oops\n  |\n3 | bad = [1, 2]\n  |       ^^^^^^");
        let e = LoadError::at("s.toml", src, None, LoadErrorKind::Syntax("x".into()));
        assert_eq!((e.line, e.column), (1, 1));
    }
}

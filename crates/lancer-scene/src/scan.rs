//! One pass over a TOML text before the toml crate reads it: refuses nesting deeper than
//! [`MAX_NESTING`] (a located error naming the key, in constant memory), and finds the file's
//! root-level `[[objects]]` sections so a scene of many objects is read in batches.
//!
//! Why: the toml crate builds the whole document before handing it over, at about 3 KB an
//! object (40 bytes per byte of a sphere's four lines), and refuses deep nesting at the start of
//! the file with no key named ("recursion limit"), after parsing a 10⁶-part dotted key into
//! 150 MB. The pass reads only what decides nesting (keys, brackets, strings and comments);
//! anything else it skips, leaving errors to the toml crate.

use std::ops::Range;

/// The deepest nesting a scene or model file may have: each part of a dotted key or of a table
/// header, and each array and inline table, is a level. Scenes need a handful (a CSG tree one
/// per level of operands); the toml crate itself stops at about 80.
pub(crate) const MAX_NESTING: usize = 64;

/// `[[objects]]` sections read by the toml crate at once: its document of a batch is a few MB.
const BATCH: usize = 1024;

/// Nesting deeper than [`MAX_NESTING`]: where (the key, or the bracket that goes too deep) and
/// what to say.
#[derive(Debug, PartialEq, Eq)]
pub(crate) struct TooDeep {
    pub span: Range<usize>,
    pub message: String,
}

/// What the pass found.
#[derive(Debug, Default, PartialEq, Eq)]
pub(crate) struct Layout {
    /// Runs of root-level `[[objects]]` sections (each with its `[objects.…]` subtables), cut
    /// into batches of at most [`BATCH`] objects, in file order. Empty when the file defines
    /// `objects` otherwise (`objects = [...]`, a quoted header...): then the whole text is read
    /// at once, as the toml crate reads it.
    pub object_batches: Vec<Range<usize>>,
}

/// What a root-level table header is, as far as batching cares.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Header {
    /// `[[objects]]`: a new object.
    Object,
    /// Any other header whose first part is `objects` (`[objects.a]`, `[objects]`).
    ObjectPart,
    /// A header of something else.
    Other,
    /// A header whose first part is quoted: it may spell `objects`.
    Quoted,
}

/// A key's first part, as far as batching cares.
#[derive(Clone, Copy, PartialEq, Eq)]
enum First {
    /// No key at all.
    None,
    /// Bare `objects`.
    Objects,
    /// A quoted part: it may spell `objects`.
    Quoted,
    /// Another bare key.
    Other,
}

/// An open array or inline table.
struct Frame {
    table: bool,
    /// The nesting of what it holds.
    depth: usize,
    /// The key whose value it is part of, for messages.
    key: Range<usize>,
}

/// What comes next.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Want {
    /// A key: a root-level statement (or header), or an inline table's next entry.
    Key,
    /// A value: after `=`, or an array's next element.
    Value,
    /// A separator after a value.
    After,
}

struct Scanner<'a> {
    b: &'a [u8],
    src: &'a str,
    i: usize,
}

fn is_bare(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_' || c == b'-'
}

impl Scanner<'_> {
    fn peek(&self) -> Option<u8> {
        self.b.get(self.i).copied()
    }

    fn starts(&self, s: &[u8]) -> bool {
        self.b[self.i..].starts_with(s)
    }

    /// Spaces and tabs.
    fn blanks(&mut self) {
        while matches!(self.peek(), Some(b' ' | b'\t')) {
            self.i += 1;
        }
    }

    /// Spaces, tabs, newlines and comments (inside brackets).
    fn blanks_and_lines(&mut self) {
        loop {
            match self.peek() {
                Some(b' ' | b'\t' | b'\r' | b'\n') => self.i += 1,
                Some(b'#') => self.skip_line(),
                _ => return,
            }
        }
    }

    /// Up to (not past) the next newline.
    fn skip_line(&mut self) {
        self.i = self.b[self.i..].iter().position(|&c| c == b'\n').map_or(self.b.len(), |k| self.i + k);
    }

    /// A string starting at a quote: basic or literal, one line or multi-line.
    fn string(&mut self) {
        let quote = self.b[self.i];
        let triple = [quote; 3];
        if self.starts(&triple) {
            self.i += 3;
            while self.i < self.b.len() {
                if quote == b'"' && self.b[self.i] == b'\\' {
                    self.i += 2;
                } else if self.starts(&triple) {
                    self.i += 3;
                    // Up to two more quotes are part of the string.
                    for _ in 0..2 {
                        if self.peek() == Some(quote) {
                            self.i += 1;
                        }
                    }
                    return;
                } else {
                    self.i += 1;
                }
            }
            self.i = self.i.min(self.b.len());
            return;
        }
        self.i += 1;
        while let Some(c) = self.peek() {
            match c {
                b'\\' if quote == b'"' => self.i += 2,
                b'\n' => return,
                c => {
                    self.i += 1;
                    if c == quote {
                        return;
                    }
                }
            }
        }
        self.i = self.i.min(self.b.len());
    }

    /// A key (`a`, `"a b"`, `a.b.c`) whose first part is at nesting `depth + 1`: the nesting
    /// of its value, what its first part is and its span. Too deep a key is an error at the key,
    /// up to its first part past the limit.
    fn key(&mut self, depth: usize) -> Result<(usize, First, Range<usize>), TooDeep> {
        let start = self.i;
        let mut end = start;
        let mut parts = 0;
        let mut first = First::None;
        loop {
            self.blanks();
            let part = self.i;
            match self.peek() {
                Some(b'"' | b'\'') => self.string(),
                Some(c) if is_bare(c) => {
                    while self.peek().is_some_and(is_bare) {
                        self.i += 1;
                    }
                }
                _ => break,
            }
            parts += 1;
            end = self.i;
            if parts == 1 {
                first = match self.b[part] {
                    b'"' | b'\'' => First::Quoted,
                    _ if &self.b[part..self.i] == b"objects" => First::Objects,
                    _ => First::Other,
                };
            }
            if depth + parts > MAX_NESTING {
                let key = self.src.get(start..end).unwrap_or_default().trim_start();
                let message = format!(
                    "the key `{}` is nested more than {MAX_NESTING} levels deep ({LEVELS}): expected at most \
                     {MAX_NESTING} levels",
                    shortened(key)
                );
                return Err(TooDeep { span: end - key.len()..end, message });
            }
            self.blanks();
            if self.peek() == Some(b'.') {
                self.i += 1;
            } else {
                break;
            }
        }
        let key = self.src.get(start..end).unwrap_or_default().trim_start();
        Ok((depth + parts, first, end - key.len()..end))
    }

    /// A scalar value: up to the next separator, blank or comment.
    fn scalar(&mut self) {
        while let Some(c) = self.peek() {
            if matches!(c, b',' | b']' | b'}' | b'#' | b' ' | b'\t' | b'\r' | b'\n') {
                return;
            }
            self.i += 1;
        }
    }
}

/// What counts as a level, for messages.
const LEVELS: &str = "a level is each part of a dotted key or table header, each array and each inline table";

/// `key` for a message: its first 40 characters when longer.
fn shortened(key: &str) -> String {
    match key.char_indices().nth(40) {
        Some((cut, _)) => format!("{}…", &key[..cut]),
        None => key.to_owned(),
    }
}

/// Reads `src` for nesting and (when `batches`) for root-level `[[objects]]` sections.
pub(crate) fn scan(src: &str, batches: bool) -> Result<Layout, TooDeep> {
    let mut s = Scanner { b: src.as_bytes(), src, i: 0 };
    let mut stack: Vec<Frame> = Vec::new();
    // The nesting of root-level keys: the last header's parts.
    let mut root = 0;
    let mut want = Want::Key;
    // The key/value being read (for messages), and its value's nesting.
    let mut key = 0..0;
    let mut value_depth = 0;
    let mut headers: Vec<(usize, Header)> = Vec::new();
    // Whether a root-level key before any header is `objects` (or quoted).
    let mut objects_at_root = false;
    while s.i < s.b.len() {
        match want {
            Want::Key => {
                match stack.last() {
                    None => {
                        s.blanks_and_lines();
                        match s.peek() {
                            None => break,
                            Some(b'[') => {
                                let at = s.i;
                                let array = s.starts(b"[[");
                                s.i += if array { 2 } else { 1 };
                                let (depth, first, _) = s.key(0)?;
                                root = depth;
                                let kind = match first {
                                    First::Objects if array && depth == 1 => Header::Object,
                                    First::Objects => Header::ObjectPart,
                                    First::Quoted => Header::Quoted,
                                    First::None | First::Other => Header::Other,
                                };
                                headers.push((at, kind));
                                // The closing brackets and anything else on the line.
                                s.skip_line();
                                continue;
                            }
                            Some(_) => {}
                        }
                        let (depth, first, span) = s.key(root)?;
                        if headers.is_empty() && matches!(first, First::Objects | First::Quoted) {
                            objects_at_root = true;
                        }
                        key = span;
                        value_depth = depth;
                    }
                    Some(f) => {
                        s.blanks_and_lines();
                        if s.peek() == Some(b'}') {
                            s.i += 1;
                            stack.pop();
                            want = Want::After;
                            continue;
                        }
                        let depth = f.depth;
                        let (depth, _, span) = s.key(depth)?;
                        key = span;
                        value_depth = depth;
                    }
                }
                s.blanks();
                if s.peek() == Some(b'=') {
                    s.i += 1;
                    want = Want::Value;
                } else {
                    // Not a key/value: the toml crate says what is wrong.
                    want = Want::After;
                }
            }
            Want::Value => {
                if stack.is_empty() {
                    s.blanks();
                } else {
                    s.blanks_and_lines();
                }
                let Some(c) = s.peek() else { break };
                if let Some(f) = stack.last().filter(|f| !f.table) {
                    if c == b']' {
                        s.i += 1;
                        stack.pop();
                        want = Want::After;
                        continue;
                    }
                    value_depth = f.depth;
                }
                match c {
                    b'[' | b'{' => {
                        let depth = value_depth + 1;
                        if depth > MAX_NESTING {
                            let what = if c == b'[' { "array" } else { "inline table" };
                            let message = format!(
                                "the value of `{}` is nested more than {MAX_NESTING} levels deep: this {what} is level \
                                 {depth} ({LEVELS}): expected at most {MAX_NESTING} levels",
                                shortened(src.get(key.clone()).unwrap_or_default())
                            );
                            return Err(TooDeep { span: s.i..s.i + 1, message });
                        }
                        s.i += 1;
                        stack.push(Frame { table: c == b'{', depth, key: key.clone() });
                        want = if c == b'{' { Want::Key } else { Want::Value };
                    }
                    b'"' | b'\'' => {
                        s.string();
                        want = Want::After;
                    }
                    b'\n' | b'#' if stack.is_empty() => want = Want::After,
                    _ => {
                        let at = s.i;
                        s.scalar();
                        // A stray character: skipped (the toml crate says what is wrong).
                        if s.i == at {
                            s.i += 1;
                        }
                        want = Want::After;
                    }
                }
            }
            Want::After => match stack.last() {
                None => {
                    // The rest of the root-level line: the next statement starts on the next.
                    s.skip_line();
                    want = Want::Key;
                }
                Some(f) => {
                    s.blanks_and_lines();
                    let table = f.table;
                    match s.peek() {
                        None => break,
                        Some(b',') => {
                            s.i += 1;
                            want = if table { Want::Key } else { Want::Value };
                        }
                        Some(b']') if !table => {
                            s.i += 1;
                            stack.pop();
                            key = stack.last().map_or(key.clone(), |f| f.key.clone());
                        }
                        Some(b'}') if table => {
                            s.i += 1;
                            stack.pop();
                            key = stack.last().map_or(key.clone(), |f| f.key.clone());
                        }
                        // Anything else (a date's time, a missing comma): skipped.
                        Some(b'"' | b'\'') => s.string(),
                        Some(_) => {
                            let at = s.i;
                            s.scalar();
                            if s.i == at {
                                s.i += 1;
                            }
                        }
                    }
                }
            },
        }
    }
    let mut layout = Layout::default();
    if batches && !objects_at_root && !headers.iter().any(|(_, h)| *h == Header::Quoted) {
        layout.object_batches = object_batches(&headers, src.len());
    }
    Ok(layout)
}

/// The runs of object sections among the root-level `headers` (each its start and kind), cut
/// into batches; none when a run starts otherwise than with `[[objects]]`.
fn object_batches(headers: &[(usize, Header)], end: usize) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let mut batch: Option<(usize, usize)> = None;
    for (k, &(at, kind)) in headers.iter().enumerate() {
        let next = headers.get(k + 1).map_or(end, |h| h.0);
        match (kind, &mut batch) {
            (Header::Object, Some((_, count))) if *count < BATCH => *count += 1,
            (Header::Object, _) => {
                if let Some((start, _)) = batch.take() {
                    out.push(start..at);
                }
                batch = Some((at, 1));
            }
            (Header::ObjectPart, Some(_)) => {}
            // A part of an object with no `[[objects]]` before it in its run: read whole.
            (Header::ObjectPart, None) => return Vec::new(),
            (Header::Other | Header::Quoted, _) => {
                if let Some((start, _)) = batch.take() {
                    out.push(start..at);
                }
            }
        }
        if k + 1 == headers.len()
            && let Some((start, _)) = batch.take()
        {
            out.push(start..next);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "[camera]\nfrom = [0, 0, -5]\nto = [0, 0, 0]\n[[objects]]\nshape = \"sphere\"\n";

    /// Loads `src` on a thread with a 256 KiB stack (a stack overflow would abort the test
    /// binary): the error, shown.
    fn load_on_a_small_stack(src: String) -> crate::LoadError {
        std::thread::Builder::new()
            .stack_size(256 << 10)
            .spawn(move || crate::load_scene(&src, "s.toml", &lancer_shading::Registry::with_builtins()).err())
            .unwrap()
            .join()
            .unwrap()
            .expect("too deep a file is an error")
    }

    /// The error's first line (the whole would show a line of 10⁵ characters).
    fn head(e: &crate::LoadError) -> String {
        e.to_string().lines().next().unwrap_or_default().to_owned()
    }

    #[test]
    fn regression_deep_dotted_keys_are_a_located_error_at_the_key() {
        // 10⁵ parts: the toml crate said "recursion limit" at line 1, column 1, after reading
        // the whole key into some 15 MB.
        let key = vec!["a"; 100_000].join(".");
        // In an object (level 1) the 64th part is level 65; at the root, the 65th.
        for (src, line, column, width) in [
            (format!("{HEAD}{key} = 1\n"), 6, 1, 127),
            (format!("{HEAD}[{key}]\nb = 1\n"), 6, 2, 129),
            (format!("  {key} = 1"), 1, 3, 129),
        ] {
            let e = load_on_a_small_stack(src);
            assert_eq!((e.line, e.column, e.width), (line, column, width), "{}", head(&e));
            let expected = "the key `a.a.a.a.a.a.a.a.a.a.a.a.a.a.a.a.a.a.a.a.…` is nested more than 64 levels deep";
            assert!(head(&e).contains(expected), "{}", head(&e));
            // The source line shown, the key underlined (its first 80 characters).
            let text = e.to_string();
            let underline = format!(
                "{:w$} | {}{}",
                "",
                " ".repeat(column - 1),
                "^".repeat(width.min(80)),
                w = line.to_string().len()
            );
            assert_eq!((text.lines().count(), text.lines().last()), (4, Some(underline.as_str())));
        }
    }

    #[test]
    fn regression_deep_arrays_and_inline_tables_are_a_located_error_naming_the_key() {
        let n = 100_000;
        let arrays = format!("{HEAD}scale = {}1{}\n", "[".repeat(n), "]".repeat(n));
        let e = load_on_a_small_stack(arrays);
        // `scale` is level 2 (in an object), its arrays 3 and on: the 63rd is level 65.
        assert_eq!((e.line, e.column, e.width), (6, 9 + 62, 1), "{}", head(&e));
        assert!(head(&e).contains("the value of `scale` is nested more than 64 levels deep: this array is level 65"));
        let unclosed = format!("{HEAD}scale = {}\n", "[".repeat(n));
        assert_eq!(load_on_a_small_stack(unclosed).column, 71);
        let tables = format!("{HEAD}a = {}1{}\n", "{ a = ".repeat(n), "}".repeat(n));
        let e = load_on_a_small_stack(tables);
        // `a` is level 2, `{` 3, the next `a` 4...: the 32nd `{` is level 65.
        assert_eq!((e.line, e.column), (6, 5 + 31 * 6), "{}", head(&e));
        assert!(
            head(&e).contains("the value of `a` is nested more than 64 levels deep: this inline table is level 65")
        );
    }

    #[test]
    fn nesting_up_to_the_limit_passes_and_one_more_does_not() {
        let deep = |levels: usize| {
            [
                format!("{} = 1", vec!["k"; levels].join(".")),
                format!("[{}]\n", vec!["k"; levels].join(".")),
                format!("k = {}1{}", "[".repeat(levels - 1), "]".repeat(levels - 1)),
                format!("k = {}1{}", "{ k = ".repeat((levels - 1) / 2), "}".repeat((levels - 1) / 2)),
                format!("[[k]]\nk = {}{}", "[".repeat(levels - 2), "]".repeat(levels - 2)),
            ]
        };
        for src in deep(MAX_NESTING) {
            assert_eq!(scan(&src, true).map(|_| ()), Ok(()), "{src}");
        }
        for src in deep(MAX_NESTING + 2) {
            assert!(scan(&src, true).is_err(), "{src}");
        }
    }

    #[test]
    fn brackets_in_strings_and_comments_are_not_nesting() {
        let b = "[".repeat(100);
        let src = format!(
            "a = \"{b}\" # {b}\nb = '{b}'\nc = \"\"\"\n{b}\"\"\"\"\nd = '''{b}\n'''\ne = \"\\\"{b}\"\n# {b}\n\
             f = [ # {b}\n  \"{b}\", '{b}', {{ g = \"{b}\" }},\n]\n[h] # {b}\ni.j = \"{b}\"\n"
        );
        assert_eq!(scan(&src, true), Ok(Layout::default()));
        toml::from_str::<toml::Table>(&src).expect("valid TOML");
    }

    #[test]
    fn object_sections_are_found_and_batched_only_where_the_file_defines_objects_by_them_alone() {
        let objects = |n: usize| "[[objects]]\nshape = \"sphere\"\n[objects.a]\nb = 1\n".repeat(n);
        let src = format!("a = 1\n[camera]\nx = 1\n{}[lights]\n{}", objects(3), objects(BATCH + 1));
        let at = |k: usize| src.match_indices("[[objects]]").nth(k).unwrap().0;
        let lights = src.find("[lights]").unwrap();
        assert_eq!(
            scan(&src, true).unwrap().object_batches,
            [at(0)..lights, lights + 9..at(3 + BATCH), at(3 + BATCH)..src.len()]
        );
        assert_eq!(scan(&src, false).unwrap().object_batches, []);
        // `objects` written otherwise: the file is read whole, as the toml crate reads it.
        for whole in [
            format!("objects = []\n{}", objects(2)),
            format!("{}[camera]\n[objects.a]\n", objects(2)),
            format!("[\"objects\"]\n{}", objects(2)),
            format!("[objects]\n{}", objects(2)),
        ] {
            assert_eq!(scan(&whole, true).unwrap().object_batches, [], "{whole}");
        }
        // A header in a multi-line string or an array is not one.
        let hidden = "a = \"\"\"\n[[objects]]\n\"\"\"\nb = [\n[[objects]]\n]\n";
        assert_eq!(scan(hidden, true).unwrap().object_batches, []);
    }
}

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
    /// The source line, for display.
    pub source_line: String,
    /// How many characters to underline from `column`.
    pub width: usize,
    /// What went wrong (boxed: errors travel through `Result`s on every path).
    pub kind: Box<LoadErrorKind>,
}

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

impl Place {
    /// Where byte `at` of `src` is.
    pub(crate) fn of(file: &str, src: &str, at: usize) -> Place {
        let start = at.min(src.len());
        let line_start = src[..start].rfind('\n').map_or(0, |i| i + 1);
        Place {
            file: file.to_owned(),
            line: src[..start].matches('\n').count() + 1,
            column: src[line_start..start].chars().count() + 1,
        }
    }
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
    /// An error at byte range `span` of `src` (the start of the file when `None`).
    pub(crate) fn at(file: &str, src: &str, span: Option<Range<usize>>, kind: LoadErrorKind) -> LoadError {
        let span = span.unwrap_or(0..0);
        let start = span.start.min(src.len());
        let place = Place::of(file, src, start);
        let line_start = src[..start].rfind('\n').map_or(0, |i| i + 1);
        let line_end = src[start..].find('\n').map_or(src.len(), |i| start + i);
        let source_line = src[line_start..line_end].trim_end_matches('\r').to_owned();
        let end = span.end.clamp(start, line_end);
        LoadError {
            file: place.file,
            line: place.line,
            column: place.column,
            width: src[start..end].chars().count().max(1),
            source_line,
            kind: Box::new(kind),
        }
    }
}

impl std::fmt::Display for LoadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}:{}: {}", self.file, self.line, self.column, self.kind)?;
        if !self.source_line.is_empty() {
            let gutter = self.line.to_string().len();
            write!(
                f,
                "\n{:gutter$} |\n{} | {}\n{:gutter$} | {}{}",
                "",
                self.line,
                self.source_line,
                "",
                " ".repeat(self.column - 1),
                "^".repeat(self.width)
            )?;
        }
        Ok(())
    }
}

impl std::error::Error for LoadError {}

#[cfg(test)]
mod tests {
    use super::*;

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

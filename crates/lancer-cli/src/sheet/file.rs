//! The sheet file (docs/sheets.md): TOML read with serde, every value the sheet checks later
//! kept with its place, so that an error points at the line and column it is about, as a scene
//! file's errors do (the same messages: `lancer_scene::toml_error`, `LoadError::at`).

use std::collections::BTreeMap;
use std::ops::Range;

use lancer_scene::{LoadError, LoadErrorKind};
use lancer_studio::MaterialState;
use serde::Deserialize;
use toml::Spanned;

/// The widest and tallest sheet, in pixels.
pub(crate) const MAX_SIDE: u32 = 8192;
/// The narrowest and shortest sheet, in pixels.
pub(crate) const MIN_SIDE: u32 = 64;

/// A sheet file as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SheetDoc {
    /// Drawn at the top, large.
    pub(crate) title: Spanned<String>,
    /// Drawn under the title, wrapped.
    #[serde(default)]
    pub(crate) description: Option<String>,
    /// The scene file, relative to the sheet file's folder.
    pub(crate) scene: Spanned<String>,
    /// The sheet's width in pixels (1920 when absent).
    pub(crate) width: Option<Spanned<u32>>,
    /// The sheet's height in pixels (9/16 of the width when absent).
    pub(crate) height: Option<Spanned<u32>>,
    /// Samples per pixel of every cell, over the scene's.
    pub(crate) samples: Option<Spanned<u32>>,
    /// The columns, left to right (one unlabelled column when absent).
    #[serde(default)]
    pub(crate) columns: Vec<Spanned<Change>>,
    /// The rows, top to bottom (one unlabelled row when absent).
    #[serde(default)]
    pub(crate) rows: Vec<Spanned<Change>>,
}

/// What a column or a row changes, over the scene (a row's over its column's).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct Change {
    /// Drawn above the column or left of the row.
    pub(crate) label: Spanned<String>,
    /// A model file applied over the model (only what it sets), relative to the sheet file.
    pub(crate) model: Option<Spanned<String>>,
    /// The model's terms, as `--terms` takes them: `ambient,diffuse,specular:blinn:exponent=64`.
    pub(crate) terms: Option<Spanned<String>>,
    /// The shadow model, as `--shadows` takes it: `soft:samples=16`.
    pub(crate) shadows: Option<Spanned<String>>,
    /// The recursion limit.
    pub(crate) max_depth: Option<Spanned<u8>>,
    /// Materials changed, by their name in the scene (`[materials.NAME]`, or `object N` for an
    /// object's own).
    #[serde(default)]
    pub(crate) materials: BTreeMap<Spanned<String>, Spanned<MaterialChange>>,
    /// Which image the cell shows: `beauty`, a term's name, or `background`.
    pub(crate) image: Option<Spanned<String>>,
}

/// A material's numbers changed (the others stay the scene's).
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct MaterialChange {
    pub(crate) color: Option<Spanned<[f32; 3]>>,
    pub(crate) ambi: Option<Spanned<f32>>,
    pub(crate) diff: Option<Spanned<f32>>,
    pub(crate) spec: Option<Spanned<f32>>,
    pub(crate) shine: Option<Spanned<f32>>,
    pub(crate) alpha: Option<Spanned<f32>>,
    pub(crate) n: Option<Spanned<f32>>,
}

impl Change {
    /// Whether the change renders differently (not only another image of the same render).
    pub(crate) fn renders(&self) -> bool {
        self.model.is_some()
            || self.terms.is_some()
            || self.shadows.is_some()
            || self.max_depth.is_some()
            || !self.materials.is_empty()
    }

    /// The terms, each with its place: the entries of `terms` split at commas and trimmed, each
    /// placed where it stands in the file when the value is written plainly (a basic or literal
    /// string on one line), else where the value stands.
    pub(crate) fn term_entries(&self, src: &str) -> Vec<(String, Range<usize>)> {
        let Some(terms) = &self.terms else { return Vec::new() };
        let span = terms.span();
        let value = terms.get_ref();
        let raw = &src[span.clone()];
        let plain = raw.len() == value.len() + 2 && raw[1..raw.len() - 1] == *value;
        let mut out = Vec::new();
        let mut at = 0;
        for entry in value.split(',') {
            let lead = entry.len() - entry.trim_start().len();
            let name = entry.trim();
            let place = if plain {
                let start = span.start + 1 + at + lead;
                start..start + name.len()
            } else {
                span.clone()
            };
            if !name.is_empty() {
                out.push((name.to_owned(), place));
            }
            at += entry.len() + 1;
        }
        out
    }
}

/// Where a material's number is in the studio's state of it.
pub(crate) type Number = fn(&mut MaterialState) -> &mut f32;

impl MaterialChange {
    /// The numbers changed, in the order a scene file lists them: each one's key, where it is
    /// in a material's state, its new value and its place.
    pub(crate) fn numbers(&self) -> Vec<(&'static str, Number, f32, Range<usize>)> {
        let fields: [(&'static str, &Option<Spanned<f32>>, Number); 6] = [
            ("ambi", &self.ambi, |m| &mut m.ambi),
            ("diff", &self.diff, |m| &mut m.diff),
            ("spec", &self.spec, |m| &mut m.spec),
            ("shine", &self.shine, |m| &mut m.shine),
            ("alpha", &self.alpha, |m| &mut m.alpha),
            ("n", &self.n, |m| &mut m.n),
        ];
        fields.into_iter().filter_map(|(key, v, at)| v.as_ref().map(|v| (key, at, *v.get_ref(), v.span()))).collect()
    }
}

/// A sheet file read and checked for what needs no scene: sizes in range.
pub(crate) struct SheetFile {
    /// How the file is named in messages.
    pub(crate) name: String,
    /// Its text.
    pub(crate) src: String,
    pub(crate) doc: SheetDoc,
}

impl SheetFile {
    /// Reads the text `src` of the sheet file `name`.
    pub(crate) fn parse(name: &str, src: &str) -> Result<SheetFile, LoadError> {
        let doc: SheetDoc = toml::from_str(src).map_err(|e| lancer_scene::toml_error(name, src, e))?;
        let file = SheetFile { name: name.to_owned(), src: src.to_owned(), doc };
        for side in [&file.doc.width, &file.doc.height].into_iter().flatten() {
            if !(MIN_SIDE..=MAX_SIDE).contains(side.get_ref()) {
                let message =
                    format!("a sheet is {MIN_SIDE} to {MAX_SIDE} pixels wide and high, not {}", side.get_ref());
                return Err(file.error(side.span(), message));
            }
        }
        if let Some(s) = &file.doc.samples
            && !(1..=4096).contains(s.get_ref())
        {
            return Err(file.error(s.span(), format!("samples go from 1 to 4096, not {}", s.get_ref())));
        }
        for change in file.doc.columns.iter().chain(&file.doc.rows) {
            if let Some(d) = &change.get_ref().max_depth
                && *d.get_ref() > 64
            {
                return Err(file.error(d.span(), format!("max_depth goes from 0 to 64, not {}", d.get_ref())));
            }
        }
        Ok(file)
    }

    /// An error about the bytes `span` of the file.
    pub(crate) fn error(&self, span: Range<usize>, message: String) -> LoadError {
        LoadError::at(&self.name, &self.src, Some(span), LoadErrorKind::Syntax(message))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(src: &str) -> Result<SheetFile, String> {
        SheetFile::parse("s.toml", src).map_err(|e| e.to_string())
    }

    #[test]
    fn a_whole_sheet_reads_with_every_kind_of_change() {
        let src = r#"
title = "Shine"
description = "the highlight"
scene = "../scenes/shine-ladder.toml"
width = 960
samples = 2

[[columns]]
label = "shine 0.2"
materials.s50 = { shine = 0.2, color = [1, 0, 0] }

[[columns]]
label = "blinn"
terms = "ambient, diffuse,specular:blinn"
model = "../models/blinn.toml"
shadows = "soft:samples=4"
max_depth = 3

[[rows]]
label = "specular"
image = "specular"
"#;
        let f = parse(src).unwrap();
        let d = &f.doc;
        assert_eq!((d.title.get_ref().as_str(), d.description.as_deref()), ("Shine", Some("the highlight")));
        assert_eq!(d.width.as_ref().map(|w| *w.get_ref()), Some(960));
        assert!(d.height.is_none());
        assert_eq!((d.columns.len(), d.rows.len()), (2, 1));
        let (shine, blinn) = (d.columns[0].get_ref(), d.columns[1].get_ref());
        let (name, change) = shine.materials.iter().next().unwrap();
        assert_eq!(name.get_ref(), "s50");
        assert_eq!(&src[name.span()], "s50");
        let numbers: Vec<(&str, f32)> = change.get_ref().numbers().iter().map(|(k, _, v, _)| (*k, *v)).collect();
        assert_eq!(numbers, [("shine", 0.2)]);
        assert_eq!(change.get_ref().color.as_ref().map(|c| *c.get_ref()), Some([1.0, 0.0, 0.0]));
        assert!(shine.renders() && blinn.renders() && !d.rows[0].get_ref().renders());
        // Each term is placed where it stands, spaces trimmed.
        let entries = blinn.term_entries(src);
        let names: Vec<&str> = entries.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["ambient", "diffuse", "specular:blinn"]);
        for (name, place) in &entries {
            assert_eq!(&src[place.clone()], name);
        }
    }

    #[test]
    fn a_sheet_without_columns_or_rows_is_one_cell() {
        let f = parse("title = \"t\"\nscene = \"s.toml\"\n").unwrap();
        assert!(f.doc.columns.is_empty() && f.doc.rows.is_empty() && f.doc.description.is_none());
    }

    #[test]
    fn mistakes_in_the_file_are_located_with_what_was_expected() {
        let cases = [
            // An unknown key, with the nearest known one.
            ("title = \"t\"\nscene = \"s.toml\"\n[[columns]]\nlabl = \"a\"\n", "s.toml:4:1:", "did you mean `label`?"),
            // A key left out.
            (
                "title = \"t\"\nscene = \"s.toml\"\n[[rows]]\nimage = \"beauty\"\n",
                "s.toml:3:1:",
                "missing field `label`",
            ),
            ("scene = \"s.toml\"\n", "s.toml:1:1:", "missing field `title`"),
            // A value of the wrong type.
            ("title = \"t\"\nscene = \"s.toml\"\nwidth = \"wide\"\n", "s.toml:3:9:", "expected u32"),
            (
                "title = \"t\"\nscene = \"s.toml\"\n[[columns]]\nlabel = \"a\"\nmaterials.red = { shine = \"high\" }\n",
                "s.toml:5:27:",
                "expected f32",
            ),
            (
                "title = \"t\"\nscene = \"s.toml\"\n[[columns]]\nlabel = \"a\"\nmaterials.red = { shiny = 1 }\n",
                "s.toml:5:19:",
                "did you mean `shine`?",
            ),
            // Out of range.
            ("title = \"t\"\nscene = \"s.toml\"\nwidth = 20000\n", "s.toml:3:9:", "64 to 8192 pixels"),
            ("title = \"t\"\nscene = \"s.toml\"\nsamples = 0\n", "s.toml:3:11:", "samples go from 1 to 4096"),
            (
                "title = \"t\"\nscene = \"s.toml\"\n[[rows]]\nlabel = \"a\"\nmax_depth = 65\n",
                "s.toml:5:13:",
                "max_depth goes from 0 to 64",
            ),
            // TOML syntax: the unclosed string at its line.
            ("title = \"t\nscene = \"s.toml\"\n", "s.toml:1:", ""),
        ];
        for (src, place, what) in cases {
            let e = parse(src).err().unwrap_or_else(|| panic!("{src:?} reads"));
            assert!(e.starts_with(place), "{src:?}: {e}");
            assert!(e.contains(what), "{src:?}: {e}");
            // The offending line is shown under the message, as for a scene file.
            assert!(e.contains("\n  |\n"), "{e}");
        }
    }
}

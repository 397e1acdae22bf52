//! The sheet as a picture: where the title, the description, the labels and the cells go on a
//! sheet of a given size ([`Layout`]), and the text drawn with anti-aliasing in an embedded open
//! font (DejaVu Sans, `crates/lancer-cli/fonts/`, Bitstream Vera licence beside it).
//!
//! Sizes follow the sheet's width, so that the sheet shown across a projector's 1920 pixels
//! reads the same at any width: at 1920 the title is set at 48 px, the labels at 28 px and the
//! description at 26 px.

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};
use image::RgbImage;

/// DejaVu Sans, for the description.
const REGULAR: &[u8] = include_bytes!("../../fonts/DejaVuSans.ttf");
/// DejaVu Sans Bold, for the title and the labels.
const BOLD: &[u8] = include_bytes!("../../fonts/DejaVuSans-Bold.ttf");

/// The sheet's background (sRGB): the gallery's dark grey, which a projector shows as black
/// without the glare of white.
pub(crate) const BACKGROUND: [u8; 3] = [22, 24, 29];
const TITLE_COLOUR: [u8; 3] = [255, 255, 255];
const LABEL_COLOUR: [u8; 3] = [235, 235, 235];
const DESCRIPTION_COLOUR: [u8; 3] = [200, 200, 200];

/// The two faces, parsed once.
pub(crate) struct Fonts {
    regular: FontRef<'static>,
    bold: FontRef<'static>,
}

impl Fonts {
    /// The embedded fonts.
    pub(crate) fn embedded() -> Fonts {
        let parse = |bytes| FontRef::try_from_slice(bytes).expect("the embedded font is a valid TrueType file");
        Fonts { regular: parse(REGULAR), bold: parse(BOLD) }
    }
}

/// A face at a size: `em` is the font size in pixels (as CSS's `font-size`).
#[derive(Clone, Copy)]
pub(crate) struct Style<'f> {
    font: &'f FontRef<'static>,
    em: f32,
    colour: [u8; 3],
}

impl Style<'_> {
    /// ab_glyph's scale is the height from descent to ascent; the font size is the em.
    fn scale(&self) -> PxScale {
        let units = self.font.units_per_em().unwrap_or(2048.0);
        PxScale::from(self.em * self.font.height_unscaled() / units)
    }

    /// The distance from one line's top to the next's.
    pub(crate) fn line_height(&self) -> f32 {
        let s = self.font.as_scaled(self.scale());
        s.height() + s.line_gap()
    }

    /// How wide `text` is set on one line.
    pub(crate) fn width(&self, text: &str) -> f32 {
        let s = self.font.as_scaled(self.scale());
        let (mut caret, mut last) = (0.0, None);
        for c in text.chars() {
            let id = s.glyph_id(c);
            if let Some(prev) = last {
                caret += s.kern(prev, id);
            }
            caret += s.h_advance(id);
            last = Some(id);
        }
        caret
    }

    /// `text` broken into lines no wider than `max` at spaces (a word wider than `max` gets a
    /// line of its own); a line break in the text starts a new line.
    pub(crate) fn wrap(&self, text: &str, max: f32) -> Vec<String> {
        let mut lines = Vec::new();
        for paragraph in text.lines() {
            let mut line = String::new();
            for word in paragraph.split_whitespace() {
                let longer = if line.is_empty() { word.to_owned() } else { format!("{line} {word}") };
                if self.width(&longer) <= max || line.is_empty() {
                    line = longer;
                } else {
                    lines.push(std::mem::replace(&mut line, word.to_owned()));
                }
            }
            lines.push(line);
        }
        lines
    }

    /// Draws one line of `text` onto `image` with its left end at `x` and its top at `top`,
    /// each pixel blended with the text's colour by how much of it the glyphs cover.
    pub(crate) fn draw(&self, image: &mut RgbImage, text: &str, x: f32, top: f32) {
        let s = self.font.as_scaled(self.scale());
        let baseline = top + s.ascent();
        let (mut caret, mut last) = (x, None);
        for c in text.chars() {
            let id = s.glyph_id(c);
            if let Some(prev) = last {
                caret += s.kern(prev, id);
            }
            let glyph = id.with_scale_and_position(self.scale(), point(caret, baseline));
            caret += s.h_advance(id);
            last = Some(id);
            let Some(outline) = self.font.outline_glyph(glyph) else { continue };
            let bounds = outline.px_bounds();
            outline.draw(|gx, gy, coverage| {
                let (px, py) = (bounds.min.x as i64 + gx as i64, bounds.min.y as i64 + gy as i64);
                if px < 0 || py < 0 || px >= image.width() as i64 || py >= image.height() as i64 {
                    return;
                }
                let pixel = image.get_pixel_mut(px as u32, py as u32);
                let a = coverage.clamp(0.0, 1.0);
                for (under, over) in pixel.0.iter_mut().zip(self.colour) {
                    *under = (*under as f32 * (1.0 - a) + over as f32 * a).round() as u8;
                }
            });
        }
    }

    /// Draws `lines` one under the other from `top`, each starting at `x` (or centred on
    /// `x` when `centred`).
    pub(crate) fn draw_lines(&self, image: &mut RgbImage, lines: &[String], x: f32, top: f32, centred: bool) {
        for (k, line) in lines.iter().enumerate() {
            let left = if centred { x - self.width(line) / 2.0 } else { x };
            self.draw(image, line, left, top + k as f32 * self.line_height());
        }
    }
}

/// A rectangle of the sheet, in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Rect {
    pub(crate) x: u32,
    pub(crate) y: u32,
    pub(crate) width: u32,
    pub(crate) height: u32,
}

/// What the sheet says, for the layout.
pub(crate) struct Texts<'a> {
    pub(crate) title: &'a str,
    pub(crate) description: Option<&'a str>,
    /// The columns' labels (empty when the sheet has no `[[columns]]`).
    pub(crate) columns: Vec<&'a str>,
    /// The rows' labels (empty when the sheet has no `[[rows]]`).
    pub(crate) rows: Vec<&'a str>,
}

/// Where everything goes on a sheet of `width` × `height` pixels.
pub(crate) struct Layout<'f> {
    pub(crate) width: u32,
    pub(crate) height: u32,
    /// The title's lines, and where the first one's top is.
    title: (Vec<String>, f32),
    /// The description's lines, and where the first one's top is.
    description: (Vec<String>, f32),
    /// Each column label's lines, and the centre and top of its first line.
    columns: Vec<(Vec<String>, f32, f32)>,
    /// Each row label's lines, and the left and top of its first line.
    rows: Vec<(Vec<String>, f32, f32)>,
    /// Every cell, row by row.
    pub(crate) cells: Vec<Rect>,
    /// The band the title is drawn in.
    pub(crate) title_band: Rect,
    pub(crate) title_style: Style<'f>,
    label_style: Style<'f>,
    description_style: Style<'f>,
}

impl<'f> Layout<'f> {
    /// The layout of `texts` on a `width` × `height` sheet with `columns` × `rows` cells, each
    /// as large as fits, of the width `cell_height` turns into a cell's height (the image's
    /// aspect ratio, rounded as a render's `--width` rounds it). The grid is centred in the
    /// height left under the texts when `fit_height` is false; with it, `height` is the most
    /// the sheet may take and the sheet ends under its cells. `None` when the cells would be
    /// under 8 pixels wide or high.
    pub(crate) fn new(
        fonts: &'f Fonts,
        texts: &Texts<'_>,
        (width, height, fit_height): (u32, u32, bool),
        (columns, rows): (usize, usize),
        cell_height: &dyn Fn(u32) -> u32,
    ) -> Option<Layout<'f>> {
        let w = width as f32;
        let style = |font, em, colour| Style { font, em, colour };
        let title_style = style(&fonts.bold, w / 40.0, TITLE_COLOUR);
        let label_style = style(&fonts.bold, w / 68.0, LABEL_COLOUR);
        let description_style = style(&fonts.regular, w / 74.0, DESCRIPTION_COLOUR);
        let margin = (w / 60.0).round();
        let gap = (w / 160.0).round().max(2.0);
        let inner = w - 2.0 * margin;

        let mut y = margin;
        let title = (title_style.wrap(texts.title, inner), y);
        y += title.0.len() as f32 * title_style.line_height();
        let description = match texts.description.filter(|d| !d.trim().is_empty()) {
            Some(d) => {
                y += gap / 2.0;
                let lines = description_style.wrap(d, inner);
                let top = y;
                y += lines.len() as f32 * description_style.line_height();
                (lines, top)
            }
            None => (Vec::new(), y),
        };
        let title_band = Rect {
            x: margin as u32,
            y: margin as u32,
            width: inner as u32,
            height: (title.0.len() as f32 * title_style.line_height()).ceil() as u32,
        };
        y += 2.0 * gap;

        // The row labels' column: as wide as the widest label, at most a fifth of the sheet.
        let labels_width = texts.rows.iter().map(|l| label_style.width(l)).fold(0.0, f32::max).min(w / 5.0);
        let labels_column = if texts.rows.is_empty() { 0.0 } else { labels_width.ceil() + 2.0 * gap };
        let (ncols, nrows) = (columns.max(1) as f32, rows.max(1) as f32);
        let grid_width = inner - labels_column;
        let fit = |header_lines: usize| -> Option<(u32, u32)> {
            let header =
                if texts.columns.is_empty() { 0.0 } else { header_lines as f32 * label_style.line_height() + gap };
            let grid_height = height as f32 - y - header - margin;
            let by_width = ((grid_width - (ncols - 1.0) * gap) / ncols).floor();
            let mut cell_w = by_width.max(0.0) as u32;
            // As wide as the height allows too: the widest cell whose height fits.
            let rows_height = grid_height - (nrows - 1.0) * gap;
            while cell_w >= 8 && cell_height(cell_w) as f32 * nrows > rows_height {
                let cell_h = (rows_height / nrows).floor().max(1.0);
                let shrunk = (cell_w as f32 * cell_h / cell_height(cell_w) as f32).floor() as u32;
                cell_w = shrunk.min(cell_w - 1);
            }
            let cell_h = cell_height(cell_w);
            (cell_w >= 8 && cell_h >= 8).then_some((cell_w, cell_h))
        };
        // The column labels wrap at the cells' width, which the labels' height changes: fitted
        // with one line of labels, then again with as many as the longest label takes there.
        let wrapped = |cell_w: u32| -> Vec<Vec<String>> {
            texts.columns.iter().map(|l| label_style.wrap(l, cell_w as f32)).collect()
        };
        let (mut cell_w, mut cell_h) = fit(1)?;
        let mut column_lines = wrapped(cell_w);
        let lines = column_lines.iter().map(Vec::len).max().unwrap_or(1);
        if lines > 1 {
            (cell_w, cell_h) = fit(lines)?;
            column_lines = wrapped(cell_w);
        }
        let header_lines = column_lines.iter().map(Vec::len).max().unwrap_or(0);
        let header = if texts.columns.is_empty() { 0.0 } else { header_lines as f32 * label_style.line_height() + gap };

        // The grid, centred across the sheet and in the height left under the description.
        let grid_w = labels_column + ncols * cell_w as f32 + (ncols - 1.0) * gap;
        let grid_h = header + nrows * cell_h as f32 + (nrows - 1.0) * gap;
        let left = ((w - grid_w) / 2.0).max(margin).round();
        let top = match fit_height {
            true => y.round(),
            false => (y + ((height as f32 - y - margin - grid_h) / 2.0).max(0.0)).round(),
        };
        let height = match fit_height {
            true => ((top + grid_h + margin).ceil() as u32).min(height),
            false => height,
        };
        let cells_left = left + labels_column;
        let cells_top = top + header;
        let step_x = cell_w as f32 + gap;
        let step_y = cell_h as f32 + gap;
        let mut cells = Vec::new();
        for r in 0..rows.max(1) {
            for c in 0..columns.max(1) {
                cells.push(Rect {
                    x: (cells_left + c as f32 * step_x) as u32,
                    y: (cells_top + r as f32 * step_y) as u32,
                    width: cell_w,
                    height: cell_h,
                });
            }
        }
        let columns_placed = column_lines
            .into_iter()
            .enumerate()
            .map(|(c, lines)| {
                // Bottom-aligned on the cells' top.
                let first = cells_top - gap - lines.len() as f32 * label_style.line_height();
                (lines, cells_left + c as f32 * step_x + cell_w as f32 / 2.0, first)
            })
            .collect();
        let rows_placed = texts
            .rows
            .iter()
            .enumerate()
            .map(|(r, label)| {
                let lines = label_style.wrap(label, labels_width.max(1.0));
                // Centred on the row's cells.
                let middle = cells_top + r as f32 * step_y + cell_h as f32 / 2.0;
                let first = middle - lines.len() as f32 * label_style.line_height() / 2.0;
                (lines, left, first)
            })
            .collect();
        Some(Layout {
            width,
            height,
            title,
            description,
            columns: columns_placed,
            rows: rows_placed,
            cells,
            title_band,
            title_style,
            label_style,
            description_style,
        })
    }

    /// The sheet with its texts drawn and each cell's 8-bit sRGB pixels (row-major RGB, of the
    /// cell's size) put in place.
    pub(crate) fn compose(&self, cells: &[Vec<u8>]) -> RgbImage {
        let mut image = RgbImage::from_pixel(self.width, self.height, image::Rgb(BACKGROUND));
        let left = self.title_band.x as f32;
        self.title_style.draw_lines(&mut image, &self.title.0, left, self.title.1, false);
        self.description_style.draw_lines(&mut image, &self.description.0, left, self.description.1, false);
        for (lines, centre, top) in &self.columns {
            self.label_style.draw_lines(&mut image, lines, *centre, *top, true);
        }
        for (lines, left, top) in &self.rows {
            self.label_style.draw_lines(&mut image, lines, *left, *top, false);
        }
        for (rect, pixels) in self.cells.iter().zip(cells) {
            for row in 0..rect.height {
                for col in 0..rect.width {
                    let at = 3 * (row * rect.width + col) as usize;
                    let rgb = [pixels[at], pixels[at + 1], pixels[at + 2]];
                    image.put_pixel(rect.x + col, rect.y + row, image::Rgb(rgb));
                }
            }
        }
        image
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_sizes_are_readable_on_a_projector_at_1920() {
        let fonts = Fonts::embedded();
        let texts = Texts { title: "T", description: Some("d"), columns: vec!["a"], rows: vec!["b"] };
        let l = Layout::new(&fonts, &texts, (1920, 1080, false), (1, 1), &|w| w * 9 / 16).unwrap();
        assert!(l.title_style.em >= 40.0, "title {} px", l.title_style.em);
        assert!(l.label_style.em >= 24.0 && l.description_style.em >= 24.0);
    }

    #[test]
    fn cells_fit_the_sheet_without_overlapping_and_keep_the_aspect_ratio() {
        let fonts = Fonts::embedded();
        let texts = Texts {
            title: "A title long enough to wrap onto a second line when the sheet is narrow",
            description: Some("Some words\nand a second paragraph"),
            columns: vec!["one", "two", "a label long enough to need two lines at this width", "four"],
            rows: vec!["specular", "beauty", "diffuse"],
        };
        for (w, h, fit) in
            [(1920, 1080, false), (960, 540, false), (800, 2000, false), (3000, 1400, false), (1920, 1080, true)]
        {
            let aspect = |cw: u32| ((cw as f64 / (16.0 / 9.0)).round() as u32).max(1);
            let l =
                Layout::new(&fonts, &texts, (w, h, fit), (4, 3), &aspect).unwrap_or_else(|| panic!("{w}x{h}: no room"));
            assert_eq!(l.cells.len(), 12);
            assert!(l.height <= h && (fit || l.height == h));
            let h = l.height;
            for (i, a) in l.cells.iter().enumerate() {
                assert_eq!(a.height, aspect(a.width));
                assert!(a.x + a.width <= w && a.y + a.height <= h, "{w}x{h}: {a:?} off the sheet");
                assert!(a.y > l.title_band.y + l.title_band.height, "{w}x{h}: under the title");
                for b in &l.cells[i + 1..] {
                    let apart = a.x + a.width <= b.x || b.x + b.width <= a.x || a.y + a.height <= b.y;
                    assert!(apart, "{w}x{h}: {a:?} and {b:?} overlap");
                }
            }
        }
        // Too many cells for the sheet.
        assert!(Layout::new(&fonts, &texts, (64, 64, false), (40, 40), &|w| w).is_none());
        // A sheet that may end under its cells does: one wide row takes a band, not a slide.
        let one_row = Texts { rows: vec![], ..texts };
        let l = Layout::new(&fonts, &one_row, (1920, 1080, true), (6, 1), &|w| w * 9 / 16).unwrap();
        let last = l.cells.last().unwrap();
        assert!(l.height < 700 && l.height > last.y + last.height, "{}", l.height);
    }

    #[test]
    fn wrapping_breaks_at_spaces_within_the_width() {
        let fonts = Fonts::embedded();
        let s = Style { font: &fonts.regular, em: 20.0, colour: [255; 3] };
        let lines = s.wrap("the quick brown fox jumps over the lazy dog", 120.0);
        assert!(lines.len() > 2, "{lines:?}");
        assert_eq!(lines.join(" "), "the quick brown fox jumps over the lazy dog");
        assert!(lines.iter().all(|l| s.width(l) <= 120.0 || !l.contains(' ')), "{lines:?}");
        assert_eq!(s.wrap("a\nb", 1000.0), ["a", "b"]);
    }
}

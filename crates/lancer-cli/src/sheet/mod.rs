//! `lancer sheet SHEET.toml -o sheet.png`: a lecture sheet. A sheet file (docs/sheets.md) names
//! a scene and a grid: each column and each row changes the model (a model file, the terms and
//! their variants, the shadow model, the depth limit), the materials' numbers, or which image
//! the cell shows (the beauty image or one term's). A cell is the scene with its column's
//! changes, then its row's, rendered in-process as `lancer render` renders it (the same loading,
//! the same changes: [`crate::app::change_model`], the studio's material edits); cells that
//! differ only by the image shown share one render. The sheet is drawn with its title,
//! description and labels in an embedded font ([`draw`]) and written whole or not at all, as a
//! PNG or as a page with each cell's PNG embedded ([`html`]).

mod draw;
mod file;
mod html;

use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use lancer_core::{ImageSettings, Material};
use lancer_scene::LoadError;
use lancer_shading::{Pipeline, Registry, RenderOptions};
use lancer_studio::MaterialState;

use crate::app::{MAX_FILE_MB, SceneArgs};
use draw::{Fonts, Layout, Rect, Texts};
use file::{Change, SheetFile};

/// A sheet's width when neither the command line nor the file gives one: a projector's.
const DEFAULT_WIDTH: u32 = 1920;

/// `lancer sheet`'s command line.
#[derive(Args)]
pub(crate) struct SheetArgs {
    /// The sheet file (TOML; docs/sheets.md): a title, a scene, and the columns and rows.
    sheet: PathBuf,
    /// The sheet: .png (the grid with its title and labels drawn in) or .html (a page with every
    /// cell's PNG embedded, and each cell's model).
    #[arg(short, long, default_value = "sheet.png")]
    output: PathBuf,
    /// The sheet's width in pixels, over the file's (1920 when neither gives one); the height
    /// follows the sheet's shape unless --height is given.
    #[arg(long, value_parser = clap::value_parser!(u32).range(file::MIN_SIDE as i64..=file::MAX_SIDE as i64))]
    width: Option<u32>,
    /// The sheet's height in pixels, over the file's (when neither gives one, as tall as the
    /// cells need, at most 9/16 of the width).
    #[arg(long, value_parser = clap::value_parser!(u32).range(file::MIN_SIDE as i64..=file::MAX_SIDE as i64))]
    height: Option<u32>,
    /// Samples per pixel of every cell, over the file's and the scene's.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4096))]
    samples: Option<u32>,
    /// Worker threads (default: one per core). The sheet is identical for any count.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// No progress or summary lines.
    #[arg(short, long)]
    quiet: bool,
}

/// What `-o` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Output {
    Png,
    Html,
}

impl Output {
    fn of(path: &Path) -> Result<Output> {
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("png") => Ok(Output::Png),
            Some("html" | "htm") => Ok(Output::Html),
            _ => bail!("output {} must end in .png (the sheet as a picture) or .html (a page)", path.display()),
        }
    }
}

/// Runs `lancer sheet`.
pub(crate) fn run(registry: &Registry, args: SheetArgs) -> Result<()> {
    let output = Output::of(&args.output)?;
    if let Some(folder) = args.output.parent().filter(|p| !p.as_os_str().is_empty())
        && !folder.is_dir()
    {
        bail!("cannot write {}: there is no folder {}", args.output.display(), folder.display());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0) as usize)
        .build()
        .context("starting worker threads")?;
    let start = Instant::now();
    let options = Options { width: args.width, height: args.height, samples: args.samples, quiet: args.quiet };
    let sheet = pool.install(|| make(registry, &args.sheet, &options))?;
    let bytes = match output {
        Output::Png => png(&sheet.image)?,
        Output::Html => html::page(&sheet)?.into_bytes(),
    };
    crate::output::write_atomic(&args.output, &bytes)?;
    crate::output::outputs_done();
    if !args.quiet {
        let cell = sheet.cells[0].rect;
        eprintln!(
            "sheet {}: {} x {} cells of {}x{} ({} render{}) in {:.2} s -> {} ({}x{})",
            sheet.name,
            sheet.columns.len().max(1),
            sheet.rows.len().max(1),
            cell.width,
            cell.height,
            sheet.renders,
            if sheet.renders == 1 { "" } else { "s" },
            start.elapsed().as_secs_f64(),
            args.output.display(),
            sheet.image.width(),
            sheet.image.height()
        );
    }
    Ok(())
}

/// The command line's settings over the file's.
#[derive(Clone, Copy, Default)]
pub(crate) struct Options {
    pub(crate) width: Option<u32>,
    pub(crate) height: Option<u32>,
    pub(crate) samples: Option<u32>,
    pub(crate) quiet: bool,
}

/// A sheet made: the picture, and what each cell is.
pub(crate) struct Sheet {
    /// How the sheet file is named.
    pub(crate) name: String,
    pub(crate) title: String,
    pub(crate) description: Option<String>,
    /// How the scene is named.
    pub(crate) scene: String,
    pub(crate) columns: Vec<String>,
    pub(crate) rows: Vec<String>,
    /// Every cell, row by row.
    pub(crate) cells: Vec<Cell>,
    /// How many renders the cells took.
    pub(crate) renders: usize,
    /// The sheet with its texts and cells.
    pub(crate) image: image::RgbImage,
    /// Where the title is drawn.
    #[cfg(test)]
    pub(crate) title_band: Rect,
}

/// One cell made.
pub(crate) struct Cell {
    /// Where it is on the sheet (its size is the render's).
    pub(crate) rect: Rect,
    /// Its 8-bit sRGB pixels, row-major RGB: what `lancer render` writes into a PNG.
    pub(crate) pixels: Vec<u8>,
    /// The image shown: `beauty`, a term's name or `background`.
    pub(crate) image: String,
    /// Its model, as `lancer render`'s summary line says it.
    pub(crate) model: String,
}

/// An image's PNG bytes, as `lancer render` writes them (the same encoder and settings).
pub(crate) fn png(image: &image::RgbImage) -> Result<Vec<u8>> {
    let mut out = std::io::Cursor::new(Vec::new());
    image.write_to(&mut out, image::ImageFormat::Png).context("encoding PNG")?;
    Ok(out.into_inner())
}

/// One render of the scene, and the cells that show one of its images.
struct Job {
    pipeline: Pipeline,
    /// The materials changed: their index in the prepared table and their new numbers.
    materials: Vec<(usize, Material)>,
    /// Whether any of its cells shows a term's image.
    layers: bool,
    /// Its cells.
    cells: Vec<usize>,
    /// What it is, for the progress lines.
    what: String,
}

/// The sheet file read, with its scene, checking every change as it is applied.
struct Planner<'a> {
    registry: &'a Registry,
    file: &'a SheetFile,
    /// The sheet file's folder: its paths are relative to it.
    folder: PathBuf,
    /// The scene's materials, by their names in the scene file.
    labels: &'a [String],
}

impl Planner<'_> {
    /// An error placed at `span` of the sheet file.
    fn error(&self, span: Range<usize>, message: String) -> anyhow::Error {
        anyhow::Error::msg(self.file.error(span, message))
    }

    /// An error `e` from reading `what` named at `span`: kept as it is when it is placed in a
    /// file of its own (a scene or model file's mistake), with where the sheet names that file;
    /// else its cause placed at `span`.
    fn beside(&self, span: Range<usize>, what: &str, prefix: &str, e: anyhow::Error) -> anyhow::Error {
        if e.downcast_ref::<LoadError>().is_some() {
            let place = self.file.error(span, String::new());
            return e.context(format!("{prefix}in {what} named at {}:{}:{}", place.file, place.line, place.column));
        }
        self.error(span, format!("{prefix}{}", e.root_cause()))
    }

    /// A copy of `pipeline`, built again from its names and parameters.
    fn copy(&self, pipeline: &Pipeline) -> Result<Pipeline> {
        crate::diagnose::catalogue::rebuild(self.registry, pipeline, &[], None)
    }

    /// `change`'s changes to the model over `pipeline`, in the order `lancer render` applies
    /// its flags (model file, terms, shadows, depth); an error is placed at the key it comes
    /// from, and said to be `prefix`'s.
    fn change_model(&self, change: &Change, pipeline: Pipeline, prefix: &str) -> Result<Pipeline> {
        let apply = |set: &dyn Fn(&mut SceneArgs), p: Pipeline| {
            let mut args = SceneArgs::of(None);
            set(&mut args);
            crate::app::change_model(self.registry, &args, p).map(|(p, _)| p)
        };
        let mut p = pipeline;
        if let Some(m) = &change.model {
            let path = self.folder.join(m.get_ref());
            p = apply(&|a| a.model = Some(path.clone()), p)
                .map_err(|e| self.beside(m.span(), "the model file", prefix, e))?;
        }
        if let Some(t) = &change.terms {
            let entries = change.term_entries(&self.file.src);
            let list: Vec<String> = entries.iter().map(|(name, _)| name.clone()).collect();
            let kept = self.copy(&p)?;
            p = match apply(&|a| a.terms = Some(list.clone()), p) {
                Ok(p) => p,
                Err(e) => {
                    // Placed at the first term that is wrong on its own (else the list is: a
                    // term twice).
                    for (name, place) in &entries {
                        if let Err(e) = apply(&|a| a.terms = Some(vec![name.clone()]), self.copy(&kept)?) {
                            return Err(self.error(place.clone(), format!("{prefix}{}", e.root_cause())));
                        }
                    }
                    return Err(self.error(t.span(), format!("{prefix}{}", e.root_cause())));
                }
            };
        }
        if let Some(s) = &change.shadows {
            p = apply(&|a| a.shadows = Some(s.get_ref().clone()), p)
                .map_err(|e| self.error(s.span(), format!("{prefix}{}", e.root_cause())))?;
        }
        if let Some(d) = &change.max_depth {
            p = apply(&|a| a.max_depth = Some(*d.get_ref()), p)?;
        }
        Ok(p)
    }

    /// `change`'s material changes made to `materials` (the prepared table), each number
    /// checked as the studio checks its sliders; gives the indices changed.
    fn change_materials(&self, change: &Change, materials: &mut [Material], prefix: &str) -> Result<Vec<usize>> {
        let mut changed = Vec::new();
        for (name, edit) in &change.materials {
            let Some(i) = self.labels.iter().position(|l| l == name.get_ref()) else {
                let known = self.labels.iter().map(String::as_str);
                let hint = lancer_shading::nearest(name.get_ref(), known)
                    .map(|n| format!(" (did you mean `{n}`?)"))
                    .unwrap_or_default();
                let list = if self.labels.is_empty() { "none".to_owned() } else { self.labels.join(", ") };
                let message =
                    format!("{prefix}the scene has no material `{}`{hint}; its materials: {list}", name.get_ref());
                return Err(self.error(name.span(), message));
            };
            let edit = edit.get_ref();
            let mut state = MaterialState::of(name.get_ref().clone(), &materials[i]);
            let mut set = |state: &MaterialState, span: Range<usize>| {
                state.write_to(&mut materials[i]).map_err(|m| self.error(span, format!("{prefix}{m}")))
            };
            if let Some(c) = &edit.color {
                state.color = *c.get_ref();
                set(&state, c.span())?;
            }
            for (_, number, value, span) in edit.numbers() {
                *number(&mut state) = value;
                set(&state, span)?;
            }
            changed.push(i);
        }
        Ok(changed)
    }
}

/// A column's or a row's label (none for the one column or row of a sheet without them).
fn label(c: Option<&Change>) -> &str {
    c.map(|c| c.label.get_ref().as_str()).unwrap_or_default()
}

/// The image a cell shows, and where the sheet says so.
fn image_of<'c>(column: Option<&'c Change>, row: Option<&'c Change>) -> Option<&'c toml::Spanned<String>> {
    row.and_then(|r| r.image.as_ref()).or_else(|| column.and_then(|c| c.image.as_ref()))
}

/// Makes the sheet `path`: reads it and its scene, checks every cell, renders, draws.
pub(crate) fn make(registry: &Registry, path: &Path, options: &Options) -> Result<Sheet> {
    let name = path.display().to_string();
    let src = crate::app::read(path, "sheet", MAX_FILE_MB)?;
    let file = SheetFile::parse(&name, &src).map_err(anyhow::Error::msg)?;
    let doc = &file.doc;
    let folder = path.parent().map(Path::to_path_buf).unwrap_or_default();

    // The sheet's size: the command line's over the file's, a side left out following the
    // shape (16:9 when nothing gives one). A height nobody gives is the most the sheet takes.
    let (w, h) = (doc.width.as_ref().map(|w| *w.get_ref()), doc.height.as_ref().map(|h| *h.get_ref()));
    let mut size = ImageSettings { width: DEFAULT_WIDTH, height: DEFAULT_WIDTH * 9 / 16, ..Default::default() };
    crate::app::resize(&mut size, w.or(h.is_none().then_some(DEFAULT_WIDTH)), h);
    crate::app::resize(&mut size, options.width, options.height);
    let fit_height = h.is_none() && options.height.is_none();
    if [size.width, size.height].iter().any(|s| !(file::MIN_SIDE..=file::MAX_SIDE).contains(s)) {
        bail!(
            "{name}: a sheet of {}x{} is too {}; a sheet is {} to {} pixels wide and high",
            size.width,
            size.height,
            if size.width.max(size.height) > file::MAX_SIDE { "large" } else { "small" },
            file::MIN_SIDE,
            file::MAX_SIDE
        );
    }

    let mut input = SceneArgs::of(Some(folder.join(doc.scene.get_ref())));
    input.samples = options.samples.or(doc.samples.as_ref().map(|s| *s.get_ref())).map(crate::app::Samples::Uniform);
    let planner_of = |labels| Planner { registry, file: &file, folder: folder.clone(), labels };
    let loaded =
        crate::app::load(registry, &input).map_err(|e| planner_of(&[]).beside(doc.scene.span(), "the scene", "", e))?;
    let (mut prepared, warnings) = loaded.prepare()?;
    for w in &warnings {
        eprintln!("{w}");
    }
    let planner = planner_of(&loaded.places.materials);

    // Every cell's model, materials and image, checked before anything renders.
    let columns: Vec<Option<&Change>> =
        if doc.columns.is_empty() { vec![None] } else { doc.columns.iter().map(|c| Some(c.get_ref())).collect() };
    let rows: Vec<Option<&Change>> =
        if doc.rows.is_empty() { vec![None] } else { doc.rows.iter().map(|r| Some(r.get_ref())).collect() };
    let base = prepared.materials.clone();
    let mut jobs: Vec<Job> = Vec::new();
    let mut job_of: HashMap<(Option<usize>, Option<usize>), usize> = HashMap::new();
    let mut images = Vec::new();
    for (r, row) in rows.iter().enumerate() {
        for (c, column) in columns.iter().enumerate() {
            let cell = images.len();
            let column_renders = column.is_some_and(Change::renders);
            let row_renders = row.is_some_and(Change::renders);
            let key = (column_renders.then_some(c), row_renders.then_some(r));
            let k = match job_of.get(&key) {
                Some(&k) => k,
                None => {
                    let mut pipeline = planner.copy(&loaded.pipeline)?;
                    let mut materials = base.clone();
                    let mut changed = Vec::new();
                    if let (Some(column), true) = (column, column_renders) {
                        let prefix = format!("column `{}`: ", label(Some(column)));
                        pipeline = planner.change_model(column, pipeline, &prefix)?;
                        changed.extend(planner.change_materials(column, &mut materials, &prefix)?);
                    }
                    if let (Some(row), true) = (row, row_renders) {
                        let prefix = match column_renders {
                            true => format!("row `{}` over column `{}`: ", label(Some(row)), label(*column)),
                            false => format!("row `{}`: ", label(Some(row))),
                        };
                        pipeline = planner.change_model(row, pipeline, &prefix)?;
                        changed.extend(planner.change_materials(row, &mut materials, &prefix)?);
                    }
                    changed.sort_unstable();
                    changed.dedup();
                    let what = match key {
                        (Some(_), Some(_)) => format!("column `{}`, row `{}`", label(*column), label(*row)),
                        (Some(_), None) => format!("column `{}`", label(*column)),
                        (None, Some(_)) => format!("row `{}`", label(*row)),
                        (None, None) => "the scene as it is".to_owned(),
                    };
                    let materials = changed.into_iter().map(|i| (i, materials[i])).collect();
                    jobs.push(Job { pipeline, materials, layers: false, cells: Vec::new(), what });
                    job_of.insert(key, jobs.len() - 1);
                    jobs.len() - 1
                }
            };
            let job = &mut jobs[k];
            let image = match image_of(*column, *row) {
                None => "beauty".to_owned(),
                Some(i) => {
                    let terms: Vec<&str> = job.pipeline.terms.iter().map(|t| t.name.as_str()).collect();
                    let known: Vec<&str> =
                        ["beauty"].into_iter().chain(terms.iter().copied()).chain(["background"]).collect();
                    if !known.contains(&i.get_ref().as_str()) {
                        let hint = lancer_shading::nearest(i.get_ref(), known.iter().copied())
                            .map(|n| format!(" (did you mean `{n}`?)"))
                            .unwrap_or_default();
                        let message = format!(
                            "the cell of column `{}` and row `{}` has no image `{}`{hint}; its images: {}",
                            label(*column),
                            label(*row),
                            i.get_ref(),
                            known.join(", ")
                        );
                        return Err(planner.error(i.span(), message));
                    }
                    i.get_ref().clone()
                }
            };
            job.layers |= image != "beauty";
            job.cells.push(cell);
            images.push(image);
        }
    }

    // Where everything goes; the cells' size is a render's at the cells' width.
    let fonts = Fonts::embedded();
    let texts = Texts {
        title: doc.title.get_ref(),
        description: doc.description.as_deref(),
        columns: doc.columns.iter().map(|c| c.get_ref().label.get_ref().as_str()).collect(),
        rows: doc.rows.iter().map(|r| r.get_ref().label.get_ref().as_str()).collect(),
    };
    let scene_image = loaded.scene.image;
    let cell_height = |w: u32| {
        let mut image = scene_image;
        crate::app::resize(&mut image, Some(w), None);
        image.height
    };
    let sheet_size = (size.width, size.height, fit_height);
    let layout =
        Layout::new(&fonts, &texts, sheet_size, (columns.len(), rows.len()), &cell_height).with_context(|| {
            format!(
                "{name}: a sheet of {}x{} has no room for {} x {} cells; make it larger (width, height)",
                size.width,
                size.height,
                columns.len(),
                rows.len()
            )
        })?;
    let mut image = scene_image;
    crate::app::resize(&mut image, Some(layout.cells[0].width), None);

    let mut pixels = vec![Vec::new(); images.len()];
    let mut models = vec![String::new(); images.len()];
    for (k, job) in jobs.iter().enumerate() {
        let started = Instant::now();
        prepared.materials.clone_from(&base);
        for (i, m) in &job.materials {
            prepared.materials[*i] = *m;
        }
        let render = RenderOptions { layers: job.layers, ..Default::default() };
        let frame = lancer_shading::render_prepared(&prepared, &loaded.scene.camera, &image, &job.pipeline, render);
        for &cell in &job.cells {
            let shown = match images[cell].as_str() {
                "beauty" => &frame.beauty,
                layer => &frame.layer(layer).with_context(|| format!("the render has no {layer} image"))?.pixels,
            };
            pixels[cell] = crate::output::to_srgb8(shown);
            models[cell] = crate::stats::effective_model(&job.pipeline, &image);
        }
        if !options.quiet {
            let seconds = started.elapsed().as_secs_f64();
            eprintln!("[{}/{}] rendered {} ({seconds:.2} s)", k + 1, jobs.len(), job.what);
        }
    }
    let picture = layout.compose(&pixels);
    let cells = layout
        .cells
        .iter()
        .zip(pixels.into_iter().zip(images).zip(models))
        .map(|(rect, ((pixels, image), model))| Cell { rect: *rect, pixels, image, model })
        .collect();
    Ok(Sheet {
        name,
        title: doc.title.get_ref().clone(),
        description: doc.description.clone(),
        scene: loaded.name.clone(),
        columns: texts.columns.iter().map(|s| s.to_string()).collect(),
        rows: texts.rows.iter().map(|s| s.to_string()).collect(),
        cells,
        renders: jobs.len(),
        image: picture,
        #[cfg(test)]
        title_band: layout.title_band,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn repo(rel: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(rel).canonicalize().unwrap()
    }

    /// A sheet file `text` written into `dir`, its `SCENE` replaced by the path of `scene`.
    fn sheet_in(dir: &Path, text: &str, scene: &Path) -> PathBuf {
        let path = dir.join("s.toml");
        std::fs::write(&path, text.replace("SCENE", &scene.display().to_string())).unwrap();
        path
    }

    fn made(path: &Path, width: u32) -> Result<Sheet> {
        make(&Registry::with_builtins(), path, &Options { width: Some(width), quiet: true, ..Options::default() })
    }

    /// The cell's pixels as the sheet holds them.
    fn crop(sheet: &Sheet, rect: Rect) -> Vec<u8> {
        let mut out = Vec::new();
        for y in rect.y..rect.y + rect.height {
            for x in rect.x..rect.x + rect.width {
                out.extend(sheet.image.get_pixel(x, y).0);
            }
        }
        out
    }

    /// `scene` rendered as `lancer render` renders it, `set` changing its flags, at `width`:
    /// the 8-bit image `layer`.
    fn plain(scene: &Path, width: u32, set: impl Fn(&mut SceneArgs), layer: &str) -> Vec<u8> {
        let registry = Registry::with_builtins();
        let mut args = SceneArgs::of(Some(scene.to_path_buf()));
        set(&mut args);
        let mut loaded = crate::app::load(&registry, &args).unwrap();
        crate::app::resize(&mut loaded.scene.image, Some(width), None);
        let (prepared, _) = loaded.prepare().unwrap();
        let options = RenderOptions { layers: true, ..Default::default() };
        let frame = lancer_shading::render_prepared(
            &prepared,
            &loaded.scene.camera,
            &loaded.scene.image,
            &loaded.pipeline,
            options,
        );
        let pixels = if layer == "beauty" { &frame.beauty } else { &frame.layer(layer).unwrap().pixels };
        crate::output::to_srgb8(pixels)
    }

    const TWO_BY_TWO: &str = r#"
title = "Two by two"
description = "Terms and a material"
scene = "SCENE"

[[columns]]
label = "blinn"
terms = "ambient,diffuse,specular:blinn"

[[columns]]
label = "shine 0.8, no shadows"
shadows = "none"
materials.s50 = { shine = 0.8 }

[[rows]]
label = "specular"
image = "specular"

[[rows]]
label = "diffuse"
image = "diffuse"

[[rows]]
label = "beauty at depth 2"
max_depth = 2
"#;

    #[test]
    fn a_cell_is_a_plain_render_of_the_scene_with_the_same_changes() {
        let dir = tempfile::tempdir().unwrap();
        let scene = repo("scenes/shine-ladder.toml");
        let sheet = made(&sheet_in(dir.path(), TWO_BY_TWO, &scene), 640).unwrap();
        assert_eq!((sheet.cells.len(), sheet.renders), (6, 4), "rows that only pick an image share a render");
        let width = sheet.cells[0].rect.width;
        // The material change made in the scene's own text instead: an independent path.
        let text = std::fs::read_to_string(&scene).unwrap();
        let at = text.find("[materials.s50]").unwrap();
        let edited = format!("{}{}", &text[..at], text[at..].replacen("shine = 0.5", "shine = 0.8", 1));
        let edited_scene = dir.path().join("edited.toml");
        std::fs::write(&edited_scene, edited).unwrap();

        let blinn = || Some(vec!["ambient".into(), "diffuse".into(), "specular:blinn".into()]);
        for (row, layer) in ["specular", "diffuse", "beauty"].iter().enumerate() {
            let depth = (row == 2).then_some(2);
            let want = [
                plain(&scene, width, |a| (a.terms, a.max_depth) = (blinn(), depth), layer),
                plain(&edited_scene, width, |a| (a.shadows, a.max_depth) = (Some("none".into()), depth), layer),
            ];
            for (column, want) in want.iter().enumerate() {
                let cell = &sheet.cells[row * 2 + column];
                assert_eq!(cell.image, *layer);
                assert!(cell.pixels == *want, "row {row}, column {column}: the cell is not the plain render");
                assert!(crop(&sheet, cell.rect) == *want, "row {row}, column {column}: the sheet holds another image");
            }
        }
        // The two columns differ (the changes did something), and so do the rows' images.
        assert!(sheet.cells[0].pixels != sheet.cells[1].pixels && sheet.cells[0].pixels != sheet.cells[2].pixels);
        assert!(sheet.cells[1].model.contains("shadows none"), "{}", sheet.cells[1].model);
    }

    #[test]
    fn the_title_and_labels_are_drawn_with_anti_aliasing() {
        let dir = tempfile::tempdir().unwrap();
        let sheet = made(&sheet_in(dir.path(), TWO_BY_TWO, &repo("scenes/shine-ladder.toml")), 960).unwrap();
        let band = sheet.title_band;
        let (mut ink, mut edge) = (0, 0);
        for y in band.y..band.y + band.height {
            for x in band.x..band.x + band.width {
                let p = sheet.image.get_pixel(x, y).0;
                if p != draw::BACKGROUND {
                    ink += 1;
                }
                if p != draw::BACKGROUND && p != [255; 3] {
                    edge += 1;
                }
            }
        }
        assert!(ink > 500, "the title band holds {ink} inked pixels");
        assert!(edge > 100, "the glyphs' edges are blended ({edge} pixels between)");
        // Left of the first cell, where the row labels are, and above it, the column labels.
        let first = sheet.cells[0].rect;
        let inked = |x0: u32, y0: u32, x1: u32, y1: u32| {
            (y0..y1)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .any(|(x, y)| sheet.image.get_pixel(x, y).0 != draw::BACKGROUND)
        };
        assert!(inked(0, first.y, first.x, first.y + first.height), "a row label");
        assert!(inked(first.x, band.y + band.height + 40, first.x + first.width, first.y), "a column label");
    }

    fn error_of(text: &str) -> String {
        let dir = tempfile::tempdir().unwrap();
        let path = sheet_in(dir.path(), text, &repo("scenes/shine-ladder.toml"));
        let e = made(&path, 320).err().expect("the sheet is refused");
        format!("{e:#}").replace(&path.display().to_string(), "s.toml")
    }

    #[test]
    fn unknown_names_are_located_where_the_sheet_writes_them() {
        let head = "title = \"t\"\nscene = \"SCENE\"\n[[columns]]\nlabel = \"a\"\n";
        let cases = [
            // The wrong term of a list, at its own column, with the nearest name.
            ("terms = \"ambient, difuse,specular\"\n", "s.toml:5:19:", "did you mean `diffuse`?"),
            ("terms = \"ambient,diffuse:lambrt\"\n", "s.toml:5:18:", "lambrt"),
            ("terms = \"ambient,ambient\"\n", "s.toml:5:9:", "twice"),
            ("shadows = \"sofft\"\n", "s.toml:5:11:", "did you mean `soft`?"),
            (
                "materials.s5 = { shine = 0.8 }\n",
                "s.toml:5:11:",
                "no material `s5` (did you mean `s50`?); its materials: s",
            ),
            ("materials.s50 = { diff = 0.5, shine = 1.5 }\n", "s.toml:5:39:", "shine must be in [0, 1], not 1.5"),
            (
                "image = \"mirror\"\n",
                "s.toml:5:9:",
                "no image `mirror`; its images: beauty, ambient, diffuse, specular, background",
            ),
            ("model = \"nowhere.toml\"\n", "s.toml:5:9:", "nowhere.toml"),
        ];
        for (line, place, what) in cases {
            let e = error_of(&format!("{head}{line}"));
            assert!(e.starts_with(place), "{line:?}: {e}");
            assert!(e.contains(what), "{line:?}: {e}");
            assert!(e.contains("column `a`: ") || line.starts_with("image"), "{line:?}: {e}");
        }
        // A row's image is checked against the model of each cell it is in.
        let e =
            error_of(&format!("{head}terms = \"ambient,diffuse\"\n[[rows]]\nlabel = \"r\"\nimage = \"specular\"\n"));
        assert!(e.starts_with("s.toml:8:9:") && e.contains("column `a` and row `r` has no image `specular`"), "{e}");
        // The scene: a missing file at the `scene` key, a scene's own mistake where it is.
        let e = error_of("title = \"t\"\nscene = \"SCENE.missing\"\n");
        assert!(e.starts_with("s.toml:2:9:") && e.contains("reading scene"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("bad.toml"), "[camera]\nfov = \"wide\"\n").unwrap();
        let path = sheet_in(dir.path(), "title = \"t\"\nscene = \"bad.toml\"\n", Path::new(""));
        let e = format!("{:#}", made(&path, 320).err().unwrap());
        assert!(e.contains("in the scene named at") && e.contains("bad.toml:2:7:"), "{e}");
    }

    #[test]
    fn every_sheet_of_the_repository_makes_its_picture() {
        let dir = repo("sheets");
        let mut count = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "toml") {
                let sheet = made(&path, 480).unwrap_or_else(|e| panic!("{}: {e:#}", path.display()));
                assert_eq!(sheet.image.width(), 480);
                count += 1;
            }
        }
        assert!(count >= 8, "{count} sheets");
    }

    #[test]
    fn the_format_documents_shows_the_example_sheet_as_it_is() {
        let docs = std::fs::read_to_string(repo("docs/sheets.md")).unwrap();
        let example = std::fs::read_to_string(repo("sheets/shine.toml")).unwrap();
        assert!(docs.contains(&example), "docs/sheets.md must show sheets/shine.toml verbatim");
    }
}

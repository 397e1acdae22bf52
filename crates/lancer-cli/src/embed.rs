//! Lancer embedded in another program (the Python package, `crates/lancer-py`): a scene loaded
//! as `lancer render` loads it, the model and image changed as its flags change them, the
//! statistics of `--stats-json`, the image and `--aov` writers and `explain --json`: the same
//! code, so a render from there is the command line's bits for the same settings.

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use lancer_core::{Frame, ImageSettings, RenderStats, Scene};
use lancer_scene::{LoadError, Places, Warning};
use lancer_shading::{Params, Pipeline, Prepared, Registry};

use crate::app::{SceneArgs, change_model, check_pixels, read, read_checked, resize};

/// A scene as loaded, its model built against the registry.
pub struct Document {
    /// Objects, materials, lights, camera and image settings.
    pub scene: Scene,
    /// The scene's model (its `[model]` table, then the model file given).
    pub pipeline: Pipeline,
    /// Where each part is written, and the materials' names in the prepared table's order.
    pub places: Places,
    /// What loading found to warn about.
    pub warnings: Vec<Warning>,
    /// How the scene is named in messages (the path as given).
    pub name: String,
}

/// Why a scene could not be loaded.
#[derive(Debug)]
pub enum Failure {
    /// A located error of the scene or model file (and its others, [`LoadError::more`]).
    Located(LoadError),
    /// A file that could not be read, or anything else without a place in a file.
    Other(anyhow::Error),
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Failure::Located(e) => write!(f, "{e}"),
            Failure::Other(e) => write!(f, "{e:#}"),
        }
    }
}

/// Loads the scene file `path` (the files it names are relative to its folder), then the model
/// file `model` over its model, within the command line's default limits.
pub fn load_file(registry: &Registry, path: &Path, model: Option<&Path>) -> Result<Document, Failure> {
    let limit = SceneArgs::of(None).max_file_size;
    let text = read(path, "scene", limit).map_err(Failure::Other)?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    load_text(registry, &text, &path.display().to_string(), &base, model)
}

/// Loads the scene `text`, named `name` in messages, whose files are relative to `base`; then
/// the model file `model` over its model.
pub fn load_text(
    registry: &Registry,
    text: &str,
    name: &str,
    base: &Path,
    model: Option<&Path>,
) -> Result<Document, Failure> {
    let args = SceneArgs::of(None);
    let resolve = |rel: &str| {
        let path: PathBuf = base.join(rel);
        read_checked(&path, "file", args.max_file_size, None)
            .map_err(|e| e.replace(&format!("`{}`", path.display()), &format!("`{rel}`")))
    };
    let limits =
        lancer_scene::Limits { max_texture_pixels: args.max_texture_pixels, max_triangles: args.max_triangles };
    let loaded = lancer_scene::load_scene_within(text, name, registry, &resolve, &limits).map_err(Failure::Located)?;
    let mut pipeline = loaded.pipeline;
    let mut places = loaded.places;
    if let Some(p) = model {
        let text = read(p, "model", args.max_file_size).map_err(Failure::Other)?;
        pipeline = lancer_scene::load_model_over(&text, &p.display().to_string(), registry, pipeline)
            .map_err(Failure::Located)?;
        places.chosen_terms = true;
    }
    check_pixels(&loaded.scene.image).map_err(Failure::Other)?;
    Ok(Document { scene: loaded.scene, pipeline, places, warnings: loaded.warnings, name: name.to_owned() })
}

/// What a render changes, as `lancer render`'s flags of the same names do; `None` keeps the
/// scene's.
#[derive(Clone, Debug, Default)]
pub struct Settings {
    /// `--width` (the height follows the aspect ratio unless given too).
    pub width: Option<u32>,
    /// `--height`.
    pub height: Option<u32>,
    /// `--samples`.
    pub samples: Option<u32>,
    /// `--terms`, one entry per term (`NAME[:VARIANT][:KEY=VALUE]...`).
    pub terms: Option<Vec<String>>,
    /// `--shadows`.
    pub shadows: Option<String>,
    /// `--max-depth`.
    pub max_depth: Option<u8>,
}

impl Settings {
    /// The flags' ranges, said as the command line says them.
    fn check(&self) -> Result<()> {
        let within = |what: &str, v: Option<u32>, hi: u32| match v {
            Some(v) if !(1..=hi).contains(&v) => bail!("{what} {v} is not in 1..={hi}"),
            _ => Ok(()),
        };
        within("width", self.width, 16384)?;
        within("height", self.height, 16384)?;
        within("samples", self.samples, lancer_scene::MAX_SAMPLES)?;
        if let Some(d) = self.max_depth.filter(|d| *d > 64) {
            bail!("max_depth {d} is not in 0..=64");
        }
        Ok(())
    }
}

/// A fresh copy of `pipeline` built again from its names and parameters (each render builds its
/// own terms: a term may keep state for one render).
pub fn rebuild(registry: &Registry, pipeline: &Pipeline) -> Result<Pipeline> {
    let terms = pipeline
        .terms
        .iter()
        .map(|t| {
            registry
                .build_term(&t.name, Some(&t.variant), Params::new(t.params.clone()))
                .with_context(|| format!("building term {}:{}", t.name, t.variant))
        })
        .collect::<Result<Vec<_>>>()?;
    let shadows = registry
        .build_shadow(&pipeline.shadows.name, Params::new(pipeline.shadows.params.clone()))
        .with_context(|| format!("building shadow model {}", pipeline.shadows.name))?;
    Ok(Pipeline::new(pipeline.max_depth, shadows, terms)?)
}

/// `pipeline` (rebuilt) and `image` with `settings` applied in the command line's order.
pub fn apply(
    registry: &Registry,
    pipeline: &Pipeline,
    image: &ImageSettings,
    settings: &Settings,
) -> Result<(Pipeline, ImageSettings)> {
    settings.check()?;
    let mut args = SceneArgs::of(None);
    args.terms = settings.terms.clone();
    args.shadows = settings.shadows.clone();
    args.max_depth = settings.max_depth;
    let (pipeline, _) = change_model(registry, &args, rebuild(registry, pipeline)?)?;
    let mut image = *image;
    resize(&mut image, settings.width, settings.height);
    if let Some(s) = settings.samples {
        // Samples given: every pixel that many, in place of the scene's adaptive sampling.
        image.set_samples(s);
    }
    check_pixels(&image)?;
    Ok((pipeline, image))
}

/// The model as `--stats` names it (`ambient + diffuse + ... (hard shadows, depth 5)`).
pub fn model_name(pipeline: &Pipeline, image: &ImageSettings) -> String {
    crate::stats::effective_model(pipeline, image)
}

/// `--stats-json` of a render of `scene` (its name) that took `elapsed` on `threads` threads.
pub fn stats_json(
    scene: &str,
    image: &ImageSettings,
    pipeline: &Pipeline,
    stats: &RenderStats,
    elapsed: Duration,
    threads: usize,
) -> String {
    crate::stats::Run { scene, image, pipeline, stats, elapsed, threads }.json(&[])
}

/// Writes `frame`'s beauty image to `path`, its format from the extension (PNG, sRGB 8-bit; EXR
/// linear), whole or not at all.
pub fn write_image(path: &Path, frame: &Frame) -> Result<()> {
    let format = crate::output::Format::of(path)?;
    if let Some(folder) = path.parent().filter(|p| !p.as_os_str().is_empty())
        && !folder.is_dir()
    {
        bail!("cannot write {}: there is no folder {}", path.display(), folder.display());
    }
    format.write(path, frame.width, frame.height, &frame.beauty)
}

/// Writes `frame`'s per-term images into `dir` as `--aov DIR` does (EXR and PNG of each, the
/// beauty image and the manifest, made from `stats`: [`stats_json`]'s text).
pub fn write_aov(dir: &Path, frame: &Frame, stats: &str) -> Result<()> {
    if frame.layers.is_empty() {
        bail!("this frame keeps no per-term images");
    }
    let doc: serde_json::Value = serde_json::from_str(stats).context("the frame's statistics")?;
    crate::output::create_output_dir(dir).context("creating the AOV directory")?;
    let manifest = |files: &[String]| {
        let mut doc = doc.clone();
        doc["files"] = serde_json::json!(files);
        serde_json::to_string_pretty(&doc).expect("plain data serialises")
    };
    crate::app::write_aovs(dir, frame, &frame.beauty, crate::app::AovFormat::Both, &manifest)
}

/// `lancer explain --json` of pixel (`x`, `y`) of `document` prepared as `prepared`, rendered
/// with `pipeline` and `image`.
pub fn explain_json(
    document: &Document,
    prepared: &Prepared,
    pipeline: &Pipeline,
    image: &ImageSettings,
    x: u32,
    y: u32,
) -> Result<String> {
    let (w, h) = (image.width, image.height);
    if x >= w || y >= h {
        bail!("pixel {x},{y} is outside the {w}x{h} image (columns 0..{}, rows 0..{})", w - 1, h - 1);
    }
    let objects = lancer_studio::session::object_labels(prepared, &document.places);
    let explanation = lancer_shading::explain_pixel(prepared, &document.scene.camera, image, pipeline, x, y);
    let report = lancer_output::Report {
        scene: &document.name,
        image,
        pipeline,
        explanation: &explanation,
        objects: &objects,
        materials: &document.places.materials,
    };
    Ok(report.json())
}

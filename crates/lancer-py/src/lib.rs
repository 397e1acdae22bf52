//! Lancer for Python (`import lancer`): scenes loaded and edited, rendered to per-term NumPy
//! images with the command line's code (`lancer_cli::embed`), and terms written in Python
//! registered beside the built-in ones. The Python side (`python/lancer/__init__.py`) adds the
//! notebook display.

mod term;
mod views;

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use glam::Vec3;
use lancer_cli::embed::{self, Document, Failure, Settings};
use lancer_core::Frame as CoreFrame;
use lancer_shading::{Prepared, RenderOptions};
use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyString};

create_exception!(
    lancer,
    SceneError,
    PyException,
    "A scene or model file that cannot be loaded: `.file`, `.line`, `.column` (1-based; 0 when the error has no place in the file) and `.message`, as the command line says them."
);

/// The error as Python sees it: a located one as [`SceneError`], anything else as `ValueError`.
fn failure(py: Python<'_>, f: Failure) -> PyErr {
    match f {
        Failure::Located(e) => {
            let err = SceneError::new_err(e.to_string());
            let value = err.value(py);
            let message = e.kind.to_string();
            let _ = value.setattr("file", &e.file);
            let _ = value.setattr("line", e.line);
            let _ = value.setattr("column", e.column);
            let _ = value.setattr("message", message);
            let others: Vec<(String, usize, usize, String)> =
                e.more.iter().map(|m| (m.file.clone(), m.line, m.column, m.kind.to_string())).collect();
            let _ = value.setattr("others", others);
            err
        }
        Failure::Other(e) => {
            let err = SceneError::new_err(format!("{e:#}"));
            let value = err.value(py);
            let _ = value.setattr("file", "");
            let _ = value.setattr("line", 0);
            let _ = value.setattr("column", 0);
            let _ = value.setattr("message", format!("{e:#}"));
            let _ = value.setattr("others", Vec::<(String, usize, usize, String)>::new());
            err
        }
    }
}

fn value_error(e: anyhow::Error) -> PyErr {
    PyValueError::new_err(format!("{e:#}"))
}

/// A loaded scene: its objects, materials, lights, camera and image settings, and its model.
/// Materials, lights, the camera and the image can be edited between renders.
#[pyclass(module = "lancer")]
pub struct Scene {
    doc: Document,
    /// The scene flattened for rendering, made again only when the camera moves (an edited
    /// material or light is taken again from the World).
    prepared: Option<Prepared>,
}

impl Scene {
    fn new(doc: Document) -> Scene {
        Scene { doc, prepared: None }
    }

    /// The prepared scene, the World's edits taken in.
    fn prepared(&mut self) -> PyResult<&Prepared> {
        let fresh = match &mut self.prepared {
            Some(p) => !p.refresh_shading(&self.doc.scene),
            None => true,
        };
        if fresh {
            let prepared = lancer_shading::prepare(&self.doc.scene)
                .map_err(|e| PyValueError::new_err(format!("preparing {}: {e}", self.doc.name)))?;
            self.prepared = Some(prepared);
        }
        Ok(self.prepared.as_ref().expect("just prepared"))
    }
}

/// The `terms` argument: a comma-separated string or a list of entries.
fn term_list(terms: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Vec<String>>> {
    let Some(t) = terms else { return Ok(None) };
    if let Ok(s) = t.cast::<PyString>() {
        let s: String = s.extract()?;
        // Empty entries are kept: the model's parser refuses them with its own message, as
        // `--terms` does.
        return Ok(Some(s.split(',').map(|e| e.trim().to_owned()).collect()));
    }
    let list = t.extract::<Vec<String>>().map_err(|_| {
        PyValueError::new_err("terms: expected a string such as \"ambient,diffuse\" or a list of terms")
    })?;
    if list.is_empty() {
        return Err(PyValueError::new_err("terms: expected at least one term, such as [\"ambient\", \"diffuse\"]"));
    }
    Ok(Some(list))
}

fn u8_depth(d: Option<i64>) -> PyResult<Option<u8>> {
    d.map(|d| u8::try_from(d).map_err(|_| PyValueError::new_err(format!("max_depth {d} is not in 0..=64")))).transpose()
}

fn positive(what: &str, v: Option<i64>) -> PyResult<Option<u32>> {
    v.map(|v| u32::try_from(v).map_err(|_| PyValueError::new_err(format!("{what} {v} is not in 1..=16384"))))
        .transpose()
}

/// The Python-side settings of `render` and `explain`.
#[allow(clippy::too_many_arguments)]
fn settings(
    width: Option<i64>,
    height: Option<i64>,
    samples: Option<i64>,
    terms: Option<&Bound<'_, PyAny>>,
    shadows: Option<String>,
    max_depth: Option<i64>,
) -> PyResult<Settings> {
    Ok(Settings {
        width: positive("width", width)?,
        height: positive("height", height)?,
        samples: positive("samples", samples)?,
        terms: term_list(terms)?,
        shadows,
        max_depth: u8_depth(max_depth)?,
    })
}

/// A float array of `pixels` as (height, width, 3), owning the render's buffer (no copy).
fn image_array<'py>(py: Python<'py>, pixels: Vec<Vec3>, width: u32, height: u32) -> PyResult<Py<PyAny>> {
    let floats: Vec<f32> = bytemuck::allocation::cast_vec(pixels);
    let flat = PyArray1::from_vec(py, floats);
    Ok(flat.reshape([height as usize, width as usize, 3])?.into_any().unbind())
}

/// The pixels of a (height, width, 3) float32 array (copied).
fn pixels_of(py: Python<'_>, array: &Py<PyAny>, width: u32, height: u32) -> PyResult<Vec<Vec3>> {
    let np = py.import("numpy")?;
    let a = np.call_method1("ascontiguousarray", (array.bind(py), "float32"))?;
    let a = a.cast_into::<numpy::PyArray3<f32>>().map_err(|_| PyValueError::new_err("expected a float32 image"))?;
    if a.shape() != [height as usize, width as usize, 3] {
        return Err(PyValueError::new_err(format!(
            "an image of shape {:?}, expected ({height}, {width}, 3)",
            a.shape()
        )));
    }
    let read = a.readonly();
    let flat = read.as_slice()?;
    Ok(flat.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect())
}

#[pymethods]
impl Scene {
    /// The scene's name in messages (its path as given).
    #[getter]
    fn name(&self) -> String {
        self.doc.name.clone()
    }

    /// What loading found to warn about, as the command line prints it.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.doc.warnings.iter().map(|w| w.to_string()).collect()
    }

    /// The scene's model, as `--stats` names it.
    #[getter]
    fn model(&self) -> String {
        embed::model_name(&self.doc.pipeline, &self.doc.scene.image)
    }

    /// The materials by name (`[materials.NAME]`, or `object N` for an object's own).
    #[getter]
    fn materials(slf: Py<Scene>) -> views::Materials {
        views::Materials { scene: slf }
    }

    /// The lights, in the file's order.
    #[getter]
    fn lights(slf: Py<Scene>, py: Python<'_>) -> PyResult<Vec<views::Light>> {
        let n = views::light_entities(&views::scene_ref(&slf, py)?.doc.scene.world).len();
        Ok((0..n).map(|index| views::Light { scene: slf.clone_ref(py), index }).collect())
    }

    /// The camera.
    #[getter]
    fn camera(slf: Py<Scene>) -> views::Camera {
        views::Camera { scene: slf }
    }

    /// The image settings (`[image]`).
    #[getter]
    fn image(slf: Py<Scene>) -> views::Image {
        views::Image { scene: slf }
    }

    /// Renders the scene: the beauty image and one image per term (and the background), as
    /// `lancer render` with the flags of the same names would. The GIL is released meanwhile;
    /// Ctrl-C (a notebook's interrupt) stops the render with `KeyboardInterrupt`.
    #[pyo3(signature = (width=None, height=None, samples=None, terms=None, shadows=None, max_depth=None, threads=None))]
    #[allow(clippy::too_many_arguments)]
    fn render(
        &mut self,
        py: Python<'_>,
        width: Option<i64>,
        height: Option<i64>,
        samples: Option<i64>,
        terms: Option<&Bound<'_, PyAny>>,
        shadows: Option<String>,
        max_depth: Option<i64>,
        threads: Option<i64>,
    ) -> PyResult<Frame> {
        let settings = settings(width, height, samples, terms, shadows, max_depth)?;
        let threads = match threads {
            None => 0,
            Some(t) if (1..=1024).contains(&t) => t as usize,
            Some(t) => return Err(PyValueError::new_err(format!("threads {t} is not in 1..=1024"))),
        };
        let context = Arc::new(term::RenderContext::new(self.doc.scene.camera.origin));
        let (pipeline, image) = term::building(&context, || {
            let registry = term::registry();
            embed::apply(&registry, &self.doc.pipeline, &self.doc.scene.image, &settings)
        })
        .map_err(value_error)?;
        let name = self.doc.name.clone();
        let camera = self.doc.scene.camera;
        let prepared = self.prepared()?;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| PyValueError::new_err(format!("starting worker threads: {e}")))?;
        let started = Instant::now();
        let mut interrupted: Option<PyErr> = None;
        let frame: CoreFrame = std::thread::scope(|s| {
            let worker = s.spawn(|| {
                pool.install(|| {
                    lancer_shading::render_prepared(
                        prepared,
                        &camera,
                        &image,
                        &pipeline,
                        RenderOptions {
                            progress: None,
                            timing: true,
                            part: None,
                            cancel: Some(&context.cancel),
                            layers: true,
                            reference: false,
                            compact: false,
                            scratch: None,
                        },
                    )
                })
            });
            // Waits without the GIL, taking it back every 50 ms to look for Ctrl-C.
            while !worker.is_finished() {
                py.detach(|| {
                    let until = Instant::now() + Duration::from_millis(50);
                    while !worker.is_finished() && Instant::now() < until {
                        std::thread::sleep(Duration::from_millis(1));
                    }
                });
                if interrupted.is_none()
                    && let Err(e) = py.check_signals()
                {
                    context.cancel.store(true, Ordering::Relaxed);
                    interrupted = Some(e);
                }
            }
            worker.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic))
        });
        let elapsed = started.elapsed();
        if let Some(e) = interrupted {
            return Err(e);
        }
        if let Some(e) = context.take_error() {
            return Err(e);
        }
        if context.cancel.load(Ordering::Relaxed) {
            return Err(PyKeyboardInterrupt::new_err("the render was cancelled"));
        }
        let stats = embed::stats_json(&name, &image, &pipeline, &frame.stats, elapsed, pool.current_num_threads());
        Frame::of(py, frame, stats)
    }

    /// What pixel (`x`, `y`) is made of: its rays, their hits and each term's share, as
    /// `lancer explain --json` gives it (the same settings as `render`).
    #[pyo3(signature = (x, y, width=None, height=None, samples=None, terms=None, shadows=None, max_depth=None))]
    #[allow(clippy::too_many_arguments)]
    fn explain(
        &mut self,
        py: Python<'_>,
        x: i64,
        y: i64,
        width: Option<i64>,
        height: Option<i64>,
        samples: Option<i64>,
        terms: Option<&Bound<'_, PyAny>>,
        shadows: Option<String>,
        max_depth: Option<i64>,
    ) -> PyResult<Py<PyAny>> {
        let settings = settings(width, height, samples, terms, shadows, max_depth)?;
        let context = Arc::new(term::RenderContext::new(self.doc.scene.camera.origin));
        let (pipeline, image) = term::building(&context, || {
            let registry = term::registry();
            embed::apply(&registry, &self.doc.pipeline, &self.doc.scene.image, &settings)
        })
        .map_err(value_error)?;
        let (Ok(x), Ok(y)) = (u32::try_from(x), u32::try_from(y)) else {
            return Err(PyValueError::new_err(format!("pixel {x},{y}: expected x and y from 0, inside the image")));
        };
        self.prepared()?;
        let prepared = self.prepared.as_ref().expect("prepared above");
        let json = embed::explain_json(&self.doc, prepared, &pipeline, &image, x, y).map_err(value_error)?;
        if let Some(e) = context.take_error() {
            return Err(e);
        }
        json_value(py, &json)
    }

    fn __repr__(&self) -> String {
        let img = &self.doc.scene.image;
        format!("<lancer.Scene {} {}x{}: {}>", self.doc.name, img.width, img.height, self.model())
    }
}

fn json_value(py: Python<'_>, text: &str) -> PyResult<Py<PyAny>> {
    Ok(py.import("json")?.call_method1("loads", (text,))?.unbind())
}

/// A rendered frame: the beauty image and the per-term images as NumPy float32 arrays of
/// shape (height, width, 3), linear RGB, and the statistics of `--stats-json`.
#[pyclass(module = "lancer")]
pub struct Frame {
    /// The beauty image (the sum of the layers, in layer order).
    #[pyo3(get)]
    beauty: Py<PyAny>,
    names: Vec<String>,
    arrays: Vec<Py<PyAny>>,
    /// Width in pixels.
    #[pyo3(get)]
    width: u32,
    /// Height in pixels.
    #[pyo3(get)]
    height: u32,
    stats_json: String,
    rays: lancer_core::RenderStats,
}

impl Frame {
    fn of(py: Python<'_>, frame: CoreFrame, stats_json: String) -> PyResult<Frame> {
        let (w, h) = (frame.width, frame.height);
        let mut names = Vec::new();
        let mut arrays = Vec::new();
        for layer in frame.layers {
            names.push(layer.name);
            arrays.push(image_array(py, layer.pixels, w, h)?);
        }
        Ok(Frame {
            beauty: image_array(py, frame.beauty, w, h)?,
            names,
            arrays,
            width: w,
            height: h,
            stats_json,
            rays: frame.stats,
        })
    }

    /// The frame as the writers take it, from the arrays as they are now.
    fn core(&self, py: Python<'_>) -> PyResult<CoreFrame> {
        let mut layers = Vec::new();
        for (name, a) in self.names.iter().zip(&self.arrays) {
            layers.push(lancer_core::Layer { name: name.clone(), pixels: pixels_of(py, a, self.width, self.height)? });
        }
        Ok(CoreFrame {
            width: self.width,
            height: self.height,
            layers,
            beauty: pixels_of(py, &self.beauty, self.width, self.height)?,
            stats: self.rays.clone(),
        })
    }
}

#[pymethods]
impl Frame {
    /// The per-term images: term name (and `background`) to a (height, width, 3) array, in
    /// model order; they sum to `beauty`.
    #[getter]
    fn layers<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (n, a) in self.names.iter().zip(&self.arrays) {
            d.set_item(n, a.bind(py))?;
        }
        Ok(d)
    }

    /// The statistics, as `lancer render --stats-json` writes them.
    #[getter]
    fn stats(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        json_value(py, &self.stats_json)
    }

    /// Writes the beauty image to `path`: PNG (sRGB, 8-bit) or EXR (linear float) by its
    /// extension, whole or not at all.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let frame = self.core(py)?;
        py.detach(|| embed::write_image(&path, &frame)).map_err(value_error)
    }

    /// Writes every per-term image into the folder `dir` as `lancer render --aov DIR` does
    /// (EXR and PNG of each term, the beauty image, `manifest.json`).
    fn save_aov(&self, py: Python<'_>, dir: PathBuf) -> PyResult<()> {
        let frame = self.core(py)?;
        let stats = self.stats_json.clone();
        py.detach(|| embed::write_aov(&dir, &frame, &stats)).map_err(value_error)
    }

    /// The PNG bytes (sRGB, 8-bit) of the beauty image, or of the layer `layer`, its values
    /// times `exposure`.
    #[pyo3(signature = (layer=None, exposure=1.0))]
    fn png<'py>(
        &self,
        py: Python<'py>,
        layer: Option<&str>,
        exposure: f32,
    ) -> PyResult<Bound<'py, pyo3::types::PyBytes>> {
        let array = match layer {
            None => &self.beauty,
            Some(name) => match self.names.iter().position(|n| n == name) {
                Some(k) => &self.arrays[k],
                None => {
                    return Err(PyValueError::new_err(format!(
                        "no layer `{name}`; the layers are {}",
                        self.names.join(", ")
                    )));
                }
            },
        };
        let mut pixels = pixels_of(py, array, self.width, self.height)?;
        if exposure != 1.0 {
            pixels.iter_mut().for_each(|p| *p *= exposure);
        }
        let bytes = lancer_cli::output::Format::Png.encode(self.width, self.height, &pixels).map_err(value_error)?;
        Ok(pyo3::types::PyBytes::new(py, &bytes))
    }

    /// The beauty image as PNG, for Jupyter.
    fn _repr_png_<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyBytes>> {
        self.png(py, None, 1.0)
    }

    /// The beauty image and a strip of the per-term images, for Jupyter.
    fn _repr_html_(slf: &Bound<'_, Frame>) -> PyResult<Py<PyAny>> {
        let py = slf.py();
        Ok(py.import("lancer")?.getattr("_frame_html")?.call1((slf,))?.unbind())
    }

    fn __repr__(&self) -> String {
        format!("<lancer.Frame {}x{}: {}>", self.width, self.height, self.names.join(", "))
    }
}

/// Loads the scene file `path` (its meshes and textures relative to its folder), then the
/// model file `model` over its model. Raises `SceneError` with the file, line and column.
#[pyfunction]
#[pyo3(signature = (path, model=None))]
fn load(py: Python<'_>, path: PathBuf, model: Option<PathBuf>) -> PyResult<Scene> {
    let registry = term::registry();
    embed::load_file(&registry, &path, model.as_deref()).map(Scene::new).map_err(|f| failure(py, f))
}

/// Loads a scene from its `text` (named `name` in messages); the files it names are relative
/// to `base_dir`.
#[pyfunction]
#[pyo3(signature = (text, base_dir=PathBuf::from("."), model=None, name="<text>".to_owned()))]
fn loads(py: Python<'_>, text: &str, base_dir: PathBuf, model: Option<PathBuf>, name: String) -> PyResult<Scene> {
    let registry = term::registry();
    embed::load_text(&registry, text, &name, &base_dir, model.as_deref()).map(Scene::new).map_err(|f| failure(py, f))
}

/// The registry: every term variant with its summary and parameters (Python terms too), as
/// `lancer terms` lists them.
#[pyfunction]
fn terms<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
    let registry = term::registry();
    let list = PyList::empty(py);
    for spec in registry.terms() {
        let d = PyDict::new(py);
        d.set_item("name", spec.name)?;
        d.set_item("variant", spec.variant)?;
        d.set_item("summary", spec.summary)?;
        d.set_item("reads", spec.reads.to_vec())?;
        let params = PyList::empty(py);
        for p in spec.params {
            let pd = PyDict::new(py);
            pd.set_item("name", p.name)?;
            pd.set_item("default", p.default)?;
            pd.set_item("doc", p.doc)?;
            params.append(pd)?;
        }
        d.set_item("params", params)?;
        d.set_item("python", spec.variant == term::VARIANT)?;
        list.append(d)?;
    }
    Ok(list)
}

/// The Python module `lancer._lancer`.
#[pymodule]
fn _lancer(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    m.add_class::<Scene>()?;
    m.add_class::<Frame>()?;
    m.add_class::<views::Materials>()?;
    m.add_class::<views::Material>()?;
    m.add_class::<views::Light>()?;
    m.add_class::<views::Camera>()?;
    m.add_class::<views::Image>()?;
    m.add_class::<term::Chunk>()?;
    m.add_class::<term::LightSample>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(loads, m)?)?;
    m.add_function(wrap_pyfunction!(terms, m)?)?;
    m.add_function(wrap_pyfunction!(term::register_term, m)?)?;
    m.add_function(wrap_pyfunction!(term::unregister_term, m)?)?;
    Ok(())
}

//! Terms written in Python: `lancer.register_term(name, fn)` puts a term in the process's
//! registry whose system hands each chunk's hit rays to `fn` as NumPy arrays and adds the
//! (N, 3) colours it returns, lane by lane, to its own image.

use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, LazyLock, Mutex, MutexGuard};

use glam::{DVec3, Vec3};
use lancer_shading::{
    Chunk as TermChunk, ParamError, ParamSpec, Params, Registry, ShadeContext, Term, TermOutput, TermSpec,
};
use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The variant every Python term is registered as.
pub const VARIANT: &str = "python";

/// What one render shares with its Python terms: the flag that stops it, the first error a
/// term raised, and the prepared frame's origin (terms see world-space points).
pub struct RenderContext {
    /// Set to stop the render (a term failed, or Ctrl-C).
    pub cancel: AtomicBool,
    error: Mutex<Option<PyErr>>,
    origin: DVec3,
}

impl RenderContext {
    /// A context for a render whose prepared frame starts at `origin`.
    pub fn new(origin: DVec3) -> RenderContext {
        RenderContext { cancel: AtomicBool::new(false), error: Mutex::new(None), origin }
    }

    /// The first error a term raised, if any.
    pub fn take_error(&self) -> Option<PyErr> {
        self.error.lock().ok().and_then(|mut e| e.take())
    }

    fn fail(&self, e: PyErr) {
        if let Ok(mut slot) = self.error.lock()
            && slot.is_none()
        {
            *slot = Some(e);
        }
        self.cancel.store(true, Ordering::Relaxed);
    }
}

thread_local! {
    /// The context Python terms built on this thread belong to (set while a render's model is
    /// built).
    static BUILDING: RefCell<Option<Arc<RenderContext>>> = const { RefCell::new(None) };
}

/// Runs `f` (which builds a render's model) with `context` given to the Python terms it builds.
pub fn building<T>(context: &Arc<RenderContext>, f: impl FnOnce() -> T) -> T {
    BUILDING.with(|b| *b.borrow_mut() = Some(context.clone()));
    let out = f();
    BUILDING.with(|b| *b.borrow_mut() = None);
    out
}

/// A registered Python term.
struct Slot {
    name: &'static str,
    func: Py<PyAny>,
    reads_lights: bool,
    params: Vec<(String, f64)>,
    spec: TermSpec,
    /// Not unregistered.
    active: bool,
}

/// How many Python terms a process can hold (each slot is a builder function of its own: the
/// registry takes plain function pointers).
const SLOTS: usize = 64;

static PY_TERMS: Mutex<Vec<Slot>> = Mutex::new(Vec::new());

/// The built-in terms and the Python ones.
static REGISTRY: LazyLock<Mutex<Registry>> = LazyLock::new(|| Mutex::new(Registry::with_builtins()));

/// The process's registry.
pub fn registry() -> MutexGuard<'static, Registry> {
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner())
}

fn py_terms() -> MutexGuard<'static, Vec<Slot>> {
    PY_TERMS.lock().unwrap_or_else(|e| e.into_inner())
}

/// The builder of slot `N`.
fn build_slot<const N: usize>(params: &mut Params) -> Result<Box<dyn Term>, ParamError> {
    build(N, params)
}

/// What the registry calls to build a slot's term from a model's parameters.
type Builder = fn(&mut Params) -> Result<Box<dyn Term>, ParamError>;

macro_rules! slots {
    ($($n:literal)*) => { [$(build_slot::<$n> as Builder),*] };
}

const BUILDERS: [Builder; SLOTS] = slots!(
    0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31
    32 33 34 35 36 37 38 39 40 41 42 43 44 45 46 47 48 49 50 51 52 53 54 55 56 57 58 59 60 61 62 63
);

fn build(slot: usize, params: &mut Params) -> Result<Box<dyn Term>, ParamError> {
    let context = BUILDING.with(|b| b.borrow().clone()).unwrap_or_else(|| Arc::new(RenderContext::new(DVec3::ZERO)));
    let terms = py_terms();
    let s = &terms[slot];
    let mut values = Vec::with_capacity(s.params.len());
    for (name, default) in &s.params {
        values.push((name.clone(), params.number(name, *default, -f64::MAX, f64::MAX)?));
    }
    let func = Python::attach(|py| s.func.clone_ref(py));
    Ok(Box::new(PyTerm { name: s.name, func, reads_lights: s.reads_lights, params: values, context }))
}

/// Rebuilds `into`: the built-in terms, then every Python term of `terms`. (Locks are taken
/// registry first, then the Python terms, everywhere: a model is built with the registry locked.)
fn rebuild<'a>(into: &mut Registry, terms: impl IntoIterator<Item = &'a Slot>) -> Result<(), String> {
    let mut registry = Registry::with_builtins();
    for s in terms.into_iter().filter(|s| s.active) {
        registry.register_term(s.spec).map_err(|e| e.to_string())?;
    }
    *into = registry;
    Ok(())
}

/// Registers `fn` as the term `name` (variant `python`): called once per chunk of hit rays
/// with a `lancer.Chunk`, it returns the (N, 3) colours to add. `reads_lights=False` says it
/// does not look at `chunk.lights` (no shadow rays are traced for it). `params` maps parameter
/// names to defaults (numbers), given in a model as `name:key=value` and read as
/// `chunk.params`. Registering a name again replaces the function.
#[pyfunction]
#[pyo3(signature = (name, r#fn, reads_lights=true, params=None))]
pub fn register_term(
    name: &str,
    r#fn: &Bound<'_, PyAny>,
    reads_lights: bool,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<()> {
    if !r#fn.is_callable() {
        return Err(PyTypeError::new_err("register_term: fn must be callable, fn(chunk) -> (N, 3) array"));
    }
    let builtins = Registry::with_builtins();
    if builtins.terms().iter().chain(builtins.mistakes()).any(|t| t.name == name) {
        return Err(PyValueError::new_err(format!("`{name}` is a built-in term; give yours another name")));
    }
    let mut values = Vec::new();
    if let Some(p) = params {
        for (k, v) in p.iter() {
            let key: String = k.extract().map_err(|_| PyTypeError::new_err("params: names must be strings"))?;
            let value: f64 = v
                .extract()
                .map_err(|_| PyTypeError::new_err(format!("params: the default of `{key}` must be a number")))?;
            if key == "weight" || !value.is_finite() {
                return Err(PyValueError::new_err(format!(
                    "params: `{key}` = {value}: expected a finite default and a name other than `weight` (every term's own)"
                )));
            }
            values.push((key, value));
        }
    }
    // Python code (an attribute lookup here, a replaced function's `__del__` below) runs only
    // while the registry's locks are not held, so another thread it lets in cannot wait on them.
    let what = r#fn.getattr("__qualname__").and_then(|q| q.extract::<String>()).unwrap_or_else(|_| "a function".into());
    let mut registry = registry();
    let mut terms = py_terms();
    let index = terms.iter().position(|s| s.name == name).unwrap_or(terms.len());
    if index >= SLOTS {
        return Err(PyValueError::new_err(format!("at most {SLOTS} Python terms can be registered")));
    }
    let leak = |s: String| -> &'static str { Box::leak(s.into_boxed_str()) };
    let static_name = match terms.get(index) {
        Some(s) => s.name,
        None => leak(name.to_owned()),
    };
    let specs: Vec<ParamSpec> = values
        .iter()
        .map(|(k, v)| ParamSpec {
            name: leak(k.clone()),
            default: leak(format!("{v}")),
            doc: "a parameter of the Python term",
        })
        .collect();
    let spec = TermSpec {
        name: static_name,
        variant: VARIANT,
        summary: leak(format!("written in Python: {what}")),
        reads: &[],
        params: Box::leak(specs.into_boxed_slice()),
        build: BUILDERS[index],
        mistake: None,
    };
    let slot =
        Slot { name: static_name, func: r#fn.clone().unbind(), reads_lights, params: values, spec, active: true };
    let old = if index < terms.len() {
        Some(std::mem::replace(&mut terms[index], slot))
    } else {
        terms.push(slot);
        None
    };
    if let Err(e) = rebuild(&mut registry, terms.iter()) {
        match old {
            Some(o) => terms[index] = o,
            None => {
                terms.pop();
            }
        }
        return Err(PyValueError::new_err(format!("register_term: {e}")));
    }
    drop(terms);
    drop(registry);
    drop(old);
    Ok(())
}

/// Removes the Python term `name` from the registry (its slot stays reserved for it).
#[pyfunction]
pub fn unregister_term(name: &str) -> PyResult<()> {
    let mut registry = registry();
    let mut terms = py_terms();
    let Some(slot) = terms.iter_mut().find(|s| s.name == name && s.active) else {
        return Err(PyValueError::new_err(format!("no Python term `{name}` is registered")));
    };
    slot.active = false;
    rebuild(&mut registry, terms.iter()).map_err(PyValueError::new_err)
}

struct PyTerm {
    name: &'static str,
    func: Py<PyAny>,
    reads_lights: bool,
    params: Vec<(String, f64)>,
    context: Arc<RenderContext>,
}

/// One light's share at a chunk's hits, as a Python term sees it.
#[pyclass(module = "lancer", frozen)]
pub struct LightSample {
    /// (N, 3): the unit direction from each hit towards the light.
    #[pyo3(get)]
    w: Py<PyAny>,
    /// (N,): `N·w`, the facing normal's cosine with `w`.
    #[pyo3(get)]
    n_dot_w: Py<PyAny>,
    /// (N, 3): the light's colour times its intensity times the shadow model's transmittance
    /// (zero where it is hidden or behind the surface).
    #[pyo3(get)]
    incoming: Py<PyAny>,
}

/// A chunk's hit rays, as a Python term gets them: one row per hit.
#[pyclass(module = "lancer", frozen)]
pub struct Chunk {
    /// (N, 3): the shading normal, facing the ray.
    #[pyo3(get)]
    normal: Py<PyAny>,
    /// (N, 3): the ray's unit direction `u`.
    #[pyo3(get)]
    dir: Py<PyAny>,
    /// (N, 3): the hit point, in world space.
    #[pyo3(get)]
    point: Py<PyAny>,
    /// (N, 3): `Col_Ω`, the surface colour there.
    #[pyo3(get)]
    color: Py<PyAny>,
    /// (N,) each: the material's parameters.
    #[pyo3(get)]
    ambi: Py<PyAny>,
    #[pyo3(get)]
    diff: Py<PyAny>,
    #[pyo3(get)]
    spec: Py<PyAny>,
    #[pyo3(get)]
    shine: Py<PyAny>,
    #[pyo3(get)]
    alpha: Py<PyAny>,
    #[pyo3(get)]
    n: Py<PyAny>,
    /// (N,): how deep each ray is (0 for camera rays).
    #[pyo3(get)]
    depth: Py<PyAny>,
    /// One entry per light, in scene order (empty for a term registered with
    /// `reads_lights=False`).
    #[pyo3(get)]
    lights: Vec<Py<LightSample>>,
    /// The term's parameters, as the model gives them.
    #[pyo3(get)]
    params: Py<PyDict>,
    len: usize,
}

#[pymethods]
impl Chunk {
    fn __len__(&self) -> usize {
        self.len
    }

    fn __repr__(&self) -> String {
        format!("<lancer.Chunk of {} hits, {} lights>", self.len, self.lights.len())
    }
}

fn vectors<'py>(py: Python<'py>, v: impl Iterator<Item = Vec3>, n: usize) -> PyResult<Py<PyAny>> {
    let mut flat = Vec::with_capacity(3 * n);
    v.for_each(|x| flat.extend_from_slice(&x.to_array()));
    Ok(PyArray1::from_vec(py, flat).reshape([n, 3])?.into_any().unbind())
}

fn scalars(py: Python<'_>, v: impl Iterator<Item = f32>) -> Py<PyAny> {
    PyArray1::from_iter(py, v).into_any().unbind()
}

impl PyTerm {
    fn call(
        &self,
        py: Python<'_>,
        ctx: &ShadeContext<'_>,
        chunk: TermChunk<'_>,
        lanes: &[usize],
    ) -> PyResult<Vec<Vec3>> {
        let n = lanes.len();
        let hits = chunk.hits;
        let normals: Vec<Vec3> = lanes.iter().map(|&l| hits.facing_normal(l)).collect();
        let origin = self.context.origin;
        let m = |l: usize| ctx.material(hits, l);
        let mut lights = Vec::new();
        if self.reads_lights {
            for k in 0..chunk.lights.lights {
                let w: Vec<Vec3> = lanes.iter().map(|&l| chunk.lights.w[k].at(l)).collect();
                let sample = LightSample {
                    n_dot_w: scalars(py, w.iter().zip(&normals).map(|(w, n)| n.dot(*w))),
                    w: vectors(py, w.into_iter(), n)?,
                    incoming: vectors(py, lanes.iter().map(|&l| chunk.lights.incoming[k].at(l)), n)?,
                };
                lights.push(Py::new(py, sample)?);
            }
        }
        let params = PyDict::new(py);
        for (k, v) in &self.params {
            params.set_item(k, v)?;
        }
        let c = Chunk {
            normal: vectors(py, normals.iter().copied(), n)?,
            dir: vectors(py, lanes.iter().map(|&l| chunk.rays.dir.at(l)), n)?,
            point: vectors(py, lanes.iter().map(|&l| (origin + hits.point.at(l).as_dvec3()).as_vec3()), n)?,
            color: vectors(py, lanes.iter().map(|&l| ctx.color(hits, l)), n)?,
            ambi: scalars(py, lanes.iter().map(|&l| m(l).ambi)),
            diff: scalars(py, lanes.iter().map(|&l| m(l).diff)),
            spec: scalars(py, lanes.iter().map(|&l| m(l).spec)),
            shine: scalars(py, lanes.iter().map(|&l| m(l).shine)),
            alpha: scalars(py, lanes.iter().map(|&l| m(l).alpha)),
            n: scalars(py, lanes.iter().map(|&l| m(l).n)),
            depth: scalars(py, lanes.iter().map(|&l| chunk.rays.depth[l] as f32)),
            lights,
            params: params.unbind(),
            len: n,
        };
        let out = self.func.bind(py).call1((c,))?;
        let np = py.import("numpy")?;
        let array = np.call_method1("ascontiguousarray", (out, "float32")).map_err(|e| {
            PyTypeError::new_err(format!(
                "term `{}` returned something that is not an array of numbers: {e}",
                self.name
            ))
        })?;
        let array = array.cast_into::<numpy::PyArray2<f32>>().map_err(|_| {
            PyValueError::new_err(format!("term `{}` must return an array of shape ({n}, 3)", self.name))
        })?;
        if array.shape() != [n, 3] {
            return Err(PyValueError::new_err(format!(
                "term `{}` returned an array of shape ({}); expected ({n}, 3), one colour per hit",
                self.name,
                array.shape().iter().map(|d| d.to_string()).collect::<Vec<_>>().join(", ")
            )));
        }
        let read = array.readonly();
        let flat = read.as_slice()?;
        let colours: Vec<Vec3> = flat.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
        if let Some(i) = colours.iter().position(|c| !c.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "term `{}` returned {:?} for hit {i}: every colour must be finite",
                self.name, colours[i]
            )));
        }
        Ok(colours)
    }
}

impl Term for PyTerm {
    fn run(&self, ctx: &ShadeContext<'_>, chunk: TermChunk<'_>, out: &mut TermOutput<'_>) {
        if self.context.cancel.load(Ordering::Relaxed) {
            return;
        }
        let lanes: Vec<usize> = chunk.hit_lanes().collect();
        if lanes.is_empty() {
            return;
        }
        match Python::attach(|py| self.call(py, ctx, chunk, &lanes)) {
            Ok(colours) => {
                for (&lane, colour) in lanes.iter().zip(colours) {
                    out.add(lane, colour);
                }
            }
            Err(e) => self.context.fail(e),
        }
    }

    fn reads_lights(&self, _: &lancer_core::Material) -> bool {
        self.reads_lights
    }
}

//! The editable parts of a loaded scene as Python objects: `scene.materials["glass"].shine`,
//! `scene.lights[0].intensity`, `scene.camera.fov`, `scene.image.width`. Each reads and writes
//! the scene's World, checked as the scene file's values are.

use glam::{DVec3, Vec3};
use lancer_core::{Camera as CoreCamera, Light as CoreLight, Material as CoreMaterial, Position};
use pyo3::exceptions::{PyIndexError, PyKeyError, PyValueError};
use pyo3::prelude::*;

use crate::Scene;

/// The error of a scene read or changed while it renders (from a Python term or another thread).
fn busy<E>(_: E) -> PyErr {
    pyo3::exceptions::PyRuntimeError::new_err("the scene is rendering: read or change it after `render` returns")
}

/// The scene, to read: `RuntimeError` while it renders (its render holds it mutably).
pub(crate) fn scene_ref<'py>(scene: &'py Py<Scene>, py: Python<'py>) -> PyResult<PyRef<'py, Scene>> {
    scene.try_borrow(py).map_err(busy)
}

/// The scene, to change: `RuntimeError` while it renders.
fn scene_mut<'py>(scene: &'py Py<Scene>, py: Python<'py>) -> PyResult<PyRefMut<'py, Scene>> {
    scene.try_borrow_mut(py).map_err(busy)
}

/// The material entities in the prepared table's order (the order of `Places::materials`).
fn material_entities(world: &hecs::World) -> Vec<hecs::Entity> {
    let mut e: Vec<hecs::Entity> = world.query::<(hecs::Entity, &CoreMaterial)>().iter().map(|(e, _)| e).collect();
    e.sort_by_key(|e| e.id());
    e
}

/// The light entities in scene order.
pub(crate) fn light_entities(world: &hecs::World) -> Vec<hecs::Entity> {
    let mut e: Vec<hecs::Entity> = world.query::<(hecs::Entity, &CoreLight)>().iter().map(|(e, _)| e).collect();
    e.sort_by_key(|e| e.id());
    e
}

fn in_range(what: &str, v: f64, lo: f64, hi: f64) -> PyResult<f32> {
    if (lo..=hi).contains(&v) {
        Ok(v as f32)
    } else {
        Err(PyValueError::new_err(format!("{what}: expected a number in [{lo}, {hi}], found {v}")))
    }
}

fn colour(what: &str, c: [f64; 3]) -> PyResult<Vec3> {
    let hi = lancer_scene::MAX_CHANNEL as f64;
    if c.iter().any(|x| !(0.0..=hi).contains(x)) {
        return Err(PyValueError::new_err(format!(
            "{what}: expected a colour (r, g, b) with channels in [0, {hi}] (the handout's are in [0, 1])"
        )));
    }
    Ok(Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32))
}

fn finite_point(what: &str, p: [f64; 3]) -> PyResult<DVec3> {
    let p = DVec3::from(p);
    if !p.is_finite() || p.abs().max_element() > 1e9 {
        return Err(PyValueError::new_err(format!("{what}: expected a finite point within 1e9 of the origin")));
    }
    Ok(p)
}

/// `scene.materials`: the scene's materials by name.
#[pyclass(module = "lancer")]
pub struct Materials {
    pub(crate) scene: Py<Scene>,
}

#[pymethods]
impl Materials {
    fn __getitem__(&self, py: Python<'_>, name: &str) -> PyResult<Material> {
        let s = scene_ref(&self.scene, py)?;
        match s.doc.places.materials.iter().position(|n| n == name) {
            Some(index) => Ok(Material { scene: self.scene.clone_ref(py), index }),
            None => Err(PyKeyError::new_err(format!(
                "no material `{name}`; the scene's materials are {}",
                s.doc.places.materials.join(", ")
            ))),
        }
    }

    fn __len__(&self, py: Python<'_>) -> PyResult<usize> {
        Ok(scene_ref(&self.scene, py)?.doc.places.materials.len())
    }

    fn __contains__(&self, py: Python<'_>, name: &str) -> PyResult<bool> {
        Ok(scene_ref(&self.scene, py)?.doc.places.materials.iter().any(|n| n == name))
    }

    /// The materials' names, in the file's order.
    fn keys(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        Ok(scene_ref(&self.scene, py)?.doc.places.materials.clone())
    }

    fn __iter__(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let keys = self.keys(py)?;
        Ok(pyo3::types::PyList::new(py, keys)?.call_method0("__iter__")?.unbind())
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!("<lancer.Materials {}>", self.keys(py)?.join(", ")))
    }
}

/// One material: `ambi diff spec shine alpha n` and `color`.
#[pyclass(module = "lancer")]
pub struct Material {
    scene: Py<Scene>,
    index: usize,
}

impl Material {
    fn read(&self, py: Python<'_>) -> PyResult<CoreMaterial> {
        let s = scene_ref(&self.scene, py)?;
        let e = material_entities(&s.doc.scene.world)[self.index];
        Ok(*s.doc.scene.world.get::<&CoreMaterial>(e).map_err(|_| PyValueError::new_err("the material is gone"))?)
    }

    fn write(&self, py: Python<'_>, f: impl FnOnce(&mut CoreMaterial)) -> PyResult<()> {
        let s = scene_mut(&self.scene, py)?;
        let e = material_entities(&s.doc.scene.world)[self.index];
        let mut m =
            s.doc.scene.world.get::<&mut CoreMaterial>(e).map_err(|_| PyValueError::new_err("the material is gone"))?;
        f(&mut m);
        Ok(())
    }
}

#[pymethods]
impl Material {
    /// The ambient fraction.
    #[getter]
    fn ambi(&self, py: Python<'_>) -> PyResult<f32> {
        Ok(self.read(py)?.ambi)
    }

    #[setter]
    fn set_ambi(&self, py: Python<'_>, v: f64) -> PyResult<()> {
        let v = in_range("ambi", v, 0.0, 1.0)?;
        self.write(py, |m| m.ambi = v)
    }

    /// The diffuse (Lambert) weight.
    #[getter]
    fn diff(&self, py: Python<'_>) -> PyResult<f32> {
        Ok(self.read(py)?.diff)
    }

    #[setter]
    fn set_diff(&self, py: Python<'_>, v: f64) -> PyResult<()> {
        let v = in_range("diff", v, 0.0, 1.0)?;
        self.write(py, |m| m.diff = v)
    }

    /// The specular weight (highlight and mirror).
    #[getter]
    fn spec(&self, py: Python<'_>) -> PyResult<f32> {
        Ok(self.read(py)?.spec)
    }

    #[setter]
    fn set_spec(&self, py: Python<'_>, v: f64) -> PyResult<()> {
        let v = in_range("spec", v, 0.0, 1.0)?;
        self.write(py, |m| m.spec = v)
    }

    /// Glossiness: the highlight exponent is 1 / (1 − shine).
    #[getter]
    fn shine(&self, py: Python<'_>) -> PyResult<f32> {
        Ok(self.read(py)?.shine)
    }

    #[setter]
    fn set_shine(&self, py: Python<'_>, v: f64) -> PyResult<()> {
        let v = in_range("shine", v, 0.0, 1.0)?;
        self.write(py, |m| m.shine = v)
    }

    /// The transparency weight.
    #[getter]
    fn alpha(&self, py: Python<'_>) -> PyResult<f32> {
        Ok(self.read(py)?.alpha)
    }

    #[setter]
    fn set_alpha(&self, py: Python<'_>, v: f64) -> PyResult<()> {
        let v = in_range("alpha", v, 0.0, 1.0)?;
        self.write(py, |m| m.alpha = v)
    }

    /// The refractive index.
    #[getter]
    fn n(&self, py: Python<'_>) -> PyResult<f32> {
        Ok(self.read(py)?.n)
    }

    #[setter]
    fn set_n(&self, py: Python<'_>, v: f64) -> PyResult<()> {
        let v = in_range("n", v, 1.0, 2.5)?;
        self.write(py, |m| m.n = v)
    }

    /// `Col_Ω`, linear RGB (a pattern's first colour).
    #[getter]
    fn color(&self, py: Python<'_>) -> PyResult<(f32, f32, f32)> {
        let c = self.read(py)?.color;
        Ok((c.x, c.y, c.z))
    }

    #[setter]
    fn set_color(&self, py: Python<'_>, c: [f64; 3]) -> PyResult<()> {
        let c = colour("color", c)?;
        self.write(py, |m| m.color = c)
    }

    /// The material's name in the file.
    #[getter]
    fn name(&self, py: Python<'_>) -> PyResult<String> {
        Ok(scene_ref(&self.scene, py)?.doc.places.materials[self.index].clone())
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let m = self.read(py)?;
        Ok(format!(
            "<lancer.Material {}: color={:?} ambi={} diff={} spec={} shine={} alpha={} n={}>",
            self.name(py)?,
            m.color.to_array(),
            m.ambi,
            m.diff,
            m.spec,
            m.shine,
            m.alpha,
            m.n
        ))
    }
}

/// One light: `at`, `color`, `intensity`, `size`.
#[pyclass(module = "lancer")]
pub struct Light {
    pub(crate) scene: Py<Scene>,
    pub(crate) index: usize,
}

impl Light {
    fn entity(&self, py: Python<'_>) -> PyResult<hecs::Entity> {
        let s = scene_ref(&self.scene, py)?;
        light_entities(&s.doc.scene.world)
            .get(self.index)
            .copied()
            .ok_or_else(|| PyIndexError::new_err("no such light"))
    }

    fn read(&self, py: Python<'_>) -> PyResult<(CoreLight, DVec3)> {
        let e = self.entity(py)?;
        let s = scene_ref(&self.scene, py)?;
        let world = &s.doc.scene.world;
        let l = *world.get::<&CoreLight>(e).map_err(|_| PyIndexError::new_err("no such light"))?;
        let at = world.get::<&Position>(e).map(|p| p.0).unwrap_or(l.at.as_dvec3());
        Ok((l, at))
    }

    fn write(&self, py: Python<'_>, f: impl FnOnce(&mut CoreLight)) -> PyResult<()> {
        let e = self.entity(py)?;
        let s = scene_mut(&self.scene, py)?;
        let mut l = s.doc.scene.world.get::<&mut CoreLight>(e).map_err(|_| PyIndexError::new_err("no such light"))?;
        f(&mut l);
        Ok(())
    }
}

#[pymethods]
impl Light {
    /// The position, in world space.
    #[getter]
    fn at(&self, py: Python<'_>) -> PyResult<(f64, f64, f64)> {
        let (_, at) = self.read(py)?;
        Ok((at.x, at.y, at.z))
    }

    #[setter]
    fn set_at(&self, py: Python<'_>, p: [f64; 3]) -> PyResult<()> {
        let p = finite_point("at", p)?;
        let e = self.entity(py)?;
        {
            let mut s = scene_mut(&self.scene, py)?;
            let world = &mut s.doc.scene.world;
            if let Ok(mut l) = world.get::<&mut CoreLight>(e) {
                l.at = p.as_vec3();
            }
            world.insert_one(e, Position(p)).map_err(|_| PyIndexError::new_err("no such light"))?;
        }
        Ok(())
    }

    /// `Col_L` before intensity, linear RGB.
    #[getter]
    fn color(&self, py: Python<'_>) -> PyResult<(f32, f32, f32)> {
        let c = self.read(py)?.0.color;
        Ok((c.x, c.y, c.z))
    }

    #[setter]
    fn set_color(&self, py: Python<'_>, c: [f64; 3]) -> PyResult<()> {
        let c = colour("color", c)?;
        self.write(py, |l| l.color = c)
    }

    /// Scales `color`.
    #[getter]
    fn intensity(&self, py: Python<'_>) -> PyResult<f32> {
        Ok(self.read(py)?.0.intensity)
    }

    #[setter]
    fn set_intensity(&self, py: Python<'_>, v: f64) -> PyResult<()> {
        let v = in_range("intensity", v, 0.0, lancer_scene::MAX_LIGHT as f64)?;
        self.write(py, |l| l.intensity = v)
    }

    /// The side of a square area light (0 for a point light).
    #[getter]
    fn size(&self, py: Python<'_>) -> PyResult<f32> {
        Ok(self.read(py)?.0.size)
    }

    #[setter]
    fn set_size(&self, py: Python<'_>, v: f64) -> PyResult<()> {
        let v = in_range("size", v, 0.0, lancer_scene::MAX_LIGHT as f64)?;
        self.write(py, |l| l.size = v)
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let (l, at) = self.read(py)?;
        Ok(format!(
            "<lancer.Light {}: at={:?} color={:?} intensity={} size={}>",
            self.index,
            at.to_array(),
            l.color.to_array(),
            l.intensity,
            l.size
        ))
    }
}

/// The camera: `position`, `look_at`, `up`, `fov` (degrees, vertical).
#[pyclass(module = "lancer")]
pub struct Camera {
    pub(crate) scene: Py<Scene>,
}

impl Camera {
    fn get(&self, py: Python<'_>) -> PyResult<CoreCamera> {
        Ok(scene_ref(&self.scene, py)?.doc.scene.camera)
    }

    fn fov_of(c: &CoreCamera) -> f32 {
        (2.0 * c.tan_half_fov.atan()).to_degrees()
    }

    fn set(&self, py: Python<'_>, from: DVec3, to: DVec3, up: Vec3, fov: f32) -> PyResult<()> {
        let c = CoreCamera::look_at(from, to, up, fov).map_err(|e| {
            PyValueError::new_err(format!("bad camera: {e:?} (from {from}, to {to}, up {up}, fov {fov})"))
        })?;
        scene_mut(&self.scene, py)?.doc.scene.camera = c;
        Ok(())
    }
}

#[pymethods]
impl Camera {
    /// The eye's position, in world space.
    #[getter]
    fn position(&self, py: Python<'_>) -> PyResult<(f64, f64, f64)> {
        let c = self.get(py)?;
        Ok((c.origin.x, c.origin.y, c.origin.z))
    }

    /// Moves the eye, keeping the viewing direction.
    #[setter]
    fn set_position(&self, py: Python<'_>, p: [f64; 3]) -> PyResult<()> {
        let p = finite_point("position", p)?;
        scene_mut(&self.scene, py)?.doc.scene.camera.origin = p;
        Ok(())
    }

    /// A point the camera looks at (the eye plus the viewing direction).
    #[getter]
    fn look_at(&self, py: Python<'_>) -> PyResult<(f64, f64, f64)> {
        let c = self.get(py)?;
        let to = c.origin + c.forward.as_dvec3();
        Ok((to.x, to.y, to.z))
    }

    /// Turns the camera to look at this point (its up direction and field of view kept).
    #[setter]
    fn set_look_at(&self, py: Python<'_>, to: [f64; 3]) -> PyResult<()> {
        let to = finite_point("look_at", to)?;
        let c = self.get(py)?;
        self.set(py, c.origin, to, c.up, Self::fov_of(&c))
    }

    /// The image's up direction.
    #[getter]
    fn up(&self, py: Python<'_>) -> PyResult<(f32, f32, f32)> {
        let c = self.get(py)?;
        Ok((c.up.x, c.up.y, c.up.z))
    }

    #[setter]
    fn set_up(&self, py: Python<'_>, up: [f64; 3]) -> PyResult<()> {
        let c = self.get(py)?;
        let up = DVec3::from(up).as_vec3();
        self.set(py, c.origin, c.origin + c.forward.as_dvec3(), up, Self::fov_of(&c))
    }

    /// The vertical field of view, in degrees.
    #[getter]
    fn fov(&self, py: Python<'_>) -> PyResult<f32> {
        Ok(Self::fov_of(&self.get(py)?))
    }

    #[setter]
    fn set_fov(&self, py: Python<'_>, fov: f64) -> PyResult<()> {
        if !(fov > 0.0 && fov < 180.0) {
            return Err(PyValueError::new_err(format!(
                "fov: expected degrees strictly between 0 and 180, found {fov}"
            )));
        }
        let mut s = scene_mut(&self.scene, py)?;
        s.doc.scene.camera.tan_half_fov = (fov.to_radians() / 2.0).tan() as f32;
        Ok(())
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!(
            "<lancer.Camera at {:?} looking at {:?}, fov {}>",
            self.position(py)?,
            self.look_at(py)?,
            self.fov(py)?
        ))
    }
}

/// The image settings: `width`, `height`, `samples`, `background`.
#[pyclass(module = "lancer")]
pub struct Image {
    pub(crate) scene: Py<Scene>,
}

fn side(what: &str, v: i64, hi: i64) -> PyResult<u32> {
    if (1..=hi).contains(&v) {
        Ok(v as u32)
    } else {
        Err(PyValueError::new_err(format!("{what}: expected a whole number in [1, {hi}], found {v}")))
    }
}

#[pymethods]
impl Image {
    #[getter]
    fn width(&self, py: Python<'_>) -> PyResult<u32> {
        Ok(scene_ref(&self.scene, py)?.doc.scene.image.width)
    }

    #[setter]
    fn set_width(&self, py: Python<'_>, v: i64) -> PyResult<()> {
        let v = side("width", v, 16384)?;
        scene_mut(&self.scene, py)?.doc.scene.image.width = v;
        Ok(())
    }

    #[getter]
    fn height(&self, py: Python<'_>) -> PyResult<u32> {
        Ok(scene_ref(&self.scene, py)?.doc.scene.image.height)
    }

    #[setter]
    fn set_height(&self, py: Python<'_>, v: i64) -> PyResult<()> {
        let v = side("height", v, 16384)?;
        scene_mut(&self.scene, py)?.doc.scene.image.height = v;
        Ok(())
    }

    /// Samples per pixel.
    #[getter]
    fn samples(&self, py: Python<'_>) -> PyResult<u32> {
        Ok(scene_ref(&self.scene, py)?.doc.scene.image.samples)
    }

    #[setter]
    fn set_samples(&self, py: Python<'_>, v: i64) -> PyResult<()> {
        let v = side("samples", v, 4096)?;
        // Every pixel that many: the scene's adaptive anti-aliasing, if it had it, is off.
        scene_mut(&self.scene, py)?.doc.scene.image.set_samples(v);
        Ok(())
    }

    /// The scene's adaptive anti-aliasing as `(threshold, depth)`, or `None`; setting
    /// `samples` turns it off.
    #[getter]
    fn adaptive(&self, py: Python<'_>) -> PyResult<Option<(f32, u32)>> {
        Ok(scene_ref(&self.scene, py)?.doc.scene.image.adaptive.map(|a| (a.threshold, a.depth)))
    }

    /// What rays that hit nothing see, linear RGB.
    #[getter]
    fn background(&self, py: Python<'_>) -> PyResult<(f32, f32, f32)> {
        let b = scene_ref(&self.scene, py)?.doc.scene.image.background;
        Ok((b.x, b.y, b.z))
    }

    #[setter]
    fn set_background(&self, py: Python<'_>, c: [f64; 3]) -> PyResult<()> {
        let c = colour("background", c)?;
        scene_mut(&self.scene, py)?.doc.scene.image.background = c;
        Ok(())
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let samples = match self.adaptive(py)? {
            Some((threshold, depth)) => format!("adaptive samples (threshold {threshold}, depth {depth})"),
            None => format!("{} samples", self.samples(py)?),
        };
        Ok(format!(
            "<lancer.Image {}x{}, {samples}, background {:?}>",
            self.width(py)?,
            self.height(py)?,
            self.background(py)?
        ))
    }
}

//! A scene loaded for the page, with no file, thread or clock of its own (what the browser build
//! runs in each Web Worker): loaded from its text and the bytes of the files it names, it
//! answers the page's hello, renders any state as a whole frame or a part of one, explains a
//! pixel and writes the edits back into its text.

use lancer_core::{Camera, Frame, ImageSettings};
use lancer_scene::{Limits, Resolver};
use lancer_shading::{Prepared, Registry, RenderOptions};
use serde::Serialize;
use serde_json::{Value, json};

use crate::State;

/// Why a scene did not load: where (when the error has a place in the file) and the whole
/// message as the command line prints it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct SceneError {
    /// The file the error is in, as the page named it (the scene, or a mesh it names).
    pub file: String,
    /// 1-based line, 0 when the error has no place.
    pub line: usize,
    /// 1-based column, in characters, 0 when the error has no place.
    pub column: usize,
    /// The located message, with the line shown and underlined.
    pub message: String,
}

impl std::fmt::Display for SceneError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for SceneError {}

impl From<lancer_scene::LoadError> for SceneError {
    fn from(e: lancer_scene::LoadError) -> SceneError {
        SceneError { file: e.file.clone(), line: e.line, column: e.column, message: e.to_string() }
    }
}

/// A state applied to a session's scene: ready to render.
pub struct Applied {
    prepared: Prepared,
    pipeline: lancer_shading::Pipeline,
}

/// A loaded and prepared scene, and what the page needs of it.
pub struct Session {
    registry: Registry,
    /// How the scene is named (its file name).
    pub name: String,
    /// The scene's text, as loaded.
    pub source: String,
    prepared: Prepared,
    camera: Camera,
    image: ImageSettings,
    /// The state as the text has it.
    pub loaded: State,
    /// What loading and checking warn about, one line each.
    pub warnings: Vec<String>,
    /// How each prepared object is named: `object 3 (sphere, glass.toml:45)`.
    pub objects: Vec<String>,
    /// The render's scratch buffers, kept from one render to the next (a browser worker renders
    /// band after band).
    scratch: lancer_shading::Scratches,
}

impl Session {
    /// Loads the scene `name` whose text is `source`; `files` gives the bytes of each file it
    /// names (meshes, textures), by the name the scene writes.
    pub fn load(
        registry: &Registry,
        name: &str,
        source: &str,
        files: Resolver<'_>,
        limits: &Limits,
    ) -> Result<Session, SceneError> {
        let loaded = lancer_scene::load_scene_within(source, name, registry, files, limits)?;
        let unplaced = |message: String| SceneError { file: name.to_owned(), line: 0, column: 0, message };
        let prepared =
            lancer_shading::prepare(&loaded.scene).map_err(|e| unplaced(format!("preparing {name}: {e}")))?;
        let mut warnings: Vec<String> = loaded.warnings.iter().map(|w| w.to_string()).collect();
        warnings.extend(
            lancer_scene::check(&loaded.scene, &loaded.pipeline, &prepared, &loaded.places)
                .iter()
                .map(|w| w.to_string()),
        );
        let objects = object_labels(&prepared, &loaded.places);
        let samples = loaded.scene.image.samples.clamp(1, 256);
        let state = State::of(&prepared, &loaded.pipeline, &loaded.places.materials, samples);
        Ok(Session {
            registry: registry.clone(),
            name: name.to_owned(),
            source: source.to_owned(),
            prepared,
            camera: loaded.scene.camera,
            image: loaded.scene.image,
            loaded: state,
            warnings,
            objects,
            scratch: Default::default(),
        })
    }

    /// The message a page gets when the scene is loaded: its name and size, the warnings, the
    /// state as the text has it and the registry (the same fields as `lancer serve`'s).
    pub fn hello(&self) -> Value {
        json!({
            "type": "hello",
            "scene": self.name,
            "width": self.image.width,
            "height": self.image.height,
            "adaptive": crate::state::adaptive_json(&self.image),
            "warnings": self.warnings,
            "can_save": false,
            "file": self.name.rsplit('/').next().unwrap_or(&self.name),
            "state": self.loaded,
            "file_state": self.loaded,
            "objects": self.objects,
            "registry": crate::state::registry_json(&self.registry),
        })
    }

    /// The image settings a render of `state` uses (the coarse one a quarter of the size, one
    /// sample per pixel).
    pub fn image(&self, state: &State, coarse: bool) -> ImageSettings {
        crate::state::image_for(&self.image, state, coarse)
    }

    /// Renders `state`, with every term's image: the whole frame, or with `part = Some((I, N))`
    /// the bands of part `I` of `N` one under the other (`RenderOptions::compact`).
    pub fn render(&self, state: &State, coarse: bool, part: Option<(u32, u32)>) -> Result<Frame, String> {
        let applied = self.apply(state)?;
        Ok(self.render_applied(&applied, state, coarse, part))
    }

    /// The scene with `state`'s materials and lights, and its model: what [`Session::render`]
    /// renders, for a caller that renders one state many times (a worker's bands).
    pub fn apply(&self, state: &State) -> Result<Applied, String> {
        let mut prepared = self.prepared.clone();
        let pipeline = state.apply(&mut prepared, &self.registry)?;
        Ok(Applied { prepared, pipeline })
    }

    /// [`Session::render`] of a state already applied (`applied` is [`Session::apply`] of
    /// `state`).
    pub fn render_applied(&self, applied: &Applied, state: &State, coarse: bool, part: Option<(u32, u32)>) -> Frame {
        let image = self.image(state, coarse);
        let options = RenderOptions {
            layers: true,
            part,
            compact: part.is_some(),
            scratch: Some(&self.scratch),
            ..RenderOptions::default()
        };
        lancer_shading::render_prepared(&applied.prepared, &self.camera, &image, &applied.pipeline, options)
    }

    /// Pixel `(x, y)` of the full image of `state` explained, as `lancer explain --json` gives it.
    pub fn explain(&self, state: &State, x: u32, y: u32) -> Result<String, String> {
        let image = self.image(state, false);
        if x >= image.width || y >= image.height {
            return Err(format!("pixel {x},{y} is outside the {}x{} image", image.width, image.height));
        }
        let mut prepared = self.prepared.clone();
        let pipeline = state.apply(&mut prepared, &self.registry)?;
        let e = lancer_shading::explain_pixel(&prepared, &self.camera, &image, &pipeline, x, y);
        let materials: Vec<String> = self.loaded.materials.iter().map(|m| m.label.clone()).collect();
        let report = lancer_output::Report {
            scene: &self.name,
            image: &image,
            pipeline: &pipeline,
            explanation: &e,
            objects: &self.objects,
            materials: &materials,
        };
        Ok(report.json())
    }

    /// The scene's text with the edits of `state` written in (every other byte kept).
    pub fn edited(&self, state: &State) -> Result<String, String> {
        crate::save::edited(&self.source, state, &self.loaded)
    }
}

/// Each prepared object named as the file has it: its number in file order (from 1), its shape
/// and where its `[[objects]]` entry is written.
pub fn object_labels(prepared: &Prepared, places: &lancer_scene::Places) -> Vec<String> {
    prepared
        .geometry
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| match places.objects.get(i) {
            Some(p) => format!("object {} ({}, {}:{})", i + 1, o.shape.name(), p.file, p.line),
            None => format!("object {} ({})", i + 1, o.shape.name()),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use lancer_shading::Registry;

    use super::Session;

    const SCENE: &str = "[camera]\nfrom = [0, 1, -6]\nto = [0, 0, 0]\n[image]\nwidth = 40\nheight = 30\n\
                         [[lights]]\nat = [4, 6, -4]\n[materials.red]\ncolor = [1, 0.2, 0.1]\n\
                         [[objects]]\nshape = \"sphere\"\nmaterial = \"red\"\n";

    fn load(src: &str) -> Result<Session, super::SceneError> {
        let none = |p: &str| Err(format!("no file `{p}` was given"));
        Session::load(&Registry::with_builtins(), "s.toml", src, &none, &Default::default())
    }

    #[test]
    fn a_broken_scene_is_an_error_at_its_line_and_column() {
        let e = load(&SCENE.replace("width = 40", "width = \"wide\"")).err().expect("a string is no width");
        assert_eq!((e.file.as_str(), e.line, e.column), ("s.toml", 5, 9), "{}", e.message);
        assert!(e.message.starts_with("s.toml:5:9: "), "{}", e.message);
    }

    #[test]
    fn regression_the_page_showed_one_error_of_a_file_with_several() {
        // The engine's error is placed at the first (the editor marks its line), and its message
        // tells every one, in file order.
        let e = load(&SCENE.replace("\"red\"\n", "\"blue\"\n").replace("\"sphere\"", "\"spere\""))
            .err()
            .expect("two mistakes");
        assert_eq!((e.line, e.column), (12, 9), "{}", e.message);
        let (shape, material) =
            (e.message.find("s.toml:12:9: unknown shape"), e.message.find("s.toml:13:12: unknown material"));
        assert!(shape.is_some() && material.is_some() && shape < material, "{}", e.message);
    }

    #[test]
    fn a_part_renders_its_bands_of_the_whole_frame_and_an_edit_changes_the_text() {
        let s = load(SCENE).unwrap();
        let whole = s.render(&s.loaded, false, None).unwrap();
        let part = s.render(&s.loaded, false, Some((1, 2))).unwrap();
        // Bands 1 (rows 16..30): 14 rows.
        assert_eq!((part.width, part.height), (40, 14));
        let bits = |px: &[glam::Vec3]| px.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
        assert_eq!(bits(&part.beauty), bits(&whole.beauty[16 * 40..]));
        let coarse = s.render(&s.loaded, true, None).unwrap();
        assert_eq!((coarse.width, coarse.height), (10, 7));
        let mut state = s.loaded.clone();
        state.materials[0].shine = 0.75;
        let text = s.edited(&state).unwrap();
        assert!(text.contains("[materials.red]\ncolor = [1, 0.2, 0.1]\nshine = 0.75\n"), "{text}");
        assert_eq!(s.hello()["state"]["materials"][0]["label"], "red");
        assert_eq!(s.hello()["objects"][0], "object 1 (sphere, s.toml:11)");
    }

    #[test]
    fn a_scene_with_adaptive_anti_aliasing_keeps_it_until_the_samples_change() {
        let s =
            load(&SCENE.replace("height = 30\n", "height = 30\nsamples = { adaptive = 0.2, depth = 2 }\n")).unwrap();
        assert_eq!(s.hello()["adaptive"], serde_json::json!({ "threshold": 0.2, "depth": 2 }));
        assert_eq!(load(SCENE).unwrap().hello()["adaptive"], serde_json::Value::Null);
        let mut state = s.loaded.clone();
        let aa = lancer_core::Adaptive { threshold: 0.2, depth: 2 };
        assert_eq!(s.image(&state, false).adaptive, Some(aa));
        // The coarse image is one sample a pixel; another number of samples is every pixel's.
        assert_eq!((s.image(&state, true).adaptive, s.image(&state, true).samples), (None, 1));
        state.model.samples = 4;
        assert_eq!((s.image(&state, false).adaptive, s.image(&state, false).samples), (None, 4));
        let frame = s.render(&s.loaded, false, None).unwrap();
        assert!(frame.stats.supersampled > 0);
    }
}

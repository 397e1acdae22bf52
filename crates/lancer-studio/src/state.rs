//! What the page edits: the materials, the lights and the model, as JSON both ways, and how an
//! edited state becomes a prepared scene and a pipeline to render.

use glam::Vec3;
use lancer_shading::{ParamValue, Params, Pipeline, Prepared, Registry};
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

/// One material's numbers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaterialState {
    /// Its name in the scene (`[materials.NAME]`, or `object N` for an inline one).
    pub label: String,
    /// `Col_Ω` (the first colour of a pattern).
    pub color: [f32; 3],
    /// Ambient factor.
    pub ambi: f32,
    /// Diffuse factor.
    pub diff: f32,
    /// Specular factor (highlight and mirror).
    pub spec: f32,
    /// Shininess.
    pub shine: f32,
    /// Transparency.
    pub alpha: f32,
    /// Refractive index.
    pub n: f32,
}

impl MaterialState {
    /// The numbers of the material `m`, named `label`.
    pub fn of(label: String, m: &lancer_core::Material) -> MaterialState {
        MaterialState {
            label,
            color: m.color.to_array(),
            ambi: m.ambi,
            diff: m.diff,
            spec: m.spec,
            shine: m.shine,
            alpha: m.alpha,
            n: m.n,
        }
    }

    /// Checks the numbers against the ranges a scene file allows and writes them into `m`
    /// (whose pattern stays); an error names the number out of range and leaves `m` as it was.
    pub fn write_to(&self, m: &mut lancer_core::Material) -> Result<(), String> {
        let unit = |x: f32, what: &str| {
            if (0.0..=1.0).contains(&x) { Ok(x) } else { Err(format!("{what} must be in [0, 1], not {x}")) }
        };
        let colour = Vec3::from(self.color);
        if !colour.is_finite() || colour.min_element() < 0.0 || colour.max_element() > 1000.0 {
            return Err(format!("{}: colour channels must be in [0, 1000]", self.label));
        }
        let (ambi, diff, spec) = (unit(self.ambi, "ambi")?, unit(self.diff, "diff")?, unit(self.spec, "spec")?);
        let (shine, alpha) = (unit(self.shine, "shine")?, unit(self.alpha, "alpha")?);
        if !(1.0..=2.5).contains(&self.n) {
            return Err(format!("n must be in [1, 2.5], not {}", self.n));
        }
        (m.color, m.ambi, m.diff, m.spec, m.shine, m.alpha, m.n) = (colour, ambi, diff, spec, shine, alpha, self.n);
        Ok(())
    }
}

/// One light.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LightState {
    /// Position, in world space (rounded to f32).
    pub at: [f32; 3],
    /// `Col_L` before intensity.
    pub color: [f32; 3],
    /// Scales the colour.
    pub intensity: f32,
}

/// One term of the model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TermState {
    /// The term's name.
    pub name: String,
    /// Its variant.
    pub variant: String,
    /// Switched off terms keep their place and parameters but are not rendered.
    pub enabled: bool,
    /// Its parameters as given (the others have their defaults).
    pub params: Map<String, Value>,
}

/// The shadow model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShadowState {
    /// The shadow model's name.
    pub name: String,
    /// Its parameters as given.
    pub params: Map<String, Value>,
}

/// The lighting model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelState {
    /// The terms in summation order.
    pub terms: Vec<TermState>,
    /// The shadow model.
    pub shadows: ShadowState,
    /// The recursion limit.
    pub max_depth: u8,
    /// Samples per pixel of the full image (the coarse one takes one).
    pub samples: u32,
}

/// Everything the page can change.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct State {
    /// Which load of the scene the state belongs to (edits made before a reload are dropped).
    #[serde(default)]
    pub epoch: u64,
    /// The materials, in the prepared table's order.
    pub materials: Vec<MaterialState>,
    /// The lights, in scene order.
    pub lights: Vec<LightState>,
    /// The model.
    pub model: ModelState,
}

fn params_json(params: &[(String, ParamValue)]) -> Map<String, Value> {
    params
        .iter()
        .map(|(k, v)| {
            let v = match v {
                ParamValue::Number(x) => serde_json::json!(x),
                ParamValue::Bool(b) => Value::Bool(*b),
                ParamValue::Text(t) => Value::String(t.clone()),
            };
            (k.clone(), v)
        })
        .collect()
}

fn params_of(map: &Map<String, Value>) -> Result<Params, String> {
    let mut out = Vec::new();
    for (k, v) in map {
        let value = match v {
            Value::Number(n) => ParamValue::Number(n.as_f64().ok_or_else(|| format!("`{k}`: not a number"))?),
            Value::Bool(b) => ParamValue::Bool(*b),
            Value::String(s) => ParamValue::Text(s.clone()),
            _ => return Err(format!("`{k}`: expected a number, a boolean or text")),
        };
        out.push((k.clone(), value));
    }
    Ok(Params::new(out))
}

impl State {
    /// The state of a freshly loaded scene: `labels` names the prepared materials in order.
    pub fn of(prepared: &Prepared, pipeline: &Pipeline, labels: &[String], samples: u32) -> State {
        // The prepared table ends with the default material for objects that name none.
        let named = prepared.materials.len().saturating_sub(1);
        let materials = prepared.materials[..named]
            .iter()
            .enumerate()
            .map(|(i, m)| MaterialState::of(labels.get(i).cloned().unwrap_or_else(|| format!("material {}", i + 1)), m))
            .collect();
        let lights = prepared
            .lights
            .iter()
            .map(|l| LightState {
                at: world(prepared.origin, l.at).to_array(),
                color: l.color.to_array(),
                intensity: l.intensity,
            })
            .collect();
        let terms = pipeline
            .terms
            .iter()
            .map(|t| TermState {
                name: t.name.clone(),
                variant: t.variant.clone(),
                enabled: true,
                params: params_json(&t.params),
            })
            .collect();
        let shadows =
            ShadowState { name: pipeline.shadows.name.clone(), params: params_json(&pipeline.shadows.params) };
        State {
            epoch: 0,
            materials,
            lights,
            model: ModelState { terms, shadows, max_depth: pipeline.max_depth, samples },
        }
    }

    /// Writes the materials and lights into `prepared` (whose geometry stays) and builds the
    /// pipeline; an error names what is wrong (an unknown variant, a parameter out of range).
    pub fn apply(&self, prepared: &mut Prepared, registry: &Registry) -> Result<Pipeline, String> {
        if self.materials.len() + 1 != prepared.materials.len() || self.lights.len() != prepared.lights.len() {
            return Err("the edit does not match the scene (reloaded meanwhile?)".into());
        }
        for (m, s) in prepared.materials.iter_mut().zip(&self.materials) {
            s.write_to(m)?;
        }
        let origin = prepared.origin;
        for (l, s) in prepared.lights.iter_mut().zip(&self.lights) {
            let (at, colour) = (Vec3::from(s.at), Vec3::from(s.color));
            // Within 1e6 of the camera, wherever the scene is.
            if !at.is_finite() || (at.as_dvec3() - origin).abs().max_element() > 1e6 {
                return Err("a light's position must be finite, within 1e6 of the camera".into());
            }
            if !colour.is_finite() || colour.min_element() < 0.0 || colour.max_element() > 1000.0 {
                return Err("a light's colour channels must be in [0, 1000]".into());
            }
            if !(0.0..=1e6).contains(&s.intensity) {
                return Err("a light's intensity must be in [0, 1e6]".into());
            }
            // A light left where it was keeps its position as prepared (the world one rounded to
            // f32 may be coarser); a moved one is placed from the prepared frame's origin.
            if at != world(origin, l.at) {
                l.at = (at.as_dvec3() - origin).as_vec3();
            }
            (l.color, l.intensity) = (colour, s.intensity);
        }
        let model = &self.model;
        if model.max_depth > 64 {
            return Err("max_depth goes to 64".into());
        }
        if !(1..=256).contains(&model.samples) {
            return Err("samples go from 1 to 256 in the studio".into());
        }
        let mut terms = Vec::new();
        for t in model.terms.iter().filter(|t| t.enabled) {
            terms.push(
                registry
                    .build_term(&t.name, Some(&t.variant), params_of(&t.params)?)
                    // The registry's errors name the term (and its variant) themselves.
                    .map_err(|e| e.to_string())?,
            );
        }
        let shadows = registry
            .build_shadow(&model.shadows.name, params_of(&model.shadows.params)?)
            .map_err(|e| format!("shadows: {e}"))?;
        Pipeline::new(model.max_depth, shadows, terms).map_err(|e| e.to_string())
    }
}

/// The image settings a render of `state` uses: the scene's, with the state's samples per pixel;
/// the coarse image, shown at once while the full one renders, a quarter of the size at one
/// sample per pixel. The scene's adaptive anti-aliasing is kept while the samples are the
/// scene's; samples set in the studio are every pixel's.
pub fn image_for(base: &lancer_core::ImageSettings, state: &State, coarse: bool) -> lancer_core::ImageSettings {
    let mut image = *base;
    if state.model.samples != base.samples {
        image.set_samples(state.model.samples);
    }
    if coarse {
        image.width = (image.width / 4).max(1);
        image.height = (image.height / 4).max(1);
        image.set_samples(1);
    }
    image
}

/// The scene's adaptive anti-aliasing as the page's hello says it: `{threshold, depth}`, or
/// null (every pixel the model's samples).
pub fn adaptive_json(image: &lancer_core::ImageSettings) -> Value {
    // The threshold as the file writes it (0.3, not the f32's 0.30000001192092896).
    let shortest = |t: f32| t.to_string().parse::<f64>().unwrap_or(f64::from(t));
    image.adaptive.map_or(Value::Null, |a| serde_json::json!({ "threshold": shortest(a.threshold), "depth": a.depth }))
}

/// The world position, rounded to f32, of the point `at` of a prepared frame whose origin is
/// `origin`.
fn world(origin: glam::DVec3, at: Vec3) -> Vec3 {
    (origin + at.as_dvec3()).as_vec3()
}

/// The registry as the page lists it: every term with its variants and parameters, every
/// shadow model.
pub fn registry_json(registry: &Registry) -> Value {
    let mut terms: Vec<Value> = Vec::new();
    for name in registry.term_names() {
        let variants: Vec<Value> = registry
            .terms()
            .iter()
            .filter(|t| t.name == name)
            .map(|t| {
                serde_json::json!({
                    "variant": t.variant,
                    "summary": t.summary,
                    "params": t.params.iter().map(|p| serde_json::json!({"name": p.name, "default": p.default, "doc": p.doc})).collect::<Vec<_>>(),
                })
            })
            .collect();
        terms.push(serde_json::json!({ "name": name, "variants": variants }));
    }
    let shadows: Vec<Value> = registry
        .shadows()
        .iter()
        .map(|s| {
            serde_json::json!({
                "name": s.name,
                "summary": s.summary,
                "params": s.params.iter().map(|p| serde_json::json!({"name": p.name, "default": p.default, "doc": p.doc})).collect::<Vec<_>>(),
            })
        })
        .collect();
    serde_json::json!({ "terms": terms, "shadows": shadows })
}

#[cfg(test)]
mod tests {
    use lancer_shading::Registry;

    use super::State;

    #[test]
    fn lights_far_from_the_origin_are_edited_in_world_coordinates() {
        // The prepared lights are measured from the camera; the page sees and edits world ones.
        let src = "[camera]\nfrom = [1000000, 2, -250000]\nto = [1000000, 0, -249990]\n\
                   [[lights]]\nat = [1000003, 8.5, -249995]\n[[lights]]\nat = [999990, 6, -250001]\n\
                   [[objects]]\nshape = \"sphere\"\ntranslate = [1000000, 0, -249990]\n";
        let registry = Registry::with_builtins();
        let l = lancer_scene::load_scene(src, "s.toml", &registry).unwrap();
        let prepared = lancer_shading::prepare(&l.scene).unwrap();
        assert_eq!(prepared.lights[0].at, glam::Vec3::new(3.0, 6.5, 5.0), "from the camera");
        let mut state = State::of(&prepared, &l.pipeline, &l.places.materials, 1);
        assert_eq!(state.lights[0].at, [1000003.0, 8.5, -249995.0]);
        // Left where it is, a light keeps its prepared position to the bit; moved, it goes
        // where the page puts it.
        state.lights[1].at = [999991.0, 7.0, -250000.0];
        let mut edited = prepared.clone();
        state.apply(&mut edited, &registry).unwrap();
        assert_eq!(edited.lights[0].at, prepared.lights[0].at);
        assert_eq!(edited.lights[1].at, glam::Vec3::new(-9.0, 5.0, 0.0));
    }

    #[test]
    fn regression_a_bad_term_parameter_named_its_term_twice() {
        // Found in use: "term `specular`: `specular`: ..." on the page.
        let src = "[camera]\nfrom = [0, 0, -5]\nto = [0, 0, 0]\n[[objects]]\nshape = \"sphere\"\n";
        let registry = Registry::with_builtins();
        let l = lancer_scene::load_scene(src, "s.toml", &registry).unwrap();
        let prepared = lancer_shading::prepare(&l.scene).unwrap();
        let mut state = State::of(&prepared, &l.pipeline, &l.places.materials, 1);
        let specular = state.model.terms.iter_mut().find(|t| t.name == "specular").unwrap();
        specular.variant = "blinn".into();
        specular.params.insert("exponent".into(), serde_json::json!(-1));
        let e = state.apply(&mut prepared.clone(), &registry).err().unwrap();
        assert_eq!(e.matches("specular").count(), 1, "{e}");
        assert!(e.starts_with("`specular`: "), "{e}");
    }
}

//! `lancer explain`'s output: a pixel's ray tree as indented text for a terminal, or as JSON.

use std::fmt::Write;

use glam::{DVec3, Vec3};
use lancer_core::ImageSettings;
use lancer_core::frame::BACKGROUND;
use lancer_shading::{NoteValue, Pipeline, PixelExplanation, RayNode};
use serde::Serialize;

use crate::Ordered;

/// An explanation with what it needs to name things.
pub struct Report<'a> {
    /// How the scene is named.
    pub scene: &'a str,
    /// The image settings it was rendered with.
    pub image: &'a ImageSettings,
    /// The model.
    pub pipeline: &'a Pipeline,
    /// What the render found.
    pub explanation: &'a PixelExplanation,
    /// Each object named as the file has it, in file order (`object 3 (sphere, scene.toml:45)`);
    /// an object past the list is named by its number and shape.
    pub objects: &'a [String],
    /// Each material's name in the prepared table's order (`glass`, or `object 2` for an
    /// object's own); one past the list is the default material.
    pub materials: &'a [String],
}

fn v(v: Vec3) -> String {
    format!("({:.4}, {:.4}, {:.4})", v.x, v.y, v.z)
}

/// A point, in world space.
fn p(p: DVec3) -> String {
    format!("({:.4}, {:.4}, {:.4})", p.x, p.y, p.z)
}

impl Report<'_> {
    /// The object numbered `number` (from 1, file order), as the file names it.
    fn object_name(&self, number: u32, shape: &str) -> String {
        match (number as usize).checked_sub(1).and_then(|i| self.objects.get(i)) {
            Some(label) => label.clone(),
            None => format!("object {number} ({shape})"),
        }
    }

    /// The material numbered `number` (from 1, the prepared table), as the file names it:
    /// `material "glass"`, or the default material for objects that name none.
    fn material_name(&self, number: u32) -> String {
        match (number as usize).checked_sub(1).and_then(|i| self.materials.get(i)) {
            Some(name) => format!("material \"{name}\""),
            None => "the default material".to_owned(),
        }
    }

    fn term_name(&self, term: usize) -> &str {
        &self.pipeline.terms[term].name
    }

    /// The image a ray's contributions go to.
    fn credit_name(&self, ray: &RayNode) -> Option<&str> {
        ray.credit.map(|c| self.pipeline.terms.get(c).map_or(BACKGROUND, |t| t.name.as_str()))
    }

    fn kind(&self, ray: &RayNode) -> String {
        match ray.parent {
            None => "camera".to_owned(),
            Some((_, term)) => self.term_name(term).to_owned(),
        }
    }

    /// The pixel's camera rays (with adaptive anti-aliasing, 1 or the supersampled pixel's).
    fn camera_rays(&self) -> usize {
        self.explanation.rays.iter().filter(|r| r.parent.is_none()).count()
    }

    /// Whether the pixel keeps a background layer (as `--aov` writes one).
    fn has_background(&self) -> bool {
        self.image.background != Vec3::ZERO
    }

    /// The indented tree, then the totals.
    pub fn text(&self) -> String {
        let e = self.explanation;
        let p = self.pipeline;
        let mut out = String::new();
        let model: Vec<String> = p.terms.iter().map(|t| format!("{}:{}", t.name, t.variant)).collect();
        let rays = self.camera_rays();
        let sampling = match self.image.adaptive {
            Some(a) => format!(
                "adaptive anti-aliasing (threshold {}, depth {}): {}",
                a.threshold,
                a.depth,
                if rays > 1 {
                    let twice = if a.depth % 2 == 1 { ", the centre's counting twice" } else { "" };
                    format!("supersampled, the mean of {} samples in {rays} rays{twice}", a.samples())
                } else {
                    "not supersampled, 1 sample".to_owned()
                }
            ),
            None => format!("{rays} sample{}", if rays > 1 { "s" } else { "" }),
        };
        let _ = writeln!(
            out,
            "pixel {},{} of {} ({}x{}, {sampling})",
            e.x, e.y, self.scene, self.image.width, self.image.height,
        );
        let _ = writeln!(out, "model: {}; shadows: {}; max_depth {}", model.join(", "), p.shadows.name, p.max_depth);
        let _ = writeln!(out, "u: ray direction, N: normal facing the ray, w: direction to a light\n");
        for (id, ray) in e.rays.iter().enumerate() {
            if ray.parent.is_none() {
                self.ray_text(&mut out, id, 0);
            }
        }
        let _ = writeln!(out, "\ntotals (linear RGB, the values of the --aov images at this pixel):");
        for (name, value) in self.layers() {
            let _ = writeln!(out, "  {name:<12} {}", v(value));
        }
        let _ = writeln!(out, "  {:<12} {}", "beauty", v(e.beauty));
        out
    }

    /// The layers `--aov` writes: every term's, and the background's when the scene has one.
    fn layers(&self) -> impl Iterator<Item = (&str, Vec3)> + '_ {
        self.explanation
            .layers
            .iter()
            .filter(|(name, _)| name != BACKGROUND || self.has_background())
            .map(|(name, value)| (name.as_str(), *value))
    }

    fn ray_text(&self, out: &mut String, id: usize, indent: usize) {
        let ray = &self.explanation.rays[id];
        let pad = "  ".repeat(indent);
        let credit = match self.credit_name(ray) {
            Some(name) => format!(", counts in the {name} image"),
            None => String::new(),
        };
        let sample = if self.camera_rays() > 1 { format!(" (sample {})", ray.sample) } else { String::new() };
        let _ = writeln!(
            out,
            "{pad}{} ray{sample}, generation {}: from {} u = {}, weight {}{credit}",
            self.kind(ray),
            ray.depth,
            p(ray.origin),
            v(ray.dir),
            v(ray.weight)
        );
        let pad = "  ".repeat(indent + 1);
        let Some(hit) = &ray.hit else {
            match ray.background {
                Some(b) => {
                    let _ = writeln!(out, "{pad}hits nothing: sees the background, adds {}", v(b));
                }
                None => {
                    let _ = writeln!(out, "{pad}hits nothing (black background)");
                }
            }
            return;
        };
        let _ = writeln!(
            out,
            "{pad}hits {}, {}, at t = {:.4}, {}: I = {}, N = {}, Col_Ω = {}",
            self.object_name(hit.object, hit.shape),
            self.material_name(hit.material),
            hit.t,
            if hit.front { "from outside" } else { "from inside" },
            p(hit.point),
            v(hit.normal),
            v(hit.color)
        );
        for (k, light) in ray.lights.iter().enumerate() {
            let line = if light.traced {
                format!(
                    "w = {}, N·w = {:.4}, transmittance ({}) {}, light arriving {}",
                    v(light.w),
                    light.n_dot_w,
                    self.pipeline.shadows.name,
                    v(light.transmittance),
                    v(light.incoming)
                )
            } else if !light.read {
                format!(
                    "w = {}, N·w = {:.4}; not traced: no term of the model reads lights on this material",
                    v(light.w),
                    light.n_dot_w
                )
            } else {
                format!("behind the surface (N·w = {:.4}): sends nothing", light.n_dot_w)
            };
            let _ = writeln!(out, "{pad}light {}: {line}", k + 1);
        }
        for term in &ray.terms {
            let name = self.term_name(term.term);
            let children: Vec<usize> = ray
                .children
                .iter()
                .copied()
                .filter(|&c| self.explanation.rays[c].parent == Some((id, term.term)))
                .collect();
            if term.colour == Vec3::ZERO && term.added == Vec3::ZERO && children.is_empty() {
                let _ = writeln!(out, "{pad}{name}: nothing");
                continue;
            }
            let notes: Vec<String> = term
                .notes
                .iter()
                .map(|n| match &n.value {
                    NoteValue::Number(x) => format!("{} = {x:.4}", n.name),
                    NoteValue::Vector(x) => format!("{} = {}", n.name, v(*x)),
                    NoteValue::Point(x) => format!("{} = {}", n.name, p(*x)),
                    NoteValue::Text(t) => format!("{}: {t}", n.name),
                })
                .collect();
            let into = self.credit_name(ray).unwrap_or(name);
            if term.colour == Vec3::ZERO && term.added == Vec3::ZERO {
                let n = children.len();
                let _ = writeln!(
                    out,
                    "{pad}{name}: spawns {n} ray{} (what {} brings back counts in the {into} image)",
                    if n == 1 { "" } else { "s" },
                    if n == 1 { "it" } else { "they" }
                );
            } else {
                let _ =
                    writeln!(out, "{pad}{name}: colour {}, adds {} to the {into} image", v(term.colour), v(term.added));
            }
            for note in notes {
                let _ = writeln!(out, "{pad}  {note}");
            }
            for child in children {
                self.ray_text(out, child, indent + 2);
            }
        }
    }

    /// The same as JSON: the model, the tree (camera rays with nested children), and `terms`
    /// mapping every image `--aov` writes to its value, and `beauty`. Points (ray origins, hit
    /// points, the refraction's `I` and `J`) are in world space, in f64.
    pub fn json(&self) -> String {
        let e = self.explanation;
        let roots: Vec<JsonRay> =
            e.rays.iter().enumerate().filter(|(_, r)| r.parent.is_none()).map(|(id, _)| self.json_ray(id)).collect();
        let doc = JsonDoc {
            scene: self.scene,
            pixel: [e.x, e.y],
            width: self.image.width,
            height: self.image.height,
            samples: match self.image.adaptive {
                Some(a) if self.camera_rays() > 1 => a.samples(),
                _ => self.camera_rays() as u32,
            },
            camera_rays: self.camera_rays() as u32,
            adaptive: self.image.adaptive.map(|a| JsonAdaptive { threshold: a.threshold, depth: a.depth }),
            model: JsonModel {
                terms: self
                    .pipeline
                    .terms
                    .iter()
                    .map(|t| JsonTerm { name: &t.name, variant: &t.variant, weight: t.weight })
                    .collect(),
                shadows: &self.pipeline.shadows.name,
                max_depth: self.pipeline.max_depth,
            },
            rays: roots,
            terms: self.layers().map(|(name, value)| (name, value.to_array())).collect(),
            beauty: e.beauty.to_array(),
        };
        serde_json::to_string_pretty(&doc).expect("plain data serialises")
    }

    fn json_ray(&self, id: usize) -> JsonRay<'_> {
        let ray = &self.explanation.rays[id];
        JsonRay {
            kind: self.kind(ray),
            generation: ray.depth,
            sample: ray.sample,
            origin: ray.origin.to_array(),
            direction: ray.dir.to_array(),
            weight: ray.weight.to_array(),
            credited_to: self.credit_name(ray),
            hit: ray.hit.as_ref().map(|h| JsonHit {
                object: h.object,
                object_name: self.object_name(h.object, h.shape),
                shape: h.shape,
                material: h.material,
                material_name: (h.material as usize).checked_sub(1).and_then(|i| self.materials.get(i)).cloned(),
                t: h.t,
                point: h.point.to_array(),
                normal: h.normal.to_array(),
                front: h.front,
                color: h.color.to_array(),
            }),
            lights: ray
                .lights
                .iter()
                .map(|l| JsonLight {
                    w: l.w.to_array(),
                    n_dot_w: l.n_dot_w,
                    read: l.read,
                    traced: l.traced,
                    transmittance: l.transmittance.to_array(),
                    incoming: l.incoming.to_array(),
                })
                .collect(),
            terms: ray
                .terms
                .iter()
                .map(|t| JsonTermRun {
                    term: self.term_name(t.term),
                    colour: t.colour.to_array(),
                    added: t.added.to_array(),
                    notes: t
                        .notes
                        .iter()
                        .map(|n| JsonNote {
                            name: &n.name,
                            value: match &n.value {
                                NoteValue::Number(x) => serde_json::json!(x),
                                NoteValue::Vector(x) => serde_json::json!(x.to_array()),
                                NoteValue::Point(x) => serde_json::json!(x.to_array()),
                                NoteValue::Text(t) => serde_json::json!(t),
                            },
                        })
                        .collect(),
                })
                .collect(),
            background: ray.background.map(|b| b.to_array()),
            children: ray.children.iter().map(|&c| self.json_ray(c)).collect(),
        }
    }
}

#[derive(Serialize)]
struct JsonAdaptive {
    threshold: f32,
    depth: u32,
}

#[derive(Serialize)]
struct JsonDoc<'a> {
    scene: &'a str,
    pixel: [u32; 2],
    width: u32,
    height: u32,
    /// The samples the pixel's value is the mean of (with adaptive anti-aliasing, 1 or the
    /// supersampled pixel's).
    samples: u32,
    /// Its camera rays (an odd depth's centre ray stands for two samples).
    camera_rays: u32,
    #[serde(skip_serializing_if = "Option::is_none")]
    adaptive: Option<JsonAdaptive>,
    model: JsonModel<'a>,
    rays: Vec<JsonRay<'a>>,
    terms: Ordered<'a, [f32; 3]>,
    beauty: [f32; 3],
}

#[derive(Serialize)]
struct JsonModel<'a> {
    terms: Vec<JsonTerm<'a>>,
    shadows: &'a str,
    max_depth: u8,
}

#[derive(Serialize)]
struct JsonTerm<'a> {
    name: &'a str,
    variant: &'a str,
    weight: f32,
}

#[derive(Serialize)]
struct JsonRay<'a> {
    kind: String,
    generation: u8,
    sample: u32,
    /// In world space.
    origin: [f64; 3],
    direction: [f32; 3],
    weight: [f32; 3],
    credited_to: Option<&'a str>,
    hit: Option<JsonHit>,
    lights: Vec<JsonLight>,
    terms: Vec<JsonTermRun<'a>>,
    background: Option<[f32; 3]>,
    children: Vec<JsonRay<'a>>,
}

#[derive(Serialize)]
struct JsonHit {
    /// From 1, in file order.
    object: u32,
    /// As `explain`'s text names it: `object 3 (sphere, scene.toml:45)`.
    object_name: String,
    shape: &'static str,
    /// From 1, in the order of `materials` ([`Report::materials`]).
    material: u32,
    /// The material's name in the file (`null` for the default material).
    material_name: Option<String>,
    t: f32,
    /// In world space.
    point: [f64; 3],
    normal: [f32; 3],
    front: bool,
    color: [f32; 3],
}

#[derive(Serialize)]
struct JsonLight {
    w: [f32; 3],
    n_dot_w: f32,
    read: bool,
    traced: bool,
    transmittance: [f32; 3],
    incoming: [f32; 3],
}

#[derive(Serialize)]
struct JsonTermRun<'a> {
    term: &'a str,
    colour: [f32; 3],
    added: [f32; 3],
    notes: Vec<JsonNote<'a>>,
}

#[derive(Serialize)]
struct JsonNote<'a> {
    name: &'a str,
    value: serde_json::Value,
}

//! Warnings about a loaded and prepared scene that only its geometry and model can tell: the
//! camera or a light inside an object, transparent objects that reach into others, terms that
//! act on no material, a render far costlier than usual.

use lancer_core::Scene;
use lancer_shading::{Pipeline, Prepared};

use crate::{Places, Warning};

/// Camera rays, times lights plus one, above which a render is "far costlier than usual" (the
/// example scenes trace a few million rays; this is over a minute on a 2-core machine).
const COSTLY_RAYS: f64 = 2e9;

/// What `lancer check` (and `lancer render`) warns about beyond what loading found. `places`
/// locates the objects, lights and camera in the file (objects in the prepared order).
pub fn check(scene: &Scene, pipeline: &Pipeline, prepared: &Prepared, places: &Places) -> Vec<Warning> {
    let mut out = Vec::new();
    let geometry = &prepared.geometry;
    let material = |i: usize| &prepared.materials[geometry.objects[i].material as usize];
    let object = |i: usize| {
        let at = places.objects.get(i).map(|p| format!(", {p}")).unwrap_or_default();
        format!("object {} ({}{at})", i + 1, geometry.objects[i].shape.name())
    };
    // The prepared frame's objects and lights are measured from its origin; the camera too.
    let camera = scene.camera.seen_from(prepared.origin).origin.as_vec3();
    for i in (0..geometry.objects.len()).filter(|&i| geometry.objects[i].contains(camera)) {
        let see = if material(i).alpha > 0.0 {
            "the image is seen through its surface from inside"
        } else {
            "its surface hides the rest of the scene"
        };
        out.push(Warning {
            place: places.camera.clone(),
            message: format!("the camera is inside {}: {see}", object(i)),
        });
    }
    let shadows = pipeline.shadows.name.as_str();
    for (k, light) in prepared.lights.iter().enumerate() {
        for i in (0..geometry.objects.len()).filter(|&i| geometry.objects[i].contains(light.at)) {
            // What the shadow model makes of the surface around the light.
            let through = match (shadows, material(i).alpha > 0.0) {
                ("none", _) => {
                    "with `none` shadows nothing blocks its light, so it lights the scene outside as if the \
                     object were not there"
                }
                (_, false) => "it lights nothing outside that object",
                ("hard", true) => {
                    "with `hard` shadows it lights nothing outside it either: a shadow ray stops at any surface, \
                     transparent or not (`transmissive` shadows let light through)"
                }
                (_, true) => "its light reaches outside only through transparent shadows",
            };
            out.push(Warning {
                place: places.lights.get(k).cloned(),
                message: format!("light {} is inside {}: {through}", k + 1, object(i)),
            });
        }
    }
    // `refraction:traced` meets what is inside a transparent object: every other model hides it.
    let hides_inside = !pipeline.terms.iter().any(|t| t.name == "refraction" && t.variant == "traced");
    for a in (0..geometry.objects.len()).filter(|&a| hides_inside && material(a).alpha > 0.0) {
        // Two transparent objects: said once.
        for b in (0..geometry.objects.len()).filter(|&b| b != a && (b > a || material(b).alpha <= 0.0)) {
            if geometry.overlap(a as u32, b as u32) {
                out.push(Warning {
                    place: places.objects.get(a).cloned(),
                    message: format!(
                        "transparent {} reaches into {}: the handout's refraction path crosses a transparent object \
                         without meeting anything inside it, so the part of the other object inside it will not show \
                         (`refraction:traced` traces inside and shows it)",
                        object(a),
                        object(b)
                    ),
                });
            }
        }
    }
    for term in &pipeline.terms {
        let used = (0..geometry.objects.len()).any(|i| term.term.acts_on(material(i)));
        if !used && !geometry.objects.is_empty() && places.chosen_terms {
            out.push(Warning { place: None, message: idle(term, (0..geometry.objects.len()).map(material)) });
        }
    }
    if pipeline.shadows.name == "soft" && !prepared.lights.is_empty() && prepared.lights.iter().all(|l| l.size <= 0.0) {
        out.push(Warning {
            place: None,
            message: "the `soft` shadow model samples area lights, and every light here is a point (`size = 0`): \
                      the shadows are the same as `transmissive`'s; give a light a `size` for a penumbra"
                .into(),
        });
    }
    let image = &scene.image;
    let camera_rays = image.width as f64 * image.height as f64 * image.samples.max(1) as f64;
    let estimate = camera_rays * (1.0 + prepared.lights.len() as f64);
    if estimate > COSTLY_RAYS {
        // Adaptive anti-aliasing traces one sample a pixel first, and more at the edges.
        let edges = match image.adaptive {
            Some(a) => format!(", and up to {} more a pixel where adaptive anti-aliasing supersamples", a.rays()),
            None => String::new(),
        };
        out.push(Warning {
            place: None,
            message: format!(
                "this render traces at least {:.0} M rays ({}x{} pixels x {} samples, each with {} shadow ray(s){edges}): \
                 about {:.0} thread-minutes at 10 M rays per thread-second; lower --samples or the size to try it first",
                estimate / 1e6,
                image.width,
                image.height,
                image.samples.max(1),
                prepared.lights.len(),
                estimate / 1e7 / 60.0
            ),
        });
    }
    out
}

/// Why `term` adds nothing on any of `materials`: for each material, the term's own reason (a
/// highlight's infinite exponent...) or the fields it reads that are zero there, each reason
/// said once.
fn idle<'m>(term: &lancer_shading::NamedTerm, materials: impl Iterator<Item = &'m lancer_core::Material>) -> String {
    let mut reasons: Vec<String> = Vec::new();
    for m in materials {
        let reason = term.term.why_idle(m).unwrap_or_else(|| {
            let zero: Vec<String> =
                term.reads.iter().filter(|f| is_zero(m, f)).map(|f| format!("`{f}` is 0")).collect();
            match zero.is_empty() {
                true => format!("the fields it reads (`{}`) leave it nothing to add", term.reads.join("`, `")),
                false => zero.join(" and "),
            }
        });
        if !reasons.contains(&reason) {
            reasons.push(reason);
        }
    }
    format!(
        "term `{}` adds nothing to this scene: on every material, {} (`lancer terms` lists what each term reads)",
        term.name,
        reasons.join(", or ")
    )
}

/// Whether the material field `field` (as [`lancer_shading::MATERIAL_FIELDS`] names it) is
/// zero on `m`; a patterned colour is not.
fn is_zero(m: &lancer_core::Material, field: &str) -> bool {
    match field {
        "ambi" => m.ambi == 0.0,
        "diff" => m.diff == 0.0,
        "spec" => m.spec == 0.0,
        "shine" => m.shine == 0.0,
        "alpha" => m.alpha == 0.0,
        "color" => m.color == glam::Vec3::ZERO && matches!(m.pattern, lancer_core::Pattern::Solid),
        // `n` is at least 1.
        _ => false,
    }
}

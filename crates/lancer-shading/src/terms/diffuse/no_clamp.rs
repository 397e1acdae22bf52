//! `diffuse`, variant `no-clamp`: a classic mistake of the course, kept to show it and for
//! `lancer diagnose` to recognise it: Lambert's `N·w` without `max(…, 0)`.
//!
//! Formula: `Col += diff · (N·w) · Col_Ω · Col_L` for every light, also those behind the
//! surface (`N·w < 0`), which subtract: a light in front arrives as the shadow model says; a
//! light behind arrives whole (the visibility system traces no shadow ray towards a light
//! behind a surface, as a renderer without shadows, or whose shadow ray ignores the object it
//! leaves, does not either). The side of an object turned from a light goes darker than its
//! ambient colour, black once the sum is clamped for display.
//! Reads: `diff`, `color`. Parameters: `weight` (every term has it).
//!
//! ```toml
//! [model]
//! terms = ["ambient", { term = "diffuse", variant = "no-clamp" }]
//! ```

use glam::Vec3;

use crate::term::facing;
use crate::{Chunk, Mistake, Note, Params, ShadeContext, Term, TermOutput, TermSpec};

/// The spec registered as `diffuse`, variant `no-clamp` (a mistake of `lambert`).
pub const SPEC: TermSpec = TermSpec {
    name: "diffuse",
    variant: "no-clamp",
    summary: "Lambert without max(N·w, 0): lights behind the surface subtract, its unlit side goes darker than ambient",
    reads: &["diff", "color"],
    params: &[],
    build: |_: &mut Params| Ok(Box::new(NoClamp)),
    mistake: Some(Mistake {
        of: "lambert",
        hint: "clamp the cosine: diff · max(N·w, 0) · Col_Ω · Col_L, so that a light behind the surface (N·w < 0) adds nothing instead of taking light away",
    }),
};

struct NoClamp;

/// `diff · Σ (N·w) · Col_L,k` with no clamp: for each light `k`, `w` and the light arriving
/// through the shadow model where `N·w > 0`, and the light's own colour `Col_L` where it is
/// behind the surface.
#[inline]
pub fn unclamped_sum(n: Vec3, lights: impl Iterator<Item = (Vec3, Vec3, Vec3)>) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for (w, arriving, col_l) in lights {
        let nw = n.dot(w);
        sum += if nw > 0.0 { nw * arriving } else { nw * col_l };
    }
    sum
}

impl Term for NoClamp {
    fn acts_on(&self, material: &lancer_core::Material) -> bool {
        material.diff > 0.0
    }

    fn reads_lights(&self, material: &lancer_core::Material) -> bool {
        material.diff > 0.0
    }

    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let m = ctx.material(chunk.hits, lane);
        let (_, n) = facing(&chunk, lane);
        let mut notes = vec![Note::number("diff", m.diff), Note::vector("Col_Ω", ctx.color(chunk.hits, lane))];
        for (k, (w, _)) in chunk.lights.lane(lane).enumerate() {
            notes.push(Note::number(format!("light {}: N·w (not clamped: the mistake)", k + 1), n.dot(w)));
        }
        notes
    }

    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        for lane in chunk.hit_lanes() {
            let diff = ctx.material(chunk.hits, lane).diff;
            if diff <= 0.0 {
                continue;
            }
            let (_, n) = facing(&chunk, lane);
            let lights = chunk.lights.lane(lane).zip(ctx.lights).map(|((w, arriving), l)| (w, arriving, l.radiance()));
            out.add(lane, diff * ctx.color(chunk.hits, lane) * unclamped_sum(n, lights));
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec3};
    use lancer_core::Material;
    use lancer_shapes::{Object, Shape};

    use crate::terms::probe;

    #[test]
    fn a_light_behind_the_surface_takes_light_away() {
        // The floor y = 0 seen from above; one light 45° above it, one straight below it:
        // N·w = 0.7071 and −1. Lambert adds diff · Col_Ω · 0.7071; the mistake adds
        // diff · Col_Ω · (0.7071 − 1), less than nothing.
        let m = Material { color: Vec3::new(1.0, 0.5, 0.25), diff: 0.8, ..Material::default() };
        let floor = Object::new(Shape::Plane, Affine3A::IDENTITY, 0).unwrap();
        let lights = [probe::light(Vec3::new(4.0, 4.0, 0.0)), probe::light(Vec3::new(0.0, -4.0, 0.0))];
        let (from, u) = (Vec3::new(0.0, 2.0, -2.0), Vec3::new(0.0, -1.0, 1.0).normalize());
        // The ray meets the floor at (0, 0, 0).
        let wrong = probe::run("diffuse", "no-clamp", &[(floor.clone(), m)], &lights, from, u);
        let want = 0.8 * m.color * (std::f32::consts::FRAC_1_SQRT_2 - 1.0);
        assert!((wrong.added - want).abs().max_element() < 1e-5, "{:?} vs {want:?}", wrong.added);
        let right = probe::run("diffuse", "lambert", &[(floor, m)], &lights, from, u);
        assert!((right.added - 0.8 * m.color * std::f32::consts::FRAC_1_SQRT_2).abs().max_element() < 1e-5);
    }

    #[test]
    fn lights_in_front_arrive_as_the_shadow_model_says() {
        // A light in front wholly in shadow (nothing arriving) adds nothing, as in Lambert.
        let sum = super::unclamped_sum(
            Vec3::Y,
            [(Vec3::Y, Vec3::ZERO, Vec3::ONE), (-Vec3::Y, Vec3::ZERO, Vec3::ONE)].into_iter(),
        );
        assert_eq!(sum, -Vec3::ONE);
    }
}

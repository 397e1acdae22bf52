//! `specular`, variant `sign`: a classic mistake of the course, kept to show it and for
//! `lancer diagnose` to recognise it: the Phong highlight with `max(u·w_r, 0)` instead of
//! `max(−u·w_r, 0)`, forgetting that `u` points from the eye towards the surface.
//!
//! Formula, per visible light with `N·w > 0`: `w_r = 2 (N·w) N − w`,
//! `Col += spec · shine · max(u·w_r, 0)^(1/(1−shine)) · Col_L`. The highlight leaves the mirror
//! direction: it shines where the reflected light goes away from the eye, near the silhouette on
//! the side opposite the light, and vanishes where it belongs.
//! Reads: `spec`, `shine`. Parameters: `weight` (every term has it).
//!
//! ```toml
//! [model]
//! terms = ["ambient", "diffuse", { term = "specular", variant = "sign" }]
//! ```

use glam::Vec3;

use super::phong::phong_factor;
use crate::term::facing;
use crate::{Chunk, Mistake, Note, Params, ShadeContext, Term, TermOutput, TermSpec, lit_by, sum_lights};

/// The spec registered as `specular`, variant `sign` (a mistake of `phong`).
pub const SPEC: TermSpec = TermSpec {
    name: "specular",
    variant: "sign",
    summary: "Phong with max(u·w_r, 0) instead of max(−u·w_r, 0): the highlight leaves the mirror direction for the far side",
    reads: &["spec", "shine"],
    params: &[],
    build: |_: &mut Params| Ok(Box::new(Sign)),
    mistake: Some(Mistake {
        of: "phong",
        hint: "check the sign in your Phong term: u is the ray's direction, from the eye towards I, so the highlight is max(−u·w_r, 0)^(1/(1−shine)) with w_r = 2(N·w)N − w",
    }),
};

struct Sign;

impl Term for Sign {
    fn acts_on(&self, material: &lancer_core::Material) -> bool {
        material.spec > 0.0 && material.shine > 0.0 && material.shine < 1.0
    }

    fn why_idle(&self, material: &lancer_core::Material) -> Option<String> {
        super::infinite_exponent(material, "1/(1 − shine)")
    }

    fn reads_lights(&self, material: &lancer_core::Material) -> bool {
        self.acts_on(material)
    }

    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let m = ctx.material(chunk.hits, lane);
        let (_, n) = facing(&chunk, lane);
        let u = chunk.rays.dir.at(lane);
        let mut notes = vec![Note::number("spec", m.spec), Note::number("shine", m.shine)];
        for (k, nw, w) in lit_by(&chunk, lane, n) {
            let c = u.dot(2.0 * nw * n - w);
            notes.push(Note::number(format!("light {k}: u·w_r (mistake: the sign of −u·w_r)"), c));
            notes.push(Note::number(format!("light {k}: shine·max(u·w_r, 0)^exponent"), phong_factor(m.shine, c)));
        }
        notes
    }

    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        for lane in chunk.hit_lanes() {
            let m = ctx.material(chunk.hits, lane);
            if !self.acts_on(m) {
                continue;
            }
            let (_, n) = facing(&chunk, lane);
            let u = chunk.rays.dir.at(lane);
            let sum: Vec3 = sum_lights(&chunk, lane, n, |nw, w| phong_factor(m.shine, u.dot(2.0 * nw * n - w)));
            out.add(lane, m.spec * sum);
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec3};
    use lancer_core::Material;
    use lancer_shapes::{Object, Shape};

    use crate::terms::probe;

    fn floor() -> Object {
        Object::new(Shape::Plane, Affine3A::IDENTITY, 0).unwrap()
    }

    #[test]
    fn seen_along_the_mirror_direction_the_highlight_is_gone() {
        // The floor y = 0, the light at 45° on one side, the eye at 45° on the other: the
        // mirror direction. Phong gives spec · shine · 1; the mistake, u·w_r = −1, nothing.
        let m = Material { spec: 0.8, shine: 0.5, ..Material::default() };
        let light = [probe::light(Vec3::new(-3.0, 3.0, 0.0))];
        let u = Vec3::new(-1.0, -1.0, 0.0).normalize();
        let from = Vec3::new(3.0, 3.0, 0.0);
        let right = probe::run("specular", "phong", &[(floor(), m)], &light, from, u);
        assert!((right.added - Vec3::splat(0.8 * 0.5)).abs().max_element() < 1e-5, "{:?}", right.added);
        let wrong = probe::run("specular", "sign", &[(floor(), m)], &light, from, u);
        assert_eq!(wrong.added, Vec3::ZERO);
    }

    #[test]
    fn it_shines_where_the_reflected_light_goes_away_from_the_eye() {
        // The eye grazing the floor from 10° above it, the light behind the eye at 20°: with
        // u = (cos 10°, −sin 10°, 0) and w = (−cos 20°, sin 20°, 0), w_r = (cos 20°, sin 20°, 0)
        // goes on ahead, away from the eye: −u·w_r = −cos 30° (no highlight), and the mistake's
        // u·w_r = cos 10° cos 20° − sin 10° sin 20° = cos 30° gives spec · shine · cos² 30°.
        let m = Material { spec: 0.8, shine: 0.5, ..Material::default() };
        let (a, b) = (10f32.to_radians(), 20f32.to_radians());
        let u = Vec3::new(a.cos(), -a.sin(), 0.0);
        let light = [probe::light(Vec3::new(-10.0 * b.cos(), 10.0 * b.sin(), 0.0))];
        let from = -u * 2.0;
        let wrong = probe::run("specular", "sign", &[(floor(), m)], &light, from, u);
        let want = 0.8 * 0.5 * (a + b).cos().powi(2);
        assert!((wrong.added - Vec3::splat(want)).abs().max_element() < 1e-4, "{:?} vs {want}", wrong.added);
        let right = probe::run("specular", "phong", &[(floor(), m)], &light, from, u);
        assert_eq!(right.added, Vec3::ZERO, "−u·w_r = −cos 30°: no highlight for the right model");
    }
}

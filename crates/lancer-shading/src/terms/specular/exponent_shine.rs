//! `specular`, variant `exponent-shine`: a classic mistake of the course, kept to show it and
//! for `lancer diagnose` to recognise it: the Phong highlight with the exponent `shine` instead
//! of `1/(1−shine)`.
//!
//! Formula, per visible light with `N·w > 0`: `w_r = 2 (N·w) N − w`,
//! `Col += spec · shine · max(−u·w_r, 0)^shine · Col_L`. With `shine` below 1 the exponent is
//! below 1: the "highlight" is a wide glow over the whole lit side, brightest where it should
//! be but nowhere small. Reads: `spec`, `shine`. Parameters: `weight` (every term has it).
//!
//! ```toml
//! [model]
//! terms = ["ambient", "diffuse", { term = "specular", variant = "exponent-shine" }]
//! ```

use glam::Vec3;

use crate::term::facing;
use crate::{Chunk, Mistake, Note, Params, ShadeContext, Term, TermOutput, TermSpec, lit_by, sum_lights};

/// The spec registered as `specular`, variant `exponent-shine` (a mistake of `phong`).
pub const SPEC: TermSpec = TermSpec {
    name: "specular",
    variant: "exponent-shine",
    summary: "Phong with the exponent shine instead of 1/(1−shine): a wide glow over the lit side, no small highlight",
    reads: &["spec", "shine"],
    params: &[],
    build: |_: &mut Params| Ok(Box::new(ExponentShine)),
    mistake: Some(Mistake {
        of: "phong",
        hint: "check the exponent of your Phong term: it is 1/(1−shine) (shine = 0.95 gives 20, 0.99 gives 100), not shine itself",
    }),
};

struct ExponentShine;

/// The mistaken highlight factor `shine · c^shine` for `c = max(−u·w_r, 0)` (0 where `shine`
/// or `c` is not positive).
#[inline]
pub fn exponent_shine_factor(shine: f32, c: f32) -> f32 {
    if shine <= 0.0 || c <= 0.0 {
        return 0.0;
    }
    shine * super::lobe(c.min(1.0), shine)
}

impl Term for ExponentShine {
    fn acts_on(&self, material: &lancer_core::Material) -> bool {
        material.spec > 0.0 && material.shine > 0.0
    }

    fn reads_lights(&self, material: &lancer_core::Material) -> bool {
        self.acts_on(material)
    }

    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let m = ctx.material(chunk.hits, lane);
        let (_, n) = facing(&chunk, lane);
        let u = chunk.rays.dir.at(lane);
        let mut notes = vec![Note::number("spec", m.spec), Note::number("exponent shine (mistake)", m.shine)];
        for (k, nw, w) in lit_by(&chunk, lane, n) {
            let c = -u.dot(2.0 * nw * n - w);
            notes.push(Note::number(format!("light {k}: −u·w_r"), c));
            notes.push(Note::number(
                format!("light {k}: shine·max(−u·w_r, 0)^shine"),
                exponent_shine_factor(m.shine, c),
            ));
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
            let sum: Vec3 =
                sum_lights(&chunk, lane, n, |nw, w| exponent_shine_factor(m.shine, -u.dot(2.0 * nw * n - w)));
            out.add(lane, m.spec * sum);
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec3};
    use lancer_core::Material;
    use lancer_shapes::{Object, Shape};

    use super::exponent_shine_factor;
    use crate::terms::probe;

    #[test]
    fn the_exponent_is_shine_itself() {
        // c^0.95 instead of c^20: at c = 0.5, 0.5176 instead of 9.5e-7.
        let f = exponent_shine_factor(0.95, 0.5);
        assert!((f - 0.95 * 0.5f32.powf(0.95)).abs() < 1e-6, "{f}");
        assert!(f > 1e5 * crate::terms::specular::phong::phong_factor(0.95, 0.5));
        assert_eq!(exponent_shine_factor(0.0, 0.5), 0.0);
        assert_eq!(exponent_shine_factor(0.5, -0.1), 0.0);
    }

    #[test]
    fn on_a_floor_seen_off_the_mirror_direction_it_still_shines() {
        // The floor y = 0, a light straight above the point hit, the eye at 45°: −u·w_r is
        // cos 45° = 0.7071 (w_r = N, u = (1, −1, 0)/√2). Phong with shine 0.95 gives almost
        // nothing (0.7071^20 = 0.00098); the mistake gives spec · shine · 0.7071^0.95.
        let m = Material { spec: 0.5, shine: 0.95, ..Material::default() };
        let floor = Object::new(Shape::Plane, Affine3A::IDENTITY, 0).unwrap();
        let u = Vec3::new(1.0, -1.0, 0.0).normalize();
        let seen = probe::run(
            "specular",
            "exponent-shine",
            &[(floor.clone(), m)],
            &[probe::light(Vec3::new(1.0, 5.0, 0.0))],
            Vec3::new(0.0, 1.0, 0.0),
            u,
        );
        let want = 0.5 * 0.95 * std::f32::consts::FRAC_1_SQRT_2.powf(0.95);
        assert!((seen.added - Vec3::splat(want)).abs().max_element() < 1e-5, "{:?} vs {want}", seen.added);
        let right = probe::run(
            "specular",
            "phong",
            &[(floor, m)],
            &[probe::light(Vec3::new(1.0, 5.0, 0.0))],
            Vec3::new(0.0, 1.0, 0.0),
            u,
        );
        assert!(right.added.x < 1e-3 && right.added.x > 0.0, "{:?}", right.added);
    }
}

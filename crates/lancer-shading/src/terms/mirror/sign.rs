//! `mirror`, variant `sign`: a classic mistake of the course, kept to show it and for
//! `lancer diagnose` to recognise it: the reflected direction with the wrong sign,
//! `u_r = 2 (N·u) N − u` instead of `u − 2 (N·u) N`.
//!
//! Formula: `u_r = −(u − 2 (N·u) N)`, trace `R_r = [I, u_r)`, `Col += spec · Col(R_r)`. The
//! reflected ray goes into the surface instead of away from it: a mirror ball shows its own
//! inside, a mirror plane what lies behind it.
//! Reads: `spec`. Parameters: `weight` (every term has it).
//!
//! ```toml
//! [model]
//! terms = ["ambient", "diffuse", "specular", { term = "mirror", variant = "sign" }]
//! ```

use glam::Vec3;

use crate::{Chunk, Mistake, Note, Params, ShadeContext, Term, TermOutput, TermSpec};

/// The spec registered as `mirror`, variant `sign` (a mistake of `constant`).
pub const SPEC: TermSpec = TermSpec {
    name: "mirror",
    variant: "sign",
    summary: "the reflected direction with the wrong sign, u_r = 2(N·u)N − u: the ray goes into the surface, not away",
    reads: &["spec"],
    params: &[],
    build: |_: &mut Params| Ok(Box::new(Sign)),
    mistake: Some(Mistake {
        of: "constant",
        hint: "check u_r = u − 2(N·u)N with u the incoming ray's direction (from the eye towards I): the reflected ray must leave on the side it came from, N·u_r = −N·u",
    }),
};

struct Sign;

/// The mistaken direction `−(u − 2 (N·u) N)` at `hit` (the opposite of
/// [`crate::mirror_direction`]).
#[inline]
pub fn wrong_mirror_direction(hit: &lancer_shapes::Hit, u: Vec3) -> Vec3 {
    -crate::mirror_direction(hit, u)
}

impl Term for Sign {
    fn acts_on(&self, material: &lancer_core::Material) -> bool {
        material.spec > 0.0
    }

    fn reads_lights(&self, _: &lancer_core::Material) -> bool {
        false
    }

    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let m = ctx.material(chunk.hits, lane);
        let hit = ctx.hit(chunk.hits, lane);
        vec![
            Note::number("spec (weight of R_r)", m.spec),
            Note::vector("u_r = 2(N·u)N − u (the mistake)", wrong_mirror_direction(&hit, chunk.rays.dir.at(lane))),
        ]
    }

    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        for lane in chunk.hit_lanes() {
            let spec = ctx.material(chunk.hits, lane).spec;
            if spec <= 0.0 || !out.can_spawn(lane) {
                continue;
            }
            let hit = ctx.hit(chunk.hits, lane);
            let u_r = wrong_mirror_direction(&hit, chunk.rays.dir.at(lane));
            out.spawn(lane, ctx.geometry.spawn(&hit, u_r), u_r, Vec3::splat(spec));
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
    fn the_reflected_ray_goes_into_the_surface() {
        // A ray going down at 45° onto the floor y = 0: u = (1, −1, 0)/√2 reflects to
        // (1, 1, 0)/√2; the mistake sends it to (−1, −1, 0)/√2, back where it came from and
        // through the floor, weighted by spec.
        let m = Material { spec: 0.6, ..Material::default() };
        let floor = Object::new(Shape::Plane, Affine3A::IDENTITY, 0).unwrap();
        let u = Vec3::new(1.0, -1.0, 0.0).normalize();
        let from = Vec3::new(-2.0, 2.0, 0.0);
        let right = probe::run("mirror", "constant", &[(floor.clone(), m)], &[], from, u);
        let wrong = probe::run("mirror", "sign", &[(floor, m)], &[], from, u);
        let ([r], [w]) = (&right.children[..], &wrong.children[..]) else { panic!("one child each") };
        assert!((r.1 - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6, "{:?}", r.1);
        assert!((w.1 - Vec3::new(-1.0, -1.0, 0.0).normalize()).length() < 1e-6, "{:?}", w.1);
        assert_eq!(w.2, Vec3::splat(0.6));
        assert!((w.0 - r.0).length() < 1e-4, "both start at the hit: {:?} {:?}", w.0, r.0);
    }
}

//! `refraction`, variant `no-exit-bend`: a classic mistake of the course, kept to show it and for
//! `lancer diagnose` to recognise it: the ray is bent on entering the object but leaves it at
//! `J` along `u_t`, never bent again.
//!
//! Formula: entering at `I`, `u_t = VctTransmis(u, −N, 1/n)`; the ray crosses the object to its
//! exit `J` and `Col += alpha · Col(R_t)` with `R_t = [J, u_t)` (the right model bends it again,
//! `v_t = VctTransmis(u_t, N_j, n)`). A glass slab no longer gives a ray parallel to the one that
//! came in; a ball bends the view half as much. A ray that reaches the surface from inside (a
//! camera in glass) goes straight on. Only when `alpha > 0`.
//! Reads: `alpha`, `n`. Parameters: `weight` (every term has it).
//!
//! ```toml
//! [model]
//! terms = ["ambient", "diffuse", { term = "refraction", variant = "no-exit-bend" }]
//! ```

use glam::Vec3;
use lancer_shapes::{Hit, Origin};

use crate::{Chunk, Mistake, Note, Params, ShadeContext, Term, TermOutput, TermSpec};

/// The spec registered as `refraction`, variant `no-exit-bend` (a mistake of `seed`).
pub const SPEC: TermSpec = TermSpec {
    name: "refraction",
    variant: "no-exit-bend",
    summary: "the ray leaves the object at J along u_t, never bent again by VctTransmis(u_t, N_j, n)",
    reads: &["alpha", "n"],
    params: &[],
    build: |_: &mut Params| Ok(Box::new(NoExitBend)),
    mistake: Some(Mistake {
        of: "seed",
        hint: "after finding the exit point J, bend the ray a second time: v_t = VctTransmis(u_t, N_j, n) with N_j the outward normal at J, and trace R_t = [J, v_t)",
    }),
};

struct NoExitBend;

/// Where the mistaken `R_t` starts and its direction, for a hit `hit` reached along `u` on
/// glass of index `n`.
fn unbent(ctx: &ShadeContext<'_>, hit: &Hit, u: Vec3, n: f32) -> Option<(Origin, Vec3)> {
    if !hit.front {
        return Some((ctx.geometry.spawn(hit, u), u));
    }
    let (u_t, _) = super::bend(u, hit, 1.0 / n, false)?;
    let exit = ctx.geometry.exit(hit, u_t)?;
    Some((ctx.geometry.spawn(&exit, u_t), u_t))
}

impl Term for NoExitBend {
    fn acts_on(&self, material: &lancer_core::Material) -> bool {
        material.alpha > 0.0
    }

    fn reads_lights(&self, _: &lancer_core::Material) -> bool {
        false
    }

    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let m = ctx.material(chunk.hits, lane);
        let hit = ctx.hit(chunk.hits, lane);
        let mut notes = vec![Note::number("alpha (weight of R_t)", m.alpha), Note::number("n", m.n)];
        if let Some((from, u_t)) = unbent(ctx, &hit, chunk.rays.dir.at(lane), m.n) {
            notes.push(Note::point("J (exit)", from.point));
            notes.push(Note::vector("u_t, not bent at J (the mistake)", u_t));
        }
        notes
    }

    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        super::spawn_along(ctx, chunk, out, unbent);
    }
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec3};
    use lancer_core::Material;
    use lancer_shapes::{Object, Shape};

    use crate::terms::probe;

    #[test]
    fn through_a_slab_the_ray_leaves_along_its_inside_direction() {
        // u = (0.6, −0.8, 0), n = 1.5: inside (0.4, −√0.84, 0), leaving the slab's bottom at
        // x = 2 · 0.4/√0.84 = 0.873 still going that way (the right model: along u again).
        let glass = Material { alpha: 1.0, n: 1.5, diff: 0.0, ..Material::default() };
        let slab = Object::new(Shape::Cube, Affine3A::from_scale(Vec3::new(10.0, 1.0, 10.0)), 0).unwrap();
        let u = Vec3::new(0.6, -0.8, 0.0);
        let from = Vec3::new(0.0, 1.0, 0.0) - 2.0 * u;
        let seen = probe::run("refraction", "no-exit-bend", &[(slab.clone(), glass)], &[], from, u);
        let [(at, dir, _)] = seen.children[..] else { panic!("one child: {:?}", seen.children) };
        assert!((at - Vec3::new(2.0 * 0.4 / 0.84f32.sqrt(), -1.0, 0.0)).length() < 2e-3, "{at}");
        assert!((dir - Vec3::new(0.4, -(0.84f32).sqrt(), 0.0)).length() < 1e-5, "{dir}");
        let right = probe::run("refraction", "seed", &[(slab, glass)], &[], from, u);
        assert!((right.children[0].1 - u).length() < 1e-5, "{:?}", right.children);
    }
}

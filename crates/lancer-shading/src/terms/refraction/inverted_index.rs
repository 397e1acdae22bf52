//! `refraction`, variant `inverted-index`: a classic mistake of the course, kept to show it and
//! for `lancer diagnose` to recognise it: `VctTransmis` given `n` where `1/n` belongs (entering
//! from the air) and `1/n` where `n` belongs (leaving the object): the index ratio `δ = n1/n2`
//! taken upside down.
//!
//! Formula: entering at `I`, `u_t = VctTransmis(u, −N, n)`; the ray crosses the object to its
//! exit `J`, then `v_t = VctTransmis(u_t, N_j, 1/n)` and `Col += alpha · Col(R_t)` with
//! `R_t = [J, v_t)`. Inside, the ray bends away from the normal instead of towards it: a glass
//! ball magnifies the wrong way, and a ray entering past the critical angle of the inverted
//! ratio reflects totally at `I` and brings nothing back. Only when `alpha > 0`.
//! Reads: `alpha`, `n`. Parameters: `weight` (every term has it).
//!
//! ```toml
//! [model]
//! terms = ["ambient", "diffuse", { term = "refraction", variant = "inverted-index" }]
//! ```

use glam::Vec3;
use lancer_shapes::{Hit, Origin};

use crate::{Chunk, Mistake, Note, Params, ShadeContext, Term, TermOutput, TermSpec};

/// The spec registered as `refraction`, variant `inverted-index` (a mistake of `seed`).
pub const SPEC: TermSpec = TermSpec {
    name: "refraction",
    variant: "inverted-index",
    summary: "VctTransmis given n on entry and 1/n on exit, where 1/n and n belong: the glass bends the view the wrong way",
    reads: &["alpha", "n"],
    params: &[],
    build: |_: &mut Params| Ok(Box::new(InvertedIndex)),
    mistake: Some(Mistake {
        of: "seed",
        hint: "VctTransmis takes delta = n1/n2, the index the ray leaves over the index it enters: entering the object from the air it is 1/n, leaving it it is n",
    }),
};

struct InvertedIndex;

/// The direction inside and where the mistaken `R_t` starts with its direction, for a hit
/// `hit` reached along `u` on glass of index `n`. `None` where the inverted ratio reflects
/// totally.
fn inverted(ctx: &ShadeContext<'_>, hit: &Hit, u: Vec3, n: f32) -> Option<(Option<Vec3>, Origin, Vec3)> {
    let (at, u_t, inside) = if hit.front {
        let (u_t, _) = super::bend(u, hit, n, false)?;
        (ctx.geometry.exit(hit, u_t)?, u_t, Some(u_t))
    } else {
        (*hit, u, None)
    };
    let (v_t, _) = super::bend(u_t, &at, 1.0 / n, true)?;
    Some((inside, ctx.geometry.spawn(&at, v_t), v_t))
}

impl Term for InvertedIndex {
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
        match inverted(ctx, &hit, chunk.rays.dir.at(lane), m.n) {
            Some((inside, _, v_t)) => {
                if let Some(u_t) = inside {
                    notes.push(Note::vector("u_t = VctTransmis(u, −N, n) (the mistake: n, not 1/n)", u_t));
                }
                notes.push(Note::vector("v_t = VctTransmis(u_t, N_j, 1/n) (the mistake: 1/n, not n)", v_t));
            }
            None => notes.push(Note::text("R_t", "total reflection by the inverted ratio: brings nothing")),
        }
        notes
    }

    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        super::spawn_along(ctx, chunk, out, |ctx, hit, u, n| {
            inverted(ctx, hit, u, n).map(|(_, from, dir)| (from, dir))
        });
    }
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec3};
    use lancer_core::Material;
    use lancer_shapes::{Object, Shape};

    use crate::terms::probe;

    fn slab() -> Object {
        // 2 thick: from y = −1 to y = 1.
        Object::new(Shape::Cube, Affine3A::from_scale(Vec3::new(10.0, 1.0, 10.0)), 0).unwrap()
    }

    #[test]
    fn through_a_slab_the_ray_is_shifted_by_the_inverted_ratio() {
        // u = (0.6, −0.8, 0), n = 1.5. Inside, sin θt = 1.5 · 0.6 = 0.9 (the right 0.6/1.5 =
        // 0.4), cos θt = √0.19: across the slab the ray moves 2 · 0.9/√0.19 = 4.129 along x
        // (the right 0.873), and leaves parallel to itself.
        let glass = Material { alpha: 1.0, n: 1.5, diff: 0.0, ..Material::default() };
        let u = Vec3::new(0.6, -0.8, 0.0);
        let from = Vec3::new(0.0, 1.0, 0.0) - 2.0 * u;
        let seen = probe::run("refraction", "inverted-index", &[(slab(), glass)], &[], from, u);
        let [(at, dir, _)] = seen.children[..] else { panic!("one child: {:?}", seen.children) };
        assert!((at - Vec3::new(2.0 * 0.9 / 0.19f32.sqrt(), -1.0, 0.0)).length() < 2e-3, "{at}");
        assert!((dir - u).length() < 1e-5, "{dir}");
        let right = probe::run("refraction", "seed", &[(slab(), glass)], &[], from, u);
        assert!((right.children[0].0.x - 2.0 * 0.4 / 0.84f32.sqrt()).abs() < 2e-3, "{:?}", right.children);
    }

    #[test]
    fn past_the_inverted_critical_angle_nothing_comes_through() {
        // 60° from the normal: sin 60° · 1.5 = 1.3 > 1, a total reflection at the entry.
        let glass = Material { alpha: 1.0, n: 1.5, diff: 0.0, ..Material::default() };
        let a = 60f32.to_radians();
        let u = Vec3::new(a.sin(), -a.cos(), 0.0);
        let seen =
            probe::run("refraction", "inverted-index", &[(slab(), glass)], &[], Vec3::new(0.0, 1.0, 0.0) - 2.0 * u, u);
        assert!(seen.children.is_empty(), "{:?}", seen.children);
        let right = probe::run("refraction", "seed", &[(slab(), glass)], &[], Vec3::new(0.0, 1.0, 0.0) - 2.0 * u, u);
        assert_eq!(right.children.len(), 1);
    }
}

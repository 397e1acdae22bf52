//! `refraction`, variant `sign-trap`: a classic mistake of the course, kept to show it and for
//! `lancer diagnose` to recognise it: the handout's sign trap, `VctTransmis` given the outward
//! normal `N` on entry instead of the normal on the transmission side, `−N`.
//!
//! Formula: entering at `I`, `u_t = VctTransmis(u, N, 1/n)` by the handout's formula as
//! written, `(√k − δ (N·u)) N + δ u` with `δ = 1/n`, `k = 1 − δ² (1 − (N·u)²)`: since `N·u < 0`
//! its normal component is `√k`, outwards. The ray turns back out at `I` and leaves there:
//! `R_t = [I, u_t)`, `Col += alpha · Col(R_t)`. The glass shows a mirror-like image of what
//! is in front of it instead of what is behind it. A ray that reaches the surface from inside
//! (a camera in glass) leaves as in `seed`. Only when `alpha > 0`.
//! Reads: `alpha`, `n`. Parameters: `weight` (every term has it).
//!
//! ```toml
//! [model]
//! terms = ["ambient", "diffuse", { term = "refraction", variant = "sign-trap" }]
//! ```

use glam::Vec3;
use lancer_shapes::{Hit, Origin};

use crate::{Chunk, Mistake, Note, Params, ShadeContext, Term, TermOutput, TermSpec};

/// The spec registered as `refraction`, variant `sign-trap` (a mistake of `seed`).
pub const SPEC: TermSpec = TermSpec {
    name: "refraction",
    variant: "sign-trap",
    summary: "VctTransmis given the outward normal N on entry, not −N: the ray turns back out and the glass shows a reflection",
    reads: &["alpha", "n"],
    params: &[],
    build: |_: &mut Params| Ok(Box::new(SignTrap)),
    mistake: Some(Mistake {
        of: "seed",
        hint: "on entry give VctTransmis the normal on the transmission side, −N (N·u < 0 there): u_t = VctTransmis(u, −N, 1/n), which goes into the object",
    }),
};

struct SignTrap;

/// The handout's `VctTransmis(u, N', δ)` as written, `(√k − δ ps) N' + δ u` with `ps = N'·u`
/// and `k = 1 − δ² (1 − ps²)`, taking `N'` as given even on the wrong side (unlike
/// [`lancer_core::optics::vct_transmis`], which turns it round). `None` when `k < 0`.
#[inline]
pub fn handout_vct_transmis(u: Vec3, n: Vec3, delta: f32) -> Option<Vec3> {
    let ps = n.dot(u).clamp(-1.0, 1.0);
    let k = 1.0 - delta * delta * (1.0 - ps * ps);
    if k < 0.0 {
        return None;
    }
    Some(((k.sqrt() - delta * ps) * n + delta * u).try_normalize().unwrap_or(u))
}

/// Where the mistaken `R_t` starts and its direction, for a hit `hit` reached along `u` on
/// glass of index `n`.
fn trapped(ctx: &ShadeContext<'_>, hit: &Hit, u: Vec3, n: f32) -> Option<(Origin, Vec3)> {
    if !hit.front {
        return super::passage(ctx, hit, u, n).map(|p| (p.from, p.dir));
    }
    let u_t = handout_vct_transmis(u, hit.shading, 1.0 / n)?;
    Some((ctx.geometry.spawn(hit, u_t), u_t))
}

impl Term for SignTrap {
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
        if let Some((_, u_t)) = trapped(ctx, &hit, chunk.rays.dir.at(lane), m.n) {
            notes.push(Note::vector("u_t = VctTransmis(u, N, 1/n) (the mistake: N, not −N)", u_t));
        }
        notes
    }

    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        super::spawn_along(ctx, chunk, out, trapped);
    }
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec3};
    use lancer_core::Material;
    use lancer_shapes::{Object, Shape};

    use super::handout_vct_transmis;
    use crate::terms::probe;

    #[test]
    fn the_outward_normal_sends_the_ray_back_out_as_snells_mirror_image() {
        // u = (0.6, −0.8, 0) onto a face of normal +y, n = 1.5: sin θt = 0.6/1.5 = 0.4, so the
        // right direction is (0.4, −√0.84, 0); the trap gives (0.4, +√0.84, 0).
        let u = Vec3::new(0.6, -0.8, 0.0);
        let right = lancer_core::optics::vct_transmis(u, -Vec3::Y, 1.0 / 1.5).unwrap();
        let trap = handout_vct_transmis(u, Vec3::Y, 1.0 / 1.5).unwrap();
        assert!((right - Vec3::new(0.4, -(0.84f32).sqrt(), 0.0)).length() < 1e-5, "{right}");
        assert!((trap - Vec3::new(0.4, (0.84f32).sqrt(), 0.0)).length() < 1e-5, "{trap}");
        // With −N, the handout's formula is the right one.
        assert!((handout_vct_transmis(u, -Vec3::Y, 1.0 / 1.5).unwrap() - right).length() < 1e-6);
    }

    #[test]
    fn through_a_slab_the_ray_leaves_at_the_entry_point() {
        let glass = Material { alpha: 1.0, n: 1.5, diff: 0.0, ..Material::default() };
        let slab = Object::new(Shape::Cube, Affine3A::from_scale(Vec3::new(10.0, 1.0, 10.0)), 0).unwrap();
        let u = Vec3::new(0.6, -0.8, 0.0);
        let from = Vec3::new(0.0, 1.0, 0.0) - 2.0 * u;
        let seen = probe::run("refraction", "sign-trap", &[(slab, glass)], &[], from, u);
        let [(at, dir, weight)] = seen.children[..] else { panic!("one child: {:?}", seen.children) };
        assert!((at - Vec3::new(0.0, 1.0, 0.0)).length() < 1e-4, "{at}");
        assert!((dir - Vec3::new(0.4, (0.84f32).sqrt(), 0.0)).length() < 1e-5, "{dir}");
        assert_eq!(weight, Vec3::ONE);
    }
}

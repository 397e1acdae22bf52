//! `mirror`, variant `constant` (the default, the handout's): recursive reflection of the rest
//! of the scene, weighted by `spec`.
//!
//! Formula: `u_r = u − 2 (N·u) N`, trace `R_r = [I, u_r)`, `Col += spec · Col(R_r)`, until the
//! depth reaches `max_depth`. The mirror image holds everything the reflected rays bring back.
//! Reads: `spec`. Parameters: `weight` (every term has it).
//!
//! ```toml
//! [model]
//! max_depth = 5
//! terms = ["ambient", "diffuse", "specular", "mirror"]
//! ```

use glam::Vec3;

use crate::{Chunk, Note, Params, ShadeContext, Term, TermOutput, TermSpec};

/// The spec registered as `mirror`, variant `constant`.
pub const SPEC: TermSpec = TermSpec {
    name: "mirror",
    variant: "constant",
    summary: "spec · Col(R_r): recursive mirror reflection weighted by spec",
    params: &[],
    build: |_: &mut Params| Ok(Box::new(Mirror)),
};

struct Mirror;

impl Term for Mirror {
    fn acts_on(&self, material: &lancer_core::Material) -> bool {
        material.spec > 0.0
    }

    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let m = ctx.material(chunk.hits, lane);
        let hit = ctx.hit(chunk.hits, lane);
        vec![
            Note::number("spec (weight of R_r)", m.spec),
            Note::vector("u_r = u − 2(N·u)N", crate::mirror_direction(&hit, chunk.rays.dir.at(lane))),
        ]
    }

    fn reads_lights(&self, _: &lancer_core::Material) -> bool {
        false
    }

    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        for lane in chunk.hit_lanes() {
            let m = ctx.material(chunk.hits, lane);
            if m.spec <= 0.0 || !out.can_spawn(lane) {
                continue;
            }
            let hit = ctx.hit(chunk.hits, lane);
            let u_r = crate::mirror_direction(&hit, chunk.rays.dir.at(lane));
            let from = ctx.geometry.spawn(&hit, u_r);
            out.spawn(lane, from, u_r, Vec3::splat(m.spec));
        }
    }
}

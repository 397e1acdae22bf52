//! `ambient`, variant `seed` (its only one, the handout's): light that bathes the whole scene
//! uniformly.
//!
//! Formula: `Col += ambi · Col_Ω`, once per hit, whatever the lights.
//! Reads: `ambi`, `color`. Parameters: `weight` (every term has it).
//!
//! ```toml
//! [model]
//! terms = ["ambient"]
//! ```

use glam::Vec3;

use crate::lanes::Group;
use crate::{Chunk, Note, Params, ShadeContext, Term, TermOutput, TermSpec};

/// The spec registered as `ambient`, variant `seed`.
pub const SPEC: TermSpec = TermSpec {
    name: "ambient",
    variant: "seed",
    summary: "ambi · Col_Ω: uniform light from unmodelled inter-reflections",
    reads: &["ambi", "color"],
    params: &[],
    build: |_: &mut Params| Ok(Box::new(Ambient)),
    mistake: None,
};

struct Ambient;

impl Term for Ambient {
    fn acts_on(&self, material: &lancer_core::Material) -> bool {
        material.ambi > 0.0
    }

    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let m = ctx.material(chunk.hits, lane);
        vec![Note::number("ambi", m.ambi), Note::vector("Col_Ω", ctx.color(chunk.hits, lane))]
    }

    fn reads_lights(&self, _: &lancer_core::Material) -> bool {
        false
    }

    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        if ctx.reference {
            for lane in chunk.hit_lanes() {
                if let Some(colour) = reference(ctx, chunk, lane) {
                    out.add(lane, colour);
                }
            }
            return;
        }
        // Eight lanes at a time: `reference`'s arithmetic lane by lane (so the same bits).
        for group in Group::all(chunk.hits) {
            let (ambi, active) = group.param(ctx, chunk.hits, |m| m.ambi, |a| a > 0.0);
            if active != 0 {
                let (ambi, color) = (wide::f32x8::new(ambi), group.color(chunk.hits));
                out.add_lanes(group.base, active, &color.map(|c| ambi * c));
            }
        }
    }
}

/// The reference form, one hit at a time: `ambi · Col_Ω`, or nothing where `ambi` is not
/// positive.
fn reference(ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Option<Vec3> {
    let ambi = ctx.material(chunk.hits, lane).ambi;
    let col_omega = ctx.color(chunk.hits, lane);
    (ambi > 0.0).then(|| ambi * col_omega)
}

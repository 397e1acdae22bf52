//! `diffuse`, variant `lambert` (the default, the handout's): matte reflection, independent of
//! the viewpoint.
//!
//! Formula: `Col += diff · max(N·w, 0) · Col_Ω · Col_L` per visible light.
//! Reads: `diff`, `color`. Parameters: `weight` (every term has it).
//!
//! ```toml
//! [model]
//! terms = ["ambient", "diffuse"]
//! ```

use glam::Vec3;
use wide::f32x8;

use crate::lanes::{self, Group};
use crate::term::facing;
use crate::{Chunk, Note, Params, ShadeContext, Term, TermOutput, TermSpec, lit_by};

/// The spec registered as `diffuse`, variant `lambert`.
pub const SPEC: TermSpec = TermSpec {
    name: "diffuse",
    variant: "lambert",
    summary: "diff · (N·w) · Col_Ω · Col_L: Lambert's matte reflection",
    reads: &["diff", "color"],
    params: &[],
    build: |_: &mut Params| Ok(Box::new(Lambert)),
    mistake: None,
};

struct Lambert;

impl Term for Lambert {
    fn acts_on(&self, material: &lancer_core::Material) -> bool {
        material.diff > 0.0
    }

    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let m = ctx.material(chunk.hits, lane);
        let (_, n) = facing(&chunk, lane);
        let mut notes = vec![Note::number("diff", m.diff), Note::vector("Col_Ω", ctx.color(chunk.hits, lane))];
        notes.extend(lit_by(&chunk, lane, n).map(|(k, nw, _)| Note::number(format!("light {k}: N·w"), nw)));
        notes
    }

    fn reads_lights(&self, material: &lancer_core::Material) -> bool {
        material.diff > 0.0
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
        // Eight lanes at a time, `reference`'s arithmetic lane by lane (so the same bits).
        for group in Group::all(chunk.hits) {
            // Skipped where `diff <= 0` (a NaN goes on, as lane by lane).
            let (diff, active) = group.param(ctx, chunk.hits, |m| m.diff, |d| d > 0.0 || d.is_nan());
            if active == 0 {
                continue;
            }
            let n = group.facing(chunk.hits);
            let sum = group.sum_lights::<false>(chunk.lights, &n, lanes::mask(active), |nw, _| nw);
            let (diff, color) = (f32x8::new(diff), group.color(chunk.hits));
            let colour: lanes::V3 = std::array::from_fn(|a| diff * color[a] * sum[a]);
            out.add_lanes(group.base, active, &colour);
        }
    }
}

/// The reference form, one hit at a time: `Σ_lights diff · max(N·w, 0) · Col_Ω · Col_L · T`,
/// with `N` the shading normal facing the ray and `Col_L · T` the light arriving from each light
/// ([`Chunk::lights`]), summed as `diff · Col_Ω · Σ (N·w) · Col_L · T` over the lights in front of
/// the surface that send something. Nothing where `diff` is not positive.
fn reference(ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Option<Vec3> {
    let diff = ctx.material(chunk.hits, lane).diff;
    if diff <= 0.0 {
        return None;
    }
    let n = chunk.hits.facing_normal(lane);
    let mut sum = Vec3::ZERO;
    for (w, col_l_t) in chunk.lights.lane(lane) {
        let n_dot_w = n.dot(w);
        // `max(N·w, 0)`: a light behind the surface, or wholly in shadow, adds nothing.
        if n_dot_w > 0.0 && col_l_t != Vec3::ZERO {
            sum += n_dot_w * col_l_t;
        }
    }
    Some(diff * ctx.color(chunk.hits, lane) * sum)
}

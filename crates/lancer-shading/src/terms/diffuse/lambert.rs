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

use crate::term::facing;
use crate::{Chunk, Note, Params, ShadeContext, Term, TermOutput, TermSpec, lit_by, sum_lights};

/// The spec registered as `diffuse`, variant `lambert`.
pub const SPEC: TermSpec = TermSpec {
    name: "diffuse",
    variant: "lambert",
    summary: "diff · (N·w) · Col_Ω · Col_L: Lambert's matte reflection",
    params: &[],
    build: |_: &mut Params| Ok(Box::new(Lambert)),
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
        for lane in chunk.hit_lanes() {
            let m = ctx.material(chunk.hits, lane);
            if m.diff <= 0.0 {
                continue;
            }
            let (_, n) = facing(&chunk, lane);
            let sum = sum_lights(&chunk, lane, n, |nw, _| nw);
            out.add(lane, m.diff * ctx.color(chunk.hits, lane) * sum);
        }
    }
}

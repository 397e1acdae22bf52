//! `specular`, variant `blinn-normalized`: energy-normalised Blinn-Phong.
//!
//! Formula, per visible light with `N·w > 0`: `h = normalize(w − u)`,
//! `Col += spec · (e + 8)/(8π) · (N·h)^e · (N·w) · Col_L`. The factor `(e + 8)/(8π)` keeps the
//! reflected energy about constant as `e` changes: sharper highlights get brighter peaks, not
//! just smaller spots. `e` is `exponent` if given, else `4 / (1 − shine)`; here `spec` alone sets
//! the strength (`shine` only the sharpness), and `shine = 1` with no `exponent` gives nothing.
//! Reads: `spec`, `shine`. Parameters: `exponent` (default derived from `shine`), `weight`.
//!
//! ```toml
//! [model]
//! terms = ["ambient", "diffuse", { term = "specular", variant = "blinn-normalized" }]
//! ```

use std::f32::consts::PI;

use super::{EXPONENT, blinn_exponent, half_vector_lobe, read_exponent};
use crate::term::facing;
use crate::{Chunk, Note, Params, ShadeContext, Term, TermOutput, TermSpec, lit_by, sum_lights};

/// The spec registered as `specular`, variant `blinn-normalized`.
pub const SPEC: TermSpec = TermSpec {
    name: "specular",
    variant: "blinn-normalized",
    summary: "spec · (e+8)/(8π) · (N·h)^e · (N·w) · Col_L: energy-normalised Blinn-Phong",
    reads: &["spec", "shine"],
    params: &[EXPONENT],
    build: |p: &mut Params| Ok(Box::new(BlinnNormalized { exponent: read_exponent(p)? })),
    mistake: None,
};

struct BlinnNormalized {
    exponent: Option<f32>,
}

impl Term for BlinnNormalized {
    fn acts_on(&self, material: &lancer_core::Material) -> bool {
        material.spec > 0.0 && (self.exponent.is_some() || material.shine < 1.0)
    }

    /// `exponent` if given, else derived from `shine` ([`blinn_exponent`]).
    fn highlight_exponent(&self, material: &lancer_core::Material) -> Option<f32> {
        self.exponent.or_else(|| blinn_exponent(material.shine))
    }

    fn why_idle(&self, material: &lancer_core::Material) -> Option<String> {
        // A fixed exponent does not come from shine.
        if self.exponent.is_some() { None } else { super::infinite_exponent(material, "4/(1 − shine)") }
    }

    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let m = ctx.material(chunk.hits, lane);
        let (_, n) = facing(&chunk, lane);
        let u = chunk.rays.dir.at(lane);
        let mut notes = vec![Note::number("spec", m.spec)];
        let Some(e) = self.highlight_exponent(m) else { return notes };
        notes.push(Note::number(if self.exponent.is_some() { "exponent" } else { "exponent 4/(1−shine)" }, e));
        notes.push(Note::number("(e + 8)/(8π)", (e + 8.0) / (8.0 * PI)));
        for (k, nw, w) in lit_by(&chunk, lane, n) {
            let h = (w - u).normalize_or_zero();
            notes.push(Note::number(format!("light {k}: N·h"), n.dot(h)));
            notes.push(Note::number(format!("light {k}: N·w"), nw));
        }
        notes
    }

    fn reads_lights(&self, material: &lancer_core::Material) -> bool {
        material.spec > 0.0
    }

    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        for lane in chunk.hit_lanes() {
            let m = ctx.material(chunk.hits, lane);
            if m.spec <= 0.0 {
                continue;
            }
            let Some(e) = self.highlight_exponent(m) else { continue };
            let (_, n) = facing(&chunk, lane);
            let u = chunk.rays.dir.at(lane);
            let norm = (e + 8.0) / (8.0 * PI);
            let sum = sum_lights(&chunk, lane, n, |nw, w| norm * half_vector_lobe(n, w, u, e) * nw);
            out.add(lane, m.spec * sum);
        }
    }
}

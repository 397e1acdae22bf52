//! `mirror`, variant `schlick`: reflection weighted by the Fresnel–Schlick approximation, so
//! surfaces reflect little head-on and almost everything at grazing angles (a lake at sunset).
//!
//! Formula: with `cos θ = |N·u|` and `F0 = ((n − 1)/(n + 1))²` from the material's index
//! (0.04 for n = 1.5), or the `f0` parameter when given: `Col += F(θ) · Col(R_r)`,
//! `F(θ) = F0 + (1 − F0)(1 − cos θ)⁵`. Only surfaces with `spec > 0` are mirrors at all.
//! Reads: `spec` (as a switch), `n`. Parameters: `f0` (default: from `n`), `weight`.
//!
//! ```toml
//! [model]
//! terms = ["ambient", "diffuse", "specular", { term = "mirror", variant = "schlick" }]
//! ```

use glam::Vec3;
use lancer_core::optics::{f0_from_index, schlick};

use crate::term::facing;
use crate::{Chunk, Note, ParamSpec, Params, ShadeContext, Term, TermOutput, TermSpec};

/// The spec registered as `mirror`, variant `schlick`.
pub const SPEC: TermSpec = TermSpec {
    name: "mirror",
    variant: "schlick",
    summary: "F(θ) · Col(R_r): reflection weighted by Fresnel–Schlick from the index n",
    reads: &["spec", "n"],
    params: &[ParamSpec {
        name: "f0",
        default: "((n−1)/(n+1))² per material",
        doc: "reflectance at normal incidence for every material (e.g. 0.9 for metal)",
    }],
    build: |p: &mut Params| {
        let f0 = p.number("f0", -1.0, 0.0, 1.0)?;
        Ok(Box::new(Schlick { f0: (f0 >= 0.0).then_some(f0 as f32) }))
    },
    mistake: None,
};

struct Schlick {
    f0: Option<f32>,
}

impl Term for Schlick {
    fn acts_on(&self, material: &lancer_core::Material) -> bool {
        material.spec > 0.0
    }

    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let m = ctx.material(chunk.hits, lane);
        let (_, n) = facing(&chunk, lane);
        let u = chunk.rays.dir.at(lane);
        let f0 = self.f0.unwrap_or_else(|| f0_from_index(m.n));
        let hit = ctx.hit(chunk.hits, lane);
        vec![
            Note::number("F0", f0),
            Note::number("N·u", n.dot(u)),
            Note::number("F = F0 + (1 − F0)(1 − |N·u|)^5 (weight of R_r)", schlick(n.dot(u), f0)),
            Note::vector("u_r = u − 2(N·u)N", crate::mirror_direction(&hit, u)),
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
            let (_, n) = facing(&chunk, lane);
            let u = chunk.rays.dir.at(lane);
            let f = schlick(n.dot(u), self.f0.unwrap_or_else(|| f0_from_index(m.n)));
            let hit = ctx.hit(chunk.hits, lane);
            let u_r = crate::mirror_direction(&hit, u);
            out.spawn(lane, ctx.geometry.spawn(&hit, u_r), u_r, Vec3::splat(f));
        }
    }
}

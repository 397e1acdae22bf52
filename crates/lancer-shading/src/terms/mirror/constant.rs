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
use lancer_core::rays::PACKET;

use crate::lanes::{self, Group};
use crate::{Chunk, Note, Params, ShadeContext, Term, TermOutput, TermSpec};

/// The spec registered as `mirror`, variant `constant`.
pub const SPEC: TermSpec = TermSpec {
    name: "mirror",
    variant: "constant",
    summary: "spec · Col(R_r): recursive mirror reflection weighted by spec",
    reads: &["spec"],
    params: &[],
    build: |_: &mut Params| Ok(Box::new(Mirror)),
    mistake: None,
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
        if ctx.reference {
            for lane in chunk.hit_lanes() {
                if !out.can_spawn(lane) {
                    continue;
                }
                if let Some((r_r, spec)) = reference(ctx, chunk, lane) {
                    out.spawn(lane, r_r.from, r_r.dir, Vec3::splat(spec));
                }
            }
            return;
        }
        // Eight lanes at a time: the mirror directions and where the children start, with the
        // bits `reference` gives lane by lane.
        for group in Group::all(chunk.hits) {
            // Skipped where `spec <= 0` (a NaN goes on, as lane by lane).
            let (spec, shiny) = group.param(ctx, chunk.hits, |m| m.spec, |s| s > 0.0 || s.is_nan());
            let active = shiny & group.may_spawn(chunk.rays, out.max_depth);
            if active == 0 {
                continue;
            }
            let (point, normal, error, object) = group.surface(chunk.hits);
            let shading = lanes::load(&chunk.hits.shading.packets()[group.base / PACKET]);
            let u_r = lanes::mirror_direction(&group.dir(chunk.rays), &shading, &normal);
            let (origin, skip) = ctx.geometry.spawn_packet(
                &point.map(|c| c.to_array()),
                &normal.map(|c| c.to_array()),
                &error,
                &object,
                &u_r.map(|c| c.to_array()),
            );
            let spec = wide::f32x8::new(spec);
            out.spawn_lanes(group.base, active, &origin, &skip, &u_r, &[spec; 3]);
        }
    }
}

/// A ray to trace: where it starts (and the object it ignores), and its unit direction.
struct Ray {
    from: lancer_shapes::Origin,
    dir: Vec3,
}

/// The reference form, one hit at a time: the reflected ray `R_r = [I, u_r)` with
/// `u_r = u − 2(N·u)N` ([`crate::mirror_direction`]), starting where
/// [`lancer_shapes::Geometry::spawn`] says, and its weight `spec`: once traced, it adds
/// `spec · Col(R_r)`. Nothing where `spec` is not positive.
fn reference(ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Option<(Ray, f32)> {
    let spec = ctx.material(chunk.hits, lane).spec;
    if spec <= 0.0 {
        return None;
    }
    let (hit, u) = (ctx.hit(chunk.hits, lane), chunk.rays.dir.at(lane));
    let u_r = crate::mirror_direction(&hit, u);
    Some((Ray { from: ctx.geometry.spawn(&hit, u_r), dir: u_r }, spec))
}

//! `hard`: the handout's shadows. A light is seen or not; any object between the point and the
//! light blocks it, transparent or not.
//!
//! Formula: transmittance = 0 if the segment to the light meets an object, else 1.
//! Reads no material parameter, has no parameter.
//!
//! ```toml
//! [model]
//! shadows = "hard"
//! ```

use glam::Vec3;
use lancer_core::Light;
use lancer_shapes::{Hit, Lines};

use crate::shadow::BLOCK;
use crate::{Params, ShadowContext, ShadowModel, ShadowSpec};

/// The spec registered under `hard`.
pub const SPEC: ShadowSpec = ShadowSpec {
    name: "hard",
    summary: "the handout's shadows: any object between the point and the light blocks it",
    params: &[],
    build: |_: &mut Params| Ok(Box::new(Hard)),
};

struct Hard;

impl ShadowModel for Hard {
    fn transmittance(&self, ctx: &ShadowContext<'_>, at: &Hit, light: &Light) -> Vec3 {
        let Some((dir, dist)) = ctx.toward(at, light.at) else { return Vec3::ONE };
        if ctx.blocked(at, dir, dist) { Vec3::ZERO } else { Vec3::ONE }
    }

    fn transmittance_each(&self, ctx: &ShadowContext<'_>, hits: &[Hit], light: &Light, out: &mut [Vec3]) {
        for (hits, out) in hits.chunks(BLOCK).zip(out.chunks_mut(BLOCK)) {
            let (mut origin, mut skip, mut dir) =
                ([[[0.0f32; 8]; 3]; BLOCK / 8], [0u32; BLOCK], [[[0.0f32; 8]; 3]; BLOCK / 8]);
            let (mut dist, mut which) = ([0.0f32; BLOCK], [0usize; BLOCK]);
            let mut rays = 0;
            for (i, (at, out)) in hits.iter().zip(out.iter_mut()).enumerate() {
                *out = Vec3::ONE;
                // The shadow ray `blocked` traces.
                let Some((d, far)) = ctx.toward(at, light.at) else { continue };
                let from = ctx.geometry.spawn(at, d);
                for axis in 0..3 {
                    (origin[rays / 8][axis][rays % 8], dir[rays / 8][axis][rays % 8]) = (from.point[axis], d[axis]);
                }
                (skip[rays], dist[rays], which[rays]) = (from.skip, far, i);
                rays += 1;
            }
            let packets = rays.div_ceil(8);
            let lines = Lines { origin: &origin[..packets], dir: &dir[..packets], skip: &skip[..rays] };
            ctx.blocked_each(lines, |r| dist[r], |r| out[which[r]] = Vec3::ZERO);
        }
    }
}

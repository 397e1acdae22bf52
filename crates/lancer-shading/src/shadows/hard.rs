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
use lancer_shapes::Hit;

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
            let (mut origin, mut skip, mut dir) = ([Vec3::ZERO; BLOCK], [0u32; BLOCK], [Vec3::ZERO; BLOCK]);
            let (mut dist, mut which) = ([0.0f32; BLOCK], [0usize; BLOCK]);
            let mut rays = 0;
            for (i, (at, out)) in hits.iter().zip(out.iter_mut()).enumerate() {
                *out = Vec3::ONE;
                // The shadow ray `blocked` traces.
                let Some((d, far)) = ctx.toward(at, light.at) else { continue };
                let from = ctx.geometry.spawn(at, d);
                (origin[rays], skip[rays], dir[rays], dist[rays], which[rays]) = (from.point, from.skip, d, far, i);
                rays += 1;
            }
            ctx.blocked_each(&origin[..rays], &skip[..rays], &dir[..rays], |r| dist[r], |r| out[which[r]] = Vec3::ZERO);
        }
    }
}

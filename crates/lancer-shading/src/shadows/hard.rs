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

use crate::{HitBlock, Params, ShadowContext, ShadowModel, ShadowSpec};

/// The spec registered under `hard`.
pub const SPEC: ShadowSpec = ShadowSpec {
    name: "hard",
    summary: "the handout's shadows: any object between the point and the light blocks it",
    params: &[],
    build: |_: &mut Params| Ok(Box::new(Hard)),
    mistake: None,
};

struct Hard;

impl ShadowModel for Hard {
    fn transmittance(&self, ctx: &ShadowContext<'_>, at: &Hit, light: &Light) -> Vec3 {
        if ctx.blocked(at, light.at) { Vec3::ZERO } else { Vec3::ONE }
    }

    fn transmittance_each(&self, ctx: &ShadowContext<'_>, block: &HitBlock<'_>, light: &Light, out: &mut [Vec3]) {
        debug_assert_eq!(block.target(), light.at, "the block's rays go to the light");
        out[..block.len()].fill(Vec3::ONE);
        // The shadow rays `blocked` traces, each aimed at the light from its start and as long
        // as that (`transmissive` traces the same rays): every hit's but one within the start's
        // offset of the light.
        block.rays_where(
            |i| block.left(i) > 0.0,
            |lines, which| ctx.blocked_each(lines, |r| block.left(which[r]), |r| out[which[r]] = Vec3::ZERO),
        );
    }
}

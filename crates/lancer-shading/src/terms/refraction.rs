//! `refraction` (variant `seed`): light through a transparent object.
//!
//! Formula: entering at `I` with outward normal `N`, `u_t = VctTransmis(u, −N, 1/n)` (the normal
//! on the transmission side); the ray crosses the object unshaded to the exit point `J` (normal
//! `N_j`), then `v_t = VctTransmis(u_t, N_j, n)` and `Col += alpha · Col(R_t)` with
//! `R_t = [J, v_t)`. Only when `alpha > 0`.
//! Total internal reflection at `J` (not covered by the handout): the ray reflects inside and
//! goes on to the next exit, at most `max_depth` times; a ray still trapped after that brings
//! nothing back. A ray that hits the object from inside (a camera inside glass) leaves through
//! that surface directly.
//! Reads: `alpha`, `n`. Parameters: none.
//!
//! ```toml
//! [model]
//! terms = ["ambient", "diffuse", "specular", "mirror", "refraction"]
//! ```

use glam::Vec3;
use lancer_core::optics::{reflect, vct_transmis};
use lancer_shapes::{Origin, offset_origin};

use crate::{Chunk, Params, ShadeContext, Term, TermOutput, TermSpec};

/// The spec registered as `refraction`, variant `seed`.
pub const SPEC: TermSpec = TermSpec {
    name: "refraction",
    variant: "seed",
    summary: "alpha · Col(R_t): the handout's refraction through the object, weighted by alpha",
    params: &[],
    build: |_: &mut Params| Ok(Box::new(Refraction)),
};

struct Refraction;

impl Term for Refraction {
    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        for lane in chunk.hit_lanes() {
            let m = ctx.material(chunk.hits, lane);
            if m.alpha <= 0.0 || !out.can_spawn(lane) {
                continue;
            }
            let object = chunk.hits.object[lane];
            let (p, n_out, u) = (chunk.hits.point[lane], chunk.hits.normal[lane], chunk.rays.dir[lane]);
            if let Some((origin, dir)) = through(ctx, object, p, n_out, u, m.n, chunk.hits.front[lane]) {
                out.spawn(lane, origin, dir, Vec3::splat(m.alpha));
            }
        }
    }
}

/// The ray `R_t` that leaves the object after entering it at `p` (or, with `front = false`,
/// reaching its surface at `p` from inside). `None` when it never leaves.
pub fn through(
    ctx: &ShadeContext<'_>,
    object: u32,
    p: Vec3,
    n_out: Vec3,
    u: Vec3,
    n: f32,
    front: bool,
) -> Option<(Origin, Vec3)> {
    // (position on the surface, direction inside, outward normal there)
    let (mut pos, mut dir, mut normal) = if front {
        let u_t = vct_transmis(u, -n_out, 1.0 / n)?;
        let inside = offset_origin(p, -n_out);
        let exit = ctx.geometry.exit(object, inside, u_t)?;
        (inside + exit.t * u_t, u_t, exit.normal)
    } else {
        (p, u, n_out)
    };
    for _ in 0..=ctx.max_depth {
        match vct_transmis(dir, normal, n) {
            Some(v_t) => return Some((ctx.geometry.leave(object, pos, normal), v_t)),
            None => {
                dir = reflect(dir, normal);
                let inside = offset_origin(pos, -normal);
                let exit = ctx.geometry.exit(object, inside, dir)?;
                pos = inside + exit.t * dir;
                normal = exit.normal;
            }
        }
    }
    None
}

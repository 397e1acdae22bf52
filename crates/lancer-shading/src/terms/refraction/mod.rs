//! The `refraction` term's variants, and the passage of a ray through a transparent object that
//! they share.
//!
//! | variant | weight of the transmitted ray |
//! |---|---|
//! | `seed` (default, the handout's) | `alpha` |
//! | `fresnel` | `alpha · (1 − R_in)(1 − R_out)` (+ a reflected ray `alpha · R_in`), optional Beer–Lambert |

pub mod fresnel;
pub mod seed;

use glam::Vec3;
use lancer_core::optics::{reflect, vct_transmis};
use lancer_shapes::{Origin, offset_origin};

use crate::ShadeContext;

/// A ray's way through a transparent object: where it comes out, how long it was inside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Passage {
    /// Where the ray `R_t` leaves the object.
    pub from: Origin,
    /// Its direction `v_t`.
    pub dir: Vec3,
    /// The distance travelled inside (all segments, total internal reflections included).
    pub length: f32,
    /// `cos` of the incidence angle inside at the final exit.
    pub exit_cos: f32,
}

/// The ray `R_t` that leaves the object after entering it at `p` (with outward normal `n_out`,
/// direction `u`, index `n`), or, with `front = false`, that reaches its surface at `p` from
/// inside. Entering uses `VctTransmis(u, −N, 1/n)` (the normal on the transmission side); the ray
/// crosses the object meeting nothing else, to the exit `J` found by the shape's exit query.
/// Total internal reflection at `J` reflects the ray inside, at most `max_depth` times.
/// `None` when it never leaves.
pub fn passage(
    ctx: &ShadeContext<'_>,
    object: u32,
    p: Vec3,
    n_out: Vec3,
    u: Vec3,
    n: f32,
    front: bool,
) -> Option<Passage> {
    // (position on the surface, direction inside, outward normal there)
    let mut length = 0.0;
    let (mut pos, mut dir, mut normal) = if front {
        let u_t = vct_transmis(u, -n_out, 1.0 / n)?;
        let inside = offset_origin(p, -n_out);
        let exit = ctx.geometry.exit(object, inside, u_t)?;
        length += exit.t;
        (inside + exit.t * u_t, u_t, exit.normal)
    } else {
        (p, u, n_out)
    };
    for _ in 0..=ctx.max_depth {
        match vct_transmis(dir, normal, n) {
            Some(v_t) => {
                let from = ctx.geometry.leave(object, pos, normal);
                return Some(Passage { from, dir: v_t, length, exit_cos: normal.dot(dir).clamp(0.0, 1.0) });
            }
            None => {
                dir = reflect(dir, normal);
                let inside = offset_origin(pos, -normal);
                let exit = ctx.geometry.exit(object, inside, dir)?;
                length += exit.t;
                pos = inside + exit.t * dir;
                normal = exit.normal;
            }
        }
    }
    None
}

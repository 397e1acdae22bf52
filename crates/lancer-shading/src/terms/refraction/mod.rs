//! The `refraction` term's variants, and the passage of a ray through a transparent object that
//! they share.
//!
//! | variant | weight of the transmitted ray |
//! |---|---|
//! | `seed` (default, the handout's) | `alpha` |
//! | `fresnel` | `alpha · (1 − R_in)(1 − R_out)` (+ a reflected ray `alpha · R_in`), optional Beer–Lambert |
//! | `traced` | `alpha` at every surface crossed: the ray is traced inside, each inner surface shaded |
//!
//! Classic mistakes of the course, kept as variants to show them (`lancer terms --mistakes`):
//! `sign-trap` (`VctTransmis` given the outward normal on entry), `inverted-index` (`n` where
//! `1/n` belongs, and `1/n` where `n` does) and `no-exit-bend` (the ray leaves at `J` along
//! `u_t`).

pub mod fresnel;
pub mod inverted_index;
pub mod no_exit_bend;
pub mod seed;
pub mod sign_trap;
pub mod traced;

use glam::Vec3;
use lancer_core::optics::{reflect, vct_transmis};
use lancer_shapes::{Hit, Origin};

use crate::{Chunk, Note, ShadeContext, TermOutput};

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

/// The ray `R_t` that leaves the object after entering it at `hit` (direction `u`, index `n`),
/// or, for a back-face `hit`, that reaches its surface there from inside. Entering uses
/// `VctTransmis(u, −N, 1/n)` (the normal on the transmission side); the ray crosses the object
/// meeting nothing else, to the exit `J` found by [`lancer_shapes::Geometry::exit`] (the same
/// query the transmissive shadows use). Total internal reflection at `J` reflects the ray inside,
/// at most `max_depth` times. `None` when it never leaves.
///
/// Directions bend about the shading normal; where a smooth mesh's interpolated normal would send
/// the ray to the wrong side of the actual surface (near a silhouette), the geometric normal is
/// used instead, so the ray always goes in on entering and out on leaving.
pub fn passage(ctx: &ShadeContext<'_>, hit: &Hit, u: Vec3, n: f32) -> Option<Passage> {
    passage_with(ctx, hit, u, n, |_| {})
}

/// One step of a [`passage`], for [`passage_notes`].
enum Step {
    /// Entered with direction `u_t`; reaches the surface again at the point.
    Entered(Vec3, Vec3),
    /// Reflected inside at the first point (total internal reflection); reaches the surface
    /// again at the second.
    Reflected(Vec3, Vec3),
    /// Leaves (at the last exit point) with direction `v_t`.
    Left(Vec3),
}

/// [`passage`], telling `step` what happens on the way.
#[inline]
fn passage_with(ctx: &ShadeContext<'_>, hit: &Hit, u: Vec3, n: f32, mut step: impl FnMut(Step)) -> Option<Passage> {
    let mut length = 0.0;
    let (mut at, mut dir) = if hit.front {
        let (u_t, _) = bend(u, hit, 1.0 / n, false)?;
        let exit = ctx.geometry.exit(hit, u_t)?;
        step(Step::Entered(u_t, exit.point));
        length += (exit.point - hit.point).length();
        (exit, u_t)
    } else {
        (*hit, u)
    };
    for _ in 0..=ctx.max_depth {
        match bend(dir, &at, n, true) {
            Some((v_t, normal)) => {
                step(Step::Left(v_t));
                let from = ctx.geometry.spawn(&at, v_t);
                let exit_cos = normal.dot(dir).abs().min(1.0);
                return Some(Passage { from, dir: v_t, length, exit_cos });
            }
            None => {
                dir = reflect(dir, at.shading);
                if dir.dot(at.normal) >= 0.0 {
                    dir = reflect(dir, at.normal);
                }
                let exit = ctx.geometry.exit(&at, dir)?;
                step(Step::Reflected(at.point, exit.point));
                length += (exit.point - at.point).length();
                at = exit;
            }
        }
    }
    None
}

/// The way through the object as [`crate::Term::explain`] notes: the entry `I`, `u_t`, the
/// exit `J` (each total internal reflection on the way), `v_t`, and the length inside.
pub fn passage_notes(ctx: &ShadeContext<'_>, hit: &Hit, u: Vec3, n: f32) -> Vec<Note> {
    let mut notes = vec![Note::point("I (entry)", hit.point)];
    if !hit.front {
        notes[0] = Note::text("I", "reached from inside: the ray leaves there");
    }
    let mut reflections = 0;
    let result = passage_with(ctx, hit, u, n, |step| match step {
        Step::Entered(u_t, j) => {
            notes.push(Note::vector("u_t = VctTransmis(u, −N, 1/n)", u_t));
            notes.push(Note::point("J (exit)", j));
        }
        Step::Reflected(at, next) => {
            reflections += 1;
            notes.push(Note::point(format!("total internal reflection {reflections} at"), at));
            notes.push(Note::point("J (exit)", next));
        }
        Step::Left(v_t) => notes.push(Note::vector("v_t = VctTransmis(u_t, N_j, n)", v_t)),
    });
    match result {
        Some(p) => notes.push(Note::number("length inside", p.length)),
        None => notes.push(Note::text("R_t", "never leaves (trapped, or no exit found): brings nothing")),
    }
    notes
}

/// The run of a refraction variant that sends one ray per transparent hit along `path` (the
/// mistakes of the catalogue): weight `alpha`, lane by lane.
pub(crate) fn spawn_along(
    ctx: &ShadeContext<'_>,
    chunk: Chunk<'_>,
    out: &mut TermOutput<'_>,
    path: impl Fn(&ShadeContext<'_>, &Hit, Vec3, f32) -> Option<(Origin, Vec3)>,
) {
    for lane in chunk.hit_lanes() {
        let m = ctx.material(chunk.hits, lane);
        if m.alpha <= 0.0 || !out.can_spawn(lane) {
            continue;
        }
        if let Some((from, dir)) = path(ctx, &ctx.hit(chunk.hits, lane), chunk.rays.dir.at(lane), m.n) {
            out.spawn(lane, from, dir, Vec3::splat(m.alpha));
        }
    }
}

/// Where the rays of eight lanes that all hit one sphere with a world-space form from outside
/// leave it, with the bits [`passage`] gives each: the lanes set in the result's mask went in
/// and out with no total internal reflection (and there the shading normal is the geometric
/// one, so [`bend`]'s second try changes nothing), each leaving from its origin (and ignoring
/// its object) along its direction. The other lanes are left to [`passage`]; `None` when the
/// object has no such form. `object` is the sphere's index, `n` its refractive index.
pub(crate) fn passage_group(
    ctx: &ShadeContext<'_>,
    hits: &lancer_core::rays::Hits,
    u: &crate::lanes::V3,
    group: usize,
    object: u32,
    n: f32,
) -> Option<(lancer_core::rays::Packet, [u32; 8], crate::lanes::V3, u8)> {
    use crate::lanes::{dot, load, neg, vct_transmis};
    use wide::{CmpGt, f32x8};
    let point = &hits.point.packets()[group];
    let normal = load(&hits.normal.packets()[group]);
    let base = group * lancer_core::rays::PACKET;
    let error: [f32; 8] = std::array::from_fn(|k| hits.error.get(base + k).copied().unwrap_or(0.0));
    // In: `VctTransmis(u, −N, 1/n)`, on the inside of the surface.
    let (u_t, through) = vct_transmis(u, &normal.map(neg), f32x8::splat(1.0 / n));
    let inward = !dot(&u_t, &normal).cmp_gt(f32x8::ZERO);
    let u_t_lanes = u_t.map(|c| c.to_array());
    let (exit, found) = ctx.geometry.exit_group(object, point, &normal.map(|c| c.to_array()), &error, &u_t_lanes)?;
    // Out: `VctTransmis(u_t, N_j, n)`, on the outside.
    let normal_j = load(&exit.normal);
    let (v_t, out) = vct_transmis(&u_t, &normal_j, f32x8::splat(n));
    let outward = dot(&v_t, &normal_j).cmp_gt(f32x8::ZERO);
    let ok = (through & inward & out & outward).move_mask() as u8 & found;
    let (from, skip) =
        ctx.geometry.spawn_packet(&exit.point, &exit.normal, &exit.error, &[object; 8], &v_t.map(|c| c.to_array()));
    Some((from, skip, v_t, ok))
}

/// `VctTransmis` through the surface of `at` with the index ratio `delta`, about the shading
/// normal when that sends the ray to the right side of the geometric surface (out when
/// `leaving`, in otherwise), else about the geometric normal: the direction and the normal used.
/// `None` on total internal reflection.
pub(crate) fn bend(u: Vec3, at: &Hit, delta: f32, leaving: bool) -> Option<(Vec3, Vec3)> {
    let right_side = |v: Vec3| (v.dot(at.normal) > 0.0) == leaving;
    let t = vct_transmis(u, if leaving { at.shading } else { -at.shading }, delta)?;
    if right_side(t) {
        return Some((t, at.shading));
    }
    vct_transmis(u, if leaving { at.normal } else { -at.normal }, delta)
        .filter(|&t| right_side(t))
        .map(|t| (t, at.normal))
}

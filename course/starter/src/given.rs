//! What your terms see at a hit, in the handout's notation, and how they reach Lancer (given:
//! you need not change this file). Each of your five functions gets one [`Hit`]: the incident
//! direction `u`, the point `I`, the normal `N`, `Col_Ω`, the material and the lights; the
//! recursive terms (mirror, refraction) answer with the [`Child`] ray to trace and its weight,
//! and Lancer traces it and adds `weight · Col(child)`.

use glam::Vec3;
use lancer_core::Material;
use lancer_shading::{Chunk, ShadeContext, Term, TermOutput};
use lancer_shapes::Origin;

/// One hit of a ray `[A, u)` on an object Ω, as a term sees it.
pub struct Hit<'a> {
    /// `u`: the incident ray's unit direction (from `A` towards `I`).
    pub u: Vec3,
    /// `I`: the point hit (in the frame Lancer renders in, the camera at the origin: only
    /// differences of points mean anything).
    pub i: Vec3,
    /// `N`: the unit normal at `I`, on the side the ray comes from (`N·u < 0`). Every ray of
    /// the course's scenes comes from outside the objects, so this is the outward normal.
    pub n: Vec3,
    /// `Col_Ω`: the object's colour at `I`, linear RGB.
    pub col_omega: Vec3,
    /// The object's material: `ambi`, `diff`, `spec`, `shine`, `alpha` and `n` (its index).
    pub material: Material,
    /// The lights, in the scene's order.
    pub lights: Vec<Light>,
    ctx: &'a ShadeContext<'a>,
    hit: lancer_shapes::Hit,
}

/// One light as seen from a hit.
#[derive(Clone, Copy, Debug)]
pub struct Light {
    /// `w`: the unit direction from `I` towards the light, `(L − I)/|L − I|`.
    pub w: Vec3,
    /// `Col_L`: the light's colour (times its intensity) arriving at `I`. In front of the
    /// surface (`N·w > 0`) it is what the scene's shadow model lets through (black in a hard
    /// shadow); behind it, no shadow ray is traced and the light's own colour is given, as a
    /// renderer that does not look gives it.
    pub col_l: Vec3,
}

/// A ray leaving a surface: where it starts, and its unit direction.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Where it starts: a hair off the surface, on the side it goes to (Lancer's
    /// `Geometry::spawn`, so that it does not hit the surface it leaves).
    origin: Origin,
    /// Its unit direction.
    pub dir: Vec3,
}

/// A ray for Lancer to trace, and what its colour counts for: the term adds
/// `weight · Col(ray)`.
#[derive(Clone, Copy, Debug)]
pub struct Child {
    /// The ray.
    pub ray: Ray,
    /// Its weight (`spec` for the mirror, `alpha` for refraction).
    pub weight: f32,
}

/// Where a ray that entered an object leaves it: the exit point `J` and its normal.
pub struct Exit<'a> {
    /// `J`: where the ray meets the object's surface again, from inside.
    pub j: Vec3,
    /// `N_j`: the unit outward normal at `J` (`N_j · u_t > 0` for the ray `u_t` leaving).
    pub n_j: Vec3,
    ctx: &'a ShadeContext<'a>,
    hit: lancer_shapes::Hit,
}

impl Hit<'_> {
    /// The ray from `I` in direction `dir` (unit): `[I, dir)`.
    pub fn ray(&self, dir: Vec3) -> Ray {
        Ray { origin: self.ctx.geometry.spawn(&self.hit, dir), dir }
    }

    /// Where a ray that goes into the object at `I` in direction `u_t` (unit, into the object)
    /// leaves it: the object's own exit query, meeting nothing else on the way. `None` for an
    /// object with no inside (a plane's half-space never ends).
    pub fn exit(&self, u_t: Vec3) -> Option<Exit<'_>> {
        let hit = self.ctx.geometry.exit(&self.hit, u_t)?;
        Some(Exit { j: hit.point, n_j: hit.shading, ctx: self.ctx, hit })
    }
}

impl Exit<'_> {
    /// The ray from `J` in direction `dir` (unit, out of the object): `[J, dir)`.
    pub fn ray(&self, dir: Vec3) -> Ray {
        Ray { origin: self.ctx.geometry.spawn(&self.hit, dir), dir }
    }
}

/// What one of your terms is: a colour it adds at a hit, or a ray it traces.
#[derive(Clone, Copy)]
pub(crate) enum Formula {
    /// Ambient, diffuse, specular: the colour added at the hit.
    Adds(fn(&Hit<'_>) -> Vec3),
    /// Mirror, refraction: the ray to trace, if any.
    Traces(fn(&Hit<'_>) -> Option<Child>),
}

/// A term of yours as Lancer runs it: for each hit, in order, your function on its [`Hit`].
pub(crate) struct Yours(pub(crate) Formula);

impl Term for Yours {
    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        for lane in chunk.hit_lanes() {
            if let Formula::Traces(_) = self.0
                && !out.can_spawn(lane)
            {
                continue;
            }
            let hit = ctx.hit(chunk.hits, lane);
            let n = chunk.hits.facing_normal(lane);
            let lights = chunk
                .lights
                .lane(lane)
                .zip(ctx.lights)
                .map(|((w, arriving), light)| Light {
                    w,
                    col_l: if n.dot(w) > 0.0 { arriving } else { light.radiance() },
                })
                .collect();
            let at = Hit {
                u: chunk.rays.dir.at(lane),
                i: hit.point,
                n,
                col_omega: ctx.color(chunk.hits, lane),
                material: *ctx.material(chunk.hits, lane),
                lights,
                ctx,
                hit,
            };
            match self.0 {
                Formula::Adds(f) => out.add(lane, f(&at)),
                Formula::Traces(f) => {
                    if let Some(child) = f(&at) {
                        out.spawn(lane, child.ray.origin, child.ray.dir, Vec3::splat(child.weight));
                    }
                }
            }
        }
    }
}

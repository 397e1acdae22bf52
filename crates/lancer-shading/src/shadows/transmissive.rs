//! `transmissive`: transparent occluders let light through. Each object crossed on the way to the
//! light multiplies it by its `alpha` (and, with `tint = true`, by its colour); an opaque object
//! (`alpha = 0`) blocks it. So glass casts a lighter shadow.
//!
//! Formula: transmittance = Π over objects crossed of `alpha_k` (× `Col_k` with `tint`). A
//! closed object is crossed from where the ray enters it to where it leaves, meeting nothing
//! inside it (as the handout's refraction path). With `each_surface = true` the shadow ray is
//! followed surface by surface as `refraction:traced` follows its rays: Π over surfaces crossed
//! (`alpha_k²` through a closed object, as POV-Ray's shadows), and an object inside a
//! transparent one casts its shadow.
//! Reads: `alpha`, `color` of occluders. Parameters: `tint` (default `false`), `each_surface`
//! (default `false`).
//!
//! ```toml
//! [model]
//! shadows = { model = "transmissive", tint = true }
//! ```

use glam::Vec3;
use lancer_core::Light;
use lancer_shapes::{Hit, Lines, Packet};

use crate::HitBlock;
use crate::shadow::BLOCK;
use crate::{ParamSpec, Params, ShadowContext, ShadowModel, ShadowSpec};

/// The spec registered under `transmissive`.
pub const SPEC: ShadowSpec = ShadowSpec {
    name: "transmissive",
    summary: "transparent occluders attenuate the light by their alpha instead of blocking it",
    params: &[TINT, EACH_SURFACE],
    build: |p: &mut Params| Ok(Box::new(Transmissive { filter: Filter::from_params(p)? })),
    mistake: None,
};

/// The `tint` parameter, shared with the `soft` model.
pub const TINT: ParamSpec =
    ParamSpec { name: "tint", default: "false", doc: "also filter the light by each occluder's colour" };

/// The `each_surface` parameter, shared with the `soft` model.
pub const EACH_SURFACE: ParamSpec = ParamSpec {
    name: "each_surface",
    default: "false",
    doc: "count alpha at each surface crossed (twice through a closed object, as refraction:traced weighs its rays and POV-Ray its shadows), not once per object",
};

/// How transparent occluders filter the light: the `tint` and `each_surface` parameters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Filter {
    /// Also by each occluder's colour.
    pub tint: bool,
    /// `alpha` at each surface crossed, not once per object.
    pub each_surface: bool,
}

impl Filter {
    /// The filter the model's parameters ask for.
    pub fn from_params(p: &mut Params) -> Result<Filter, crate::ParamError> {
        Ok(Filter { tint: p.boolean(TINT.name, false)?, each_surface: p.boolean(EACH_SURFACE.name, false)? })
    }
}

/// More objects crossed than this on one shadow ray count as fully blocked (a pathological stack
/// of thin glass); it keeps the loop bounded (twice as many surfaces with `each_surface`).
const MAX_CROSSINGS: usize = 64;

struct Transmissive {
    filter: Filter,
}

impl ShadowModel for Transmissive {
    fn transmittance(&self, ctx: &ShadowContext<'_>, at: &Hit, light: &Light) -> Vec3 {
        through_occluders(ctx, at, light.at, self.filter)
    }

    fn transmittance_each(&self, ctx: &ShadowContext<'_>, block: &HitBlock<'_>, light: &Light, out: &mut [Vec3]) {
        debug_assert_eq!(block.target(), light.at, "the block's rays go to the light");
        through_occluders_each(ctx, block, self.filter, out);
    }
}

/// The light left after crossing every object between the surface at `at` and the point
/// `target` (each stretch of the way a shadow ray [`crate::aim`]ed at the target from where it
/// starts): each transparent object crossed multiplies it by its `alpha` (and its
/// colour where the ray enters, with `tint`) once; an opaque one stops it. A closed object counts
/// once, from where the ray enters it to where it leaves ([`lancer_shapes::Geometry::past`], the
/// same exit query as the refraction path); a surface with no inside (a disk, an open mesh)
/// counts at each crossing, and the ray goes on beyond it.
pub fn through_occluders(ctx: &ShadowContext<'_>, at: &Hit, target: Vec3, filter: Filter) -> Vec3 {
    onward(ctx, at, target, filter, None)
}

/// [`through_occluders`] from each hit of `block` along its straight ray, into `out`: the first
/// stretch of every shadow ray traced together ([`ShadowContext::occluders_through`], convex
/// transparent objects seen through), the rest (past transparent objects, where something else
/// lies on the ray) one by one. Each hit gets what `through_occluders` gives it alone.
pub fn through_occluders_each(ctx: &ShadowContext<'_>, block: &HitBlock<'_>, filter: Filter, out: &mut [Vec3]) {
    FIRST.with(|cell| match cell.try_borrow_mut() {
        Ok(mut first) => through_block(ctx, block, filter, out, &mut first),
        Err(_) => through_block(ctx, block, filter, out, &mut [None; BLOCK]),
    })
}

type Crossing = Option<(u32, lancer_shapes::ShapeHit)>;

thread_local! {
    /// Each thread's record of what each ray of a block meets first, reused from block to
    /// block (a block clears the entries it uses).
    static FIRST: std::cell::RefCell<[Crossing; BLOCK]> = const { std::cell::RefCell::new([None; BLOCK]) };
}

fn through_block(
    ctx: &ShadowContext<'_>,
    block: &HitBlock<'_>,
    filter: Filter,
    out: &mut [Vec3],
    first: &mut [Crossing; BLOCK],
) {
    let n = block.len();
    first[..n].fill(None);
    // A ray with nothing left (a hit at the light, or within the start's offset of it) is not
    // traced: the light reaches it whole, as `onward` finds before tracing.
    let ahead = |i: usize| block.left(i) > 0.0;
    let mut blocked = [true; BLOCK];
    block.rays_where(ahead, |lines, which| {
        ctx.occluders_through(
            lines,
            Some(block.target()),
            |r| block.left(which[r]),
            |object| see_through(ctx, object),
            |r, object, c, alone| (first[which[r]], blocked[which[r]]) = (Some((object, *c)), !alone),
        );
    });
    for (i, out) in out.iter_mut().enumerate().take(n) {
        *out = if ahead(i) {
            settled(ctx, block.origin(i).point, block.dir(i), block.left(i), first[i], filter, blocked[i])
                .unwrap_or_else(|| onward(ctx, &block.hit(ctx, i), block.target(), filter, Some(first[i])))
        } else {
            Vec3::ONE
        };
    }
}

/// [`through_occluders`] from each hit `i` of `hits` to its own `target(i)`, traced as
/// [`through_occluders_each`] does: `done(i, light)` for each hit, in order, with `None` where
/// the target is the hit point itself (no ray).
pub(crate) fn through_each(
    ctx: &ShadowContext<'_>,
    hits: &[Hit],
    target: impl Fn(usize) -> Vec3,
    filter: Filter,
    done: impl FnMut(usize, Option<Vec3>),
) {
    SCRATCH.with(|cell| match cell.try_borrow_mut() {
        Ok(mut columns) => through_blocks(&mut columns, ctx, hits, target, filter, done),
        Err(_) => through_blocks(&mut Box::new(Columns::new()), ctx, hits, target, filter, done),
    })
}

/// A block's shadow rays (origin, object skipped, direction, length, the point it goes to),
/// each hit's ray (an index into them) or what it gets without one, and what each ray
/// meets first.
struct Columns {
    origin: [Packet; BLOCK / 8],
    skip: [u32; BLOCK],
    dir: [Packet; BLOCK / 8],
    left: [f32; BLOCK],
    goal: [Vec3; BLOCK],
    ray: [Result<usize, Option<Vec3>>; BLOCK],
    first: [Option<(u32, lancer_shapes::ShapeHit)>; BLOCK],
}

impl Columns {
    fn new() -> Columns {
        Columns {
            origin: [[[0.0; 8]; 3]; BLOCK / 8],
            skip: [0; BLOCK],
            dir: [[[0.0; 8]; 3]; BLOCK / 8],
            left: [0.0; BLOCK],
            goal: [Vec3::ZERO; BLOCK],
            ray: [Err(None); BLOCK],
            first: [None; BLOCK],
        }
    }
}

thread_local! {
    /// Each thread's columns, reused from block to block (not cleared: a block writes the
    /// lanes it reads).
    static SCRATCH: std::cell::RefCell<Box<Columns>> = std::cell::RefCell::new(Box::new(Columns::new()));
}

fn through_blocks(
    c: &mut Columns,
    ctx: &ShadowContext<'_>,
    hits: &[Hit],
    target: impl Fn(usize) -> Vec3,
    filter: Filter,
    mut done: impl FnMut(usize, Option<Vec3>),
) {
    let Columns { origin, skip, dir, left, goal, ray, first } = c;
    for (start, hits) in (0..).step_by(BLOCK).zip(hits.chunks(BLOCK)) {
        let mut rays = 0;
        for (i, at) in hits.iter().enumerate() {
            ray[i] = Err(None);
            let to = target(start + i);
            let Some((leaving, _)) = ctx.toward(at, to) else { continue };
            // The first stretch exactly as `onward` starts it (`aim`, its two halves).
            let from = ctx.geometry.spawn(at, leaving);
            let Some((from, d, l)) = crate::shadow::aim_from(from, leaving, to) else {
                ray[i] = Err(Some(Vec3::ONE));
                continue;
            };
            for axis in 0..3 {
                (origin[rays / 8][axis][rays % 8], dir[rays / 8][axis][rays % 8]) = (from.point[axis], d[axis]);
            }
            (skip[rays], left[rays], goal[rays]) = (from.skip, l, to);
            ray[i] = Ok(rays);
            rays += 1;
        }
        first[..rays].fill(None);
        let packets = rays.div_ceil(8);
        let lines = Lines { origin: &origin[..packets], dir: &dir[..packets], skip: &skip[..rays] };
        let mut blocked = [true; BLOCK];
        ctx.occluders_through(
            lines,
            None,
            |r| left[r],
            |object| see_through(ctx, object),
            |r, object, c, alone| (first[r], blocked[r]) = (Some((object, *c)), !alone),
        );
        for (i, at) in hits.iter().enumerate() {
            let light = match ray[i] {
                Err(light) => light,
                Ok(r) => {
                    let (from, d) = (lines.origin(r), lines.dir(r));
                    Some(
                        settled(ctx, from, d, left[r], first[r], filter, blocked[r])
                            .unwrap_or_else(|| onward(ctx, at, goal[r], filter, Some(first[r]))),
                    )
                }
            };
            done(start + i, light);
        }
    }
}

/// Whether object `object` is transparent and convex: a straight shadow ray crosses it once (in
/// and out, or only out), so if nothing else lies on the ray, its share of the light is all the
/// walk past it would find.
#[inline]
fn see_through(ctx: &ShadowContext<'_>, object: u32) -> bool {
    ctx.material_of(object).alpha > 0.0 && ctx.geometry.objects[object as usize].shape.is_convex()
}

/// What a shadow ray from `from` along `dir` whose first stretch meets `first` lets through,
/// when that decides it without the walk of [`onward`]: all of the light when it meets nothing,
/// none when it meets an opaque object first, and the share of a [`see_through`] object it
/// meets first when nothing else lies on the ray (`!blocked`). `None`: the walk decides.
#[inline]
fn settled(
    ctx: &ShadowContext<'_>,
    from: Vec3,
    dir: Vec3,
    left: f32,
    first: Crossing,
    filter: Filter,
    blocked: bool,
) -> Option<Vec3> {
    match first {
        None => Some(Vec3::ONE),
        Some((object, _)) if ctx.material_of(object).alpha <= 0.0 => Some(Vec3::ZERO),
        Some((object, crossing)) if !blocked && see_through(ctx, object) => {
            Some(share(ctx, object, from, dir, left, &crossing, filter))
        }
        Some(_) => None,
    }
}

/// The share of the light a transparent object lets through where the ray from `from` along
/// `dir` crosses it (`crossing`), the light `left` away: its `alpha`, times its colour there with
/// `tint` (a filter passes at most all the light: a colour above 1 does not amplify it); squared
/// with `each_surface` where the ray goes in and out of a closed object before the light.
#[inline]
fn share(
    ctx: &ShadowContext<'_>,
    object: u32,
    from: Vec3,
    dir: Vec3,
    left: f32,
    crossing: &lancer_shapes::ShapeHit,
    filter: Filter,
) -> Vec3 {
    if !filter.tint && !filter.each_surface {
        return Vec3::splat(ctx.material_of(object).alpha);
    }
    let hit = ctx.geometry.objects[object as usize].hit(object, from, dir, crossing);
    let once = surface_share(ctx, &hit, filter);
    // In and out before the light: two surfaces (`past` is the hit itself where the ray
    // leaves there, or where the object has no inside).
    let exit = ctx.geometry.past(&hit, dir).filter(|p| p.point != hit.point && (p.point - from).dot(dir) < left);
    match exit {
        // The colour at each surface, as the walk surface by surface finds it.
        Some(exit) if filter.each_surface => once * surface_share(ctx, &exit, filter),
        _ => once,
    }
}

/// The share of the light the transparent surface of `hit` lets through: `alpha`, times the
/// colour there with `tint` (at most 1).
#[inline]
fn surface_share(ctx: &ShadowContext<'_>, hit: &Hit, filter: Filter) -> Vec3 {
    let alpha = ctx.material_of(hit.object).alpha;
    if filter.tint { alpha * ctx.color_at(hit).min(Vec3::ONE) } else { Vec3::splat(alpha) }
}

/// The walk of [`through_occluders`]; `given`: the answer to its first shadow ray when it was
/// already traced.
fn onward(
    ctx: &ShadowContext<'_>,
    at: &Hit,
    target: Vec3,
    filter: Filter,
    mut given: Option<Option<(u32, lancer_shapes::ShapeHit)>>,
) -> Vec3 {
    let mut light = Vec3::ONE;
    let mut surface = *at;
    // Surface by surface, a closed object takes two steps.
    let steps = if filter.each_surface { 2 * MAX_CROSSINGS } else { MAX_CROSSINGS };
    for _ in 0..steps {
        // Each stretch aimed at the target from where it starts (past each object crossed).
        let Some((from, dir, left)) = crate::aim(ctx.geometry, &surface, target) else {
            return light;
        };
        // A stretch traced here, not handed in: a transparent object it crosses once, with
        // nothing else on it, settles the rest (as `settled` does for a block's first stretch).
        let (first, traced) = match given.take() {
            Some(first) => (first, false),
            None => (ctx.occluder(from, dir, left), true),
        };
        let Some((object, crossing)) = first else {
            return light;
        };
        let m = ctx.material_of(object);
        if m.alpha <= 0.0 {
            return Vec3::ZERO;
        }
        // (The same stretch asked again, past the object: one shadow ray, as a block's stretch
        // traced with the object seen through is.)
        if traced && see_through(ctx, object) && !ctx.geometry.any_hit_without(from, dir, left, object) {
            return light * share(ctx, object, from.point, dir, left, &crossing, filter);
        }
        let hit = ctx.geometry.objects[object as usize].hit(object, from.point, dir, &crossing);
        if filter.each_surface {
            // Surface by surface, as `refraction:traced`'s rays go: the next stretch starts at
            // this one, so what lies inside the object is met (an opaque ball inside glass
            // casts its shadow).
            light *= surface_share(ctx, &hit, filter);
            surface = hit;
            continue;
        }
        light *= share(ctx, object, from.point, dir, left, &crossing, filter);
        match ctx.geometry.past(&hit, dir) {
            // Leaving it beyond the light: the light is inside it, and nothing else counts.
            Some(past) if (past.point - from.point).dot(dir) >= left => return light,
            Some(past) => surface = past,
            // It never ends (a plane's half-space): the light is inside it.
            None => return light,
        }
    }
    Vec3::ZERO
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec2, Vec3};
    use lancer_core::{Light, Material, Pattern, Texture};
    use lancer_shapes::{Geometry, Mesh, Object, Origin, Shape};

    use crate::{Params, ShadeContext, ShadowContext};

    fn sphere_at(z: f32, material: u32) -> Object {
        Object::new(Shape::Sphere, Affine3A::from_translation(Vec3::new(0.0, 0.0, z)), material).unwrap()
    }

    /// The light from `light_at` reaching the point `at` (on a small opaque disk facing +z, added
    /// as the last object), through `objects` with materials 0 = glass (alpha 0.5, orange),
    /// 1 = opaque, 2 = glass textured with `texture`, 3 = glass of colour 1000 (alpha 0.5).
    fn reaching(model: &str, tint: bool, objects: Vec<Object>, at: Vec3, light_at: Vec3, textures: &[Texture]) -> Vec3 {
        let glass = Material { color: Vec3::new(1.0, 0.5, 0.25), alpha: 0.5, ..Material::default() };
        let opaque = Material::default();
        let textured =
            Material { alpha: 0.5, pattern: Pattern::Image { texture: 0, scale: 1.0 }, ..Material::default() };
        let bright = Material { color: Vec3::splat(1000.0), alpha: 0.5, ..Material::default() };
        let materials = [glass, opaque, textured, bright];
        let mut objects = objects;
        let facing_z = Affine3A::from_translation(at) * Affine3A::from_rotation_x(-std::f32::consts::FRAC_PI_2);
        objects.push(Object::new(Shape::Disk, facing_z * Affine3A::from_scale(Vec3::splat(1e-3)), 1).unwrap());
        let g = Geometry::new(objects);
        let scene =
            ShadeContext { geometry: &g, materials: &materials, lights: &[], max_depth: 5, textures, reference: false };
        let ctx = ShadowContext::new(&scene);
        let hit = g.closest_hit(Origin::free(at + Vec3::new(0.0, 0.0, -1.0)), Vec3::Z, 0.0, 2.0).unwrap();
        assert_eq!(hit.object as usize, g.objects.len() - 1, "the shaded point is on the little disk");
        let params = if model == "transmissive" {
            Params::new([("tint".to_owned(), crate::ParamValue::Bool(tint))])
        } else {
            Params::default()
        };
        let m = crate::Registry::with_builtins().build_shadow(model, params).unwrap();
        let light = Light { at: light_at, color: Vec3::ONE, intensity: 1.0, size: 0.0 };
        m.model.transmittance(&ctx, &hit, &light)
    }

    fn transmittance(model: &str, tint: bool, objects: Vec<Object>, dist: f32) -> Vec3 {
        reaching(model, tint, objects, Vec3::ZERO, Vec3::new(0.0, 0.0, dist), &[])
    }

    #[test]
    fn regression_an_open_glass_surface_does_not_hide_what_is_behind_it() {
        // A glass disk, then an opaque sphere, between the point and the light: the sphere still
        // blocks (before the fix the disk, having no exit, ended the shadow ray: 0.5).
        let disk = Object::new(
            Shape::Disk,
            Affine3A::from_translation(Vec3::new(0.0, 0.0, 2.0))
                * Affine3A::from_rotation_x(std::f32::consts::FRAC_PI_2),
            0,
        )
        .unwrap();
        assert_eq!(transmittance("transmissive", false, vec![disk.clone(), sphere_at(5.0, 1)], 10.0), Vec3::ZERO);
        // Alone, the disk dims the light once.
        assert_eq!(transmittance("transmissive", false, vec![disk], 10.0), Vec3::splat(0.5));
    }

    #[test]
    fn regression_a_textured_glass_mesh_tints_its_shadow_where_the_ray_crosses_it() {
        // A square pane at z = 2, its left half red and its right half blue in the texture: the
        // light through each half takes that half's colour (before the fix every shadow ray read
        // the texel at (0, 0): one colour everywhere).
        let texture = Texture::linear(2, 1, vec![Vec3::X, Vec3::Z]);
        let positions = vec![
            Vec3::new(-1.0, -1.0, 2.0),
            Vec3::new(1.0, -1.0, 2.0),
            Vec3::new(1.0, 1.0, 2.0),
            Vec3::new(-1.0, 1.0, 2.0),
        ];
        let uvs = vec![Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.0)];
        let pane = Mesh::new(positions, Vec::new(), uvs, vec![[0, 1, 2], [0, 2, 3]]).unwrap();
        let pane = Object::new(Shape::Mesh(std::sync::Arc::new(pane)), Affine3A::IDENTITY, 2).unwrap();
        let through = |x: f32| {
            let at = Vec3::new(x, 0.0, 0.0);
            reaching(
                "transmissive",
                true,
                vec![pane.clone()],
                at,
                at + Vec3::new(0.0, 0.0, 10.0),
                std::slice::from_ref(&texture),
            )
        };
        assert_eq!(through(-0.5), Vec3::new(0.5, 0.0, 0.0));
        assert_eq!(through(0.5), Vec3::new(0.0, 0.0, 0.5));
    }

    #[test]
    fn regression_a_colour_above_one_does_not_amplify_tinted_shadows() {
        // Found by the fuzzer: colours multiplied along a shadow ray overflowed to infinity.
        let bright = vec![sphere_at(3.0, 3), sphere_at(6.0, 3)];
        assert_eq!(transmittance("transmissive", true, bright, 10.0), Vec3::splat(0.25));
    }

    #[test]
    fn each_glass_object_crossed_counts_once() {
        assert_eq!(transmittance("transmissive", false, vec![], 10.0), Vec3::ONE);
        assert_eq!(transmittance("transmissive", false, vec![sphere_at(3.0, 0)], 10.0), Vec3::splat(0.5));
        assert_eq!(
            transmittance("transmissive", false, vec![sphere_at(3.0, 0), sphere_at(6.0, 0)], 10.0),
            Vec3::splat(0.25)
        );
        // The second sphere lies beyond the light: it does not count.
        assert_eq!(
            transmittance("transmissive", false, vec![sphere_at(3.0, 0), sphere_at(6.0, 0)], 4.5),
            Vec3::splat(0.5)
        );
        // A light inside a glass sphere is dimmed by it once.
        assert_eq!(transmittance("transmissive", false, vec![sphere_at(3.0, 0)], 3.0), Vec3::splat(0.5));
    }

    #[test]
    fn an_opaque_object_inside_glass_is_not_met_as_on_the_refraction_path() {
        // As the handout's refraction path, a shadow ray crosses a transparent object meeting
        // nothing inside it: a small opaque ball within the glass casts no shadow through it.
        let inner = Object::new(
            Shape::Sphere,
            Affine3A::from_scale_rotation_translation(Vec3::splat(0.2), glam::Quat::IDENTITY, Vec3::new(0.0, 0.0, 3.0)),
            1,
        )
        .unwrap();
        assert_eq!(transmittance("transmissive", false, vec![sphere_at(3.0, 0), inner], 10.0), Vec3::splat(0.5));
    }

    #[test]
    fn opaque_blocks_and_tint_filters() {
        assert_eq!(transmittance("transmissive", false, vec![sphere_at(3.0, 0), sphere_at(6.0, 1)], 10.0), Vec3::ZERO);
        assert_eq!(transmittance("transmissive", true, vec![sphere_at(3.0, 0)], 10.0), Vec3::new(0.5, 0.25, 0.125));
    }

    #[test]
    fn hard_blocks_even_glass_and_none_blocks_nothing() {
        assert_eq!(transmittance("hard", false, vec![sphere_at(3.0, 0)], 10.0), Vec3::ZERO);
        assert_eq!(
            transmittance("hard", false, vec![sphere_at(3.0, 0)], 1.5),
            Vec3::ONE,
            "the occluder is past the light"
        );
        assert_eq!(transmittance("none", false, vec![sphere_at(3.0, 1)], 10.0), Vec3::ONE);
    }
}

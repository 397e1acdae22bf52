//! The `ShadowModel` trait: how much of a light reaches a point.

use std::cell::Cell;

use glam::Vec3;
use lancer_core::Light;
use lancer_core::rays::{Hits, PACKET};
use lancer_shapes::{Hit, Lines, NO_SKIP, Origin, Packet};

use crate::ShadeContext;

/// What a shadow model works with: the scene as terms see it (through `Deref`: geometry,
/// materials, colours), and a count of the shadow rays it traces.
pub struct ShadowContext<'a> {
    /// The scene.
    pub scene: &'a ShadeContext<'a>,
    rays: Cell<u64>,
}

impl<'a> std::ops::Deref for ShadowContext<'a> {
    type Target = ShadeContext<'a>;
    fn deref(&self) -> &ShadeContext<'a> {
        self.scene
    }
}

impl<'a> ShadowContext<'a> {
    /// A context over `scene`, with no ray traced yet.
    pub fn new(scene: &'a ShadeContext<'a>) -> ShadowContext<'a> {
        ShadowContext { scene, rays: Cell::new(0) }
    }

    /// The closest object between `from` and the distance `dist` along `dir`, and where the ray
    /// crosses it (`Object::hit` describes the surface there when needed): a shadow ray, counted
    /// in [`ShadowContext::rays`].
    #[inline]
    pub fn occluder(&self, from: Origin, dir: Vec3, dist: f32) -> Option<(u32, lancer_shapes::ShapeHit)> {
        self.rays.set(self.rays.get() + 1);
        self.geometry.closest(from, dir, 0.0, dist)
    }

    /// Whether anything lies between the surface at `at` and the point `target`: a shadow ray
    /// ([`aim`]ed from where it starts) that stops at the first occluder, counted in
    /// [`ShadowContext::rays`]. A target within the start's offset of the surface is never
    /// blocked.
    #[inline]
    pub fn blocked(&self, at: &Hit, target: Vec3) -> bool {
        let Some((from, dir, left)) = aim(self.geometry, at, target) else { return false };
        self.rays.set(self.rays.get() + 1);
        self.geometry.any_hit(from, dir, left)
    }

    /// The first object on each segment of `lines` (ray `i` from its origin, ignoring its
    /// `skip`, along its unit direction) within `0 < t < left(i)`: [`ShadowContext::occluder`]
    /// for many shadow rays at once (each ray gets the answer it would get alone),
    /// `found(i, object, crossing)` for each one that meets something, counted in
    /// [`ShadowContext::rays`].
    pub fn occluders(
        &self,
        lines: Lines<'_>,
        left: impl Fn(usize) -> f32,
        mut found: impl FnMut(usize, u32, &lancer_shapes::ShapeHit),
    ) {
        self.rays.set(self.rays.get() + lines.len() as u64);
        if self.reference {
            // One ray at a time, by the BVH walk.
            return lines.each_ray(|i, o, d| {
                let from = Origin { point: o, skip: lines.skip[i] };
                if let Some((object, c)) = self.geometry.closest(from, d, 0.0, left(i)) {
                    found(i, object, &c);
                }
            });
        }
        self.geometry.closest_each(lines, left, found);
    }

    /// [`ShadowContext::blocked`] for many shadow rays at once: `blocked(i)` for each segment of
    /// `lines` within `0 < t < dist(i)` that meets an object, counted in
    /// [`ShadowContext::rays`].
    pub fn blocked_each(&self, lines: Lines<'_>, dist: impl Fn(usize) -> f32, mut blocked: impl FnMut(usize)) {
        self.rays.set(self.rays.get() + lines.len() as u64);
        if self.reference {
            // One ray at a time, by the BVH walk.
            return lines.each_ray(|i, o, d| {
                if self.geometry.any_hit(Origin { point: o, skip: lines.skip[i] }, d, dist(i)) {
                    blocked(i);
                }
            });
        }
        self.geometry.any_each(lines, dist, blocked);
    }

    /// [`ShadowContext::occluders`] for rays that see through some objects (`through(object)`,
    /// see [`lancer_shapes::Geometry::first_each_through`], with the point they all go to if
    /// they do): `found(i, object, crossing, alone)`,
    /// `alone` when the first object met is see-through and nothing else lies on the ray.
    pub fn occluders_through(
        &self,
        lines: Lines<'_>,
        toward: Option<Vec3>,
        left: impl Fn(usize) -> f32,
        through: impl Fn(u32) -> bool,
        mut found: impl FnMut(usize, u32, &lancer_shapes::ShapeHit, bool),
    ) {
        self.rays.set(self.rays.get() + lines.len() as u64);
        if self.reference {
            // One ray at a time, by the BVH walk: the first object met, and whether it is
            // see-through with nothing else on the ray.
            return lines.each_ray(|i, o, d| {
                let from = Origin { point: o, skip: lines.skip[i] };
                if let Some((object, c)) = self.geometry.closest(from, d, 0.0, left(i)) {
                    found(i, object, &c, through(object) && !self.geometry.any_hit_without(from, d, left(i), object));
                }
            });
        }
        self.geometry.first_each_through(lines, toward, left, through, found);
    }

    /// How many shadow rays were traced through this context.
    pub fn rays(&self) -> u64 {
        self.rays.get()
    }

    /// The unit direction and distance from the hit point `at` to `target`; `None` if they
    /// coincide.
    #[inline]
    pub fn toward(&self, at: &Hit, target: Vec3) -> Option<(Vec3, f32)> {
        toward(at.point, target)
    }
}

/// The unit direction and distance from `point` to `target`; `None` if they coincide (or the
/// distance is not finite).
#[inline]
fn toward(point: Vec3, target: Vec3) -> Option<(Vec3, f32)> {
    let d = target - point;
    let dist = d.length();
    (dist > 0.0 && dist.is_finite()).then(|| (d / dist, dist))
}

/// A shadow ray from the surface at `at` to `target`: it starts where
/// [`lancer_shapes::Geometry::spawn`] puts a ray leaving the surface towards the target, and is
/// aimed at the target from there, so it ends at the target wherever the offset moved its
/// start (a ray that kept the direction from the hit point would end beside the target, by as
/// much as the offset). Gives the start, the unit direction and the length. `None` when no ray
/// is needed: the target is the hit point, or lies behind where the ray starts (within the
/// offset of the surface).
#[inline]
pub fn aim(geometry: &lancer_shapes::Geometry, at: &Hit, target: Vec3) -> Option<(Origin, Vec3, f32)> {
    let (leaving, _) = toward(at.point, target)?;
    let from = geometry.spawn(at, leaving);
    aim_from(from, leaving, target)
}

/// The second half of [`aim`]: the ray from `from` (spawned leaving along `leaving`) towards
/// `target`, if the target lies ahead.
#[inline]
pub(crate) fn aim_from(from: Origin, leaving: Vec3, target: Vec3) -> Option<(Origin, Vec3, f32)> {
    let (dir, left) = toward(from.point, target)?;
    (dir.dot(leaving) > 0.0).then_some((from, dir, left))
}

/// The most hits the visibility system hands a shadow model at once
/// ([`ShadowModel::transmittance_each`], [`HitBlock::CAPACITY`]), and the block the built-in
/// models trace together.
pub(crate) const BLOCK: usize = 64;
// Whole packets.
const _: () = assert!(BLOCK.is_multiple_of(PACKET));

/// Entry `i` is `i`: the map of a block whose rays are all traced, in place.
const IN_PLACE: [usize; BLOCK] = {
    let mut map = [0; BLOCK];
    let mut i = 0;
    while i < BLOCK {
        map[i] = i;
        i += 1;
    }
    map
};

/// Up to [`BLOCK`] hits of a chunk that one light's point may reach, and the straight shadow ray
/// from each towards that point: where [`lancer_shapes::Geometry::spawn`] starts it and the
/// object it ignores, its unit direction (exactly [`ShadowContext::toward`]'s), the distance
/// from the hit point to the light, and what is left of it past the start. The visibility
/// system makes them eight lanes at a time; [`HitBlock::toward`] makes the same bits one hit
/// at a time.
pub struct HitBlock<'a> {
    hits: &'a Hits,
    /// The point the straight rays go to.
    target: Vec3,
    len: usize,
    pub(crate) lane: [u32; BLOCK],
    pub(crate) origin: [Packet; BLOCK / PACKET],
    pub(crate) dir: [Packet; BLOCK / PACKET],
    pub(crate) skip: [u32; BLOCK],
    pub(crate) dist: [f32; BLOCK],
    pub(crate) left: [f32; BLOCK],
}

impl<'a> HitBlock<'a> {
    /// The most hits a block holds.
    pub const CAPACITY: usize = BLOCK;

    /// An empty block over the hits of a chunk, for straight rays towards `target`.
    pub fn empty(hits: &'a Hits, target: Vec3) -> HitBlock<'a> {
        HitBlock {
            hits,
            target,
            len: 0,
            lane: [0; BLOCK],
            origin: [[[0.0; PACKET]; 3]; BLOCK / PACKET],
            dir: [[[0.0; PACKET]; 3]; BLOCK / PACKET],
            skip: [NO_SKIP; BLOCK],
            dist: [0.0; BLOCK],
            left: [0.0; BLOCK],
        }
    }

    /// The hits of `lanes` (at most [`HitBlock::CAPACITY`], each with a hit) with their straight
    /// rays towards `target`, one by one. A hit at the target itself gets no ray: distance and
    /// length left 0.
    pub fn toward(ctx: &ShadeContext<'_>, hits: &'a Hits, lanes: &[usize], target: Vec3) -> HitBlock<'a> {
        assert!(lanes.len() <= BLOCK, "{} hits in a block of {BLOCK}", lanes.len());
        let mut block = HitBlock::empty(hits, target);
        for &lane in lanes {
            assert!(hits.object[lane] != lancer_core::rays::NO_HIT, "lane {lane} has no hit");
            let at = ctx.hit(hits, lane);
            let (from, dir, dist, left) = match toward(at.point, target) {
                Some((leaving, dist)) => {
                    let from = ctx.geometry.spawn(&at, leaving);
                    match aim_from(from, leaving, target) {
                        Some((from, dir, left)) => (from, dir, dist, left),
                        // The target within the offset: no ray (nothing left of it).
                        None => (from, leaving, dist, 0.0),
                    }
                }
                None => (Origin::free(at.point), Vec3::ZERO, 0.0, 0.0),
            };
            block.push(lane, from, dir, dist, left);
        }
        block
    }

    /// The point the block's straight rays go to.
    #[inline]
    pub fn target(&self) -> Vec3 {
        self.target
    }

    /// Appends an entry.
    #[inline(always)]
    pub(crate) fn push(&mut self, lane: usize, from: Origin, dir: Vec3, dist: f32, left: f32) {
        let (i, (p, k)) = (self.len, (self.len / PACKET, self.len % PACKET));
        for axis in 0..3 {
            (self.origin[p][axis][k], self.dir[p][axis][k]) = (from.point[axis], dir[axis]);
        }
        (self.lane[i], self.skip[i], self.dist[i], self.left[i]) = (lane as u32, from.skip, dist, left);
        self.len += 1;
    }

    /// Removes every entry; the rays to come go to `target`.
    #[inline]
    pub(crate) fn clear(&mut self, target: Vec3) {
        (self.len, self.target) = (0, target);
    }

    /// Number of hits.
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the block has no hit.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Hit `i` ([`ShadeContext::hit`] of its lane).
    #[inline]
    pub fn hit(&self, ctx: &ShadeContext<'_>, i: usize) -> Hit {
        ctx.hit(self.hits, self.lane(i))
    }

    /// The chunk lane of hit `i`.
    #[inline]
    pub fn lane(&self, i: usize) -> usize {
        assert!(i < self.len, "hit {i} of {}", self.len);
        self.lane[i] as usize
    }

    /// Where hit `i`'s straight ray starts, and the object it ignores.
    #[inline]
    pub fn origin(&self, i: usize) -> Origin {
        assert!(i < self.len, "hit {i} of {}", self.len);
        Origin { point: lancer_core::rays::lane(&self.origin[i / PACKET], i % PACKET), skip: self.skip[i] }
    }

    /// The unit direction of hit `i`'s straight ray.
    #[inline]
    pub fn dir(&self, i: usize) -> Vec3 {
        assert!(i < self.len, "hit {i} of {}", self.len);
        lancer_core::rays::lane(&self.dir[i / PACKET], i % PACKET)
    }

    /// The distance from hit `i`'s point to the target (0: no ray).
    #[inline]
    pub fn dist(&self, i: usize) -> f32 {
        self.dist[..self.len][i]
    }

    /// The length of hit `i`'s straight ray: aimed at the target from its start ([`aim`]), it
    /// reaches the target at this distance from its origin (0: no ray, the target is within the
    /// start's offset of the surface).
    #[inline]
    pub fn left(&self, i: usize) -> f32 {
        self.left[..self.len][i]
    }

    /// The straight rays of the hits `keep` accepts, and the hit each of them is:
    /// `traced(rays, hit_of_ray)`. When every hit is kept (the usual case) they are the block's
    /// own columns; else a copy of those kept.
    pub fn rays_where<R>(&self, keep: impl Fn(usize) -> bool, traced: impl FnOnce(Lines<'_>, &[usize]) -> R) -> R {
        let n = self.len;
        if (0..n).all(&keep) {
            let lines = Lines {
                origin: &self.origin[..n.div_ceil(PACKET)],
                dir: &self.dir[..n.div_ceil(PACKET)],
                skip: &self.skip[..n],
            };
            return traced(lines, &IN_PLACE[..n]);
        }
        let mut kept = HitBlock::empty(self.hits, self.target);
        let mut which = [0usize; BLOCK];
        for i in (0..n).filter(|&i| keep(i)) {
            which[kept.len] = i;
            kept.push(self.lane[i] as usize, self.origin(i), self.dir(i), self.dist[i], self.left[i]);
        }
        let m = kept.len;
        let lines = Lines {
            origin: &kept.origin[..m.div_ceil(PACKET)],
            dir: &kept.dir[..m.div_ceil(PACKET)],
            skip: &kept.skip[..m],
        };
        traced(lines, &which[..m])
    }
}

/// `list` as a chunk's hit columns (material 0, colour black), for tests.
#[cfg(test)]
pub(crate) fn columns_of(list: &[Hit]) -> Hits {
    let mut hits = Hits::default();
    hits.reset(list.len());
    for (lane, h) in list.iter().enumerate() {
        (hits.t[lane], hits.object[lane], hits.local[lane], hits.uv[lane]) = (h.t, h.object, h.local, h.uv);
        (hits.error[lane], hits.front[lane], hits.material[lane]) = (h.error, h.front, 0);
        hits.color.set(lane, Vec3::ZERO);
        hits.point.set(lane, h.point);
        hits.normal.set(lane, h.normal);
        hits.shading.set(lane, h.shading);
    }
    hits
}

/// A shadow model: the fraction (per RGB channel) of a light's colour that reaches a point.
pub trait ShadowModel: Send + Sync {
    /// Transmittance of `light` to the surface point of `at`, per RGB channel. Shadow rays start
    /// where [`lancer_shapes::Geometry::spawn`] says (the helpers on [`ShadowContext`] do it).
    fn transmittance(&self, ctx: &ShadowContext<'_>, at: &Hit, light: &Light) -> Vec3;

    /// [`ShadowModel::transmittance`] of `light` to each hit of `block`, into `out` (as long):
    /// the visibility system asks for a block of hits at a time, each with its straight ray
    /// towards the light's point (`block.target()`, which is `light.at`) already made. The default asks for each hit in turn; a model
    /// may trace the rays together (with [`ShadowContext::occluders`]) as long as each hit gets
    /// what `transmittance` gives it.
    fn transmittance_each(&self, ctx: &ShadowContext<'_>, block: &HitBlock<'_>, light: &Light, out: &mut [Vec3]) {
        for (i, out) in out.iter_mut().enumerate().take(block.len()) {
            *out = self.transmittance(ctx, &block.hit(ctx, i), light);
        }
    }
}

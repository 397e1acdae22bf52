//! The `ShadowModel` trait: how much of a light reaches a point.

use std::cell::Cell;

use glam::Vec3;
use lancer_core::Light;
use lancer_shapes::{Hit, Lines, Origin};

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

    /// Whether anything lies between the surface at `at` and the distance `dist` along `dir`: a
    /// shadow ray that stops at the first occluder, counted in [`ShadowContext::rays`].
    #[inline]
    pub fn blocked(&self, at: &Hit, dir: Vec3, dist: f32) -> bool {
        self.rays.set(self.rays.get() + 1);
        self.geometry.any_hit(self.geometry.spawn(at, dir), dir, dist)
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
        found: impl FnMut(usize, u32, &lancer_shapes::ShapeHit),
    ) {
        self.rays.set(self.rays.get() + lines.len() as u64);
        self.geometry.closest_each(lines, left, found);
    }

    /// [`ShadowContext::blocked`] for many shadow rays at once: `blocked(i)` for each segment of
    /// `lines` within `0 < t < dist(i)` that meets an object, counted in
    /// [`ShadowContext::rays`].
    pub fn blocked_each(&self, lines: Lines<'_>, dist: impl Fn(usize) -> f32, blocked: impl FnMut(usize)) {
        self.rays.set(self.rays.get() + lines.len() as u64);
        self.geometry.any_each(lines, dist, blocked);
    }

    /// How many shadow rays were traced through this context.
    pub fn rays(&self) -> u64 {
        self.rays.get()
    }

    /// The unit direction and distance from the hit point `at` to `target`; `None` if they
    /// coincide.
    #[inline]
    pub fn toward(&self, at: &Hit, target: Vec3) -> Option<(Vec3, f32)> {
        let d = target - at.point;
        let dist = d.length();
        (dist > 0.0 && dist.is_finite()).then(|| (d / dist, dist))
    }
}

/// The most hits the visibility system hands a shadow model at once
/// ([`ShadowModel::transmittance_each`]), and the block the built-in models trace together.
pub(crate) const BLOCK: usize = 64;

/// A shadow model: the fraction (per RGB channel) of a light's colour that reaches a point.
pub trait ShadowModel: Send + Sync {
    /// Transmittance of `light` to the surface point of `at`, per RGB channel. Shadow rays start
    /// where [`lancer_shapes::Geometry::spawn`] says (the helpers on [`ShadowContext`] do it).
    fn transmittance(&self, ctx: &ShadowContext<'_>, at: &Hit, light: &Light) -> Vec3;

    /// [`ShadowModel::transmittance`] of `light` to each of `hits`, into `out` (as long): the
    /// visibility system asks for a block of hits at a time. The default asks for each hit in
    /// turn; a model may trace the rays together (with [`ShadowContext::occluders`]) as long as
    /// each hit gets what `transmittance` gives it.
    fn transmittance_each(&self, ctx: &ShadowContext<'_>, hits: &[Hit], light: &Light, out: &mut [Vec3]) {
        for (at, out) in hits.iter().zip(out) {
            *out = self.transmittance(ctx, at, light);
        }
    }
}

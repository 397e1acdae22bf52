//! The `ShadowModel` trait: how much of a light reaches a point.

use std::cell::Cell;

use glam::Vec3;
use lancer_core::{Light, Material, Texture};
use lancer_shapes::{Geometry, Origin};

/// Scene data a shadow model may use, and a count of the shadow rays it traces.
pub struct ShadowContext<'a> {
    /// The scene's objects.
    pub geometry: &'a Geometry,
    /// The material table.
    pub materials: &'a [Material],
    /// Images for `Pattern::Image` materials.
    pub textures: &'a [Texture],
    rays: Cell<u64>,
}

impl<'a> ShadowContext<'a> {
    /// A context over `geometry` and `materials`, with no ray traced yet.
    pub fn new(geometry: &'a Geometry, materials: &'a [Material], textures: &'a [Texture]) -> ShadowContext<'a> {
        ShadowContext { geometry, materials, textures, rays: Cell::new(0) }
    }

    /// `Col_Ω` of object `object` at the world point `p` on its surface.
    pub fn color_at(&self, object: u32, p: Vec3) -> Vec3 {
        let o = &self.geometry.objects[object as usize];
        crate::surface_color(
            self.material(object),
            &o.shape,
            o.object_from_world.transform_point3(p),
            glam::Vec2::ZERO,
            self.textures,
        )
    }

    /// The closest object between `from` and the distance `dist` along `dir`: a shadow ray,
    /// counted in [`ShadowContext::rays`].
    #[inline]
    pub fn occluder(&self, from: Origin, dir: Vec3, dist: f32) -> Option<lancer_shapes::Hit> {
        self.rays.set(self.rays.get() + 1);
        self.geometry.closest_hit(from, dir, 0.0, dist)
    }

    /// Whether anything lies between `from` and the distance `dist` along `dir`: a shadow ray
    /// that stops at the first occluder, counted in [`ShadowContext::rays`].
    #[inline]
    pub fn blocked(&self, from: Origin, dir: Vec3, dist: f32) -> bool {
        self.rays.set(self.rays.get() + 1);
        self.geometry.any_hit(from, dir, dist)
    }

    /// How many shadow rays were traced through this context.
    pub fn rays(&self) -> u64 {
        self.rays.get()
    }

    /// The unit direction and distance from `from` to `target`; `None` if they coincide.
    #[inline]
    pub fn toward(&self, from: Origin, target: Vec3) -> Option<(Vec3, f32)> {
        let d = target - from.point;
        let dist = d.length();
        (dist > 0.0).then(|| (d / dist, dist))
    }

    /// The material of object `object`.
    #[inline]
    pub fn material(&self, object: u32) -> &Material {
        &self.materials[self.geometry.objects[object as usize].material as usize]
    }
}

/// A shadow model: the fraction (per RGB channel) of a light's colour that reaches a point.
pub trait ShadowModel: Send + Sync {
    /// Transmittance of `light` to the point `from` (see [`Geometry::leave`]), per RGB channel.
    fn transmittance(&self, ctx: &ShadowContext<'_>, from: Origin, light: &Light) -> Vec3;
}

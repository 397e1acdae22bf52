//! The `ShadowModel` trait: how much of a light reaches a point.

use glam::Vec3;
use lancer_core::{Light, Material};
use lancer_shapes::{Geometry, Origin};

/// Scene data a shadow model may use.
pub struct ShadowContext<'a> {
    /// The scene's objects.
    pub geometry: &'a Geometry,
    /// The material table.
    pub materials: &'a [Material],
}

impl ShadowContext<'_> {
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

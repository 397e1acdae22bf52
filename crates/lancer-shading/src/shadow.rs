//! The `ShadowModel` trait: how much of a light reaches a point.

use glam::Vec3;
use lancer_core::Material;
use lancer_shapes::{Geometry, Origin};

/// Scene data a shadow model may use.
pub struct ShadowContext<'a> {
    /// The scene's objects.
    pub geometry: &'a Geometry,
    /// The material table.
    pub materials: &'a [Material],
}

impl ShadowContext<'_> {
    /// The material of object `object`.
    #[inline]
    pub fn material(&self, object: u32) -> &Material {
        &self.materials[self.geometry.objects[object as usize].material as usize]
    }
}

/// A shadow model: the fraction (per RGB channel) of a light's colour that reaches a point.
pub trait ShadowModel: Send + Sync {
    /// Transmittance from `from` (see [`Geometry::leave`]) along the unit direction `dir` to the
    /// light at distance `dist`.
    fn transmittance(&self, ctx: &ShadowContext<'_>, from: Origin, dir: Vec3, dist: f32) -> Vec3;
}

//! The handout's material (six numbers and a colour) and lights.

use glam::Vec3;

/// How `Col_Ω` varies over a surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pattern {
    /// `Material::color` everywhere.
    Solid,
    /// A 3D checker in object space: cubes of side `scale` alternate between
    /// `Material::color` and `other`.
    Checker {
        /// The second colour, linear RGB.
        other: Vec3,
        /// Side of a checker cube, in object units.
        scale: f32,
    },
    /// An image (index into the scene's textures) mapped by the shape's UV coordinates; for
    /// planes and disks one copy of the image covers `scale` × `scale` object units.
    Image {
        /// Index into `Scene::textures`.
        texture: u32,
        /// Tile size for planar mappings.
        scale: f32,
    },
}

/// A material of the handout's model. Every factor is in [0, 1] except `n`, in [1, 2.5].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// `Col_Ω`, linear RGB (the first colour of a pattern).
    pub color: Vec3,
    /// How the colour varies over the surface.
    pub pattern: Pattern,
    /// Ambient fraction.
    pub ambi: f32,
    /// Diffuse (Lambert) weight.
    pub diff: f32,
    /// Specular weight: highlight and mirror.
    pub spec: f32,
    /// Glossiness: the highlight exponent is `1 / (1 - shine)`.
    pub shine: f32,
    /// Transparency weight (0: no refraction work at all).
    pub alpha: f32,
    /// Refractive index.
    pub n: f32,
}

impl Default for Material {
    /// A plain white matte material: what an object without a material gets.
    fn default() -> Self {
        Material {
            color: Vec3::ONE,
            pattern: Pattern::Solid,
            ambi: 0.1,
            diff: 0.9,
            spec: 0.0,
            shine: 0.0,
            alpha: 0.0,
            n: 1.0,
        }
    }
}

/// A light: a point, or a square area light when `size > 0`. No distance fall-off (the
/// handout's model).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// Position (the square's centre for an area light). In a prepared scene it is measured
    /// from the prepared frame's origin (the camera); in a scene's World it is the world
    /// position rounded to f32, a [`crate::Position`] beside it holding it in f64.
    pub at: Vec3,
    /// `Col_L` before intensity, linear RGB.
    pub color: Vec3,
    /// Scales `color`.
    pub intensity: f32,
    /// Side of the square area light, parallel to the xz-plane (facing down); 0 for a point.
    /// Only the `soft` shadow model samples the square; the others see its centre.
    pub size: f32,
}

impl Light {
    /// The light's colour times its intensity: `Col_L` in the model's formulas.
    #[inline]
    pub fn radiance(&self) -> Vec3 {
        self.color * self.intensity
    }
}

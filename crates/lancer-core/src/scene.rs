//! The scene: a `hecs::World` of objects, materials and lights, plus camera and image settings.

use glam::{Affine3A, DVec3, Mat3A, Vec3};

use crate::Camera;

/// Placement of an object: `world_from_object` (scale, then rotate, then translate), with its
/// translation kept in f64 as well: prepare takes the camera's position off it before it
/// rounds it ([`Transform::seen_from`]), so an object far from the origin is placed as exactly,
/// relative to the camera, as one near it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Object space to world space, in f32 (its translation `translation` rounded).
    pub world_from_object: Affine3A,
    /// The translation in f64, as the scene gives it.
    pub translation: DVec3,
}

impl Transform {
    /// The placement by the linear part `linear` (scale and rotation), then `translation`.
    pub fn new(linear: Mat3A, translation: DVec3) -> Transform {
        Transform {
            world_from_object: Affine3A { matrix3: linear, translation: translation.as_vec3().into() },
            translation,
        }
    }

    /// The placement `world_from_object`, its translation exactly its f32 one.
    pub fn from_affine(world_from_object: Affine3A) -> Transform {
        Transform { world_from_object, translation: Vec3::from(world_from_object.translation).as_dvec3() }
    }

    /// Object space to the frame whose origin is the world point `origin`: the translation less
    /// `origin`, in f64, rounded to f32 once.
    pub fn seen_from(&self, origin: DVec3) -> Affine3A {
        Affine3A { matrix3: self.world_from_object.matrix3, translation: (self.translation - origin).as_vec3().into() }
    }
}

/// A light's position in world space, in f64 as the scene gives it, beside its
/// [`crate::Light`] (whose `at` holds it rounded to f32): prepare places the light by this one,
/// with the camera's position taken off first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Position(pub DVec3);

/// Links an object entity to the entity holding its [`crate::Material`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MaterialOf(pub hecs::Entity);

/// Image settings of the `[image]` table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageSettings {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear RGB seen by rays that hit nothing.
    pub background: Vec3,
    /// Samples per pixel (1 with [`ImageSettings::adaptive`]: the first pass).
    pub samples: u32,
    /// Adaptive anti-aliasing: one sample at each pixel's centre, then more where a pixel
    /// differs from a neighbour; `None`, every pixel gets `samples`.
    pub adaptive: Option<Adaptive>,
}

impl Default for ImageSettings {
    fn default() -> Self {
        ImageSettings { width: 640, height: 480, background: Vec3::ZERO, samples: 1, adaptive: None }
    }
}

impl ImageSettings {
    /// Every pixel `samples` samples: adaptive anti-aliasing, if the image had it, is off.
    pub fn set_samples(&mut self, samples: u32) {
        (self.samples, self.adaptive) = (samples, None);
    }

    /// Adaptive anti-aliasing (its first pass is one sample a pixel).
    pub fn set_adaptive(&mut self, adaptive: Adaptive) {
        (self.samples, self.adaptive) = (1, Some(adaptive));
    }
}

/// Adaptive anti-aliasing, as POV-Ray's method 1 (`+A<threshold> +R<depth>`): every pixel is
/// first traced once, at its centre; a pixel whose first value differs from one of its four
/// neighbours' by `threshold` or more is traced again at its centre and at the centres of a
/// `depth` x `depth` grid of cells, and its value is the mean of those `depth² + 1` samples.
/// Two values differ by the sum over red, green and blue of their difference as a PNG stores
/// them (8-bit sRGB, in steps of 1/255), from 0 to 3.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptive {
    /// The difference from which a pixel is supersampled, in [0, 3].
    pub threshold: f32,
    /// The side of the grid of samples of a supersampled pixel, from [`Adaptive::MIN_DEPTH`] to
    /// [`Adaptive::MAX_DEPTH`].
    pub depth: u32,
}

impl Adaptive {
    /// Smallest grid side: 2 (a grid of one cell would be the centre again).
    pub const MIN_DEPTH: u32 = 2;
    /// Largest grid side: 9, as POV-Ray's `+R` (82 samples a pixel).
    pub const MAX_DEPTH: u32 = 9;

    /// The samples of a supersampled pixel: its centre and the grid's.
    pub fn samples(self) -> u32 {
        self.depth * self.depth + 1
    }

    /// Sub-pixel position of sample `s` of a supersampled pixel: sample 0 at the centre, then
    /// the grid's cell centres row by row.
    pub fn offset(self, s: u32) -> (f32, f32) {
        if s == 0 {
            return (0.5, 0.5);
        }
        let (k, r) = (s - 1, self.depth.max(1));
        (((k % r) as f32 + 0.5) / r as f32, ((k / r) as f32 + 0.5) / r as f32)
    }

    /// A pixel's value as it is compared: the bytes a PNG stores for it ([`crate::srgb8`]).
    pub fn shown(v: Vec3) -> [u8; 3] {
        v.to_array().map(crate::srgb8)
    }

    /// Whether two pixels' [`Adaptive::shown`] values differ by the threshold or more: the sum
    /// over red, green and blue of their differences, in steps of 1/255, from 0 to 3.
    pub fn differ(self, a: [u8; 3], b: [u8; 3]) -> bool {
        let steps: u32 = (0..3).map(|i| a[i].abs_diff(b[i]) as u32).sum();
        steps as f32 / 255.0 >= self.threshold
    }
}

/// Optional human-facing description of a scene (`[meta]`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Meta {
    /// Short title.
    pub title: Option<String>,
    /// What the scene shows.
    pub description: Option<String>,
}

/// A loaded scene. Objects are entities with a shape component (from the shapes crate), a
/// [`Transform`] and a [`MaterialOf`]; materials are entities with a [`crate::Material`]; lights
/// are entities with a [`crate::Light`] and, when their position needs more than f32, a
/// [`Position`].
pub struct Scene {
    /// The scene's entities.
    pub world: hecs::World,
    /// The camera, in world space (its position in f64).
    pub camera: Camera,
    /// Image size, background, samples.
    pub image: ImageSettings,
    /// Title and description.
    pub meta: Meta,
    /// Images used by `Pattern::Image` materials.
    pub textures: Vec<crate::Texture>,
}

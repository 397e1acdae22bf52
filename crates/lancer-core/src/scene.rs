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
    /// Samples per pixel.
    pub samples: u32,
}

impl Default for ImageSettings {
    fn default() -> Self {
        ImageSettings { width: 640, height: 480, background: Vec3::ZERO, samples: 1 }
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

//! The scene: a `hecs::World` of objects, materials and lights, plus camera and image settings.

use glam::{Affine3A, Vec3};

use crate::Camera;

/// Placement of an object: `world_from_object` (scale, then rotate, then translate).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Object space to world space.
    pub world_from_object: Affine3A,
}

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
/// are entities with a [`crate::Light`].
pub struct Scene {
    /// The scene's entities.
    pub world: hecs::World,
    /// The camera.
    pub camera: Camera,
    /// Image size, background, samples.
    pub image: ImageSettings,
    /// Title and description.
    pub meta: Meta,
    /// Images used by `Pattern::Image` materials.
    pub textures: Vec<crate::Texture>,
}

//! Lancer's core: optics helpers, camera, materials and lights, the scene's ECS components, the
//! SoA ray/hit chunks of the per-tile ray world, and the per-term image buffers (the frame).
//!
//! This crate knows nothing of shape internals, terms or files: it is the vocabulary the other
//! crates share.

pub mod camera;
pub mod frame;
pub mod material;
pub mod optics;
pub mod rays;
pub mod scene;
pub mod srgb;
pub mod texture;

pub use camera::Camera;
pub use frame::{Frame, Layer, RenderStats, SystemTimes};
pub use glam::Vec3;
pub use material::{Light, Material, Pattern};
pub use scene::{Adaptive, ImageSettings, MaterialOf, Meta, Position, Scene, Transform};
pub use srgb::{srgb_decode, srgb_encode, srgb8};
pub use texture::{Texels, Texture};

/// A linear RGB colour (no gamma), stored as a `Vec3`.
pub type Rgb = Vec3;

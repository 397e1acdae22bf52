//! Intersection: canonical shapes in object space, objects placed by affine transforms, and the
//! flattened scene geometry with its BVH. Answers "first hit" and "where does a ray that starts
//! inside this object leave" (the refraction exit point).
//!
//! This crate knows nothing of hecs, terms or files.

mod aabb;
mod bvh;
mod csg;
mod geometry;
mod mesh;
mod quartic;
mod shape;
mod topology;
mod torus;

pub use aabb::Aabb;
pub use bvh::Bvh;
pub use csg::{Csg, CsgNode, CsgOp, Span, combine};
pub use geometry::{Geometry, Hit, NO_SKIP, Object, Origin, invertible};
pub use mesh::{Mesh, MeshError};
pub use shape::{LocalSurface, Shape, ShapeHit};

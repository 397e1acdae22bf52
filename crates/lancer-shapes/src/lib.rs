//! Intersection: canonical shapes in object space, objects placed by affine transforms, and the
//! flattened scene geometry with its BVH. Answers "first hit" and "where does a ray that starts
//! inside this object leave" (the refraction exit point).
//!
//! This crate knows nothing of hecs, terms or files.

mod aabb;
mod bvh;
mod csg;
mod geometry;
mod lanes;
mod mesh;
mod quartic;
mod shape;
mod stream;
mod topology;
mod torus;

pub use aabb::Aabb;
pub use bvh::Bvh;
pub use csg::{Csg, CsgNode, CsgOp, Span, combine};
pub use geometry::{Geometry, Hit, HitGroup, Lines, NO_SKIP, Object, Origin, Packet, invertible};
pub use mesh::{Mesh, MeshError};
pub use shape::{LocalSurface, Shape, ShapeHit};

/// What the unit tests share.
#[cfg(test)]
pub(crate) mod testing {
    /// A fixed xorshift sequence from `seed` as uniform numbers in `[lo, hi)`: the same cases on
    /// every run, with no generator crate.
    pub(crate) fn uniform(seed: u64) -> impl FnMut(f32, f32) -> f32 {
        let mut state = seed;
        move |lo, hi| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            lo + (hi - lo) * ((state >> 40) as f32 / (1u64 << 24) as f32)
        }
    }

    /// `v` as packets, for [`crate::Lines`].
    pub(crate) fn packets(v: &[glam::Vec3]) -> Vec<crate::Packet> {
        v.chunks(8)
            .map(|c| {
                let mut p = [[0.0; 8]; 3];
                for (k, v) in c.iter().enumerate() {
                    (p[0][k], p[1][k], p[2][k]) = (v.x, v.y, v.z);
                }
                p
            })
            .collect()
    }
}

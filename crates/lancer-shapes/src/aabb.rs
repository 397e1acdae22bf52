//! Axis-aligned bounding boxes (the ray–box slab test is in `bvh.rs`, four boxes at a time).

use glam::{Affine3A, Vec3};

/// An axis-aligned box; `min > max` on some axis means empty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Default for Aabb {
    /// The empty box.
    fn default() -> Aabb {
        Aabb::EMPTY
    }
}

impl Aabb {
    /// The empty box (the identity of [`Aabb::union`]).
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    /// The smallest box holding both.
    #[inline]
    pub fn union(self, o: Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    /// The box's centre.
    #[inline]
    pub fn centre(self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Half the surface area (enough for SAH ratios); 0 for an empty box.
    #[inline]
    pub fn half_area(self) -> f32 {
        let e = (self.max - self.min).max(Vec3::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    /// The world box of this object-space box under `m` (its eight corners, transformed).
    pub fn transformed(self, m: &Affine3A) -> Aabb {
        let mut out = Aabb::EMPTY;
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            );
            let p = m.transform_point3(c);
            out = out.union(Aabb { min: p, max: p });
        }
        out
    }
}

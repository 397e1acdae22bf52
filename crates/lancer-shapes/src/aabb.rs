//! Axis-aligned bounding boxes and the ray–box slab test.

use glam::{Affine3A, Vec3};

/// An axis-aligned box; `min > max` on some axis means empty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
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

    /// Entry distance of the ray `o + t d` (with `inv_d = 1 / d`) if it meets the box within
    /// `[0, tmax]`.
    #[inline]
    pub fn hit(&self, o: Vec3, inv_d: Vec3, tmax: f32) -> Option<f32> {
        self.hit_range(o, inv_d, 0.0, tmax)
    }

    /// Entry distance if the ray meets the box within `[tmin, tmax]`.
    #[inline]
    pub fn hit_range(&self, o: Vec3, inv_d: Vec3, tmin: f32, tmax: f32) -> Option<f32> {
        let t0 = (self.min - o) * inv_d;
        let t1 = (self.max - o) * inv_d;
        // min/max ignore a NaN operand (0 · ∞ on a slab's own plane), which keeps such rays in.
        let near = t0.min(t1).max_element().max(tmin);
        let far = t0.max(t1).min_element().min(tmax);
        (near <= far).then_some(near)
    }
}

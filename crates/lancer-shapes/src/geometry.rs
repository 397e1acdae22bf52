//! The prepared scene geometry: objects as flat arrays, a BVH over the bounded ones, a list of
//! the unbounded ones, closest-hit and exit queries in world space, and robust ray offsets.

use glam::{Affine3A, Mat3A, Vec3};

use crate::{Aabb, Bvh, Shape};

/// One placed shape.
#[derive(Clone, Debug)]
pub struct Object {
    /// The canonical shape.
    pub shape: Shape,
    /// Object space to world space.
    pub world_from_object: Affine3A,
    /// World space to object space.
    pub object_from_world: Affine3A,
    /// Maps object-space normals to world space (inverse transpose of the linear part).
    pub world_from_object_normal: Mat3A,
    /// Index into the prepared material table.
    pub material: u32,
}

impl Object {
    /// Places `shape` with `world_from_object`; `None` if the transform is singular.
    pub fn new(shape: Shape, world_from_object: Affine3A, material: u32) -> Option<Object> {
        let det = world_from_object.matrix3.determinant();
        if !det.is_finite() || det.abs() < 1e-12 {
            return None;
        }
        let object_from_world = world_from_object.inverse();
        Some(Object {
            shape,
            world_from_object,
            object_from_world,
            world_from_object_normal: object_from_world.matrix3.transpose(),
            material,
        })
    }

    fn world_normal(&self, n_obj: Vec3) -> Vec3 {
        (self.world_from_object_normal * n_obj).normalize_or(Vec3::Y)
    }

    /// The world ray `o + t d` in object space (same `t`).
    #[inline]
    fn to_object(&self, o: Vec3, d: Vec3) -> (Vec3, Vec3) {
        (self.object_from_world.transform_point3(o), self.object_from_world.transform_vector3(d))
    }

    /// First hit of the world ray `o + t d` with `tmin < t < tmax`.
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, Vec3)> {
        let (oo, od) = self.to_object(o, d);
        self.shape.intersect(oo, od, tmin, tmax).map(|(t, n)| (t, self.world_normal(n)))
    }

    /// Whether the object lies on the world ray within `0 < t < tmax` (any hit will do).
    #[inline]
    pub fn occludes(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        let (oo, od) = self.to_object(o, d);
        self.shape.occludes(oo, od, tmax)
    }

    /// Where the world ray `o + t d`, starting inside, leaves this object.
    #[inline]
    pub fn exit(&self, o: Vec3, d: Vec3) -> Option<(f32, Vec3)> {
        let (oo, od) = self.to_object(o, d);
        self.shape.exit(oo, od).map(|(t, n)| (t, self.world_normal(n)))
    }

    /// World-space bounds; `None` for unbounded shapes.
    pub fn bounds(&self) -> Option<Aabb> {
        self.shape.bounds().map(|b| b.transformed(&self.world_from_object))
    }
}

/// A ray–surface hit in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray (in units of the ray's direction length).
    pub t: f32,
    /// Index of the object hit.
    pub object: u32,
    /// Unit outward normal.
    pub normal: Vec3,
    /// Whether the ray arrived from outside.
    pub front: bool,
}

/// All objects of a scene, ready for queries.
#[derive(Clone, Debug, Default)]
pub struct Geometry {
    /// The objects; hits name them by index.
    pub objects: Vec<Object>,
    bvh: Bvh,
    bounded: Vec<u32>,
    unbounded: Vec<u32>,
}

/// `Origin::skip` when a ray may hit every object.
pub const NO_SKIP: u32 = u32::MAX;

/// Where a secondary ray starts, and the object it must ignore (the one it leaves, when convex).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Origin {
    /// The start point.
    pub point: Vec3,
    /// An object index to ignore, or [`NO_SKIP`].
    pub skip: u32,
}

impl Origin {
    /// A ray from `point` that may hit anything (camera rays).
    pub fn free(point: Vec3) -> Origin {
        Origin { point, skip: NO_SKIP }
    }
}

/// How far a secondary ray's origin moves off the surface: relative to the point's magnitude so
/// that it stays above f32 rounding of the hit point wherever the object is.
const OFFSET_REL: f32 = 1e-4;

/// Moves `p` off a surface along the unit normal `n`, to the side `n` points to, by a distance
/// that scales with `|p|` (self-intersection acne otherwise).
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    p + n * (OFFSET_REL * p.abs().max_element().max(1.0))
}

impl Geometry {
    /// Builds the BVH over the bounded objects.
    pub fn new(objects: Vec<Object>) -> Geometry {
        let mut bounds = Vec::new();
        let (mut bounded, mut unbounded) = (Vec::new(), Vec::new());
        for (i, o) in objects.iter().enumerate() {
            match o.bounds() {
                Some(b) => {
                    bounds.push(b);
                    bounded.push(i as u32);
                }
                None => unbounded.push(i as u32),
            }
        }
        Geometry { bvh: Bvh::build(&bounds), objects, bounded, unbounded }
    }

    /// Where a ray leaving `object` at `p`, towards the side the unit normal `n` points to, starts.
    ///
    /// A convex object cannot be met again, so the ray ignores it and starts a hair *behind* the
    /// surface: an object touching it there (a glass cube resting on a floor) is still found,
    /// which a start in front of the surface would step over. A non-convex object is not
    /// ignored; the ray starts a hair in front of the surface instead.
    #[inline]
    pub fn leave(&self, object: u32, p: Vec3, n: Vec3) -> Origin {
        if self.objects[object as usize].shape.is_convex() {
            Origin { point: offset_origin(p, -n), skip: object }
        } else {
            Origin { point: offset_origin(p, n), skip: NO_SKIP }
        }
    }

    fn hit_with(&self, i: u32, o: Vec3, d: Vec3, tmin: f32, tmax: f32, best: &mut Option<Hit>) -> f32 {
        match self.objects[i as usize].intersect(o, d, tmin, tmax) {
            Some((t, normal)) => {
                *best = Some(Hit { t, object: i, normal, front: normal.dot(d) < 0.0 });
                t
            }
            None => tmax,
        }
    }

    /// The closest hit of `o + t d` with `tmin < t < tmax`. The BVH build and traversal order are
    /// deterministic, so the same ray always gets the same hit.
    pub fn closest_hit(&self, from: Origin, d: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        let (o, skip) = (from.point, from.skip);
        let mut best = None;
        let mut tmax = tmax;
        for &i in &self.unbounded {
            if i != skip {
                tmax = self.hit_with(i, o, d, tmin, tmax, &mut best);
            }
        }
        self.bvh.traverse(o, d, tmax, |item, tmax| {
            let i = self.bounded[item as usize];
            if i == skip { tmax } else { self.hit_with(i, o, d, tmin, tmax, &mut best) }
        });
        best
    }

    /// Whether any object (but `from.skip`) lies on the ray within `0 < t < tmax`: a shadow ray
    /// that may stop at the first occluder it finds.
    pub fn any_hit(&self, from: Origin, d: Vec3, tmax: f32) -> bool {
        let (o, skip) = (from.point, from.skip);
        let blocks = |i: u32| i != skip && self.objects[i as usize].occludes(o, d, tmax);
        if self.unbounded.iter().any(|&i| blocks(i)) {
            return true;
        }
        let mut found = false;
        self.bvh.traverse(o, d, tmax, |item, tmax| {
            if found || blocks(self.bounded[item as usize]) {
                found = true;
                return -1.0;
            }
            tmax
        });
        found
    }

    /// The closest hit by testing every object, for checking the BVH.
    pub fn closest_hit_brute_force(&self, from: Origin, d: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        let mut best = None;
        let mut tmax = tmax;
        for i in (0..self.objects.len() as u32).filter(|&i| i != from.skip) {
            tmax = self.hit_with(i, from.point, d, tmin, tmax, &mut best);
        }
        best
    }

    /// Where the ray `o + t d`, starting inside object `object`, leaves it.
    pub fn exit(&self, object: u32, o: Vec3, d: Vec3) -> Option<Hit> {
        self.objects[object as usize].exit(o, d).map(|(t, normal)| Hit { t, object, normal, front: false })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

    fn random_scene(spec: &[(u8, [f32; 3], f32, [f32; 3])]) -> Geometry {
        let objects = spec
            .iter()
            .map(|&(k, t, s, r)| {
                let shape = [Shape::Sphere, Shape::Cube, Shape::Plane][k as usize % 3].clone();
                let m = Affine3A::from_scale_rotation_translation(
                    Vec3::splat(s),
                    Quat::from_euler(glam::EulerRot::XYZ, r[0], r[1], r[2]),
                    Vec3::from(t),
                );
                Object::new(shape, m, 0).unwrap()
            })
            .collect();
        Geometry::new(objects)
    }

    #[test]
    fn bvh_gives_the_brute_force_closest_hit() {
        let mut runner = TestRunner::new_with_rng(
            Config { cases: 200, ..Config::default() },
            TestRng::from_seed(RngAlgorithm::ChaCha, &[7; 32]),
        );
        let obj = (0u8..8, prop::array::uniform3(-10f32..10.0), 0.1f32..2.0, prop::array::uniform3(-3f32..3.0));
        let ray = (prop::array::uniform3(-12f32..12.0), prop::array::uniform3(-1f32..1.0), 0u32..100);
        runner
            .run(&(prop::collection::vec(obj, 1..60), prop::collection::vec(ray, 50)), |(spec, rays)| {
                let g = random_scene(&spec);
                for (o, d, skip) in rays {
                    let Some(d) = Vec3::from(d).try_normalize() else {
                        continue;
                    };
                    let o = Origin { point: Vec3::from(o), skip: skip % 64 };
                    let a = g.closest_hit(o, d, 1e-4, f32::INFINITY);
                    let b = g.closest_hit_brute_force(o, d, 1e-4, f32::INFINITY);
                    prop_assert_eq!(a.map(|h| h.t), b.map(|h| h.t));
                    for tmax in [0.5f32, 3.0, 50.0] {
                        let near = g.closest_hit(o, d, 0.0, tmax).is_some();
                        prop_assert_eq!(g.any_hit(o, d, tmax), near, "any-hit disagrees within {}", tmax);
                    }
                }
                Ok(())
            })
            .unwrap();
    }

    #[test]
    fn scaled_sphere_exit_and_normals_are_in_world_space() {
        let m = Affine3A::from_scale_rotation_translation(
            Vec3::new(2.0, 1.0, 1.0),
            Quat::IDENTITY,
            Vec3::new(0.0, 0.0, 5.0),
        );
        let g = Geometry::new(vec![Object::new(Shape::Sphere, m, 0).unwrap()]);
        let h = g.closest_hit(Origin::free(Vec3::new(-10.0, 0.0, 5.0)), Vec3::X, 0.0, f32::INFINITY).unwrap();
        assert!((h.t - 8.0).abs() < 1e-5 && (h.normal + Vec3::X).length() < 1e-6 && h.front);
        let e = g.exit(0, Vec3::new(-1.9, 0.0, 5.0), Vec3::X).unwrap();
        assert!((e.t - 3.9).abs() < 1e-5 && (e.normal - Vec3::X).length() < 1e-6);
    }

    #[test]
    fn regression_ray_leaving_a_cube_resting_on_a_plane_hits_the_plane() {
        // A unit cube sitting on the floor: its bottom face and the floor are the same plane.
        let floor = Object::new(Shape::Plane, Affine3A::IDENTITY, 0).unwrap();
        let cube = Object::new(Shape::Cube, Affine3A::from_translation(Vec3::Y), 0).unwrap();
        let g = Geometry::new(vec![floor, cube]);
        let down = Vec3::new(0.3, -1.0, 0.2).normalize();
        let p = Vec3::new(0.1, 0.0, -0.4);
        let from = g.leave(1, p, -Vec3::Y);
        let hit = g.closest_hit(from, down, 0.0, f32::INFINITY).expect("the floor is right there");
        assert_eq!(hit.object, 0);
        assert!(hit.t < 1e-3);
    }

    #[test]
    fn offset_moves_off_the_surface_on_the_normal_side() {
        let p = Vec3::new(100.0, 0.0, 0.0);
        let q = offset_origin(p, Vec3::X);
        assert!(q.x > p.x && (q.x - p.x) < 0.1);
    }
}

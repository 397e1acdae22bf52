//! The canonical shapes in object space (SCENE-FORMAT.md) and their two queries.

use glam::Vec3;

use crate::Aabb;

/// A canonical shape in object space. A closed set: one `match` per query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// Radius 1 at the origin.
    Sphere,
    /// The box `[-1, 1]^3`.
    Cube,
    /// `y = 0`, normal `+y`; the half-space `y < 0` is inside.
    Plane,
}

impl Shape {
    /// Every shape's name as scene files spell it, in documentation order.
    pub const NAMES: &'static [&'static str] = &["sphere", "cube", "plane"];

    /// The name scene files use.
    pub fn name(self) -> &'static str {
        match self {
            Shape::Sphere => "sphere",
            Shape::Cube => "cube",
            Shape::Plane => "plane",
        }
    }

    /// The shape called `name` in scene files.
    pub fn from_name(name: &str) -> Option<Shape> {
        match name {
            "sphere" => Some(Shape::Sphere),
            "cube" => Some(Shape::Cube),
            "plane" => Some(Shape::Plane),
            _ => None,
        }
    }

    /// Whether the shape is convex (a plane counts): a ray leaving its surface never meets it
    /// again, so secondary rays may ignore it.
    pub fn is_convex(self) -> bool {
        match self {
            Shape::Sphere | Shape::Cube | Shape::Plane => true,
        }
    }

    /// Object-space bounds; `None` for unbounded shapes.
    pub fn bounds(self) -> Option<Aabb> {
        match self {
            Shape::Sphere | Shape::Cube => Some(Aabb { min: Vec3::splat(-1.0), max: Vec3::ONE }),
            Shape::Plane => None,
        }
    }

    /// The first surface crossing of `o + t d` with `tmin < t < tmax`: `(t, outward unit normal)`.
    /// `d` need not be unit length (object-space rays carry the transform's scale).
    #[inline]
    pub fn intersect(self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, Vec3)> {
        let ok = |t: f32| t > tmin && t < tmax;
        match self {
            Shape::Sphere => {
                let (t0, t1) = sphere_roots(o, d)?;
                let t = if ok(t0) {
                    t0
                } else if ok(t1) {
                    t1
                } else {
                    return None;
                };
                Some((t, (o + t * d).normalize_or(Vec3::Y)))
            }
            Shape::Cube => {
                let ((t0, n0), (t1, n1)) = cube_span(o, d)?;
                if ok(t0) {
                    Some((t0, n0))
                } else if ok(t1) {
                    Some((t1, n1))
                } else {
                    None
                }
            }
            Shape::Plane => {
                if d.y == 0.0 {
                    return None;
                }
                let t = -o.y / d.y;
                ok(t).then_some((t, Vec3::Y))
            }
        }
    }

    /// Where the line `o + t d`, starting inside the shape, leaves it: the far crossing `t > 0`,
    /// with the outward normal there. `None` when the ray never leaves (a plane's half-space).
    #[inline]
    pub fn exit(self, o: Vec3, d: Vec3) -> Option<(f32, Vec3)> {
        match self {
            Shape::Sphere => {
                let (_, t1) = sphere_roots(o, d)?;
                (t1 > 0.0).then(|| (t1, (o + t1 * d).normalize_or(Vec3::Y)))
            }
            Shape::Cube => {
                let (_, (t1, n1)) = cube_span(o, d)?;
                (t1 > 0.0).then_some((t1, n1))
            }
            Shape::Plane => {
                if d.y <= 0.0 {
                    return None;
                }
                let t = -o.y / d.y;
                (t > 0.0).then_some((t, Vec3::Y))
            }
        }
    }
}

/// Both roots of `|o + t d|² = 1`, ascending.
///
/// The discriminant `b² − a c` is computed as `a (1 − |q|²)`, with `q` the line's point closest
/// to the centre: the textbook form cancels two large terms when the origin is far away (or the
/// sphere is scaled small), putting hit points off the surface by more than the ray offset.
#[inline]
fn sphere_roots(o: Vec3, d: Vec3) -> Option<(f32, f32)> {
    let a = d.dot(d);
    if a == 0.0 {
        return None;
    }
    let b = o.dot(d);
    let q = o - (b / a) * d;
    let disc = a * (1.0 - q.dot(q));
    if disc < 0.0 {
        return None;
    }
    let c = o.dot(o) - 1.0;
    let h = -(b + disc.sqrt().copysign(b));
    if h == 0.0 {
        // b = 0 and disc = 0: the line grazes the sphere at t = 0.
        return Some((0.0, 0.0));
    }
    let (r0, r1) = (h / a, c / h);
    Some(if r0 <= r1 { (r0, r1) } else { (r1, r0) })
}

/// Entry and exit of the line through the box `[-1, 1]^3`, each with its face's outward normal.
#[inline]
fn cube_span(o: Vec3, d: Vec3) -> Option<((f32, Vec3), (f32, Vec3))> {
    let mut near = (f32::NEG_INFINITY, Vec3::ZERO);
    let mut far = (f32::INFINITY, Vec3::ZERO);
    for axis in 0..3 {
        let (oa, da) = (o[axis], d[axis]);
        let unit = Vec3::AXES[axis];
        if da == 0.0 {
            if oa.abs() > 1.0 {
                return None;
            }
            continue;
        }
        let (ta, tb) = ((-1.0 - oa) / da, (1.0 - oa) / da);
        // The ray enters through the face it moves towards the inside from.
        let (t_in, n_in, t_out, n_out) = if da > 0.0 { (ta, -unit, tb, unit) } else { (tb, unit, ta, -unit) };
        if t_in > near.0 {
            near = (t_in, n_in);
        }
        if t_out < far.0 {
            far = (t_out, n_out);
        }
    }
    (near.0 <= far.0 && far.0.is_finite()).then_some((near, far))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_from_outside_and_exit_from_inside() {
        let (t, n) = Shape::Sphere.intersect(Vec3::new(0.0, 0.0, -5.0), Vec3::Z, 0.0, f32::INFINITY).unwrap();
        assert!((t - 4.0).abs() < 1e-6 && (n + Vec3::Z).length() < 1e-6);
        let (t, n) = Shape::Sphere.exit(Vec3::new(0.0, 0.0, -0.999), Vec3::Z).unwrap();
        assert!((t - 1.999).abs() < 1e-5 && (n - Vec3::Z).length() < 1e-6);
        assert!(Shape::Sphere.intersect(Vec3::new(0.0, 2.0, -5.0), Vec3::Z, 0.0, f32::INFINITY).is_none());
    }

    #[test]
    fn cube_faces_have_outward_normals() {
        let (t, n) = Shape::Cube.intersect(Vec3::new(0.3, 0.2, 4.0), -Vec3::Z, 0.0, f32::INFINITY).unwrap();
        assert!((t - 3.0).abs() < 1e-6);
        assert_eq!(n, Vec3::Z);
        let (t, n) = Shape::Cube.exit(Vec3::new(0.3, 0.2, 0.0), Vec3::X).unwrap();
        assert!((t - 0.7).abs() < 1e-6);
        assert_eq!(n, Vec3::X);
        // Parallel to a face, outside its slab: no hit.
        assert!(Shape::Cube.intersect(Vec3::new(0.0, 2.0, 4.0), -Vec3::Z, 0.0, f32::INFINITY).is_none());
    }

    #[test]
    fn plane_is_one_sided_for_inside_and_outside() {
        let (t, n) = Shape::Plane.intersect(Vec3::new(0.0, 2.0, 0.0), -Vec3::Y, 0.0, f32::INFINITY).unwrap();
        assert_eq!((t, n), (2.0, Vec3::Y));
        assert_eq!(Shape::Plane.exit(Vec3::new(0.0, -1.0, 0.0), Vec3::Y), Some((1.0, Vec3::Y)));
        assert_eq!(Shape::Plane.exit(Vec3::new(0.0, -1.0, 0.0), -Vec3::Y), None);
    }
}

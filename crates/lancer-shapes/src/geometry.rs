//! The prepared scene geometry: objects as flat arrays, a BVH over the bounded ones, a list of
//! the unbounded ones, closest-hit and exit queries in world space (one ray at a time, or a
//! chunk's rays together: [`Geometry::closest_each`]), and the one policy for where a secondary
//! ray starts ([`Geometry::spawn`]).

use glam::{Affine3A, DVec3, Mat3A, Vec2, Vec3};

use crate::{Aabb, Bvh, LocalSurface, Shape, ShapeHit, lanes};

/// The inverse of `m` if `m` is a usable placement: finite, with a non-zero determinant and a
/// finite inverse. The one test for every transform (objects and CSG operands), so the scene
/// loader can refuse what the geometry would.
pub fn invertible(m: &Affine3A) -> Option<Affine3A> {
    let det = m.matrix3.determinant();
    if !m.is_finite() || !det.is_finite() || det == 0.0 {
        return None;
    }
    let inv = m.inverse();
    inv.is_finite().then_some(inv)
}

/// `γ₃` of f64: the relative error bound of a dot product of three terms plus a translation.
const GAMMA3_64: f64 = 3.0 * f64::EPSILON * 0.5 / (1.0 - 3.0 * f64::EPSILON * 0.5);

/// Maps an object-space point `q`, `error` away from the surface at most, to world space by `m`,
/// in f64 (the f32 placement is exact in f64): the point, not yet rounded, and a bound on its
/// error along each axis (the f64 arithmetic's own, γ₃ (|M| |q| + |T|), which is tiny at any
/// scale, plus the incoming error stretched by the placement).
pub(crate) fn place64(m: &Affine3A, q: DVec3, error: f64) -> (DVec3, DVec3) {
    let (x, y, z) = (m.matrix3.x_axis.as_dvec3(), m.matrix3.y_axis.as_dvec3(), m.matrix3.z_axis.as_dvec3());
    let t = DVec3::from(Vec3::from(m.translation));
    let world = x * q.x + y * q.y + z * q.z + t;
    let spread = x.abs() * q.x.abs() + y.abs() * q.y.abs() + z.abs() * q.z.abs() + t.abs();
    (world, GAMMA3_64 * spread + (x.abs() + y.abs() + z.abs()) * error)
}

/// A world point computed in f64 (`world`, within `error` per axis of the surface), rounded to
/// f32 once: the point and a bound on its distance from the surface along the unit world
/// `normal`, from the rounding that was actually made (exact in f64) and the error before it.
/// It grows with where the point is, never with the placement's scale (pbrt-v4's bounds on a
/// transform computed in f32 would: a floor scaled 10⁶ had an error of 0.36).
#[inline]
pub(crate) fn rounded(world: DVec3, error: DVec3, normal: Vec3) -> (Vec3, f32) {
    let point = world.as_vec3();
    // The whole rounding (not only along the normal): the point also moves along the surface,
    // which a transform that shrinks some directions more than others turns partly into a
    // distance from it.
    let rounding = (world - point.as_dvec3()).length();
    let bound = rounding + normal.abs().as_dvec3().dot(error);
    // Rounded up, so the bound still holds as an f32.
    (point, (bound as f32).next_up())
}

/// Maps an object-space point to world space by `m` ([`place64`], then [`rounded`]).
pub(crate) fn place(m: &Affine3A, q: DVec3, error: f64, normal: Vec3) -> (Vec3, f32) {
    let (world, error) = place64(m, q, error);
    rounded(world, error, normal)
}

/// [`place`] by the identity, without the products by ones and zeros: the same point and bound.
#[inline]
fn place_unmoved(q: DVec3, error: f64, normal: Vec3) -> (Vec3, f32) {
    rounded(q, DVec3::splat(error), normal)
}

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
    /// A world-space form of the shape, when it has one that needs no transform per ray.
    fast: Fast,
    /// Whether the placement is exactly the identity (a mesh loaded as it is): rays and hits
    /// skip the transforms, which would change nothing but the sign of a zero coordinate.
    identity: bool,
    /// How far in front of the surface a ray that may meet this object again must start, as
    /// `reentry.0 · |p| + reentry.1` at the world point `p`: the rounding of the object's own
    /// test of the new ray (its origin taken into object space in f32, and the shape's test
    /// there), which the hit point's error does not cover.
    reentry: (f32, f32),
}

/// The largest row sum of `|a| |b|` (`a · b` taken entrywise in absolute values).
fn abs_row_sum(a: &Mat3A, b: &Mat3A) -> f32 {
    let abs = |m: &Mat3A| Mat3A::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs());
    let p = abs(a) * abs(b);
    let t = p.transpose();
    t.x_axis.element_sum().max(t.y_axis.element_sum()).max(t.z_axis.element_sum())
}

/// How many times the bound on the rounding of an object's own test of a new ray a ray that may
/// meet it again starts in front of it: twice (the origin's rounding, and the test's own), and
/// √3 more, as the bound is per axis and the ray leaves along the normal (4 > 2√3).
const REENTRY_MARGIN: f32 = 4.0;

/// `γ₃` of f32.
const GAMMA3: f32 = 3.0 * f32::EPSILON * 0.5 / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// World-space forms of simple placements: the intersection test skips the transform into
/// object space (the hit is still refined there, once, by [`Object::hit`]).
#[derive(Clone, Copy, Debug)]
enum Fast {
    /// Any other shape or placement.
    None,
    /// A sphere scaled the same on every axis: centre, squared radius, and the radius in f64
    /// (the root of the squared one, for the hit's refinement).
    Sphere { centre: Vec3, radius2: f32, radius: f64 },
    /// A plane: unit normal `n` and offset `n · p` of its points.
    Plane { normal: Vec3, offset: f32 },
}

impl Object {
    /// Places `shape` with `world_from_object`; `None` if the transform is not
    /// [`invertible`].
    pub fn new(shape: Shape, world_from_object: Affine3A, material: u32) -> Option<Object> {
        let object_from_world = invertible(&world_from_object)?;
        let world_from_object_normal = object_from_world.matrix3.transpose();
        let m = world_from_object.matrix3;
        let centre = Vec3::from(world_from_object.translation);
        let fast = match shape {
            Shape::Sphere => {
                let (lx, ly, lz) = (m.x_axis.length(), m.y_axis.length(), m.z_axis.length());
                // Uniform to rounding (well under the hit's error bound), else the general path.
                let tol = 4.0 * f32::EPSILON;
                let uniform = (lx - ly).abs() <= tol * lx && (lx - lz).abs() <= tol * lx;
                let orthogonal = [m.x_axis.dot(m.y_axis), m.y_axis.dot(m.z_axis), m.z_axis.dot(m.x_axis)]
                    .iter()
                    .all(|c| c.abs() <= tol * lx * lx);
                if uniform && orthogonal {
                    let radius2 = lx * lx;
                    Fast::Sphere { centre, radius2, radius: (radius2 as f64).sqrt() }
                } else {
                    Fast::None
                }
            }
            Shape::Plane => {
                let normal = (world_from_object_normal * Vec3::Y).normalize_or(Vec3::Y);
                Fast::Plane { normal, offset: normal.dot(centre) }
            }
            _ => Fast::None,
        };
        let identity = world_from_object == Affine3A::IDENTITY;
        // A world point `p` taken into object space in f32 is off by γ₃ (|M⁻¹| |p| + |T⁻¹|)
        // there, so by |M| times that in the world; the shape's test adds a few roundings of its
        // unit-sized coordinates, |M| γ₃ again.
        // A CSG solid's leaves take the point on into their own spaces: each leaf's placement in
        // the world is rounded through as well (the terms of every leaf added: a bound).
        let mut placements = vec![world_from_object];
        if let Shape::Csg(csg) = &shape {
            for node in csg.nodes() {
                if let crate::CsgNode::Leaf { node_from_leaf, .. } = node {
                    placements.push(world_from_object * *node_from_leaf);
                }
            }
        }
        let (mut k, mut c) = (0.0f32, 0.0f32);
        for placed in &placements {
            let Some(inverse) = invertible(placed) else { continue };
            let m = placed.matrix3;
            let to_object = Vec3::from(inverse.translation).abs();
            let reach = Mat3A::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs()) * to_object;
            k += REENTRY_MARGIN * GAMMA3 * abs_row_sum(&m, &inverse.matrix3);
            c += REENTRY_MARGIN * GAMMA3 * (reach.max_element() + abs_row_sum(&m, &Mat3A::IDENTITY));
        }
        let reentry = if k.is_finite() && c.is_finite() { (k, c) } else { (0.0, f32::INFINITY) };
        Some(Object {
            shape,
            world_from_object,
            object_from_world,
            world_from_object_normal,
            material,
            fast,
            identity,
            reentry,
        })
    }

    /// How far in front of its surface, at a point whose largest coordinate is `reach`, a ray
    /// that may meet the object again starts beyond the hit point's own offset.
    #[inline]
    pub(crate) fn reentry_at(&self, reach: f32) -> f32 {
        self.reentry.0 * reach + self.reentry.1
    }

    /// The world-space test [`crate::stream`] runs on a SIMD group of rays at once, for a shape placed so
    /// that it has one (a sphere scaled the same on every axis, a plane); `None` otherwise.
    pub(crate) fn world_test(&self) -> Option<crate::stream::Test> {
        match self.fast {
            Fast::Sphere { centre, radius2, .. } => Some(crate::stream::Test::Sphere { centre, radius2 }),
            Fast::Plane { normal, offset } => Some(crate::stream::Test::Plane { normal, offset }),
            Fast::None => None,
        }
    }

    fn world_normal(&self, n_obj: Vec3) -> Vec3 {
        if self.identity {
            return n_obj.normalize_or(Vec3::Y);
        }
        (self.world_from_object_normal * n_obj).normalize_or(Vec3::Y)
    }

    /// The world ray `o + t d` in object space (same `t`).
    #[inline]
    fn to_object(&self, o: Vec3, d: Vec3) -> (Vec3, Vec3) {
        if self.identity {
            return (o, d);
        }
        (self.object_from_world.transform_point3(o), self.object_from_world.transform_vector3(d))
    }

    /// [`Object::to_object`] for eight rays at once (origins `o`, directions `d`), the same bits.
    #[inline(always)]
    fn to_object_lanes(&self, o: &lanes::V3, d: &lanes::V3) -> (lanes::V3, lanes::V3) {
        if self.identity {
            return (*o, *d);
        }
        let m = &self.object_from_world;
        (lanes::linear(&m.matrix3, o, Some(Vec3::from(m.translation))), lanes::linear(&m.matrix3, d, None))
    }

    /// First crossing of the world ray `o + t d` with `tmin < t < tmax` (object-space details).
    #[inline]
    pub(crate) fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<ShapeHit> {
        let ok = |t: f32| t > tmin && t < tmax;
        match self.fast {
            Fast::Sphere { centre, radius2, .. } => {
                let (t0, t1) = crate::shape::sphere_roots_world(o - centre, d, radius2)?;
                let t = if ok(t0) {
                    t0
                } else if ok(t1) {
                    t1
                } else {
                    return None;
                };
                Some(ShapeHit { t, normal: Vec3::ZERO, part: 0, bary: Vec2::ZERO })
            }
            Fast::Plane { normal, offset } => {
                let along = normal.dot(d);
                if along == 0.0 {
                    return None;
                }
                let t = (offset - normal.dot(o)) / along;
                ok(t).then_some(ShapeHit { t, normal: Vec3::Y, part: 0, bary: Vec2::ZERO })
            }
            Fast::None => {
                let (oo, od) = self.to_object(o, d);
                self.shape.intersect(oo, od, tmin, tmax)
            }
        }
    }

    /// [`Object::intersect`] with `tmin = 0` for the first `n` (1 to 4) of four world rays at
    /// once, with the same answers, when the object is a torus (the checks before its quartic
    /// are made four rays at a time: [`crate::torus::first_t4`]); `None` for any other shape.
    #[inline]
    pub(crate) fn intersect4(
        &self,
        o: &[Vec3; 4],
        d: &[Vec3; 4],
        tmax: &[f32; 4],
        n: usize,
    ) -> Option<[Option<ShapeHit>; 4]> {
        let Shape::Torus { minor } = self.shape else {
            return None;
        };
        let (mut local_o, mut local_d) = ([Vec3::ZERO; 4], [Vec3::ZERO; 4]);
        for k in 0..n {
            (local_o[k], local_d[k]) = self.to_object(o[k], d[k]);
        }
        let ts = crate::torus::first_t4(minor, &local_o, &local_d, tmax, n);
        Some(ts.map(|t| t.map(|t| ShapeHit { t, normal: Vec3::ZERO, part: 0, bary: Vec2::ZERO })))
    }

    /// Whether the object lies on the world ray within `0 < t < tmax` (any hit will do).
    #[inline]
    pub fn occludes(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        match self.fast {
            Fast::None => {
                let (oo, od) = self.to_object(o, d);
                self.shape.occludes(oo, od, tmax)
            }
            _ => self.intersect(o, d, 0.0, tmax).is_some(),
        }
    }

    /// The world-space hit record of the crossing `c` of the world ray `o + t d`.
    #[inline(always)]
    pub fn hit(&self, index: u32, o: Vec3, d: Vec3, c: &ShapeHit) -> Hit {
        let describe = |point: Vec3, local: Vec3, normal: Vec3, shading: Vec3, uv: Vec2, error: f32| Hit {
            t: c.t,
            object: index,
            point,
            local,
            normal,
            shading,
            uv,
            error,
            front: normal.dot(d) < 0.0,
        };
        let p = o.as_dvec3() + c.t as f64 * d.as_dvec3();
        match self.fast {
            // The same refinements as in object space, done where the fast test works: moved
            // onto the surface in f64, so only the rounding to f32 remains (half an ulp of the
            // point's largest coordinate).
            Fast::Sphere { centre, radius, .. } => {
                let centre = centre.as_dvec3();
                let u = (p - centre).normalize_or(glam::DVec3::Y);
                let point = (centre + radius * u).as_vec3();
                // The object-space point from the offset to the centre, not from the rounded
                // world point: patterns stay exact on a small sphere far from the origin.
                let local = self.object_from_world.transform_vector3((radius * u).as_vec3());
                let normal = u.as_vec3().normalize_or(Vec3::Y);
                describe(point, local, normal, normal, Vec2::ZERO, f32::EPSILON * point.abs().max_element())
            }
            Fast::Plane { normal, offset } => {
                let n = normal.as_dvec3();
                let point = (p - n * (n.dot(p) - offset as f64)).as_vec3();
                // On the plane: y is 0 in its own space, exactly, for the checker's sake.
                let local = self.object_from_world.transform_point3(point) * Vec3::new(1.0, 0.0, 1.0);
                describe(point, local, normal, normal, Vec2::ZERO, f32::EPSILON * point.abs().max_element())
            }
            Fast::None => {
                let (oo, od) = self.to_object(o, d);
                let local: LocalSurface = self.shape.surface(oo, od, c);
                let normal = self.world_normal(local.normal);
                let shading = if local.shading == local.normal { normal } else { self.world_normal(local.shading) };
                let (point, error) = if self.identity {
                    place_unmoved(local.exact, local.error, normal)
                } else {
                    place(&self.world_from_object, local.exact, local.error, normal)
                };
                describe(point, local.point, normal, shading, local.uv, error)
            }
        }
    }

    /// Whether [`Object::hit_group`] describes the object's hits eight at a time (from their
    /// distances alone, see [`Object::hit_at`]): a sphere scaled alike on every axis, a plane,
    /// a torus.
    #[inline]
    pub fn hits_in_groups(&self) -> bool {
        !matches!(self.fast, Fast::None) || matches!(self.shape, Shape::Torus { .. })
    }

    /// [`Object::hit`] of the crossing at `t`, for an object whose hits are described from
    /// their distance alone ([`Object::hits_in_groups`]: its crossings carry nothing else).
    #[inline]
    pub fn hit_at(&self, index: u32, o: Vec3, d: Vec3, t: f32) -> Hit {
        debug_assert!(self.hits_in_groups(), "a shape whose crossings carry more than t");
        self.hit(index, o, d, &ShapeHit { t, normal: Vec3::ZERO, part: 0, bary: Vec2::ZERO })
    }

    /// [`Object::hit`] for eight rays at once (`o`, `d` as packets, their crossings at `t`)
    /// when the object has a world-space form (a sphere scaled alike on every axis, a plane) or
    /// is a torus: the same operations in the same order, eight lanes (four in f64) at a time,
    /// so each lane gets the bits `hit` gives it alone. Only the lanes set in `live` count; the
    /// others come out as garbage. `None` for any other object, and for a torus hit of a live
    /// lane on the torus's axis (where `hit` takes another path).
    pub fn hit_group(&self, o: &Packet, d: &Packet, t: &[f32; 8], live: u8) -> Option<HitGroup> {
        use wide::{CmpLt, f32x8, f64x4};
        let (point, local, normal) = match self.fast {
            Fast::None => return self.hit_group_placed(o, d, t, live),
            Fast::Sphere { centre, radius, .. } => {
                let c = centre.as_dvec3().to_array().map(f64x4::splat);
                // `u = (p - centre).normalize_or(DVec3::Y)`.
                let u = [0, 1].map(|half| {
                    let p = lanes::on_line64(o, d, t, half);
                    lanes::unit_or64(&std::array::from_fn(|a| p[a] - c[a]), [0.0, 1.0, 0.0])
                });
                let r = f64x4::splat(radius);
                let ru = u.map(|h| h.map(|x| r * x));
                // `(centre + radius u).as_vec3()`, and `(radius u).as_vec3()` into object space.
                let point = lanes::to_f32(ru.map(|h| std::array::from_fn(|a| c[a] + h[a])));
                let local = lanes::linear(&self.object_from_world.matrix3, &lanes::to_f32(ru), None);
                // `u.as_vec3().normalize_or(Vec3::Y)`.
                (point, local, lanes::unit_or(&lanes::to_f32(u), Vec3::Y))
            }
            Fast::Plane { normal, offset } => {
                let n = normal.as_dvec3().to_array().map(f64x4::splat);
                let off = f64x4::splat(offset as f64);
                // `(p - n * (n.dot(p) - offset)).as_vec3()`.
                let point = lanes::to_f32([0, 1].map(|half| {
                    let p = lanes::on_line64(o, d, t, half);
                    let k = lanes::dot(&n, &p) - off;
                    std::array::from_fn(|a| p[a] - n[a] * k)
                }));
                let m = &self.object_from_world;
                let placed = lanes::linear(&m.matrix3, &point, Some(Vec3::from(m.translation)));
                // `* Vec3::new(1.0, 0.0, 1.0)`: y times zero (its sign, or NaN, kept as it is).
                let local = [placed[0] * f32x8::ONE, placed[1] * f32x8::ZERO, placed[2] * f32x8::ONE];
                (point, local, normal.to_array().map(f32x8::splat))
            }
        };
        let error = (f32x8::splat(f32::EPSILON) * lanes::reach(&point)).to_array();
        let front = lanes::dot(&normal, &d.map(f32x8::new)).cmp_lt(f32x8::ZERO).move_mask() as u8;
        Some(HitGroup {
            point: point.map(|c| c.to_array()),
            local: local.map(|c| c.to_array()),
            normal: normal.map(|c| c.to_array()),
            error,
            front,
        })
    }

    /// [`Object::hit_group`] for a torus (any placement): [`Object::hit`]'s general path
    /// (the line into the torus's own space, [`Shape::surface`]'s nearest point of the tube and
    /// its normal, the normal into world space, [`place`]) with the same operations in the same
    /// order. `None` for any other shape, or when a live lane is on the torus's axis (`rho`
    /// zero, in f64 or once rounded to f32, where `surface` and `torus::normal` take other
    /// paths).
    fn hit_group_placed(&self, o: &Packet, d: &Packet, t: &[f32; 8], live: u8) -> Option<HitGroup> {
        use wide::{CmpEq, CmpLt, f32x8, f64x4};
        let Shape::Torus { minor } = self.shape else {
            return None;
        };
        let (wo, wd) = (o.map(f32x8::new), d.map(f32x8::new));
        let (oo, od) = self.to_object_lanes(&wo, &wd);
        let (oo, od) = (oo.map(f32x8::to_array), od.map(f32x8::to_array));
        // The nearest point of the tube, in f64: `p` on the line, `c` on the centre circle.
        let mut axis = 0u8;
        let q = [0, 1].map(|half| {
            let p = lanes::on_line64(&oo, &od, t, half);
            let rho = (p[0] * p[0] + p[2] * p[2]).sqrt();
            axis |= (rho.cmp_eq(f64x4::ZERO).move_mask() as u8) << (4 * half);
            let c = [p[0] / rho, f64x4::ZERO, p[2] / rho];
            let toward = lanes::unit_or64(&std::array::from_fn(|a| p[a] - c[a]), [0.0, 1.0, 0.0]);
            let r = f64x4::splat(minor as f64);
            std::array::from_fn(|a| c[a] + toward[a] * r)
        });
        let local = lanes::to_f32(q);
        // `torus::normal` of the point: away from the centre circle.
        let rho = (local[0] * local[0] + local[2] * local[2]).sqrt();
        axis |= rho.cmp_eq(f32x8::ZERO).move_mask() as u8;
        if axis & live != 0 {
            return None;
        }
        let centre = [local[0] / rho, f32x8::ZERO, local[2] / rho];
        let n = lanes::unit_or(&std::array::from_fn(|a| local[a] - centre[a]), Vec3::Y);
        // `world_normal`, then `place` (or `place_unmoved`), in f64 halves.
        let normal = if self.identity {
            lanes::unit_or(&n, Vec3::Y)
        } else {
            lanes::unit_or(&lanes::linear(&self.world_from_object_normal, &n, None), Vec3::Y)
        };
        let (mut point, mut error) = ([[0.0f32; 8]; 3], [0.0f32; 8]);
        for (half, q) in q.iter().enumerate() {
            // `Shape::surface`'s bound on the projected point.
            let own = f64x4::splat(8.0 * f64::EPSILON * 0.5) * (q[0].abs() + q[1].abs() + q[2].abs());
            let (world, spread): (lanes::D3, lanes::D3) = if self.identity {
                (*q, [own; 3])
            } else {
                let m = &self.world_from_object;
                let axes = [m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis].map(|c| c.as_dvec3());
                let t = Vec3::from(m.translation).as_dvec3();
                let world = std::array::from_fn(|a| {
                    f64x4::splat(axes[0][a]) * q[0]
                        + f64x4::splat(axes[1][a]) * q[1]
                        + f64x4::splat(axes[2][a]) * q[2]
                        + f64x4::splat(t[a])
                });
                let spread = std::array::from_fn(|a| {
                    let s = f64x4::splat(axes[0][a].abs()) * q[0].abs()
                        + f64x4::splat(axes[1][a].abs()) * q[1].abs()
                        + f64x4::splat(axes[2][a].abs()) * q[2].abs()
                        + f64x4::splat(t[a].abs());
                    let stretch = axes[0][a].abs() + axes[1][a].abs() + axes[2][a].abs();
                    f64x4::splat(GAMMA3_64) * s + f64x4::splat(stretch) * own
                });
                (world, spread)
            };
            // `rounded`, lane by lane (the same function: the same bits).
            let w: [[f64; 4]; 3] = world.map(|c| c.to_array());
            let e: [[f64; 4]; 3] = spread.map(|c| c.to_array());
            let nn: [[f32; 8]; 3] = normal.map(|c| c.to_array());
            for k in 0..4 {
                let lane = 4 * half + k;
                let at = |v: &[[f64; 4]; 3]| DVec3::new(v[0][k], v[1][k], v[2][k]);
                let n = Vec3::new(nn[0][lane], nn[1][lane], nn[2][lane]);
                let (p, bound) = rounded(at(&w), at(&e), n);
                for a in 0..3 {
                    point[a][lane] = p[a];
                }
                error[lane] = bound;
            }
        }
        let front = lanes::dot(&normal, &wd).cmp_lt(f32x8::ZERO).move_mask() as u8;
        Some(HitGroup { point, local: local.map(|c| c.to_array()), normal: normal.map(|c| c.to_array()), error, front })
    }

    /// Whether the world point `p` is inside the object's solid (never for a shape with no
    /// inside: a disk, an open mesh). A plane's inside is the half-space below it.
    pub fn contains(&self, p: Vec3) -> bool {
        // Any direction will do; one along no axis keeps clear of edges and faces.
        let d = Vec3::new(0.267_261_24, 0.534_522_5, 0.801_783_7);
        match &self.shape {
            Shape::Disk => false,
            // The first surface met from inside is met from its back.
            Shape::Mesh(m) => {
                m.is_closed() && self.intersect(p, d, 0.0, f32::INFINITY).is_some_and(|c| !self.hit(0, p, d, &c).front)
            }
            shape => {
                let (o, od) = self.to_object(p, d);
                shape.spans(o, od).iter().any(|s| s.t0 < 0.0 && 0.0 < s.t1)
            }
        }
    }

    /// A world-space ball (centre, radius) that holds the object, from the shape's own ball
    /// ([`Shape::ball_radius`]) through the placement: its radius times a bound on how much the
    /// placement stretches a vector (the square root of the largest row sum of `|MᵀM|`, `M` the
    /// linear part: its largest singular value exactly for a rotation and a uniform scale).
    /// Exact but for rounding: a caller that culls by it widens it (the block tracer's plan
    /// does). `None` for shapes with no such ball.
    pub fn ball(&self) -> Option<(Vec3, f32)> {
        let r = self.shape.ball_radius()?;
        let m = self.world_from_object.matrix3;
        let cols = [m.x_axis, m.y_axis, m.z_axis];
        let stretch2 = (0..3).map(|i| (0..3).map(|j| cols[i].dot(cols[j]).abs()).sum::<f32>()).fold(0.0f32, f32::max);
        let centre = Vec3::from(self.world_from_object.translation);
        let radius = r * stretch2.sqrt();
        (centre.is_finite() && radius.is_finite()).then_some((centre, radius))
    }

    /// World-space bounds; `None` for unbounded shapes.
    pub fn bounds(&self) -> Option<Aabb> {
        self.shape.bounds().map(|b| b.transformed(&self.world_from_object))
    }
}

/// Eight hits described at once ([`Object::hit_group`]): for each lane, what [`Hit`] holds of a
/// sphere, a plane or a torus (whose shading normal is its normal, its texture coordinates
/// zero).
#[derive(Clone, Copy, Debug)]
pub struct HitGroup {
    /// The hit points.
    pub point: Packet,
    /// The object-space points.
    pub local: Packet,
    /// The unit outward normals.
    pub normal: Packet,
    /// Bounds on the points' distances from the surface.
    pub error: [f32; 8],
    /// Bit `k` set where lane `k`'s ray arrived from outside.
    pub front: u8,
}

/// A ray–surface hit in world space: everything the shading needs, found once per ray.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Hit {
    /// Distance along the ray (in units of the ray's direction length).
    pub t: f32,
    /// Index of the object hit.
    pub object: u32,
    /// The hit point on the surface.
    pub point: Vec3,
    /// The same point in the object's own space (for patterns).
    pub local: Vec3,
    /// Unit outward geometric normal: decides front and back, and where rays leave.
    pub normal: Vec3,
    /// Unit outward shading normal (interpolated on smooth meshes; else the geometric one).
    pub shading: Vec3,
    /// Texture coordinates interpolated from a mesh's vertices (zero for other shapes).
    pub uv: Vec2,
    /// A bound on the point's distance from the true surface along `normal`.
    pub error: f32,
    /// Whether the ray arrived from outside (geometric normal against the ray).
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
    /// Whether the only bounded object is a mesh: its own tree's root tests its box, so no tree
    /// goes above it. (Any other lone shape keeps the box test of the tree of one: a CSG
    /// object's spans or a torus's quartic would cost more than the box.)
    pub(crate) lone_mesh: bool,
    /// A small scene's objects in the order [`Geometry::closest_each`] tests them against blocks
    /// of rays; empty when rays walk the BVH one by one instead.
    pub(crate) stream: Vec<crate::stream::Item>,
}

/// `Origin::skip` when a ray may hit every object.
pub const NO_SKIP: u32 = u32::MAX;

/// Where a ray starts, and the object it must ignore (see [`Geometry::spawn`]).
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

/// Eight rays' origins or directions axis by axis, `[[x; 8], [y; 8], [z; 8]]`: how [`Lines`]
/// holds them, so a SIMD group of rays loads an axis at once.
pub type Packet = [[f32; 8]; 3];

/// Many rays at once: origins and unit directions eight to a [`Packet`] (ray `i` is lane
/// `i % 8` of packet `i / 8`; lanes past the last ray mean nothing), and the object each ray
/// ignores. There is one `skip` per ray, and packets enough for them.
#[derive(Clone, Copy, Debug)]
pub struct Lines<'a> {
    /// Origins.
    pub origin: &'a [Packet],
    /// Unit directions.
    pub dir: &'a [Packet],
    /// The object each ray ignores, or [`NO_SKIP`].
    pub skip: &'a [u32],
}

impl<'a> Lines<'a> {
    /// Number of rays.
    #[inline]
    pub fn len(&self) -> usize {
        self.skip.len()
    }

    /// Whether there is no ray.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.skip.is_empty()
    }

    /// The origin of ray `lane`.
    #[inline(always)]
    pub fn origin(&self, lane: usize) -> Vec3 {
        let (p, k) = (&self.origin[lane / 8], lane % 8);
        Vec3::from(glam::Vec3A::new(p[0][k], p[1][k], p[2][k]))
    }

    /// The direction of ray `lane`.
    #[inline(always)]
    pub fn dir(&self, lane: usize) -> Vec3 {
        let (p, k) = (&self.dir[lane / 8], lane % 8);
        Vec3::from(glam::Vec3A::new(p[0][k], p[1][k], p[2][k]))
    }

    /// `visit(lane, origin, direction)` for every ray in order. Each packet is turned into
    /// eight vectors at once before its rays are visited: a vector made of three loads and
    /// handed on in memory would be read back before its three stores are done (a stall per
    /// ray, on the BVH walk's first loads).
    #[inline]
    pub fn each_ray(&self, mut visit: impl FnMut(usize, Vec3, Vec3)) {
        for (p, (o, d)) in self.origin.iter().zip(self.dir).enumerate() {
            let base = p * 8;
            let lanes = (self.len() - base).min(8);
            let origin: [Vec3; 8] = std::array::from_fn(|k| Vec3::new(o[0][k], o[1][k], o[2][k]));
            let dir: [Vec3; 8] = std::array::from_fn(|k| Vec3::new(d[0][k], d[1][k], d[2][k]));
            for k in 0..lanes {
                visit(base + k, origin[k], dir[k]);
            }
        }
    }

    /// The rays `range`, which starts at a packet's first ray.
    #[inline]
    pub fn range(&self, range: std::ops::Range<usize>) -> Lines<'a> {
        assert!(range.start.is_multiple_of(8), "rays {range:?} do not start a packet");
        let packets = range.start / 8..range.end.div_ceil(8);
        Lines { origin: &self.origin[packets.clone()], dir: &self.dir[packets], skip: &self.skip[range] }
    }
}

/// How many times the hit point's error bound a secondary ray's origin moves off the surface:
/// the bound covers the point; the margin covers the rounding of the offset itself and of the
/// next intersection test's transform into object space.
const OFFSET_MARGIN: f32 = 16.0;

/// The smallest offset, for a point whose error bound is zero (at the origin of a plane).
const OFFSET_FLOOR: f32 = 1e-30;

impl Geometry {
    /// Builds the BVH over the bounded objects.
    pub fn new(objects: Vec<Object>) -> Geometry {
        let boxes: Vec<Option<Aabb>> = objects.iter().map(Object::bounds).collect();
        let mut bounds = Vec::new();
        let (mut bounded, mut unbounded) = (Vec::new(), Vec::new());
        for (i, b) in boxes.iter().enumerate() {
            match b {
                Some(b) => {
                    bounds.push(*b);
                    bounded.push(i as u32);
                }
                None => unbounded.push(i as u32),
            }
        }
        let lone_mesh = bounded.len() == 1 && matches!(objects[bounded[0] as usize].shape, Shape::Mesh(_));
        let stream = if lone_mesh || bounded.len() > crate::stream::MOST_OBJECTS {
            Vec::new()
        } else {
            crate::stream::plan(&objects, &boxes)
        };
        Geometry { bvh: Bvh::build(&bounds), objects, bounded, unbounded, lone_mesh, stream }
    }

    /// Where a secondary ray leaving the surface at `at` in direction `dir` starts, and which
    /// object it ignores. The one self-intersection policy; every term and shadow model spawns
    /// its rays here.
    ///
    /// - A ray that cannot meet the surface it leaves again ignores that object: one leaving a
    ///   convex solid outwards, or leaving a flat shape (plane, disk) to either side. It starts a
    ///   hair *behind* the surface, so an object touching it there (a glass cube resting on a
    ///   floor) is still found.
    /// - Any other ray (into a convex solid, or off a torus, mesh or CSG solid) may meet the
    ///   object again and ignores nothing: it starts a hair in front of the surface, on the side
    ///   it goes to.
    ///
    /// "A hair" is the hit point's error bound times a margin: the point's own rounding, which
    /// depends on where the point is, not on how far the ray that found it came from.
    #[inline]
    pub fn spawn(&self, at: &Hit, dir: Vec3) -> Origin {
        let outward = dir.dot(at.normal) > 0.0;
        let side = if outward { at.normal } else { -at.normal };
        let reach = at.point.abs().max_element();
        let offset = (at.error * OFFSET_MARGIN).max(OFFSET_FLOOR) + reach * f32::EPSILON;
        let object = &self.objects[at.object as usize];
        let shape = &object.shape;
        if shape.is_flat() || (outward && shape.is_convex()) {
            Origin { point: at.point - side * offset, skip: at.object }
        } else {
            Origin { point: at.point + side * (offset + object.reentry_at(reach)), skip: NO_SKIP }
        }
    }

    /// [`Geometry::spawn`] for eight hits at once, the same bits lane by lane: the hit points,
    /// geometric normals, error bounds and objects, and the directions the rays leave in; gives
    /// the origins and the objects they ignore. A lane whose `object` is no object's index (a
    /// lane with no hit) is treated as on a curved surface that is not convex; its result
    /// means nothing.
    #[inline(always)]
    pub fn spawn_packet(
        &self,
        point: &Packet,
        normal: &Packet,
        error: &[f32; 8],
        object: &[u32; 8],
        dir: &Packet,
    ) -> (Packet, [u32; 8]) {
        use wide::{CmpGt, f32x8};
        let v = |p: &Packet| p.map(f32x8::new);
        let (p, n, d) = (v(point), v(normal), v(dir));
        let mask = |on: [bool; 8]| f32x8::new(on.map(|b| if b { f32::from_bits(u32::MAX) } else { 0.0 }));
        let kind: [(bool, bool, (f32, f32)); 8] = std::array::from_fn(|k| {
            self.objects
                .get(object[k] as usize)
                .map_or((false, false, (0.0, 0.0)), |o| (o.shape.is_flat(), o.shape.is_convex(), o.reentry))
        });
        let (flat, convex) = (mask(kind.map(|k| k.0)), mask(kind.map(|k| k.1)));
        let outward = (d[0] * n[0] + d[1] * n[1] + d[2] * n[2]).cmp_gt(f32x8::ZERO);
        // Negated by the sign bit, as scalar `-` does (wide's `-c` is `0 − c`: +0 for 0).
        let side = n.map(|c| outward.blend(c, c ^ f32x8::splat(-0.0)));
        let reach = lanes::reach(&p);
        let offset = (f32x8::new(*error) * f32x8::splat(OFFSET_MARGIN)).max(f32x8::splat(OFFSET_FLOOR))
            + reach * f32x8::splat(f32::EPSILON);
        let behind = flat | (outward & convex);
        let (rk, rc) = (f32x8::new(kind.map(|k| k.2.0)), f32x8::new(kind.map(|k| k.2.1)));
        let ahead = offset + (rk * reach + rc);
        let origin: [f32x8; 3] = std::array::from_fn(|a| behind.blend(p[a] - side[a] * offset, p[a] + side[a] * ahead));
        let skips = behind.to_array();
        let skip = std::array::from_fn(|k| if skips[k].to_bits() != 0 { object[k] } else { NO_SKIP });
        (origin.map(|c| c.to_array()), skip)
    }

    fn test(&self, i: u32, o: Vec3, d: Vec3, tmin: f32, tmax: f32, best: &mut Option<(u32, ShapeHit)>) -> f32 {
        match self.objects[i as usize].intersect(o, d, tmin, tmax) {
            Some(c) => {
                *best = Some((i, c));
                c.t
            }
            None => tmax,
        }
    }

    /// The closest hit of `o + t d` with `tmin < t < tmax`. The BVH build and traversal order are
    /// deterministic, so the same ray always gets the same hit.
    pub fn closest_hit(&self, from: Origin, d: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        self.closest(from, d, tmin, tmax).map(|(i, c)| self.objects[i as usize].hit(i, from.point, d, &c))
    }

    /// The closest crossing of `o + t d` with `tmin < t < tmax` and its object, without the
    /// surface description [`Object::hit`] makes of it: for a caller that may not need it (a
    /// shadow ray stopped by an opaque object).
    pub fn closest(&self, from: Origin, d: Vec3, tmin: f32, tmax: f32) -> Option<(u32, ShapeHit)> {
        let (o, skip) = (from.point, from.skip);
        let mut best = None;
        let mut tmax = tmax;
        for &i in &self.unbounded {
            if i != skip {
                tmax = self.test(i, o, d, tmin, tmax, &mut best);
            }
        }
        let mut visit = |item: u32, tmax: f32| {
            let i = self.bounded[item as usize];
            if i == skip { tmax } else { self.test(i, o, d, tmin, tmax, &mut best) }
        };
        if self.lone_mesh {
            visit(0, tmax);
        } else {
            self.bvh.traverse(o, d, tmax, visit);
        }
        best
    }

    /// [`Geometry::closest`] with `tmin = 0` for many rays at once: for each ray `lane` of
    /// `lines`, `found(lane, object, crossing)` with its closest crossing within
    /// `0 < t < tmax(lane)`, if it has one, in lane order. A small scene tests its objects
    /// against blocks of rays, a SIMD group at a time; a larger one walks the BVH for each ray.
    /// Either way a ray's answer depends only on the ray.
    pub fn closest_each(
        &self,
        lines: Lines<'_>,
        tmax: impl Fn(usize) -> f32,
        mut found: impl FnMut(usize, u32, &ShapeHit),
    ) {
        if self.stream.is_empty() {
            lines.each_ray(|lane, o, d| {
                if let Some((i, c)) = self.closest(Origin { point: o, skip: lines.skip[lane] }, d, 0.0, tmax(lane)) {
                    found(lane, i, &c);
                }
            });
        } else {
            crate::stream::closest_each(&self.objects, &self.stream, 0, None, lines, tmax, |lane, i, c, _| {
                found(lane, i, c)
            });
        }
    }

    /// [`Geometry::any_hit`] for many rays at once: `blocked(lane)` for each ray `lane` of
    /// `lines` that meets an object within `0 < t < tmax(lane)`, in lane order. A small scene
    /// finds them object by object over blocks of rays (a ray meets an object exactly where it
    /// has a closest crossing); a larger one asks the BVH per ray.
    pub fn any_each(&self, lines: Lines<'_>, tmax: impl Fn(usize) -> f32, mut blocked: impl FnMut(usize)) {
        if self.stream.is_empty() {
            lines.each_ray(|lane, o, d| {
                if self.any_hit(Origin { point: o, skip: lines.skip[lane] }, d, tmax(lane)) {
                    blocked(lane);
                }
            });
        } else {
            crate::stream::closest_each(&self.objects, &self.stream, 0, None, lines, tmax, |lane, _, _, _| {
                blocked(lane)
            });
        }
    }

    /// [`Geometry::closest_each`] for rays that see through some objects (`through(object)`):
    /// `found(lane, object, crossing, alone)` with each ray's closest crossing, and `alone` when
    /// that is a see-through object's and the ray meets no other object within its limit (its
    /// own `skip` aside). A ray's answer depends only on the ray. `toward`: the point every ray
    /// goes to and stops at (within its start's offset), when they all do, which lets a block of
    /// them be bounded from there.
    pub fn first_each_through(
        &self,
        lines: Lines<'_>,
        toward: Option<Vec3>,
        tmax: impl Fn(usize) -> f32,
        through: impl Fn(u32) -> bool,
        mut found: impl FnMut(usize, u32, &ShapeHit, bool),
    ) {
        // The see-through items of the stream, a bit each (a stream too long for the mask, as a
        // scene without one, traces ray by ray).
        if self.stream.is_empty() || self.stream.len() > 128 {
            lines.each_ray(|lane, o, d| {
                let from = Origin { point: o, skip: lines.skip[lane] };
                if let Some((i, c)) = self.closest(from, d, 0.0, tmax(lane)) {
                    found(lane, i, &c, through(i) && !self.any_hit_without(from, d, tmax(lane), i));
                }
            });
        } else {
            let mask = self
                .stream
                .iter()
                .enumerate()
                .filter(|(_, item)| through(item.object))
                .fold(0u128, |m, (k, _)| m | 1 << k);
            crate::stream::closest_each(&self.objects, &self.stream, mask, toward, lines, tmax, found);
        }
    }

    /// Whether any object (but `from.skip`) lies on the ray within `0 < t < tmax`: a shadow ray
    /// that may stop at the first occluder it finds.
    pub fn any_hit(&self, from: Origin, d: Vec3, tmax: f32) -> bool {
        self.any_hit_without(from, d, tmax, NO_SKIP)
    }

    /// [`Geometry::any_hit`] with the object `without` ignored too.
    pub fn any_hit_without(&self, from: Origin, d: Vec3, tmax: f32, without: u32) -> bool {
        let (o, skip) = (from.point, from.skip);
        let blocks = |i: u32| i != skip && i != without && self.objects[i as usize].occludes(o, d, tmax);
        if self.unbounded.iter().any(|&i| blocks(i)) {
            return true;
        }
        if self.lone_mesh {
            return blocks(self.bounded[0]);
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

    /// Whether object `b` reaches into the solid of object `a` (more than touching it): `b`'s
    /// centre is inside both, or some chord of `a`, among a fixed set of 256 spread through its
    /// bounds, meets `b`'s surface away from its ends (beyond their error bounds), or has its
    /// middle inside `b`. For a scene check, not for rendering: a small overlap can be missed.
    /// `false` when `a` is unbounded (a plane's half-space) or has no inside.
    pub fn overlap(&self, a: u32, b: u32) -> bool {
        let (oa, ob) = (&self.objects[a as usize], &self.objects[b as usize]);
        let Some(box_a) = oa.bounds() else { return false };
        if !oa.shape.is_closed() {
            return false;
        }
        if let Some(box_b) = ob.bounds() {
            if box_b.min.cmpgt(box_a.max).any() || box_a.min.cmpgt(box_b.max).any() {
                return false;
            }
            // A point inside both: `b`'s centre (a small object wholly inside `a`, which few
            // chords would meet).
            let c = box_b.centre();
            if oa.contains(c) && ob.contains(c) {
                return true;
            }
        }
        let (centre, size) = (box_a.centre(), box_a.max - box_a.min);
        let reach = size.length().max(f32::MIN_POSITIVE);
        const CHORDS: u32 = 256;
        for k in 0..CHORDS {
            // A direction on the Fibonacci sphere and a target spread through the box (R3).
            let i = k as f32 + 0.5;
            let z = 1.0 - 2.0 * i / CHORDS as f32;
            let phi = i * 2.399_963;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let (sin, cos) = libm::sincosf(phi);
            let dir = Vec3::new(r * cos, r * sin, z);
            let g = Vec3::new(0.819_172_5, 0.671_043_5, 0.549_700_5);
            let spread = (g * i).fract() - Vec3::splat(0.5);
            let target = centre + 0.9 * spread * size;
            let origin = target - 2.0 * reach * dir;
            let Some(c) = oa.intersect(origin, dir, 0.0, f32::INFINITY) else { continue };
            let entry = oa.hit(a, origin, dir, &c);
            if !entry.front {
                continue;
            }
            let Some(exit) = self.exit(&entry, dir) else { continue };
            let length = (exit.point - entry.point).dot(dir);
            if length.is_nan() || length <= 0.0 {
                continue;
            }
            // Touching is not reaching in: the ends are only known to their error bounds.
            let reach = entry.point.abs().max_element().max(exit.point.abs().max_element());
            let rounding = 16.0 * (entry.error + exit.error) + 4.0 * f32::EPSILON * reach + oa.reentry_at(reach);
            let margin = (1e-3 * length).max(rounding);
            if ob.intersect(entry.point, dir, margin, length - margin).is_some()
                || ob.contains(entry.point + 0.5 * length * dir)
            {
                return true;
            }
        }
        false
    }

    /// The closest hit by testing every object, for checking the BVH.
    pub fn closest_hit_brute_force(&self, from: Origin, d: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        let mut best = None;
        let mut tmax = tmax;
        for i in (0..self.objects.len() as u32).filter(|&i| i != from.skip) {
            tmax = self.test(i, from.point, d, tmin, tmax, &mut best);
        }
        best.map(|(i, c): (u32, ShapeHit)| self.objects[i as usize].hit(i, from.point, d, &c))
    }

    /// Where a ray that goes into the object at `at` in direction `dir` leaves it again (meeting
    /// nothing else on the way, as the handout's refraction path does). `None` for a shape it
    /// never leaves (a plane's half-space) or that has no inside (a disk, an open mesh).
    pub fn exit(&self, at: &Hit, dir: Vec3) -> Option<Hit> {
        let object = &self.objects[at.object as usize];
        let from = self.spawn(at, dir);
        let (oo, od) = object.to_object(from.point, dir);
        let c = object.shape.exit(oo, od)?;
        Some(object.hit(at.object, from.point, dir, &c))
    }

    /// [`Geometry::exit`] for eight hits at once on one sphere with a world-space form (scaled
    /// alike on every axis): the hit points, geometric normals and error bounds, and the
    /// directions the rays go in along. The exits of the lanes set in the mask, each with the
    /// bits `exit` gives it alone (the start off the surface by [`Geometry::spawn_packet`], the
    /// line into the sphere's own space, where it leaves the unit sphere, and the hit there by
    /// [`Object::hit_group`]); the other lanes find no exit. `None` for any other object.
    pub fn exit_group(
        &self,
        object: u32,
        point: &Packet,
        normal: &Packet,
        error: &[f32; 8],
        dir: &Packet,
    ) -> Option<(HitGroup, u8)> {
        use wide::{CmpEq, CmpGe, CmpLe, CmpLt, f32x8};
        let o = self.objects.get(object as usize)?;
        if !matches!((&o.shape, o.fast), (Shape::Sphere, Fast::Sphere { .. })) {
            return None;
        }
        let (from, _) = self.spawn_packet(point, normal, error, &[object; 8], dir);
        let (p, d) = o.to_object_lanes(&from.map(f32x8::new), &dir.map(f32x8::new));
        // `sphere_roots`, then the farther root: where the line leaves the unit sphere.
        let dot = lanes::dot::<f32x8>;
        let a = dot(&d, &d);
        let b = dot(&p, &d);
        let s = b / a;
        let q: [f32x8; 3] = std::array::from_fn(|k| p[k] - s * d[k]);
        let disc = a * (f32x8::ONE - dot(&q, &q));
        let c = dot(&p, &p) - f32x8::ONE;
        let h = lanes::neg(b + disc.sqrt().copysign(b));
        let (r0, r1) = (h / a, c / h);
        let zero = h.cmp_eq(f32x8::ZERO);
        let far = zero.blend(f32x8::ZERO, r0.cmp_le(r1).blend(r1, r0));
        // (`!(disc < 0)`: a NaN goes on, as in `half_quadratic`.)
        let found = !a.cmp_eq(f32x8::ZERO) & !disc.cmp_lt(f32x8::ZERO) & far.cmp_ge(f32x8::ZERO);
        let hit = o.hit_group(&from, dir, &far.to_array(), u8::MAX)?;
        Some((hit, found.move_mask() as u8))
    }

    /// Where a straight ray that meets the surface at `at` is past the object: the exit of a
    /// closed object it enters there; the surface itself for one it leaves, or for a surface
    /// with no inside (a disk, an open mesh), which it crosses there. `None` only when it never
    /// gets out (a plane's half-space). A bounded object whose exit cannot be found (thinner
    /// than the ray's offset, or entered on an edge) is crossed where it is entered.
    pub fn past(&self, at: &Hit, dir: Vec3) -> Option<Hit> {
        let object = &self.objects[at.object as usize];
        if dir.dot(at.normal) > 0.0 || !object.shape.is_closed() {
            return Some(*at);
        }
        match self.exit(at, dir) {
            None if object.shape.bounds().is_some() => Some(*at),
            exit => exit,
        }
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
    fn an_objects_ball_holds_every_point_of_it_however_it_is_placed() {
        // The farthest points of each shape (the cube's corners, the cylinder's and the cone's
        // rims, the torus's outer circle and its tube's top, the disk's rim) under turns,
        // uniform and uneven scales and shifts: none lies outside the ball.
        let mut f = crate::testing::uniform(0x9E37_79B9_7F4A_7C15);
        let shapes =
            [Shape::Sphere, Shape::Cube, Shape::Cylinder, Shape::Cone, Shape::Torus { minor: 0.3 }, Shape::Disk];
        let mut tight = 0;
        for round in 0..400 {
            let shape = shapes[(round / 2) % shapes.len()].clone();
            let scale = if round % 2 == 0 {
                Vec3::splat(f(0.01, 20.0))
            } else {
                Vec3::new(f(0.01, 20.0), f(0.01, 20.0), f(0.01, 20.0))
            };
            let turn = Quat::from_euler(glam::EulerRot::XYZ, f(-3.0, 3.0), f(-3.0, 3.0), f(-3.0, 3.0));
            let at = Vec3::new(f(-1e3, 1e3), f(-1e3, 1e3), f(-1e3, 1e3));
            let object =
                Object::new(shape.clone(), Affine3A::from_scale_rotation_translation(scale, turn, at), 0).unwrap();
            let (centre, radius) = object.ball().expect("a ball");
            let far: Vec<Vec3> = (0..64)
                .map(|k| {
                    let (c, s) = ((k as f32 * 0.4).cos(), (k as f32 * 0.4).sin());
                    let (y, sign) = (if k % 2 == 0 { 1.0 } else { -1.0 }, if k % 4 < 2 { 1.0 } else { -1.0 });
                    match shape {
                        Shape::Sphere => Vec3::new(c * s, c * c, s).normalize(),
                        Shape::Cube => Vec3::new(sign, y, if k % 8 < 4 { 1.0 } else { -1.0 }),
                        Shape::Cylinder | Shape::Cone => Vec3::new(c, y, s),
                        Shape::Torus { minor } => {
                            Vec3::new(c, 0.0, s) * (1.0 + minor * (k % 3) as f32 * 0.5)
                                + Vec3::Y * minor * y * (k % 3 == 1) as u8 as f32
                        }
                        _ => Vec3::new(c, 0.0, s),
                    }
                })
                .collect();
            let mut most = 0.0f32;
            for p in far {
                // (Within the rounding of the placed point, a few ulps of its coordinates: the
                // block tracer widens the ball by more, 1e-6 of the centre's.)
                let d = (object.world_from_object.transform_point3(p) - centre).length();
                let slack = radius * 1e-5 + centre.abs().max_element() * 3e-7;
                assert!(d <= radius + slack, "{shape:?} {scale} {turn} {at}: {d} > {radius}");
                most = most.max(d / radius);
            }
            tight += usize::from(round % 2 == 0 && shape != Shape::Disk && most > 0.99);
        }
        // With a uniform scale the ball is no larger than the shape needs.
        assert!(tight > 150, "{tight}");
        assert!(Object::new(Shape::Plane, Affine3A::IDENTITY, 0).unwrap().ball().is_none());
    }

    #[test]
    fn eight_exits_at_once_have_the_bits_of_each_alone() {
        // Spheres (placed as they are, turned and scaled, far from the origin, tiny) entered by
        // rays from all around, going on into them bent more or less, or grazing: every lane of
        // `exit_group` that finds an exit is `exit`'s answer for that hit, and the others find
        // none either.
        let mut f = crate::testing::uniform(0x853C_49E6_748F_EA9B);
        let turn = Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 0.7);
        let g = Geometry::new(vec![
            Object::new(Shape::Sphere, Affine3A::IDENTITY, 0).unwrap(),
            Object::new(
                Shape::Sphere,
                Affine3A::from_scale_rotation_translation(Vec3::splat(0.7), turn, Vec3::new(3.0, 1.0, -2.0)),
                0,
            )
            .unwrap(),
            Object::new(
                Shape::Sphere,
                Affine3A::from_scale_rotation_translation(Vec3::splat(40.0), turn, Vec3::new(5e3, -1e3, 2e3)),
                0,
            )
            .unwrap(),
            Object::new(
                Shape::Sphere,
                Affine3A::from_scale_rotation_translation(Vec3::splat(0.01), turn, Vec3::ONE),
                0,
            )
            .unwrap(),
            Object::new(Shape::Cube, Affine3A::from_translation(Vec3::new(-5.0, 0.0, 0.0)), 0).unwrap(),
        ]);
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        let (mut exits, mut none) = (0, 0);
        for object in 0..4u32 {
            let placed = &g.objects[object as usize];
            let (centre, size) =
                (Vec3::from(placed.world_from_object.translation), placed.world_from_object.matrix3.x_axis.length());
            for _ in 0..150 {
                let mut lanes = Vec::new();
                while lanes.len() < 8 {
                    let from =
                        centre + Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)).normalize_or(Vec3::X) * size * 3.0;
                    let aim = centre + Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)) * size * 0.9;
                    let Some((i, c)) =
                        g.objects[object as usize].intersect(from, aim - from, 0.0, f32::INFINITY).map(|c| (object, c))
                    else {
                        continue;
                    };
                    let hit = g.objects[i as usize].hit(i, from, aim - from, &c);
                    // Onward into the sphere, bent towards the normal or not at all, or along
                    // the surface.
                    let u = (aim - from).normalize();
                    let dir = match lanes.len() % 4 {
                        0 => u,
                        1 => (u - hit.normal * f(0.0, 1.0)).normalize(),
                        2 => (u - hit.normal * u.dot(hit.normal)).normalize_or(u),
                        _ => -hit.normal,
                    };
                    lanes.push((hit, dir));
                }
                let packet =
                    |v: &dyn Fn(usize) -> Vec3| -> Packet { std::array::from_fn(|a| std::array::from_fn(|k| v(k)[a])) };
                let (point, normal) = (packet(&|k| lanes[k].0.point), packet(&|k| lanes[k].0.normal));
                let dir = packet(&|k| lanes[k].1);
                let error = std::array::from_fn(|k| lanes[k].0.error);
                let (group, found) = g.exit_group(object, &point, &normal, &error, &dir).expect("a sphere");
                for (k, (hit, d)) in lanes.iter().enumerate() {
                    let alone = g.exit(hit, *d);
                    assert_eq!(found >> k & 1 == 1, alone.is_some(), "lane {k}: {hit:?} {d}");
                    let Some(e) = alone else {
                        none += 1;
                        continue;
                    };
                    let lane = |p: &Packet| Vec3::new(p[0][k], p[1][k], p[2][k]);
                    assert_eq!(bits(lane(&group.point)), bits(e.point), "lane {k}");
                    assert_eq!(bits(lane(&group.normal)), bits(e.normal), "lane {k}");
                    assert_eq!(bits(lane(&group.local)), bits(e.local), "lane {k}");
                    assert_eq!((group.error[k].to_bits(), group.front >> k & 1 == 1), (e.error.to_bits(), e.front));
                    exits += 1;
                }
            }
        }
        assert!(exits > 4000, "{exits} exits, {none} none");
        // Anything but a sphere has no such form.
        let zero = [[0.0; 8]; 3];
        assert!(g.exit_group(4, &zero, &zero, &[0.0; 8], &zero).is_none());
    }

    #[test]
    fn eight_hits_described_at_once_have_the_bits_of_each_alone() {
        // Spheres (near the origin and 1e4 away, tiny and large, turned) and planes (tilted,
        // offset, one through the origin), each hit by rays from all around, eight at a time:
        // every lane of `hit_group` is `hit`'s answer for that ray, to the bit.
        let mut f = crate::testing::uniform(0x2545_F491_4F6C_DD1D);
        let turn = Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 0.7);
        let objects = [
            Object::new(Shape::Sphere, Affine3A::from_translation(Vec3::new(0.5, 1.0, -2.0)), 0),
            Object::new(
                Shape::Sphere,
                Affine3A::from_scale_rotation_translation(Vec3::splat(0.01), turn, Vec3::ONE),
                0,
            ),
            Object::new(
                Shape::Sphere,
                Affine3A::from_scale_rotation_translation(Vec3::splat(30.0), turn, Vec3::new(1e4, -2e3, 5e3)),
                0,
            ),
            Object::new(Shape::Plane, Affine3A::IDENTITY, 0),
            Object::new(Shape::Plane, Affine3A::from_rotation_translation(turn, Vec3::new(3.0, -2.0, 1.0)), 0),
            Object::new(Shape::Plane, Affine3A::from_scale_rotation_translation(Vec3::splat(2.0), turn, Vec3::ZERO), 0),
            // Tori: as they are, turned and scaled, scaled unevenly, far away.
            Object::new(Shape::Torus { minor: 0.3 }, Affine3A::IDENTITY, 0),
            Object::new(
                Shape::Torus { minor: 0.25 },
                Affine3A::from_scale_rotation_translation(Vec3::splat(0.9), turn, Vec3::X),
                0,
            ),
            Object::new(
                Shape::Torus { minor: 0.4 },
                Affine3A::from_scale_rotation_translation(Vec3::new(2.0, 0.5, 1.0), turn, Vec3::new(-3.0, 1.0, 2.0)),
                0,
            ),
            Object::new(
                Shape::Torus { minor: 0.1 },
                Affine3A::from_scale_rotation_translation(Vec3::splat(50.0), turn, Vec3::splat(3e3)),
                0,
            ),
        ];
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        let mut lanes = 0;
        for object in objects.iter().map(|o| o.as_ref().unwrap()) {
            let centre = Vec3::from(object.world_from_object.translation);
            let size = match object.shape {
                Shape::Sphere => object.world_from_object.matrix3.x_axis.length(),
                Shape::Torus { .. } => object.world_from_object.matrix3.x_axis.length().max(1.0) * 1.3,
                _ => 5.0,
            };
            for _ in 0..200 {
                let (mut o, mut d, mut t) = ([[0.0f32; 8]; 3], [[0.0f32; 8]; 3], [0.0f32; 8]);
                let mut hit = [None; 8];
                for k in 0..8 {
                    let from = centre + Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)) * size * 4.0;
                    let aim = centre + Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)) * size;
                    let dir = (aim - from) * f(0.2, 3.0);
                    for a in 0..3 {
                        (o[a][k], d[a][k]) = (from[a], dir[a]);
                    }
                    if let Some(c) = object.intersect(from, dir, 0.0, f32::INFINITY) {
                        t[k] = c.t;
                        hit[k] = Some(object.hit(7, from, dir, &c));
                    }
                }
                let live = (0..8).fold(0u8, |m, k| m | u8::from(hit[k].is_some()) << k);
                let group = object.hit_group(&o, &d, &t, live).expect("a world-space form");
                for (k, h) in hit.iter().enumerate() {
                    let Some(h) = h else { continue };
                    let lane = |p: &Packet| Vec3::new(p[0][k], p[1][k], p[2][k]);
                    assert_eq!(bits(lane(&group.point)), bits(h.point), "point, lane {k}");
                    assert_eq!(bits(lane(&group.local)), bits(h.local), "local, lane {k}");
                    assert_eq!(bits(lane(&group.normal)), bits(h.normal), "normal, lane {k}");
                    assert_eq!(bits(h.shading), bits(h.normal), "shading, lane {k}");
                    assert_eq!((h.uv, group.error[k].to_bits()), (Vec2::ZERO, h.error.to_bits()), "lane {k}");
                    assert_eq!(group.front >> k & 1 == 1, h.front, "front, lane {k}");
                    lanes += 1;
                }
            }
        }
        assert!(lanes > 6000, "{lanes} lanes compared");
        // A lane with no crossing that sits on a torus's axis does not stop the others: only a
        // live lane there sends the group lane by lane.
        let torus = Object::new(Shape::Torus { minor: 0.25 }, Affine3A::IDENTITY, 0).unwrap();
        let (mut o, mut d, mut t) = ([[0.0f32; 8]; 3], [[0.0f32; 8]; 3], [0.0f32; 8]);
        for k in 1..8 {
            let from = Vec3::new(-5.0, 0.02 * k as f32, 0.1);
            let c = torus.intersect(from, Vec3::X, 0.0, f32::INFINITY).expect("a crossing");
            (o[0][k], o[1][k], o[2][k], d[0][k], t[k]) = (from.x, from.y, from.z, 1.0, c.t);
        }
        o[1][0] = 2.0;
        assert!(torus.hit_group(&o, &d, &t, 0b1111_1110).is_some());
        assert!(torus.hit_group(&o, &d, &t, u8::MAX).is_none());
        // Any other object has no such form.
        let cube = Object::new(Shape::Cube, Affine3A::IDENTITY, 0).unwrap();
        assert!(cube.hit_group(&[[0.0; 8]; 3], &[[1.0; 8]; 3], &[1.0; 8], u8::MAX).is_none());
    }

    #[test]
    fn eight_spawns_at_once_have_the_bits_of_each_alone_lane_by_lane() {
        // Each lane its own hit (on a plane, a disk, spheres, a cube, a torus: flat, convex and
        // neither), leaving in, out and exactly along the surface, among lanes with no hit.
        let place = |shape: Shape, at: Vec3, s: f32| {
            Object::new(
                shape,
                Affine3A::from_scale_rotation_translation(Vec3::splat(s), Quat::from_rotation_y(0.3), at),
                0,
            )
            .unwrap()
        };
        let g = Geometry::new(vec![
            Object::new(Shape::Plane, Affine3A::IDENTITY, 0).unwrap(),
            place(Shape::Disk, Vec3::new(3.0, 1.0, 0.0), 0.7),
            place(Shape::Sphere, Vec3::new(-2.0, 1.0, 1.0), 1.0),
            place(Shape::Cube, Vec3::new(0.0, 1.0, 3.0), 0.6),
            place(Shape::Torus { minor: 0.3 }, Vec3::new(1.0, 0.5, -3.0), 1.2),
            place(Shape::Sphere, Vec3::new(0.0, 0.0, 0.0), 1e-3),
        ]);
        let mut f = crate::testing::uniform(0x5EED_0F5A_A5E5_1234);
        let mut hits = Vec::new();
        while hits.len() < 400 {
            let eye = Vec3::new(f(-8.0, 8.0), f(0.5, 8.0), f(-8.0, 8.0));
            let aim = g.objects[(f(0.0, 6.0) as usize).min(5)].bounds().map_or(Vec3::ZERO, |b| (b.min + b.max) * 0.5);
            if let Some(h) = g.closest_hit(Origin::free(eye), (aim - eye).normalize(), 0.0, f32::INFINITY) {
                hits.push((h, eye));
            }
        }
        let mut objects_seen = std::collections::HashSet::new();
        for group in hits.chunks(8) {
            // Lane 3 has no hit; lanes leave towards the eye, through the surface, along it.
            let dirs: Vec<Vec3> = group
                .iter()
                .enumerate()
                .map(|(k, (h, eye))| match k % 4 {
                    0 => (*eye - h.point).normalize(),
                    1 => -h.normal,
                    2 if h.object == 0 => Vec3::X,
                    _ => h.normal.any_orthonormal_vector(),
                })
                .collect();
            let packet = |v: &dyn Fn(usize) -> Vec3| -> Packet {
                std::array::from_fn(|a| std::array::from_fn(|k| if k < group.len() { v(k)[a] } else { 0.0 }))
            };
            let object: [u32; 8] =
                std::array::from_fn(|k| if k == 3 || k >= group.len() { NO_SKIP } else { group[k].0.object });
            let error = std::array::from_fn(|k| group.get(k).map_or(0.0, |h| h.0.error));
            let (origins, skips) = g.spawn_packet(
                &packet(&|k| group[k].0.point),
                &packet(&|k| group[k].0.normal),
                &error,
                &object,
                &packet(&|k| dirs[k]),
            );
            for (k, (h, _)) in group.iter().enumerate().filter(|&(k, _)| k != 3) {
                let alone = g.spawn(h, dirs[k]);
                let lane = Vec3::new(origins[0][k], origins[1][k], origins[2][k]);
                assert_eq!(
                    lane.to_array().map(f32::to_bits),
                    alone.point.to_array().map(f32::to_bits),
                    "lane {k}: {h:?}"
                );
                assert_eq!(skips[k], alone.skip, "lane {k}");
                objects_seen.insert(h.object);
            }
        }
        assert_eq!(objects_seen.len(), 6, "every object: {objects_seen:?}");
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
    fn placing_by_the_identity_without_products_gives_the_same_point_and_no_larger_bound() {
        let mut f = crate::testing::uniform(0x853C_49E6_748F_EA9B);
        for _ in 0..10_000 {
            let p = Vec3::new(f(-1e4, 1e4), f(-1.0, 1.0), f(-1e-3, 1e-3));
            let n = Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)).normalize_or(Vec3::Y);
            let (p, e) = (p.as_dvec3() * (1.0 + 1e-9), f(0.0, 1e-3) as f64);
            let (a, b) = (place(&Affine3A::IDENTITY, p, e, n), place_unmoved(p, e, n));
            // By the identity the f64 products are exact: the bound without them is tighter.
            assert_eq!(a.0.to_array().map(f32::to_bits), b.0.to_array().map(f32::to_bits));
            assert!(b.1 <= a.1 && a.1 <= b.1 * (1.0 + 1e-6), "{} {}", a.1, b.1);
        }
    }

    #[test]
    fn a_lone_mesh_without_a_tree_above_it_finds_the_triangles_hit() {
        // A mesh alone in the scene skips the tree of one object: placed by a rotation and a
        // scale (its world box no longer tests the ray), it still finds the first triangle the
        // ray meets, as testing every triangle in its own space does.
        let place = Affine3A::from_scale_rotation_translation(
            Vec3::new(2.0, 0.5, 1.0),
            Quat::from_euler(glam::EulerRot::XYZ, 0.3, 1.1, -0.4),
            Vec3::new(1.0, -2.0, 3.0),
        );
        let mesh = std::sync::Arc::new(crate::mesh::tests::octahedron());
        let g = Geometry::new(vec![Object::new(Shape::Mesh(mesh.clone()), place, 0).unwrap()]);
        assert!(g.lone_mesh);
        let inverse = place.inverse();
        let mut hits = 0;
        for k in 0..2_000 {
            let a = k as f32 * 0.618_034;
            let o = Vec3::new(6.0 * a.cos(), 4.0 * (a * 1.7).sin(), 6.0 * a.sin()) + Vec3::new(1.0, -2.0, 3.0);
            let target = Vec3::new(1.0, -2.0, 3.0) + Vec3::new((a * 3.1).sin(), (a * 2.3).cos(), (a * 1.3).sin()) * 1.2;
            let d = (target - o).normalize();
            let found = g.closest(Origin::free(o), d, 0.0, f32::INFINITY).map(|(_, c)| c.t);
            let each = mesh.intersect_brute_force(
                inverse.transform_point3(o),
                inverse.transform_vector3(d),
                0.0,
                f32::INFINITY,
            );
            assert_eq!(found, each, "ray {k}");
            assert_eq!(g.any_hit(Origin::free(o), d, f32::INFINITY), each.is_some(), "ray {k}");
            hits += usize::from(each.is_some());
        }
        assert!(hits > 200, "{hits}");
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
        let e = g.exit(&h, Vec3::X).unwrap();
        assert!((e.point - Vec3::new(2.0, 0.0, 5.0)).length() < 1e-5 && (e.normal - Vec3::X).length() < 1e-6);
    }

    #[test]
    fn regression_ray_leaving_a_cube_resting_on_a_plane_hits_the_plane() {
        // A unit cube sitting on the floor: its bottom face and the floor are the same plane.
        let floor = Object::new(Shape::Plane, Affine3A::IDENTITY, 0).unwrap();
        let cube = Object::new(Shape::Cube, Affine3A::from_translation(Vec3::Y), 0).unwrap();
        let g = Geometry::new(vec![floor, cube]);
        let down = Vec3::new(0.3, -1.0, 0.2).normalize();
        let p = Vec3::new(0.1, 0.0, -0.4);
        let (o, d) = (p + Vec3::Y * 0.5, -Vec3::Y);
        let c = g.objects[1].intersect(o, d, 0.0, f32::INFINITY).unwrap();
        let bottom = g.objects[1].hit(1, o, d, &c);
        assert!(!bottom.front && bottom.point.y.abs() < 1e-6);
        let from = g.spawn(&bottom, down);
        let hit = g.closest_hit(from, down, 0.0, f32::INFINITY).expect("the floor is right there");
        assert_eq!(hit.object, 0);
        assert!(hit.t < 1e-3);
    }

    #[test]
    fn contains_tells_inside_from_outside_for_every_solid() {
        let at = |x: f32| Affine3A::from_translation(Vec3::new(x, 0.0, 0.0));
        let torus = Shape::Torus { minor: 0.25 };
        for (shape, inside, outside) in [
            (Shape::Sphere, Vec3::new(0.5, 0.2, 0.0), Vec3::new(0.8, 0.8, 0.0)),
            (Shape::Cube, Vec3::new(0.9, -0.9, 0.9), Vec3::new(1.1, 0.0, 0.0)),
            (Shape::Cylinder, Vec3::new(0.0, 0.9, 0.5), Vec3::new(0.8, 0.0, 0.8)),
            (torus, Vec3::new(1.0, 0.1, 0.0), Vec3::ZERO),
            (Shape::Plane, Vec3::new(3.0, -0.1, 7.0), Vec3::new(3.0, 0.1, 7.0)),
        ] {
            let o = Object::new(shape.clone(), at(10.0), 0).unwrap();
            assert!(o.contains(inside + Vec3::X * 10.0), "{shape:?} contains {inside}");
            assert!(!o.contains(outside + Vec3::X * 10.0), "{shape:?} does not contain {outside}");
        }
        let disk = Object::new(Shape::Disk, Affine3A::IDENTITY, 0).unwrap();
        assert!(!disk.contains(Vec3::ZERO), "a disk has no inside");
        let octahedron = crate::mesh::tests::octahedron();
        let mesh = Object::new(Shape::Mesh(std::sync::Arc::new(octahedron)), at(10.0), 0).unwrap();
        assert!(mesh.contains(Vec3::new(10.2, 0.1, 0.1)));
        assert!(!mesh.contains(Vec3::new(10.6, 0.6, 0.0)));
    }

    #[test]
    fn overlap_finds_objects_reaching_into_a_solid_but_not_touching_ones() {
        let sphere = |x: f32, y: f32, r: f32| {
            Object::new(
                Shape::Sphere,
                Affine3A::from_scale_rotation_translation(Vec3::splat(r), Quat::IDENTITY, Vec3::new(x, y, 0.0)),
                0,
            )
            .unwrap()
        };
        let floor = Object::new(Shape::Plane, Affine3A::IDENTITY, 0).unwrap();
        // A ball resting on the floor, a ball sunk into it, two balls that overlap, a small
        // ball wholly inside a big one, a cube resting on the floor.
        let g = Geometry::new(vec![
            floor,
            sphere(0.0, 1.0, 1.0),
            sphere(5.0, 0.5, 1.0),
            sphere(10.0, 3.0, 1.0),
            sphere(11.5, 3.0, 1.0),
            sphere(20.0, 5.0, 2.0),
            sphere(20.3, 5.0, 0.3),
            Object::new(Shape::Cube, Affine3A::from_translation(Vec3::new(-5.0, 1.0, 0.0)), 0).unwrap(),
        ]);
        assert!(!g.overlap(1, 0), "resting on the floor is touching");
        assert!(!g.overlap(7, 0), "a cube resting on the floor touches it");
        assert!(g.overlap(2, 0), "sunk halfway into the floor");
        assert!(g.overlap(3, 4) && g.overlap(4, 3));
        assert!(g.overlap(5, 6), "a ball inside another");
        assert!(!g.overlap(1, 3) && !g.overlap(0, 1), "apart; a plane is not a bounded solid");
        // A tiny ball inside a big one, which few chords would meet.
        let g = Geometry::new(vec![sphere(0.0, 0.0, 2.0), sphere(0.3, 0.2, 0.05)]);
        assert!(g.overlap(0, 1));
        // Far from the origin, resting is still touching.
        let far = Affine3A::from_translation(Vec3::new(1e4, 0.0, 1e4));
        let floor = Object::new(Shape::Plane, far, 0).unwrap();
        let ball = Object::new(Shape::Sphere, far * Affine3A::from_translation(Vec3::Y), 0).unwrap();
        let cube = Object::new(Shape::Cube, far * Affine3A::from_translation(Vec3::new(3.0, 1.0, 0.0)), 0).unwrap();
        let g = Geometry::new(vec![floor, ball, cube]);
        assert!(!g.overlap(1, 0) && !g.overlap(2, 0), "resting on a floor 1e4 away from the origin");
    }
}

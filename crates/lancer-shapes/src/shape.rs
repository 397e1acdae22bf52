//! The canonical shapes in object space (docs/scene-format.md) and their two queries.

use glam::Vec3;

use crate::Aabb;

/// A canonical shape in object space. A closed set: one `match` per query.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// Radius 1 at the origin.
    Sphere,
    /// The box `[-1, 1]^3`.
    Cube,
    /// `y = 0`, normal `+y`; the half-space `y < 0` is inside.
    Plane,
    /// Radius 1 around y for y in [-1, 1], capped.
    Cylinder,
    /// Apex at y = 1, base of radius 1 at y = -1, capped.
    Cone,
    /// Around y, major radius 1, tube radius `minor` (in (0, 1)).
    Torus {
        /// The tube's radius.
        minor: f32,
    },
    /// The unit disk in the plane y = 0, normal +y (flat: it has no inside).
    Disk,
    /// A constructive solid geometry tree.
    Csg(std::sync::Arc<crate::Csg>),
    /// A triangle mesh.
    Mesh(std::sync::Arc<crate::Mesh>),
}

/// A crossing of the surface: distance along the ray and outward normal (object space).
type Crossing = (f32, Vec3);

/// A surface crossing found by a shape query, in object space: what the closest-hit search
/// compares, and what [`Shape::surface`] needs to describe the surface there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeHit {
    /// Distance along the ray (in units of the ray's direction length).
    pub t: f32,
    /// Outward normal as the query found it (unit; zero for a mesh, whose normal comes from
    /// [`Shape::surface`]).
    pub normal: Vec3,
    /// Which part of the shape: the triangle of a mesh, the leaf node of a CSG tree; 0 otherwise.
    pub part: u32,
    /// Barycentric weights of the triangle's second and third corners (meshes only).
    pub bary: glam::Vec2,
}

impl ShapeHit {
    #[inline]
    fn of((t, normal): Crossing) -> ShapeHit {
        ShapeHit { t, normal, part: 0, bary: glam::Vec2::ZERO }
    }
}

/// The surface at a hit, in object space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalSurface {
    /// The hit point, moved onto the surface (see [`Shape::surface`]), rounded to f32.
    pub point: Vec3,
    /// The same point before it was rounded: what the placement into world space starts from,
    /// so the world point is rounded once, however large the placement's scale.
    pub exact: glam::DVec3,
    /// A bound on the distance from `exact` to the true surface.
    pub error: f64,
    /// Unit outward geometric normal.
    pub normal: Vec3,
    /// Unit outward shading normal: the geometric one, except on smooth meshes, where it is
    /// interpolated from the vertex normals (and turned to the geometric normal's side).
    pub shading: Vec3,
    /// Texture coordinates interpolated from a mesh's vertices (zero for other shapes).
    pub uv: glam::Vec2,
}

/// Unit roundoff of f64.
const EPS64: f64 = f64::EPSILON * 0.5;

impl Shape {
    /// Every shape's name as scene files spell it, in documentation order.
    pub const NAMES: &'static [&'static str] =
        &["sphere", "cube", "plane", "cylinder", "cone", "torus", "disk", "csg", "mesh"];

    /// The name scene files use.
    pub fn name(&self) -> &'static str {
        match self {
            Shape::Sphere => "sphere",
            Shape::Cube => "cube",
            Shape::Plane => "plane",
            Shape::Cylinder => "cylinder",
            Shape::Cone => "cone",
            Shape::Torus { .. } => "torus",
            Shape::Disk => "disk",
            Shape::Csg(_) => "csg",
            Shape::Mesh(_) => "mesh",
        }
    }

    /// The shape called `name` in scene files, with its parameters at their defaults (a torus's
    /// `minor` is 0.25).
    pub fn from_name(name: &str) -> Option<Shape> {
        Some(match name {
            "sphere" => Shape::Sphere,
            "cube" => Shape::Cube,
            "plane" => Shape::Plane,
            "cylinder" => Shape::Cylinder,
            "cone" => Shape::Cone,
            "torus" => Shape::Torus { minor: 0.25 },
            "disk" => Shape::Disk,
            _ => return None,
        })
    }

    /// How costly the shape's intersection test is, roughly, from 0 (a box) up: the order in
    /// which a block of rays meets a small scene's objects.
    pub(crate) fn cost_rank(&self) -> u32 {
        match self {
            Shape::Sphere | Shape::Cube | Shape::Plane | Shape::Disk => 0,
            Shape::Cylinder | Shape::Cone => 1,
            Shape::Torus { .. } => 2,
            Shape::Csg(_) => 3,
            Shape::Mesh(_) => 4,
        }
    }

    /// Whether the shape is convex (a plane and a disk count): a ray leaving its surface never
    /// meets it again, so secondary rays may ignore it.
    pub fn is_convex(&self) -> bool {
        !matches!(self, Shape::Torus { .. } | Shape::Csg(_) | Shape::Mesh(_))
    }

    /// Whether the surface is flat (a plane, a disk): a ray leaving it to either side never
    /// meets it again.
    pub fn is_flat(&self) -> bool {
        matches!(self, Shape::Plane | Shape::Disk)
    }

    /// Whether the shape encloses a volume, so a ray inside it has an exit point.
    pub fn is_closed(&self) -> bool {
        match self {
            Shape::Disk => false,
            Shape::Mesh(m) => m.is_closed(),
            _ => true,
        }
    }

    /// Texture coordinates of an object-space surface point, each in [0, 1] except for the
    /// planar mappings (plane, disk, cylinder and cone caps), which use `(x, z) / scale` and tile.
    /// Spheres, cylinders, cones and tori wrap `u` once around the y axis; `v` goes from bottom
    /// (0) to top (1) (around the tube, for a torus); each cube face gets the whole image.
    pub fn uv(&self, p: Vec3, scale: f32) -> glam::Vec2 {
        use std::f32::consts::{PI, TAU};
        let around = 0.5 + libm::atan2f(p.z, p.x) / TAU;
        let planar = glam::Vec2::new(p.x, p.z) / scale;
        match self {
            Shape::Sphere => glam::Vec2::new(around, 0.5 + libm::asinf(p.y.clamp(-1.0, 1.0)) / PI),
            Shape::Plane | Shape::Disk | Shape::Csg(_) | Shape::Mesh(_) => planar,
            Shape::Cylinder | Shape::Cone => {
                if p.y.abs() >= 1.0 - 1e-4 {
                    planar
                } else {
                    glam::Vec2::new(around, (p.y + 1.0) / 2.0)
                }
            }
            Shape::Torus { .. } => {
                let rho = (p.x * p.x + p.z * p.z).sqrt();
                glam::Vec2::new(around, 0.5 + libm::atan2f(p.y, rho - 1.0) / TAU)
            }
            Shape::Cube => {
                let a = p.abs();
                let (s, t) = if a.x >= a.y && a.x >= a.z {
                    (p.z * -p.x.signum(), p.y)
                } else if a.y >= a.z {
                    (p.x, p.z * -p.y.signum())
                } else {
                    (p.x * p.z.signum(), p.y)
                };
                glam::Vec2::new((s + 1.0) / 2.0, (t + 1.0) / 2.0)
            }
        }
    }

    /// Object-space bounds; `None` for unbounded shapes.
    pub fn bounds(&self) -> Option<Aabb> {
        match self {
            Shape::Sphere | Shape::Cube | Shape::Cylinder | Shape::Cone => {
                Some(Aabb { min: Vec3::splat(-1.0), max: Vec3::ONE })
            }
            &Shape::Torus { minor } => Some(Aabb {
                min: Vec3::new(-1.0 - minor, -minor, -1.0 - minor),
                max: Vec3::new(1.0 + minor, minor, 1.0 + minor),
            }),
            // A sliver of thickness so the slab test never divides a zero-width box.
            Shape::Disk => Some(Aabb { min: Vec3::new(-1.0, -1e-4, -1.0), max: Vec3::new(1.0, 1e-4, 1.0) }),
            Shape::Csg(csg) => csg.bounds(),
            Shape::Mesh(m) => Some(m.bounds()),
            Shape::Plane => None,
        }
    }

    /// The radius of a ball around the object-space origin that holds the shape (a torus: its
    /// tube's outer circle; the shapes in the unit cube: the corners or rims they reach; up to
    /// the rounding of the root, which a caller that culls by it widens); `None` for shapes
    /// without one (a plane, a CSG tree, a mesh: their boxes serve).
    pub fn ball_radius(&self) -> Option<f32> {
        match self {
            Shape::Sphere => Some(1.0),
            Shape::Cube => Some(3f32.sqrt()),
            Shape::Cylinder | Shape::Cone => Some(2f32.sqrt()),
            &Shape::Torus { minor } => Some(1.0 + minor),
            Shape::Disk => Some(1.0),
            Shape::Csg(_) | Shape::Mesh(_) | Shape::Plane => None,
        }
    }

    /// The parts of the line `o + t d` inside the shape, sorted and disjoint, with outward
    /// normals at their ends (infinite ends for a plane's half-space). None for a disk.
    pub fn spans(&self, o: Vec3, d: Vec3) -> Vec<crate::Span> {
        let one = |((t0, n0), (t1, n1)): (Crossing, Crossing)| vec![crate::Span { t0, n0, t1, n1, part0: 0, part1: 0 }];
        match self {
            Shape::Plane => {
                if d.y == 0.0 {
                    return if o.y < 0.0 { one(ALL) } else { Vec::new() };
                }
                let t = -o.y / d.y;
                if d.y > 0.0 {
                    one(((f32::NEG_INFINITY, Vec3::ZERO), (t, Vec3::Y)))
                } else {
                    one(((t, Vec3::Y), (f32::INFINITY, Vec3::ZERO)))
                }
            }
            // Meshes are not CSG operands (the scene loader refuses them).
            Shape::Disk | Shape::Mesh(_) => Vec::new(),
            Shape::Torus { minor } => {
                let roots = crate::torus::roots(*minor, o, d);
                roots
                    .chunks_exact(2)
                    .map(|p| crate::Span { t0: p[0].0, n0: p[0].1, t1: p[1].0, n1: p[1].1, part0: 0, part1: 0 })
                    .collect()
            }
            Shape::Csg(csg) => csg.spans(o, d),
            _ => self.span(o, d).map(one).unwrap_or_default(),
        }
    }

    /// Where the line `o + t d` is inside a convex solid: entry and exit crossings (entry may
    /// be behind the origin). `None` for a line that misses, or for non-convex and flat shapes.
    #[inline]
    fn span(&self, o: Vec3, d: Vec3) -> Option<(Crossing, Crossing)> {
        match self {
            Shape::Sphere => {
                let (t0, t1) = sphere_roots(o, d)?;
                let n = |t: f32| (o + t * d).normalize_or(Vec3::Y);
                Some(((t0, n(t0)), (t1, n(t1))))
            }
            Shape::Cube => cube_span(o, d),
            Shape::Cylinder => cylinder_span(o, d),
            Shape::Cone => cone_span(o, d),
            Shape::Plane | Shape::Torus { .. } | Shape::Disk | Shape::Csg(_) | Shape::Mesh(_) => None,
        }
    }

    /// The first surface crossing of `o + t d` with `tmin < t < tmax`. `d` need not be unit length
    /// (object-space rays carry the transform's scale).
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<ShapeHit> {
        let ok = |t: f32| t > tmin && t < tmax;
        match self {
            Shape::Plane => {
                if d.y == 0.0 {
                    return None;
                }
                let t = -o.y / d.y;
                ok(t).then_some(ShapeHit::of((t, Vec3::Y)))
            }
            Shape::Disk => {
                if d.y == 0.0 {
                    return None;
                }
                let t = -o.y / d.y;
                let p = o + t * d;
                (ok(t) && p.x * p.x + p.z * p.z <= 1.0).then_some(ShapeHit::of((t, Vec3::Y)))
            }
            // The normal comes from `surface`, for the hit that wins.
            Shape::Torus { minor } => {
                crate::torus::first_t(*minor, o, d, tmin, tmax).map(|t| ShapeHit::of((t, Vec3::ZERO)))
            }
            Shape::Csg(csg) => first_boundary(&csg.spans(o, d), tmin, tmax),
            Shape::Mesh(m) => m.intersect(o, d, tmin, tmax),
            Shape::Sphere => {
                let (t0, t1) = sphere_roots(o, d)?;
                let t = if ok(t0) {
                    t0
                } else if ok(t1) {
                    t1
                } else {
                    return None;
                };
                Some(ShapeHit::of((t, Vec3::ZERO)))
            }
            _ => {
                let ((t0, n0), (t1, n1)) = self.span(o, d)?;
                if ok(t0) {
                    Some(ShapeHit::of((t0, n0)))
                } else if ok(t1) {
                    Some(ShapeHit::of((t1, n1)))
                } else {
                    None
                }
            }
        }
    }

    /// Whether the shape lies on the ray `o + t d` anywhere in `0 < t < tmax` (any hit will do).
    #[inline]
    pub fn occludes(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        match self {
            Shape::Mesh(m) => m.occludes(o, d, tmax),
            _ => self.intersect(o, d, 0.0, tmax).is_some(),
        }
    }

    /// Where the line `o + t d`, starting inside the shape, leaves it: the next crossing `t > 0`.
    /// `None` when the ray never leaves (a plane's half-space) or the shape has no inside (a
    /// disk, an open mesh).
    #[inline]
    pub fn exit(&self, o: Vec3, d: Vec3) -> Option<ShapeHit> {
        match self {
            Shape::Plane => {
                if d.y <= 0.0 {
                    return None;
                }
                let t = -o.y / d.y;
                (t > 0.0).then_some(ShapeHit::of((t, Vec3::Y)))
            }
            Shape::Disk => None,
            Shape::Torus { minor } => {
                crate::torus::first_t(*minor, o, d, 0.0, f32::INFINITY).map(|t| ShapeHit::of((t, Vec3::ZERO)))
            }
            Shape::Csg(csg) => first_boundary(&csg.spans(o, d), 0.0, f32::INFINITY),
            Shape::Mesh(m) => {
                if !m.is_closed() {
                    return None;
                }
                m.intersect(o, d, 0.0, f32::INFINITY)
            }
            _ => {
                let (_, (t1, n1)) = self.span(o, d)?;
                // `>=`: a start snapped onto an edge may leave through the next face at 0.
                (t1 >= 0.0).then_some(ShapeHit::of((t1, n1)))
            }
        }
    }

    /// The surface where the ray `o + t d` made the crossing `hit`: the point recomputed in f64
    /// and moved onto the surface (projected onto a sphere, cylinder or torus, snapped to a face
    /// or cap plane, Newton-polished onto a cone, interpolated from a triangle's corners), with a
    /// bound on its remaining distance from the surface. The point's error then no longer grows
    /// with the ray's length or its origin's distance, only with the point's own magnitude, so
    /// a secondary ray can start just off the surface wherever the scene is.
    pub fn surface(&self, o: Vec3, d: Vec3, hit: &ShapeHit) -> LocalSurface {
        let p = o.as_dvec3() + hit.t as f64 * d.as_dvec3();
        // A point projected onto the surface in f64: the projection's own rounding, a few units
        // of f64's roundoff of its coordinates.
        let plain = |point: glam::DVec3, normal: Vec3| {
            let error = 8.0 * EPS64 * (point.x.abs() + point.y.abs() + point.z.abs());
            LocalSurface { point: point.as_vec3(), exact: point, error, normal, shading: normal, uv: glam::Vec2::ZERO }
        };
        // A point snapped onto an axis-aligned plane (a face, a cap, the plane or the disk) is
        // exactly on it: no error along the normal, whatever its other coordinates.
        let snapped = |point: glam::DVec3, normal: Vec3| LocalSurface {
            point: point.as_vec3(),
            exact: point,
            error: 0.0,
            normal,
            shading: normal,
            uv: glam::Vec2::ZERO,
        };
        match self {
            Shape::Sphere => {
                let q = p.normalize_or(glam::DVec3::Y);
                plain(q, q.as_vec3().normalize_or(Vec3::Y))
            }
            Shape::Plane | Shape::Disk => snapped(glam::DVec3::new(p.x, 0.0, p.z), Vec3::Y),
            Shape::Cube => {
                let axis = hit.normal.abs().max_position();
                let mut q = p.clamp(glam::DVec3::splat(-1.0), glam::DVec3::ONE);
                q[axis] = hit.normal[axis].signum() as f64;
                snapped(q, hit.normal)
            }
            Shape::Cylinder => {
                if hit.normal.y != 0.0 {
                    let mut q = p;
                    q.y = hit.normal.y.signum() as f64;
                    return snapped(q, hit.normal);
                }
                let rho = (p.x * p.x + p.z * p.z).sqrt();
                if rho == 0.0 {
                    // On the axis (no side to project onto): the side is 1 away.
                    return LocalSurface { error: 1.0, ..plain(p, hit.normal) };
                }
                let q = glam::DVec3::new(p.x / rho, p.y.clamp(-1.0, 1.0), p.z / rho);
                plain(q, Vec3::new(q.x as f32, 0.0, q.z as f32).normalize_or(Vec3::X))
            }
            Shape::Cone => {
                if hit.normal == -Vec3::Y {
                    return snapped(glam::DVec3::new(p.x, -1.0, p.z), hit.normal);
                }
                // f = x² + z² − (1 − y)²/4 = 0; two Newton steps along the gradient.
                let mut q = p;
                for _ in 0..2 {
                    let f = q.x * q.x + q.z * q.z - (1.0 - q.y) * (1.0 - q.y) / 4.0;
                    let g = glam::DVec3::new(2.0 * q.x, (1.0 - q.y) / 2.0, 2.0 * q.z);
                    let gg = g.length_squared();
                    if gg == 0.0 {
                        break;
                    }
                    q -= f / gg * g;
                }
                // The lower nappe only (Newton may step past the apex onto the upper one).
                q.y = q.y.clamp(-1.0, 1.0);
                let n = Vec3::new(2.0 * q.x as f32, (1.0 - q.y as f32) / 2.0, 2.0 * q.z as f32);
                let mut surface = plain(q, n.normalize_or(hit.normal));
                // Two steps may leave it short of the surface (a grazing ray far away): what is
                // left of `f`, over its gradient, bounds the distance (to first order, doubled).
                let f = q.x * q.x + q.z * q.z - (1.0 - q.y) * (1.0 - q.y) / 4.0;
                let g = glam::DVec3::new(2.0 * q.x, (1.0 - q.y) / 2.0, 2.0 * q.z).length();
                if g > 0.0 {
                    surface.error += 2.0 * f.abs() / g;
                }
                surface
            }
            &Shape::Torus { minor } => {
                let rho = (p.x * p.x + p.z * p.z).sqrt();
                if rho == 0.0 {
                    // On the axis: the tube is at most this far (the centre circle's distance).
                    return LocalSurface { error: 1.0 + p.y.abs(), ..plain(p, crate::torus::normal(p.as_vec3())) };
                }
                // The nearest point of the tube: from the centre circle towards `p`, at `minor`.
                let c = glam::DVec3::new(p.x / rho, 0.0, p.z / rho);
                let q = c + (p - c).normalize_or(glam::DVec3::Y) * minor as f64;
                plain(q, crate::torus::normal(q.as_vec3()))
            }
            Shape::Mesh(m) => m.surface(hit.part, hit.bary),
            Shape::Csg(csg) => csg.surface(o, d, hit),
        }
    }
}

/// The first span boundary with `tmin < t < tmax`.
#[inline]
fn first_boundary(spans: &[crate::Span], tmin: f32, tmax: f32) -> Option<ShapeHit> {
    spans
        .iter()
        .flat_map(|s| [(s.t0, s.n0, s.part0), (s.t1, s.n1, s.part1)])
        .find(|&(t, ..)| t > tmin && t < tmax)
        .map(|(t, normal, part)| ShapeHit { t, normal, part, bary: glam::Vec2::ZERO })
}

/// The intersection of two parameter intervals given by their entry and exit crossings.
#[inline]
fn clip(a: (Crossing, Crossing), b: (Crossing, Crossing)) -> Option<(Crossing, Crossing)> {
    let near = if a.0.0 >= b.0.0 { a.0 } else { b.0 };
    let far = if a.1.0 <= b.1.0 { a.1 } else { b.1 };
    (near.0 <= far.0).then_some((near, far))
}

const ALL: (Crossing, Crossing) = ((f32::NEG_INFINITY, Vec3::ZERO), (f32::INFINITY, Vec3::ZERO));

/// Where the line is between the planes y = -1 and y = 1, with the caps' normals.
#[inline]
fn slab_y(o: Vec3, d: Vec3) -> Option<(Crossing, Crossing)> {
    if d.y == 0.0 {
        return (o.y.abs() <= 1.0).then_some(ALL);
    }
    let (ta, tb) = ((-1.0 - o.y) / d.y, (1.0 - o.y) / d.y);
    Some(if d.y > 0.0 { ((ta, -Vec3::Y), (tb, Vec3::Y)) } else { ((tb, Vec3::Y), (ta, -Vec3::Y)) })
}

/// Roots of `a t² + 2 b t + c = 0`, ascending, cancellation-free; `None` without real roots.
#[inline]
fn half_quadratic(a: f32, b: f32, c: f32, disc: f32) -> Option<(f32, f32)> {
    if disc < 0.0 {
        return None;
    }
    let h = -(b + disc.sqrt().copysign(b));
    if h == 0.0 {
        return Some((0.0, 0.0));
    }
    let (r0, r1) = (h / a, c / h);
    Some(if r0 <= r1 { (r0, r1) } else { (r1, r0) })
}

/// The capped unit cylinder: the infinite cylinder x² + z² ≤ 1 clipped to y in [-1, 1].
#[inline]
fn cylinder_span(o: Vec3, d: Vec3) -> Option<(Crossing, Crossing)> {
    let a = d.x * d.x + d.z * d.z;
    let side = if a == 0.0 {
        if o.x * o.x + o.z * o.z > 1.0 {
            return None;
        }
        ALL
    } else {
        let b = o.x * d.x + o.z * d.z;
        // b² − a c = a (1 − |q|²), q the closest point of the projected line to the axis.
        let (qx, qz) = (o.x - b / a * d.x, o.z - b / a * d.z);
        let disc = a * (1.0 - (qx * qx + qz * qz));
        let (t0, t1) = half_quadratic(a, b, o.x * o.x + o.z * o.z - 1.0, disc)?;
        let n = |t: f32| {
            let p = o + t * d;
            Vec3::new(p.x, 0.0, p.z).normalize_or(Vec3::X)
        };
        ((t0, n(t0)), (t1, n(t1)))
    };
    clip(side, slab_y(o, d)?)
}

/// The capped cone: x² + z² ≤ ((1 − y)/2)² for y in [-1, 1] (apex at y = 1).
#[inline]
fn cone_span(o: Vec3, d: Vec3) -> Option<(Crossing, Crossing)> {
    let slab = slab_y(o, d)?;
    // f(t) = x² + z² − (1 − y)²/4 = a t² + 2 b t + c; inside where f ≤ 0. In f64: c cancels
    // two large terms when the origin is far, which in f32 puts hits off the surface.
    let (od, dd) = (o.as_dvec3(), d.as_dvec3());
    let (ky, kd) = (1.0 - od.y, -dd.y);
    let a64 = dd.x * dd.x + dd.z * dd.z - kd * kd / 4.0;
    let b64 = od.x * dd.x + od.z * dd.z - ky * kd / 4.0;
    let c64 = od.x * od.x + od.z * od.z - ky * ky / 4.0;
    let (a, b, c) = (a64 as f32, b64 as f32, c64 as f32);
    let normal = |t: f32| {
        let p = o + t * d;
        Vec3::new(2.0 * p.x, (1.0 - p.y) / 2.0, 2.0 * p.z).normalize_or(Vec3::Y)
    };
    // The quadric's inside as one or two intervals of t.
    // Parallel to a generator when `a` vanishes next to the terms it is the difference of (an
    // absolute threshold would take every ray for parallel on a cone scaled up a millionfold,
    // whose object-space directions are a millionth long).
    let pieces: [Option<(Crossing, Crossing)>; 2] = if a64.abs() <= 1e-9 * dd.length_squared() {
        // Parallel to a generator: f is linear in t.
        if b == 0.0 {
            if c <= 0.0 { [Some(ALL), None] } else { return None }
        } else {
            let t = -c / (2.0 * b);
            if b > 0.0 {
                [Some(((f32::NEG_INFINITY, Vec3::ZERO), (t, normal(t)))), None]
            } else {
                [Some(((t, normal(t)), (f32::INFINITY, Vec3::ZERO))), None]
            }
        }
    } else {
        let disc = b64 * b64 - a64 * c64;
        let roots = (disc >= 0.0).then(|| {
            let h = -(b64 + disc.sqrt().copysign(b64));
            let (r0, r1) = if h == 0.0 { (0.0, 0.0) } else { (h / a64, c64 / h) };
            if r0 <= r1 { (r0 as f32, r1 as f32) } else { (r1 as f32, r0 as f32) }
        });
        match roots {
            None => {
                if a > 0.0 {
                    return None;
                } else {
                    [Some(ALL), None]
                }
            }
            Some((t0, t1)) if a > 0.0 => [Some(((t0, normal(t0)), (t1, normal(t1)))), None],
            Some((t0, t1)) => [
                Some(((f32::NEG_INFINITY, Vec3::ZERO), (t0, normal(t0)))),
                Some(((t1, normal(t1)), (f32::INFINITY, Vec3::ZERO))),
            ],
        }
    };
    // Within the slab only the lower nappe remains, so at most one piece survives; keep the
    // longer if rounding lets two touch at the apex.
    pieces
        .into_iter()
        .flatten()
        .filter_map(|p| clip(p, slab))
        .max_by(|x, y| (x.1.0 - x.0.0).total_cmp(&(y.1.0 - y.0.0)))
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
    half_quadratic(a, b, o.dot(o) - 1.0, disc)
}

/// Both roots of `|oc + t d|² = r²` (a sphere of squared radius `radius2` whose centre is at
/// `−oc` from the origin), ascending, by the same cancellation-free form as [`sphere_roots`].
#[inline]
pub(crate) fn sphere_roots_world(oc: Vec3, d: Vec3, radius2: f32) -> Option<(f32, f32)> {
    let a = d.dot(d);
    if a == 0.0 {
        return None;
    }
    let b = oc.dot(d);
    let q = oc - (b / a) * d;
    let disc = a * (radius2 - q.dot(q));
    half_quadratic(a, b, oc.dot(oc) - radius2, disc)
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
        let (o, d) = (Vec3::new(0.0, 0.0, -5.0), Vec3::Z);
        let hit = Shape::Sphere.intersect(o, d, 0.0, f32::INFINITY).unwrap();
        let n = Shape::Sphere.surface(o, d, &hit).normal;
        assert!((hit.t - 4.0).abs() < 1e-6 && (n + Vec3::Z).length() < 1e-6);
        let ShapeHit { t, normal: n, .. } = Shape::Sphere.exit(Vec3::new(0.0, 0.0, -0.999), Vec3::Z).unwrap();
        assert!((t - 1.999).abs() < 1e-5 && (n - Vec3::Z).length() < 1e-6);
        assert!(Shape::Sphere.intersect(Vec3::new(0.0, 2.0, -5.0), Vec3::Z, 0.0, f32::INFINITY).is_none());
    }

    #[test]
    fn cube_faces_have_outward_normals() {
        let ShapeHit { t, normal: n, .. } =
            Shape::Cube.intersect(Vec3::new(0.3, 0.2, 4.0), -Vec3::Z, 0.0, f32::INFINITY).unwrap();
        assert!((t - 3.0).abs() < 1e-6);
        assert_eq!(n, Vec3::Z);
        let ShapeHit { t, normal: n, .. } = Shape::Cube.exit(Vec3::new(0.3, 0.2, 0.0), Vec3::X).unwrap();
        assert!((t - 0.7).abs() < 1e-6);
        assert_eq!(n, Vec3::X);
        // Parallel to a face, outside its slab: no hit.
        assert!(Shape::Cube.intersect(Vec3::new(0.0, 2.0, 4.0), -Vec3::Z, 0.0, f32::INFINITY).is_none());
    }

    #[test]
    fn plane_is_one_sided_for_inside_and_outside() {
        let h = Shape::Plane.intersect(Vec3::new(0.0, 2.0, 0.0), -Vec3::Y, 0.0, f32::INFINITY).unwrap();
        assert_eq!((h.t, h.normal), (2.0, Vec3::Y));
        assert_eq!(
            Shape::Plane.exit(Vec3::new(0.0, -1.0, 0.0), Vec3::Y).map(|h| (h.t, h.normal)),
            Some((1.0, Vec3::Y))
        );
        assert_eq!(Shape::Plane.exit(Vec3::new(0.0, -1.0, 0.0), -Vec3::Y), None);
    }
}

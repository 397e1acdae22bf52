//! Geometric properties of every shape under random affine transforms (proptest, fixed seed):
//! hits lie on the surface, normals are unit and outward, exits from inside lie on the surface,
//! a ray leaving a convex shape never meets it again, and transforming then intersecting agrees
//! with intersecting in object space.

use glam::{Affine3A, EulerRot, Quat, Vec3};
use lancer_shapes::{Csg, CsgNode, CsgOp, Object, Shape, offset_origin};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

/// How far an object-space point is from the shape's surface (0 on it; not always a true
/// distance, but zero exactly on the surface), from the shapes' definitions in SCENE-FORMAT.md.
fn surface_distance(shape: &Shape, p: Vec3) -> f32 {
    let rho = (p.x * p.x + p.z * p.z).sqrt();
    match shape {
        Shape::Sphere => (p.length() - 1.0).abs(),
        Shape::Cube => (p.abs().max_element() - 1.0).abs(),
        Shape::Plane => p.y.abs(),
        Shape::Cylinder => (rho - 1.0).max(p.y.abs() - 1.0).abs(),
        Shape::Cone => (rho - (1.0 - p.y) / 2.0).max(-1.0 - p.y).abs(),
        Shape::Torus { minor } => (((rho - 1.0).powi(2) + p.y * p.y).sqrt() - minor).abs(),
        Shape::Disk => p.y.abs().max((rho - 1.0).max(0.0)),
        Shape::Csg(_) | Shape::Mesh(_) => unreachable!("CSG and meshes have their own tests"),
    }
}

/// The outward normal in object space at a surface point; `None` on an edge, where it is not
/// defined.
fn object_normal(shape: &Shape, p: Vec3) -> Option<Vec3> {
    let rho = (p.x * p.x + p.z * p.z).sqrt();
    let near = |a: f32, b: f32| (a - b).abs() < 1e-3;
    Some(match shape {
        Shape::Sphere => p.normalize(),
        Shape::Cube => {
            let a = p.abs();
            let mut s = a.to_array();
            s.sort_by(f32::total_cmp);
            if near(s[1], s[2]) {
                return None;
            }
            let axis = if a.x >= a.y && a.x >= a.z {
                0
            } else if a.y >= a.z {
                1
            } else {
                2
            };
            Vec3::AXES[axis] * p[axis].signum()
        }
        Shape::Plane | Shape::Disk => Vec3::Y,
        Shape::Cylinder => {
            if near(rho, 1.0) && near(p.y.abs(), 1.0) {
                return None;
            }
            if near(p.y.abs(), 1.0) { Vec3::Y * p.y.signum() } else { Vec3::new(p.x, 0.0, p.z) / rho }
        }
        Shape::Cone => {
            if near(p.y, -1.0) && near(rho, 1.0) || p.y > 0.99 {
                return None;
            }
            if near(p.y, -1.0) { -Vec3::Y } else { Vec3::new(2.0 * p.x, (1.0 - p.y) / 2.0, 2.0 * p.z).normalize() }
        }
        Shape::Torus { .. } => {
            let c = Vec3::new(p.x / rho, 0.0, p.z / rho);
            (p - c).normalize()
        }
        Shape::Csg(_) | Shape::Mesh(_) => unreachable!("CSG and meshes have their own tests"),
    })
}

/// A point strictly inside a closed shape, from three numbers in [-1, 1].
fn inside_point(shape: &Shape, u: Vec3) -> Vec3 {
    match shape {
        Shape::Sphere => u * 0.55,
        Shape::Cube => u * 0.95,
        Shape::Cylinder => Vec3::new(u.x * 0.7, u.y * 0.95, u.z * 0.7),
        Shape::Cone => {
            let y = -0.95 + (u.y + 1.0) * 0.7;
            let r = (1.0 - y) / 2.0 * 0.7;
            Vec3::new(u.x * r, y, u.z * r)
        }
        Shape::Torus { minor } => {
            let (a, minor) = (u.x * std::f32::consts::PI, *minor);
            Vec3::new(a.cos(), 0.0, a.sin()) * (1.0 + u.z * minor * 0.5) + Vec3::Y * u.y * minor * 0.5
        }
        Shape::Plane | Shape::Disk | Shape::Csg(_) | Shape::Mesh(_) => unreachable!("not in this test"),
    }
}

fn runner(seed: u8) -> TestRunner {
    TestRunner::new_with_rng(
        Config { cases: 512, ..Config::default() },
        TestRng::from_seed(RngAlgorithm::ChaCha, &[seed; 32]),
    )
}

fn transform() -> impl Strategy<Value = Affine3A> {
    (prop::array::uniform3(0.3f32..3.0), prop::array::uniform3(-3.2f32..3.2), prop::array::uniform3(-5f32..5.0))
        .prop_map(|(s, r, t)| {
            Affine3A::from_scale_rotation_translation(
                Vec3::from(s),
                Quat::from_euler(EulerRot::XYZ, r[0], r[1], r[2]),
                Vec3::from(t),
            )
        })
}

fn unit() -> impl Strategy<Value = Vec3> {
    prop::array::uniform3(-1f32..1.0).prop_filter_map("non-zero", |v| Vec3::from(v).try_normalize())
}

const SHAPES: [Shape; 7] =
    [Shape::Sphere, Shape::Cube, Shape::Plane, Shape::Cylinder, Shape::Cone, Shape::Torus { minor: 0.3 }, Shape::Disk];

#[test]
fn hits_are_on_the_surface_with_unit_outward_normals_and_match_object_space() {
    runner(1)
        .run(&(0usize..SHAPES.len(), transform(), unit(), unit()), |(k, m, aim, dir)| {
            let shape = SHAPES[k].clone();
            let obj = Object::new(shape.clone(), m, 0).unwrap();
            // Aim at a point near the object so most rays hit.
            let target = m.transform_point3(aim * 0.9);
            let origin = target
                - dir * 12.0 * m.matrix3.x_axis.length().max(m.matrix3.y_axis.length()).max(m.matrix3.z_axis.length());
            let Some((t, n)) = obj.intersect(origin, dir, 0.0, f32::INFINITY) else { return Ok(()) };
            let p_world = origin + t * dir;
            let p_obj = m.inverse().transform_point3(p_world);
            prop_assert!(surface_distance(&shape, p_obj) < 1e-3, "{shape:?}: {p_obj} is off the surface");
            prop_assert!((n.length() - 1.0).abs() < 1e-5);
            if let Some(on) = object_normal(&shape, p_obj) {
                let expected = (m.inverse().matrix3.transpose() * on).normalize();
                prop_assert!(n.dot(expected) > 0.999, "{shape:?}: normal {n} vs {expected} at {p_obj}");
            }
            // Same hit when intersecting the object-space ray directly.
            let inv = m.inverse();
            let (t_obj, _) =
                shape.intersect(inv.transform_point3(origin), inv.transform_vector3(dir), 0.0, f32::INFINITY).unwrap();
            prop_assert!((t - t_obj).abs() <= 1e-4 * t.max(1.0));
            Ok(())
        })
        .unwrap();
}

#[test]
fn exits_from_inside_are_on_the_surface_and_ahead() {
    let closed: Vec<Shape> = SHAPES.into_iter().filter(|s| s.is_closed() && *s != Shape::Plane).collect();
    runner(2)
        .run(&(0..closed.len(), transform(), prop::array::uniform3(-1f32..1.0), unit()), |(k, m, u, dir)| {
            let shape = closed[k].clone();
            let obj = Object::new(shape.clone(), m, 0).unwrap();
            let o = m.transform_point3(inside_point(&shape, Vec3::from(u)));
            let (t, n) = obj.exit(o, dir).expect("a closed shape is always left");
            prop_assert!(t > 0.0);
            let p_obj = m.inverse().transform_point3(o + t * dir);
            prop_assert!(surface_distance(&shape, p_obj) < 1e-3, "{shape:?}: exit {p_obj} off the surface");
            prop_assert!(n.dot(dir) > -1e-3, "{shape:?}: the exit normal faces the way out");
            Ok(())
        })
        .unwrap();
}

#[test]
fn a_ray_leaving_a_convex_shape_never_meets_it_again() {
    runner(3)
        .run(&(0usize..SHAPES.len(), transform(), unit(), unit(), unit()), |(k, m, aim, dir, out)| {
            let shape = SHAPES[k].clone();
            if !shape.is_convex() {
                return Ok(());
            }
            let obj = Object::new(shape.clone(), m, 0).unwrap();
            let target = m.transform_point3(aim * 0.9);
            let Some((t, n)) = obj.intersect(target - dir * 50.0, dir, 0.0, f32::INFINITY) else { return Ok(()) };
            let p = target - dir * 50.0 + t * dir;
            // Any direction into the outer half-space, from just off the surface.
            let away = if out.dot(n) > 0.0 { out } else { -out };
            if away.dot(n) < 1e-3 {
                return Ok(());
            }
            let again = obj.intersect(offset_origin(p, n), away, 0.0, f32::INFINITY);
            prop_assert!(again.is_none(), "{shape:?}: re-hit at {again:?}");
            Ok(())
        })
        .unwrap();
}

/// Whether an object-space point is inside a cube-minus-sphere-union-cylinder tree, by point
/// membership (independent of the span arithmetic under test).
fn inside_tree(op: CsgOp, p: Vec3) -> bool {
    let cube = p.abs().max_element() < 1.0;
    let ball = (p / 1.2).length() < 1.0;
    let a = match op {
        CsgOp::Union => cube || ball,
        CsgOp::Intersection => cube && ball,
        CsgOp::Difference => cube && !ball,
    };
    // Union with a cylinder of radius 0.3 along x, from x = -1.5 to 1.5 (rotated 90° about z).
    let cyl = p.y * p.y + p.z * p.z < 0.09 && p.x.abs() < 1.5;
    a || cyl
}

fn tree(op: CsgOp) -> Csg {
    let nodes = vec![
        CsgNode::Leaf { shape: Shape::Cube, node_from_leaf: Affine3A::IDENTITY },
        CsgNode::Leaf { shape: Shape::Sphere, node_from_leaf: Affine3A::from_scale(Vec3::splat(1.2)) },
        CsgNode::Op { op, a: 0, b: 1 },
        CsgNode::Leaf {
            shape: Shape::Cylinder,
            node_from_leaf: Affine3A::from_rotation_z(std::f32::consts::FRAC_PI_2)
                * Affine3A::from_scale(Vec3::new(0.3, 1.5, 0.3)),
        },
        CsgNode::Op { op: CsgOp::Union, a: 2, b: 3 },
    ];
    Csg::new(nodes, 4).unwrap()
}

#[test]
fn csg_hits_are_where_point_membership_changes() {
    for op in [CsgOp::Union, CsgOp::Intersection, CsgOp::Difference] {
        let shape = Shape::Csg(std::sync::Arc::new(tree(op)));
        runner(4)
            .run(&(prop::array::uniform3(-1.3f32..1.3), unit()), |(aim, dir)| {
                let origin = Vec3::from(aim) - dir * 6.0;
                let spans = shape.spans(origin, dir);
                let bounds: Vec<(f32, Vec3)> = spans.iter().flat_map(|s| [(s.t0, s.n0), (s.t1, s.n1)]).collect();
                // The first hit is the first boundary ahead.
                let first = bounds.iter().find(|(t, _)| *t > 0.0).map(|b| b.0);
                prop_assert_eq!(shape.intersect(origin, dir, 0.0, f32::INFINITY).map(|h| h.0), first);
                // Membership flips across every boundary: probe at a third of the gap to its
                // neighbours, so two boundaries close together are not straddled.
                for (k, &(th, n)) in bounds.iter().enumerate() {
                    let prev = if k > 0 { th - bounds[k - 1].0 } else { 1.0 };
                    let next = if k + 1 < bounds.len() { bounds[k + 1].0 - th } else { 1.0 };
                    let eps = (prev.min(next) / 3.0).min(1e-3);
                    if eps < 1e-5 {
                        continue;
                    }
                    let (ib, ia) =
                        (inside_tree(op, origin + (th - eps) * dir), inside_tree(op, origin + (th + eps) * dir));
                    prop_assert!(ib != ia, "{op:?}: no membership change at t = {th}");
                    // Entering (inside after) the outward normal faces the ray.
                    prop_assert!((n.dot(dir) < 0.0) == ia, "{op:?}: normal {n} at t = {th}");
                }
                Ok(())
            })
            .unwrap();
    }
}

#[test]
fn mesh_bvh_gives_the_brute_force_closest_hit() {
    let tri = prop::array::uniform3(prop::array::uniform3(-3f32..3.0));
    runner(5)
        .run(
            &(
                prop::collection::vec(tri, 1..200),
                prop::collection::vec((prop::array::uniform3(-5f32..5.0), unit()), 40),
            ),
            |(tris, rays)| {
                let mut positions = Vec::new();
                let mut triangles = Vec::new();
                for t in &tris {
                    let [a, b, c] = t.map(Vec3::from);
                    if (b - a).cross(c - a).length() < 1e-2 {
                        continue;
                    }
                    let base = positions.len() as u32;
                    positions.extend([a, b, c]);
                    triangles.push([base, base + 1, base + 2]);
                }
                if triangles.is_empty() {
                    return Ok(());
                }
                let mesh = lancer_shapes::Mesh::new(positions, Vec::new(), Vec::new(), triangles).unwrap();
                for (o, d) in rays {
                    let o = Vec3::from(o);
                    let fast = mesh.intersect(o, d, 0.0, f32::INFINITY).map(|h| h.t);
                    prop_assert_eq!(fast, mesh.intersect_brute_force(o, d, 0.0, f32::INFINITY));
                }
                Ok(())
            },
        )
        .unwrap();
}

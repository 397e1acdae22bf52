//! Geometric properties of every shape under random affine transforms (proptest, fixed seed),
//! at scales from 10⁻³ to 10⁴ and positions up to 10⁴, with rays from up to 10⁴ object sizes
//! away: hits lie on the surface within their error bound, normals are unit and outward, exits
//! lie on the surface ahead, and a ray spawned from a hit never meets its own surface there again.

use glam::{Affine3A, EulerRot, Quat, Vec3};
use lancer_shapes::{Csg, CsgNode, CsgOp, Geometry, Object, Origin, Shape};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

/// How far an object-space point is from the shape's surface (0 on it; not always a true
/// distance, but zero exactly on the surface), from the shapes' definitions in docs/scene-format.md.
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

fn runner(seed: u8) -> TestRunner {
    TestRunner::new_with_rng(
        Config { cases: 512, ..Config::default() },
        TestRng::from_seed(RngAlgorithm::ChaCha, &[seed; 32]),
    )
}

/// A placement: an overall size from 10⁻³ to 10⁴ (log-uniform) times an anisotropic 0.3–3,
/// any rotation, and a position up to 10⁴ (at most 2000 sizes from the origin, so the object
/// is still many f32 steps wide where it stands).
fn transform() -> impl Strategy<Value = Affine3A> {
    (
        -3f32..4.0,
        prop::array::uniform3(0.3f32..3.0),
        prop::array::uniform3(-3.2f32..3.2),
        prop::array::uniform3(-1f32..1.0),
        0f32..1.0,
    )
        .prop_map(|(log_size, s, r, dir, far)| {
            let size = 10f32.powf(log_size);
            let reach = (2000.0 * size).min(1e4) * far * far;
            Affine3A::from_scale_rotation_translation(
                Vec3::from(s) * size,
                Quat::from_euler(EulerRot::XYZ, r[0], r[1], r[2]),
                Vec3::from(dir) * reach,
            )
        })
}

fn unit() -> impl Strategy<Value = Vec3> {
    prop::array::uniform3(-1f32..1.0).prop_filter_map("non-zero", |v| Vec3::from(v).try_normalize())
}

const SHAPES: [Shape; 7] =
    [Shape::Sphere, Shape::Cube, Shape::Plane, Shape::Cylinder, Shape::Cone, Shape::Torus { minor: 0.3 }, Shape::Disk];

/// The object's largest axis length.
fn size(m: &Affine3A) -> f32 {
    m.matrix3.x_axis.length().max(m.matrix3.y_axis.length()).max(m.matrix3.z_axis.length())
}

/// The world point `p` in object space, in f64 (so the check adds no error of its own).
fn to_object(m: &Affine3A, p: Vec3) -> Vec3 {
    let m64 = glam::DAffine3::from_cols(
        m.matrix3.x_axis.as_dvec3(),
        m.matrix3.y_axis.as_dvec3(),
        m.matrix3.z_axis.as_dvec3(),
        Vec3::from(m.translation).as_dvec3(),
    );
    m64.inverse().transform_point3(p.as_dvec3()).as_vec3()
}

/// One shape, placed, with a ray from `distance` sizes away aimed near it.
fn placed_ray(k: usize, m: Affine3A, aim: Vec3, dir: Vec3, distance: f32) -> (Geometry, Vec3, Vec3) {
    let g = Geometry::new(vec![Object::new(SHAPES[k].clone(), m, 0).unwrap()]);
    let target = m.transform_point3(aim * 0.9);
    (g, target - dir * distance * size(&m), dir)
}

#[test]
fn hits_are_on_the_surface_within_their_bound_with_unit_outward_normals() {
    runner(1)
        .run(&(0usize..SHAPES.len(), transform(), unit(), unit(), 2f32..1e4), |(k, m, aim, dir, far)| {
            let shape = SHAPES[k].clone();
            let (g, origin, dir) = placed_ray(k, m, aim, dir, far);
            let Some(hit) = g.closest_hit(Origin::free(origin), dir, 0.0, f32::INFINITY) else { return Ok(()) };
            let p_obj = to_object(&m, hit.point);
            // The claimed bound (world units along the normal), in object units, with room for
            // the check's own conversion of the point to f64 and back.
            let min_scale = m.matrix3.x_axis.length().min(m.matrix3.y_axis.length()).min(m.matrix3.z_axis.length());
            // (The check's own rounding: the point to f32 and the distance in f32, a few ulps.)
            let allowed = hit.error / min_scale + 4.0 * f32::EPSILON * (1.0 + p_obj.abs().max_element());
            let off = surface_distance(&shape, p_obj);
            prop_assert!(off <= allowed, "{shape:?}: {p_obj} is {off} off the surface (bound {allowed})");
            prop_assert!((hit.normal.length() - 1.0).abs() < 1e-5);
            if let Some(on) = object_normal(&shape, p_obj) {
                // A tangent of the surface maps to a world tangent: the normal is perpendicular.
                let tangent = m.transform_vector3(on.any_orthonormal_vector()).normalize();
                prop_assert!(hit.normal.dot(tangent).abs() < 2e-3, "{shape:?}: normal {} at {p_obj}", hit.normal);
                // Outward: moving along the normal leaves the solid (or the plane's half-space).
                prop_assert!(m.transform_vector3(on).dot(hit.normal) > 0.0, "{shape:?}: normal {}", hit.normal);
            }
            // A direction twice as long meets the same point at half the distance.
            let twice = g.closest_hit(Origin::free(origin), 2.0 * dir, 0.0, f32::INFINITY).unwrap();
            prop_assert!((twice.t - hit.t / 2.0).abs() <= 1e-4 * hit.t, "{} vs {}", twice.t, hit.t / 2.0);
            Ok(())
        })
        .unwrap();
}

#[test]
fn exits_are_on_the_surface_and_ahead() {
    runner(2)
        .run(&(0usize..SHAPES.len(), transform(), unit(), unit(), 2f32..1e4), |(k, m, aim, dir, far)| {
            let shape = SHAPES[k].clone();
            if !shape.is_closed() || shape == Shape::Plane {
                return Ok(());
            }
            let (g, origin, dir) = placed_ray(k, m, aim, dir, far);
            let Some(hit) = g.closest_hit(Origin::free(origin), dir, 0.0, f32::INFINITY) else { return Ok(()) };
            prop_assert!(hit.front, "{shape:?}: a ray from outside arrives at a front face");
            let exit = g.exit(&hit, dir).expect("a closed shape is always left");
            prop_assert!((exit.point - hit.point).dot(dir) > 0.0, "{shape:?}: the exit is ahead");
            let p_obj = to_object(&m, exit.point);
            let min_scale = m.matrix3.x_axis.length().min(m.matrix3.y_axis.length()).min(m.matrix3.z_axis.length());
            let allowed = exit.error / min_scale + 4.0 * f32::EPSILON * (1.0 + p_obj.abs().max_element());
            prop_assert!(surface_distance(&shape, p_obj) <= allowed, "{shape:?}: exit {p_obj} off the surface");
            prop_assert!(exit.normal.dot(dir) > -1e-3, "{shape:?}: the exit normal faces the way out");
            Ok(())
        })
        .unwrap();
}

#[test]
fn a_spawned_ray_never_meets_its_own_surface_where_it_starts() {
    // Self-intersection acne: from any hit, rays into either half-space must not find the same
    // surface within a sliver of their start (a torus may legitimately be met again further on).
    runner(3)
        .run(&(0usize..SHAPES.len(), transform(), unit(), unit(), unit(), 2f32..1e4), |(k, m, aim, dir, out, far)| {
            let shape = SHAPES[k].clone();
            let (g, origin, dir) = placed_ray(k, m, aim, dir, far);
            let Some(hit) = g.closest_hit(Origin::free(origin), dir, 0.0, f32::INFINITY) else { return Ok(()) };
            // Eight rays leaving the hit at once get the bits each gets alone.
            let leaving = [out, -out, dir, -dir, hit.normal, -hit.normal, aim, Vec3::new(out.x, 0.0, -0.0)];
            let packet = |f: &dyn Fn(usize) -> Vec3| std::array::from_fn(|a| std::array::from_fn(|k| f(k)[a]));
            let (origins, skips) = g.spawn_packet(
                &packet(&|_| hit.point),
                &packet(&|_| hit.normal),
                &[hit.error; 8],
                &[hit.object; 8],
                &packet(&|k| leaving[k]),
            );
            for (k, &towards) in leaving.iter().enumerate() {
                let alone = g.spawn(&hit, towards);
                let lane = Vec3::new(origins[0][k], origins[1][k], origins[2][k]);
                prop_assert_eq!(lane.to_array().map(f32::to_bits), alone.point.to_array().map(f32::to_bits));
                prop_assert_eq!(skips[k], alone.skip);
            }
            for away in [out, -out] {
                if away.dot(hit.normal).abs() < 1e-3 {
                    continue;
                }
                let from = g.spawn(&hit, away);
                let side = if away.dot(hit.normal) > 0.0 { hit.normal } else { -hit.normal };
                if from.skip == 0 {
                    // Ignoring the object is right only for a ray that cannot meet it again, and
                    // it then starts behind the surface (objects touching it are still found).
                    prop_assert!(shape.is_flat() || (shape.is_convex() && away.dot(hit.normal) > 0.0));
                    prop_assert!((from.point - hit.point).dot(side) < 0.0, "{shape:?}: not behind");
                } else {
                    prop_assert!((from.point - hit.point).dot(side) > 0.0, "{shape:?}: not in front");
                }
                if let Some(again) = g.closest_hit(from, away, 0.0, f32::INFINITY) {
                    let travelled = (again.point - hit.point).length();
                    prop_assert!(
                        travelled > 1e-4 * size(&m),
                        "{shape:?}: re-hit its own surface {travelled} from the start (size {})",
                        size(&m)
                    );
                }
                // Into a closed solid the ray meets its far side.
                if away.dot(hit.normal) < 0.0 && shape.is_closed() && shape != Shape::Plane {
                    prop_assert!(g.closest_hit(from, away, 0.0, f32::INFINITY).is_some(), "{shape:?}: no far side");
                }
            }
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
                // The first hit is where a march along the ray first finds the inside (skipping
                // rays whose first piece inside is thinner than the march's step).
                let step = 1e-3;
                let march = (0..12_000).map(|i| i as f32 * step).find(|&t| inside_tree(op, origin + t * dir));
                let thin = spans.iter().any(|s| s.t1 > 0.0 && s.t1 - s.t0.max(0.0) < 2.0 * step);
                if !thin && !inside_tree(op, origin) {
                    let hit = shape.intersect(origin, dir, 0.0, f32::INFINITY).map(|h| h.t);
                    match (hit, march) {
                        (Some(a), Some(b)) => prop_assert!((a - b).abs() <= 2.0 * step, "{op:?}: {a} vs march {b}"),
                        (a, b) => prop_assert_eq!(a.is_some(), b.is_some(), "{:?}: hit {:?} vs march {:?}", op, a, b),
                    }
                }
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

//! Triangle meshes: validated on construction (indices in range, no degenerate or non-finite
//! triangle), a BVH over their triangles, and watertight ray–triangle intersection (Woop, Benthin
//! and Wald 2013), so rays never slip through the shared edge of two triangles.

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use wide::{CmpEq, CmpGt, CmpLt, f32x4};

use crate::{Aabb, Bvh, LocalSurface, ShapeHit};

/// A triangle mesh in object space. Triangles wind counter-clockwise seen from outside.
#[derive(Clone, Debug)]
pub struct Mesh {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    triangles: Vec<[u32; 3]>,
    /// The triangles' corners, in the same (leaf) order, four triangles to a [`Quad`]: the test
    /// takes a leaf's triangles four at a time, one SIMD lane each, with no lookup through
    /// indices (the same 36 bytes a triangle as a list of corners, up to three unused at the end).
    quads: Vec<Quad>,
    bvh: Bvh,
    bounds: Aabb,
    closed: bool,
}

impl PartialEq for Mesh {
    fn eq(&self, other: &Mesh) -> bool {
        self.positions == other.positions && self.triangles == other.triangles && self.normals == other.normals
    }
}

/// Why a mesh cannot be built.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum MeshError {
    /// No triangle at all.
    #[error("the mesh has no triangles")]
    Empty,
    /// A triangle names a vertex that does not exist.
    #[error("triangle {triangle} uses vertex {index}, but there are only {vertices} vertices")]
    IndexOutOfRange {
        /// The triangle (0-based, in file order).
        triangle: usize,
        /// The index it uses.
        index: u32,
        /// How many vertices there are.
        vertices: usize,
    },
    /// A triangle with (nearly) zero area.
    #[error("triangle {0} is degenerate (its corners are on one line)")]
    Degenerate(usize),
    /// A vertex coordinate that is infinite or NaN.
    #[error("vertex {0} has a coordinate that is not a finite number")]
    NonFinite(usize),
    /// Per-vertex normals or texture coordinates whose count does not match the positions.
    #[error("{what}: {got} given for {vertices} vertices")]
    Mismatch {
        /// "normals" or "texture coordinates".
        what: &'static str,
        /// How many were given.
        got: usize,
        /// How many vertices there are.
        vertices: usize,
    },
}

/// Four triangles' corners side by side: `v[corner][axis]`, a lane per triangle.
#[derive(Clone, Debug)]
struct Quad {
    v: [[f32x4; 3]; 3],
}

impl Quad {
    /// The quad of up to four triangles (unused lanes repeat the last one).
    fn of(four: &[[u32; 3]], positions: &[Vec3]) -> Quad {
        let at =
            |lane: usize, corner: usize, axis: usize| positions[four[lane.min(four.len() - 1)][corner] as usize][axis];
        Quad { v: std::array::from_fn(|c| std::array::from_fn(|a| f32x4::new(std::array::from_fn(|l| at(l, c, a))))) }
    }

    /// Lane `lane`'s corners.
    fn corners(&self, lane: usize) -> [Vec3; 3] {
        self.v.map(|[x, y, z]| Vec3::new(x.to_array()[lane], y.to_array()[lane], z.to_array()[lane]))
    }
}

/// The cost of a BVH node visit in triangle tests (see [`Bvh::build_with`]).
const TRIANGLE_STEP: f32 = 0.5;

/// A ray prepared for the watertight test: the axis it runs most along becomes z, and the
/// shear that makes the ray point along z is three dot products per corner.
struct Sheared {
    o: Vec3,
    /// `e_kx − s_x e_kz`, `e_ky − s_y e_kz` and `s_z e_kz`: a corner's sheared coordinates are
    /// its offset from `o` dotted with these (the products with 0 add nothing, so for finite
    /// input each has the value of `p[kx] − s_x p[kz]`, `p[ky] − s_y p[kz]` and `s_z p[kz]`, up
    /// to the sign of a zero).
    rows: [Vec3; 3],
}

impl Sheared {
    #[inline(always)]
    fn new(o: Vec3, d: Vec3) -> Sheared {
        let a = d.abs();
        // The axes as (kx, ky, kz) with z the one the ray runs most along; x and y swapped when
        // it runs down z, so the triangles keep their winding.
        let (x, y, z) = if a.x >= a.y && a.x >= a.z {
            (Vec3::Y, Vec3::Z, Vec3::X)
        } else if a.y >= a.z {
            (Vec3::Z, Vec3::X, Vec3::Y)
        } else {
            (Vec3::X, Vec3::Y, Vec3::Z)
        };
        // Dot products with unit axes: each picks a coordinate exactly.
        let dz = d.dot(z);
        let (x, y) = if dz < 0.0 { (y, x) } else { (x, y) };
        let (sx, sy, sz) = (d.dot(x) / dz, d.dot(y) / dz, 1.0 / dz);
        Sheared { o, rows: [x - sx * z, y - sy * z, sz * z] }
    }

    /// `(t, barycentric weights of v0, v1, v2)` if the ray meets the triangle with tmin < t < tmax.
    ///
    /// The three corners go through the shear side by side (one SIMD lane each); every lane's
    /// sums are made in the same order as a scalar dot product's, so the answer is the same to
    /// the bit.
    #[inline]
    fn hit(&self, v: &[Vec3; 3], tmin: f32, tmax: f32) -> Option<(f32, Vec3)> {
        let [rx, ry, rz] = self.rows;
        let lanes = |k: usize| f32x4::new([v[0][k] - self.o[k], v[1][k] - self.o[k], v[2][k] - self.o[k], 0.0]);
        let (px, py, pz) = (lanes(0), lanes(1), lanes(2));
        let along = |r: Vec3| px * f32x4::splat(r.x) + py * f32x4::splat(r.y) + pz * f32x4::splat(r.z);
        let (xs, ys) = (along(rx), along(ry));
        // e_i = x_{i+2} y_{i+1} − y_{i+2} x_{i+1}: the corners' lanes turned by one and by two.
        let [x0, x1, x2, _] = xs.to_array();
        let [y0, y1, y2, _] = ys.to_array();
        let (x_next, x_after) = (f32x4::new([x1, x2, x0, 0.0]), f32x4::new([x2, x0, x1, 0.0]));
        let (y_next, y_after) = (f32x4::new([y1, y2, y0, 0.0]), f32x4::new([y2, y0, y1, 0.0]));
        let [ex, ey, ez, _] = (x_after * y_next - y_after * x_next).to_array();
        let z = || {
            let [z0, z1, z2, _] = along(rz).to_array();
            Vec3::new(z0, z1, z2)
        };
        resolve([(x0, y0), (x1, y1), (x2, y2)], Vec3::new(ex, ey, ez), z, tmin, tmax)
    }
}

impl Sheared {
    /// The nearest crossing with `tmin < t < tmax` of the ray with the triangles of `quad` in
    /// the lanes `live` (bit `l` for lane `l`): `(lane, t, barycentric weights)`, the earliest lane
    /// on a tie. Each lane gets the bits [`Sheared::hit`] gives its triangle: the same sums in the
    /// same order, a triangle to a lane instead of a corner to a lane.
    #[inline]
    fn hit4(&self, quad: &Quad, live: u32, tmin: f32, mut tmax: f32) -> Option<(usize, f32, Vec3)> {
        let [rx, ry, rz] = self.rows;
        let o = [f32x4::splat(self.o.x), f32x4::splat(self.o.y), f32x4::splat(self.o.z)];
        let rel = quad.v.map(|p| [p[0] - o[0], p[1] - o[1], p[2] - o[2]]);
        let along =
            |p: &[f32x4; 3], r: Vec3| p[0] * f32x4::splat(r.x) + p[1] * f32x4::splat(r.y) + p[2] * f32x4::splat(r.z);
        let x = rel.each_ref().map(|p| along(p, rx));
        let y = rel.each_ref().map(|p| along(p, ry));
        // e_i = x_{i+2} y_{i+1} − y_{i+2} x_{i+1}.
        let e = [x[2] * y[1] - y[2] * x[1], x[0] * y[2] - y[0] * x[2], x[1] * y[0] - y[1] * x[0]];
        let zero = f32x4::ZERO;
        let on_edge = e[0].cmp_eq(zero) | e[1].cmp_eq(zero) | e[2].cmp_eq(zero);
        let outside = (e[0].cmp_lt(zero) | e[1].cmp_lt(zero) | e[2].cmp_lt(zero))
            & (e[0].cmp_gt(zero) | e[1].cmp_gt(zero) | e[2].cmp_gt(zero));
        // The lanes the edges do not rule out (an edge at exactly 0 is decided in `resolve`).
        let mut open = live & (on_edge | !outside).move_mask() as u32;
        if open == 0 {
            return None;
        }
        let z = rel.each_ref().map(|p| along(p, rz).to_array());
        let (x, y, e) = (x.map(|v| v.to_array()), y.map(|v| v.to_array()), e.map(|v| v.to_array()));
        let mut best = None;
        while open != 0 {
            let l = open.trailing_zeros() as usize;
            open &= open - 1;
            let xy = [(x[0][l], y[0][l]), (x[1][l], y[1][l]), (x[2][l], y[2][l])];
            let z = || Vec3::new(z[0][l], z[1][l], z[2][l]);
            if let Some((t, w)) = resolve(xy, Vec3::new(e[0][l], e[1][l], e[2][l]), z, tmin, tmax) {
                best = Some((l, t, w));
                tmax = t;
            }
        }
        best
    }
}

/// The lanes of the quads that hold the positions `first..first + count` of the leaf order, a
/// quad at a time: `(quad, lanes)`.
#[inline]
fn quads_of(first: u32, count: u32) -> impl Iterator<Item = (usize, u32)> {
    let (start, end) = (first as usize, (first + count) as usize);
    (start / 4..end.div_ceil(4)).map(move |q| {
        let (lo, hi) = (start.max(4 * q) - 4 * q, end.min(4 * q + 4) - 4 * q);
        (q, ((1u32 << hi) - 1) & !((1u32 << lo) - 1))
    })
}

/// The end of the watertight test, from the corners' sheared `(x, y)`, their edge functions `e`
/// and their sheared `z` (asked for only once the ray is known to cross the triangle's edges).
#[inline(always)]
fn resolve(xy: [(f32, f32); 3], mut e: Vec3, z: impl FnOnce() -> Vec3, tmin: f32, tmax: f32) -> Option<(f32, Vec3)> {
    if e.x == 0.0 || e.y == 0.0 || e.z == 0.0 {
        // On an edge in f32: decide it in f64 so neighbouring triangles agree.
        let [(ax, ay), (bx, by), (cx, cy)] = xy.map(|(x, y)| (x as f64, y as f64));
        e = Vec3::new((cx * by - cy * bx) as f32, (ax * cy - ay * cx) as f32, (bx * ay - by * ax) as f32);
    }
    if (e.x < 0.0 || e.y < 0.0 || e.z < 0.0) && (e.x > 0.0 || e.y > 0.0 || e.z > 0.0) {
        return None;
    }
    let det = e.x + e.y + e.z;
    if det == 0.0 {
        return None;
    }
    let t = e.dot(z()) / det;
    (t > tmin && t < tmax).then(|| (t, e / det))
}

/// Whether the triangle `a b c` has (nearly) no area: its corners on one line, to single
/// precision. [`Mesh::new`] refuses such triangles; [`Mesh::skipping_degenerate`] leaves them out.
fn degenerate(a: Vec3, b: Vec3, c: Vec3) -> bool {
    let area2 = (b - a).cross(c - a).length();
    let scale = (b - a).length().max((c - a).length()).max((c - b).length());
    area2.is_nan() || area2 <= 1e-7 * scale * scale
}

impl Mesh {
    /// A mesh from vertex positions, optional per-vertex normals and texture coordinates (empty
    /// for none), and triangles as vertex indices. A triangle with no area is an error.
    pub fn new(
        positions: Vec<Vec3>,
        normals: Vec<Vec3>,
        uvs: Vec<Vec2>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<Mesh, MeshError> {
        Mesh::build(positions, normals, uvs, triangles, false).map(|(mesh, _)| mesh)
    }

    /// As [`Mesh::new`], leaving out the triangles with no area (as renderers do with real
    /// files) and saying how many: `Err(MeshError::Empty)` when none is left.
    pub fn skipping_degenerate(
        positions: Vec<Vec3>,
        normals: Vec<Vec3>,
        uvs: Vec<Vec2>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<(Mesh, usize), MeshError> {
        Mesh::build(positions, normals, uvs, triangles, true)
    }

    /// Checks the arrays in one pass (degenerate triangles refused, or with `skip` left out and
    /// counted), then orients, builds the BVH and lays the triangles out in its leaf order.
    fn build(
        positions: Vec<Vec3>,
        normals: Vec<Vec3>,
        uvs: Vec<Vec2>,
        mut triangles: Vec<[u32; 3]>,
        skip: bool,
    ) -> Result<(Mesh, usize), MeshError> {
        let n = positions.len();
        for (what, got) in [("normals", normals.len()), ("texture coordinates", uvs.len())] {
            if got != 0 && got != n {
                return Err(MeshError::Mismatch { what, got, vertices: n });
            }
        }
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(MeshError::NonFinite(i));
        }
        let before = triangles.len();
        let mut problem = None;
        let mut k = 0;
        triangles.retain(|tri| {
            let at = k;
            k += 1;
            if problem.is_some() {
                return true;
            }
            if let Some(&index) = tri.iter().find(|&&i| i as usize >= n) {
                problem = Some(MeshError::IndexOutOfRange { triangle: at, index, vertices: n });
                return true;
            }
            let [a, b, c] = tri.map(|i| positions[i as usize]);
            if !degenerate(a, b, c) {
                return true;
            }
            if !skip {
                problem = Some(MeshError::Degenerate(at));
            }
            !skip
        });
        if let Some(e) = problem {
            return Err(e);
        }
        if triangles.is_empty() {
            return Err(MeshError::Empty);
        }
        let skipped = before - triangles.len();
        // Windings first: their tables and the triangle boxes are not in memory at once.
        let closed = crate::topology::orient(&positions, &mut triangles);
        let triangle_box = |t: &[u32; 3]| {
            t.iter().fold(Aabb::EMPTY, |b, &i| b.union(Aabb { min: positions[i as usize], max: positions[i as usize] }))
        };
        let mut bvh = Bvh::build_with(triangles.len(), |k| triangle_box(&triangles[k]), TRIANGLE_STEP);
        let bounds = bvh.bounds();
        // Triangles in the order the BVH's leaves visit them: no lookup per triangle.
        let order = bvh.into_leaf_order();
        let sorted: Vec<[u32; 3]> = order.par_iter().map(|&i| triangles[i as usize]).collect();
        // The file-order list goes before the corners are made: a million triangles' peak
        // holds one list of indices, not two.
        drop((order, triangles));
        let quads = sorted.par_chunks(4).map(|four| Quad::of(four, &positions)).collect();
        let triangles = sorted;
        Ok((Mesh { bvh, positions, normals, uvs, triangles, quads, bounds, closed }, skipped))
    }

    /// Triangle `triangle`'s corners (in leaf order, as [`Mesh::triangles`]).
    fn corners(&self, triangle: u32) -> [Vec3; 3] {
        self.quads[triangle as usize / 4].corners(triangle as usize % 4)
    }

    /// Vertex positions.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Per-vertex normals (empty for a flat mesh).
    pub fn normals(&self) -> &[Vec3] {
        &self.normals
    }

    /// Per-vertex texture coordinates (empty when the file has none).
    pub fn uvs(&self) -> &[Vec2] {
        &self.uvs
    }

    /// Triangles as vertex indices (in the BVH's leaf order, each wound outward on a closed mesh).
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Whether every edge is shared by exactly two triangles, so the mesh encloses a volume.
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// Object-space bounds.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Whether the file gave per-vertex normals (smooth shading).
    pub fn is_smooth(&self) -> bool {
        !self.normals.is_empty()
    }

    /// The first triangle the ray `o + t d` meets with `tmin < t < tmax`: the crossing names the
    /// triangle and carries its barycentric weights (see [`Mesh::surface`]).
    pub fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<ShapeHit> {
        let ray = Sheared::new(o, d);
        let mut best: Option<(u32, f32, Vec3)> = None;
        self.bvh.traverse_leaves_from(o, d, tmin, tmax, |first, count, mut tmax| {
            for (q, lanes) in quads_of(first, count) {
                if let Some((l, t, w)) = ray.hit4(&self.quads[q], lanes, tmin, tmax) {
                    best = Some(((4 * q + l) as u32, t, w));
                    tmax = t;
                }
            }
            tmax
        });
        let (part, t, w) = best?;
        Some(ShapeHit { t, normal: Vec3::ZERO, part, bary: Vec2::new(w.y, w.z) })
    }

    /// The surface of triangle `triangle` at barycentric weights `bary` (of its second and third
    /// corners): the point interpolated from the corners, so it lies in the triangle's plane
    /// whatever the ray's length; the geometric normal; the shading normal interpolated from the
    /// vertex normals when the mesh has them (turned to the geometric normal's side); texture
    /// coordinates.
    pub fn surface(&self, triangle: u32, bary: Vec2) -> LocalSurface {
        let idx = self.triangles[triangle as usize];
        let w = [1.0 - bary.x - bary.y, bary.x, bary.y];
        let [a, b, c] = self.corners(triangle);
        let point = w[0] * a + w[1] * b + w[2] * c;
        // Each coordinate is a sum of three products: γ₅ of the sum of their magnitudes.
        let sum = (w[0] * a).abs() + (w[1] * b).abs() + (w[2] * c).abs();
        let error = (5.0 * f32::EPSILON * sum.max_element()) as f64;
        let normal = (b - a).cross(c - a).normalize_or(Vec3::Y);
        let shading = if self.normals.is_empty() {
            normal
        } else {
            let n = idx.map(|v| self.normals[v as usize]);
            let s = (w[0] * n[0] + w[1] * n[1] + w[2] * n[2]).normalize_or(normal);
            if s.dot(normal) < 0.0 { -s } else { s }
        };
        let uv = if self.uvs.is_empty() {
            Vec2::ZERO
        } else {
            let u = idx.map(|v| self.uvs[v as usize]);
            w[0] * u[0] + w[1] * u[1] + w[2] * u[2]
        };
        LocalSurface { point, exact: point.as_dvec3(), error, normal, shading, uv }
    }

    /// Whether any triangle lies on the ray `o + t d` with `0 < t < tmax` (stops at the first).
    pub fn occludes(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        let ray = Sheared::new(o, d);
        let mut found = false;
        self.bvh.traverse_leaves_from(o, d, 0.0, tmax, |first, count, tmax| {
            if found || quads_of(first, count).any(|(q, lanes)| ray.hit4(&self.quads[q], lanes, 0.0, tmax).is_some()) {
                found = true;
                // A negative bound rejects every remaining box: the traversal winds down.
                return -1.0;
            }
            tmax
        });
        found
    }

    /// The first hit by testing every triangle, for checking the BVH.
    pub fn intersect_brute_force(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<f32> {
        let ray = Sheared::new(o, d);
        let mut best = None;
        let mut tmax = tmax;
        for t in (0..self.triangles.len() as u32).map(|i| self.corners(i)) {
            if let Some((th, _)) = ray.hit(&t, tmin, tmax) {
                best = Some(th);
                tmax = th;
            }
        }
        best
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The unit octahedron's 8 triangles wound outward (vertices ±x, ±y, ±z in that order).
    const OUTWARD: [[u32; 3]; 8] =
        [[0, 2, 4], [4, 2, 1], [1, 2, 5], [5, 2, 0], [4, 3, 0], [1, 3, 4], [5, 3, 1], [0, 3, 5]];

    /// A unit octahedron with the triangles `t`.
    fn octahedron_of(t: Vec<[u32; 3]>) -> Mesh {
        let p = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        Mesh::new(p, Vec::new(), Vec::new(), t).unwrap()
    }

    /// A unit octahedron: 6 vertices, 8 triangles wound outward.
    pub(crate) fn octahedron() -> Mesh {
        octahedron_of(OUTWARD.to_vec())
    }

    /// The triangle test's shear and edge functions with scalar dot products, as they were
    /// written before the corners went into SIMD lanes: the reference the lanes must match to
    /// the bit.
    fn hit_by_dots(ray: &Sheared, v: &[Vec3; 3], tmin: f32, tmax: f32) -> Option<(f32, Vec3)> {
        let [rx, ry, rz] = ray.rows;
        let rel = v.map(|p| p - ray.o);
        let xy = rel.map(|p| (p.dot(rx), p.dot(ry)));
        let [(ax, ay), (bx, by), (cx, cy)] = xy;
        let e = Vec3::new(cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax);
        resolve(xy, e, || Vec3::new(rel[0].dot(rz), rel[1].dot(rz), rel[2].dot(rz)), tmin, tmax)
    }

    #[test]
    fn four_triangles_at_once_give_the_answer_of_each_in_turn_to_the_bit() {
        // Quads of random triangles, some with two sharing an edge and one repeated (a tie),
        // some on a half-unit grid met by a ray along an axis through grid points (an edge
        // function exactly 0: the f64 path), and the ray aimed at one of them; every set of live
        // lanes, under three pairs of bounds, against the triangles tested one after another
        // with the nearest hit so far as the limit.
        let mut f = crate::testing::uniform(0x9E37_79B9_7F4A_7C15);
        let (mut hits, mut ties, mut on_edge) = (0, 0, 0);
        // (`ties`: lanes 0 and 3 both live and the same triangle hit: lane 0 must win.)
        for k in 0..6_000 {
            let grid = k % 4 == 3;
            let mut g = |lo: f32, hi: f32| if grid { (f(lo, hi) * 2.0).round() * 0.5 } else { f(lo, hi) };
            let mut tris: [[Vec3; 3]; 4] =
                [(); 4].map(|_| [(); 3].map(|_| Vec3::new(g(-2.0, 2.0), g(-2.0, 2.0), g(-2.0, 2.0))));
            if k % 3 == 0 {
                // Lanes 1 and 2 share an edge; lane 3 is lane 0 again (a tie).
                tris[2] = [tris[1][1], tris[1][0], tris[2][2]];
                tris[3] = tris[0];
            }
            let positions: Vec<Vec3> = tris.iter().flatten().copied().collect();
            let indices: Vec<[u32; 3]> = (0..4).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
            let quad = Quad::of(&indices, &positions);
            let ray = if grid {
                // Along an axis from a point of the grid (a corner, the middle of an edge).
                let o = Vec3::new(g(-2.0, 2.0), g(-2.0, 2.0), g(-2.0, 2.0));
                let axis = [Vec3::X, -Vec3::Y, Vec3::Z, -Vec3::Z][(k / 4) % 4];
                Sheared::new(o - 5.0 * axis, axis)
            } else {
                let o = Vec3::new(f(-5.0, 5.0), f(-5.0, 5.0), f(-5.0, 5.0));
                let aim = &tris[k % 4];
                let target = match k % 5 {
                    0 | 3 => aim[0] + (aim[1] - aim[0]) * f(0.0, 1.0),
                    // At a corner: edge functions of products that round to the same f32.
                    1 => aim[k % 3],
                    _ => aim[0] * f(0.1, 0.4) + aim[1] * f(0.1, 0.4) + aim[2] * f(0.1, 0.4),
                };
                Sheared::new(o, target - o)
            };
            // Open bounds, a far bound at one lane's own distance (its hit is then not taken), a
            // near bound past it.
            let first = (0..4).find_map(|l| ray.hit(&tris[l], 0.0, f32::INFINITY)).map_or(1.0, |(t, _)| t);
            for (tmin, tmax) in [(0.0, f32::INFINITY), (0.0, first), (first * 0.999, f32::INFINITY)] {
                for live in 1..16u32 {
                    let mut want = None;
                    let mut limit = tmax;
                    for l in (0..4).filter(|l| live >> l & 1 == 1) {
                        assert_eq!(quad.corners(l), tris[l]);
                        if let Some((t, w)) = ray.hit(&tris[l], tmin, limit) {
                            on_edge += usize::from(w.to_array().contains(&0.0));
                            want = Some((l, t, w));
                            limit = t;
                        }
                    }
                    let bits =
                        |h: Option<(usize, f32, Vec3)>| h.map(|(l, t, w)| (l, [t, w.x, w.y, w.z].map(f32::to_bits)));
                    let got = ray.hit4(&quad, live, tmin, tmax);
                    assert_eq!(bits(got), bits(want), "case {k}, lanes {live:04b}, bounds {tmin}..{tmax}");
                    hits += usize::from(want.is_some());
                    ties += usize::from(k % 3 == 0 && live & 0b1001 == 0b1001 && want.is_some_and(|(l, ..)| l == 0));
                }
            }
        }
        assert!(hits > 40_000, "the cases hit often enough to test something ({hits})");
        assert!(ties > 500, "ties between lanes come up ({ties})");
        assert!(on_edge > 500, "rays on an edge (a weight of exactly 0) come up ({on_edge})");
    }

    #[test]
    fn the_quads_of_a_leaf_cover_its_positions_once() {
        for first in 0..12u32 {
            for count in 1..14u32 {
                let covered: Vec<u32> = quads_of(first, count)
                    .flat_map(|(q, lanes)| (0..4).filter(move |l| lanes >> l & 1 == 1).map(move |l| 4 * q as u32 + l))
                    .collect();
                assert_eq!(covered, (first..first + count).collect::<Vec<_>>());
            }
        }
    }

    #[test]
    fn the_lanes_triangle_test_gives_the_scalar_answer_to_the_bit() {
        // Random triangles and rays, rays aimed at a corner or along an edge (the f64 path),
        // axis-aligned rays (a zero shear) and rays running down an axis (swapped x and y).
        let mut f = crate::testing::uniform(0x2545_F491_4F6C_DD1D);
        let bits = |h: Option<(f32, Vec3)>| h.map(|(t, w)| [t.to_bits(), w.x.to_bits(), w.y.to_bits(), w.z.to_bits()]);
        let mut hits = 0;
        for k in 0..20_000 {
            let mut v = [(); 3].map(|_| Vec3::new(f(-2.0, 2.0), f(-2.0, 2.0), f(-2.0, 2.0)));
            if k % 5 == 0 {
                v[2] = v[0] + (v[1] - v[0]) * 0.5 + Vec3::new(0.0, f(0.1, 1.0), 0.0);
            }
            let o = Vec3::new(f(-5.0, 5.0), f(-5.0, 5.0), f(-5.0, 5.0));
            let target = match k % 4 {
                0 => v[k % 3],
                1 => v[0] + (v[1] - v[0]) * f(0.0, 1.0),
                _ => v[0] * f(0.0, 0.5) + v[1] * f(0.0, 0.5) + v[2] * f(0.0, 0.5),
            };
            let mut d = target - o;
            if k % 7 == 0 {
                d = [Vec3::X, -Vec3::Y, Vec3::Z, -Vec3::Z][k % 4];
            }
            let ray = Sheared::new(o, d);
            let lanes = ray.hit(&v, 0.0, f32::INFINITY);
            assert_eq!(
                bits(lanes),
                bits(hit_by_dots(&ray, &v, 0.0, f32::INFINITY)),
                "case {k}: {v:?} from {o} along {d}"
            );
            hits += usize::from(lanes.is_some());
        }
        assert!(hits > 5_000, "the cases hit often enough to test something ({hits})");
    }

    #[test]
    fn octahedron_is_closed_and_hit_with_outward_normals() {
        let m = octahedron();
        assert!(m.is_closed());
        let h = m.intersect(Vec3::new(0.1, 0.1, -5.0), Vec3::Z, 0.0, f32::INFINITY).unwrap();
        assert!((h.t - 4.2).abs() < 1e-5, "{}", h.t);
        let s = m.surface(h.part, h.bary);
        assert!((s.point - Vec3::new(0.1, 0.1, -0.8)).length() < 1e-6, "{}", s.point);
        assert!((s.normal - Vec3::new(1.0, 1.0, -1.0).normalize()).length() < 1e-5);
        // Through a vertex and along shared edges: never slips through.
        for o in [Vec3::new(0.0, 0.0, -5.0), Vec3::new(0.3, 0.0, -5.0), Vec3::new(0.0, -0.4, -5.0)] {
            assert!(m.intersect(o, Vec3::Z, 0.0, f32::INFINITY).is_some(), "{o}");
        }
    }

    #[test]
    fn a_mesh_built_on_several_threads_gives_the_brute_force_hits() {
        // A rippled grid of 2 · 129 · 129 triangles: more than the build splits on two threads,
        // so subtrees are built at once in regions of the node array, then moved together; not a
        // multiple of four, so the last quad is partly filled.
        let n = 129;
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, z) = (i as f32 / n as f32 * 4.0 - 2.0, j as f32 / n as f32 * 4.0 - 2.0);
                positions.push(Vec3::new(x, 0.2 * (3.0 * x).sin() * (2.0 * z).cos(), z));
            }
        }
        let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let mut triangles = Vec::new();
        for j in 0..n {
            for i in 0..n {
                triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        let m = Mesh::new(positions, Vec::new(), Vec::new(), triangles).unwrap();
        assert_ne!(m.triangle_count() % 4, 0);
        for k in 0..256 {
            let f = k as f32 / 256.0;
            let o = Vec3::new(-2.5 + 5.0 * f, 3.0, -2.5 + 3.0 * (f * 7.0).fract());
            let d = (Vec3::new(2.0 * (f * 3.0).fract() - 1.0, -1.5, 0.7) - 0.3 * Vec3::X).normalize();
            let fast = m.intersect(o, d, 0.0, f32::INFINITY).map(|h| h.t);
            assert_eq!(fast, m.intersect_brute_force(o, d, 0.0, f32::INFINITY), "ray {k}");
            assert_eq!(fast.is_some(), m.occludes(o, d, f32::INFINITY), "ray {k}");
        }
    }

    #[test]
    fn degenerate_triangles_are_refused_or_skipped_and_counted() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, 2.0 * Vec3::X];
        let t = vec![[0, 1, 2], [0, 1, 3]];
        assert_eq!(Mesh::new(p.clone(), vec![], vec![], t.clone()).unwrap_err(), MeshError::Degenerate(1));
        let (m, skipped) = Mesh::skipping_degenerate(p.clone(), vec![], vec![], t).unwrap();
        assert_eq!((m.triangle_count(), skipped), (1, 1));
        assert_eq!(m.bounds(), Aabb { min: Vec3::ZERO, max: Vec3::new(1.0, 1.0, 0.0) });
        let flat = Mesh::skipping_degenerate(p.clone(), vec![], vec![], vec![[0, 1, 3]]);
        assert_eq!(flat.unwrap_err(), MeshError::Empty);
        let out = Mesh::skipping_degenerate(p, vec![], vec![], vec![[0, 1, 3], [0, 1, 9]]);
        assert_eq!(out.unwrap_err(), MeshError::IndexOutOfRange { triangle: 1, index: 9, vertices: 4 });
    }

    #[test]
    fn bad_meshes_are_refused() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        assert_eq!(Mesh::new(p.clone(), vec![], vec![], vec![]).unwrap_err(), MeshError::Empty);
        assert_eq!(
            Mesh::new(p.clone(), vec![], vec![], vec![[0, 1, 3]]).unwrap_err(),
            MeshError::IndexOutOfRange { triangle: 0, index: 3, vertices: 3 }
        );
        let line = vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        assert_eq!(Mesh::new(line, vec![], vec![], vec![[0, 1, 2]]).unwrap_err(), MeshError::Degenerate(0));
        assert!(!Mesh::new(p, vec![], vec![], vec![[0, 1, 2]]).unwrap().is_closed(), "one triangle is open");
    }

    #[test]
    fn regression_a_triangle_wound_against_its_neighbours_is_turned_round() {
        // One triangle of this octahedron is wound the other way: its edges run the same way as
        // its neighbours'. Before the fix only edge counts were checked, and that triangle's
        // normal pointed inside. Now the winding is made consistent, so the mesh is closed and
        // its normals all point out.
        let mut t = OUTWARD.to_vec();
        t[0].swap(1, 2);
        let m = octahedron_of(t);
        assert!(m.is_closed());
        // The turned-round triangle (0, 4, 2) faces +x +y +z: hit it from outside there.
        let d = -Vec3::ONE.normalize();
        let h = m.intersect(Vec3::splat(0.3) - 5.0 * d, d, 0.0, f32::INFINITY).unwrap();
        assert!(m.surface(h.part, h.bary).normal.dot(d) < 0.0, "the normal faces the ray from outside");
    }

    #[test]
    fn two_triangles_sharing_an_edge_the_same_way_are_an_open_sheet() {
        // A square of two triangles, the second wound against the first: oriented, still open.
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let m = Mesh::new(p, Vec::new(), Vec::new(), vec![[0, 1, 2], [0, 3, 2]]).unwrap();
        assert!(!m.is_closed());
        let n = |x: f32, y: f32| {
            let h = m.intersect(Vec3::new(x, y, -1.0), Vec3::Z, 0.0, f32::INFINITY).unwrap();
            m.surface(h.part, h.bary).normal
        };
        assert_eq!(n(0.7, 0.2), n(0.2, 0.7), "both halves face the same way");
    }

    #[test]
    fn a_closed_mesh_wound_inside_out_gets_outward_normals() {
        let m = octahedron_of(OUTWARD.iter().map(|&[a, b, c]| [a, c, b]).collect());
        assert!(m.is_closed());
        let h = m.intersect(Vec3::new(0.1, 0.1, -5.0), Vec3::Z, 0.0, f32::INFINITY).unwrap();
        assert!(m.surface(h.part, h.bary).normal.z < 0.0, "the normal faces the ray coming from outside");
    }
}

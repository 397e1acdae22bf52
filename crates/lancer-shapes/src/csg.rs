//! Constructive solid geometry: a tree of union, intersection and difference over transformed
//! shapes. Every leaf gives the intervals of the ray that lie inside it; the tree combines them,
//! so the first boundary is the hit and the inside/outside of the result is exact (a CSG lens
//! refracts like any solid).

use glam::{Affine3A, Mat3A, Vec3};

use crate::{Aabb, Shape};

/// How two solids combine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CsgOp {
    /// Inside either.
    Union,
    /// Inside both.
    Intersection,
    /// Inside the first and not the second.
    Difference,
}

impl CsgOp {
    /// Every operation's name as scene files spell it.
    pub const NAMES: &'static [&'static str] = &["union", "intersection", "difference"];

    /// The operation called `name`.
    pub fn from_name(name: &str) -> Option<CsgOp> {
        match name {
            "union" => Some(CsgOp::Union),
            "intersection" => Some(CsgOp::Intersection),
            "difference" => Some(CsgOp::Difference),
            _ => None,
        }
    }
}

/// A node of a CSG tree.
#[derive(Clone, Debug, PartialEq)]
pub enum CsgNode {
    /// A shape placed in the tree's space by its own transform.
    Leaf {
        /// The shape (a closed one, or a plane as a half-space).
        shape: Shape,
        /// Leaf space to the tree's space.
        node_from_leaf: Affine3A,
    },
    /// Two sub-trees (indices into the tree's nodes) combined.
    Op {
        /// The operation.
        op: CsgOp,
        /// The first operand.
        a: u32,
        /// The second operand.
        b: u32,
    },
}

/// Part of the ray inside a solid: from `t0` (entering, normal `n0`) to `t1` (leaving, `n1`),
/// normals outward of that solid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Span {
    /// Where the ray enters.
    pub t0: f32,
    /// The outward normal there.
    pub n0: Vec3,
    /// Where it leaves.
    pub t1: f32,
    /// The outward normal there.
    pub n1: Vec3,
    /// Which part of the shape the entry belongs to (a CSG tree's leaf node; 0 for a plain shape).
    pub part0: u32,
    /// Which part of the shape the exit belongs to.
    pub part1: u32,
}

/// A CSG tree ready for queries: nodes with their inverse transforms precomputed.
#[derive(Clone, Debug, PartialEq)]
pub struct Csg {
    nodes: Vec<CsgNode>,
    /// Per node: tree space to leaf space and the normal matrix back (leaves only).
    inverse: Vec<Option<(Affine3A, Mat3A)>>,
    root: u32,
}

impl Csg {
    /// The nodes, operands before the nodes that use them.
    pub fn nodes(&self) -> &[CsgNode] {
        &self.nodes
    }

    /// The root node's index.
    pub fn root(&self) -> u32 {
        self.root
    }

    /// A tree from its nodes (operands before the nodes that use them) and its root. `None` if a
    /// leaf's transform is singular or an index is out of range.
    pub fn new(nodes: Vec<CsgNode>, root: u32) -> Option<Csg> {
        let mut inverse = Vec::with_capacity(nodes.len());
        for (i, n) in nodes.iter().enumerate() {
            inverse.push(match n {
                CsgNode::Leaf { node_from_leaf, .. } => {
                    let leaf_from_node = crate::invertible(node_from_leaf)?;
                    Some((leaf_from_node, leaf_from_node.matrix3.transpose()))
                }
                CsgNode::Op { a, b, .. } => {
                    if *a as usize >= i || *b as usize >= i {
                        return None;
                    }
                    None
                }
            });
        }
        ((root as usize) < nodes.len()).then_some(Csg { nodes, inverse, root })
    }

    /// Bounds in the tree's space; `None` when unbounded (a plane that nothing clips).
    pub fn bounds(&self) -> Option<Aabb> {
        self.node_bounds(self.root)
    }

    fn node_bounds(&self, i: u32) -> Option<Aabb> {
        match &self.nodes[i as usize] {
            CsgNode::Leaf { shape, node_from_leaf } => shape.bounds().map(|b| b.transformed(node_from_leaf)),
            CsgNode::Op { op, a, b } => {
                let (ba, bb) = (self.node_bounds(*a), self.node_bounds(*b));
                match op {
                    CsgOp::Union => Some(ba?.union(bb?)),
                    CsgOp::Intersection => match (ba, bb) {
                        (Some(x), Some(y)) => Some(Aabb { min: x.min.max(y.min), max: x.max.min(y.max) }),
                        (x, y) => x.or(y),
                    },
                    CsgOp::Difference => ba,
                }
            }
        }
    }

    /// The spans of the ray `o + t d` inside the solid, sorted and disjoint.
    pub fn spans(&self, o: Vec3, d: Vec3) -> Vec<Span> {
        self.node_spans(self.root, o, d)
    }

    fn node_spans(&self, i: u32, o: Vec3, d: Vec3) -> Vec<Span> {
        match &self.nodes[i as usize] {
            CsgNode::Leaf { shape, .. } => {
                let (leaf_from_node, normal_back) = self.inverse[i as usize].expect("leaves have inverses");
                let (lo, ld) = (leaf_from_node.transform_point3(o), leaf_from_node.transform_vector3(d));
                let back = |n: Vec3| (normal_back * n).normalize_or(Vec3::Y);
                shape
                    .spans(lo, ld)
                    .into_iter()
                    .map(|s| Span { t0: s.t0, n0: back(s.n0), t1: s.t1, n1: back(s.n1), part0: i, part1: i })
                    .collect()
            }
            CsgNode::Op { op, a, b } => {
                let (sa, sb) = (self.node_spans(*a, o, d), self.node_spans(*b, o, d));
                combine(*op, &sa, &sb)
            }
        }
    }
}

impl Csg {
    /// The surface at a crossing of the tree found on the ray `o + t d` (tree space): the leaf
    /// that owns the boundary refines the point in its own space (see [`Shape::surface`]), and
    /// the normal stays the tree's (turned round where a difference removed the leaf).
    pub(crate) fn surface(&self, o: Vec3, d: Vec3, hit: &crate::ShapeHit) -> crate::LocalSurface {
        let leaf = hit.part as usize;
        let (CsgNode::Leaf { shape, node_from_leaf }, Some((leaf_from_node, _))) =
            (&self.nodes[leaf], self.inverse[leaf])
        else {
            unreachable!("CSG crossings name their leaf");
        };
        let (lo, ld) = (leaf_from_node.transform_point3(o), leaf_from_node.transform_vector3(d));
        // The leaf's own crossing nearest to `t` (the same computation that produced it).
        let own = shape
            .spans(lo, ld)
            .iter()
            .flat_map(|s| [(s.t0, s.n0), (s.t1, s.n1)])
            .filter(|(t, _)| t.is_finite())
            .min_by(|a, b| (a.0 - hit.t).abs().total_cmp(&(b.0 - hit.t).abs()))
            .map_or(*hit, |(t, normal)| crate::ShapeHit { t, normal, part: 0, bary: glam::Vec2::ZERO });
        let local = shape.surface(lo, ld, &own);
        let normal = hit.normal.normalize_or(Vec3::Y);
        // Into the tree's space in f64, rounded once (as an object's placement is).
        let (exact, error) = crate::geometry::place64(node_from_leaf, local.exact, local.error);
        let error = error.max_element();
        crate::LocalSurface { point: exact.as_vec3(), exact, error, normal, shading: normal, uv: glam::Vec2::ZERO }
    }
}

/// Combines two sorted, disjoint span lists.
pub fn combine(op: CsgOp, a: &[Span], b: &[Span]) -> Vec<Span> {
    // Sweep the boundaries in order, tracking whether we are inside a, inside b, and the result.
    #[derive(Clone, Copy)]
    struct Event {
        t: f32,
        n: Vec3,
        part: u32,
        of_a: bool,
        entering: bool,
    }
    let mut events: Vec<Event> = Vec::with_capacity(2 * (a.len() + b.len()));
    for (list, of_a) in [(a, true), (b, false)] {
        for s in list {
            events.push(Event { t: s.t0, n: s.n0, part: s.part0, of_a, entering: true });
            events.push(Event { t: s.t1, n: s.n1, part: s.part1, of_a, entering: false });
        }
    }
    events.sort_by(|x, y| x.t.total_cmp(&y.t));
    let inside = |ia: bool, ib: bool| match op {
        CsgOp::Union => ia || ib,
        CsgOp::Intersection => ia && ib,
        CsgOp::Difference => ia && !ib,
    };
    let (mut ia, mut ib) = (false, false);
    let mut out = Vec::new();
    let mut open: Option<(f32, Vec3, u32)> = None;
    for e in events {
        if e.of_a {
            ia = e.entering
        } else {
            ib = e.entering
        }
        let now = inside(ia, ib);
        // A boundary of b is a boundary of the difference with its normal turned round.
        let n = if op == CsgOp::Difference && !e.of_a { -e.n } else { e.n };
        match (open, now) {
            (None, true) => open = Some((e.t, n, e.part)),
            (Some((t0, n0, part0)), false) => {
                if e.t > t0 {
                    out.push(Span { t0, n0, t1: e.t, n1: n, part0, part1: e.part });
                }
                open = None;
            }
            _ => {}
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn span(t0: f32, t1: f32) -> Span {
        Span { t0, n0: -Vec3::X, t1, n1: Vec3::X, part0: 0, part1: 0 }
    }

    #[test]
    fn interval_algebra() {
        let a = [span(0.0, 4.0)];
        let b = [span(1.0, 2.0), span(3.0, 6.0)];
        let ts = |v: Vec<Span>| v.iter().map(|s| (s.t0, s.t1)).collect::<Vec<_>>();
        assert_eq!(ts(combine(CsgOp::Union, &a, &b)), [(0.0, 6.0)]);
        assert_eq!(ts(combine(CsgOp::Intersection, &a, &b)), [(1.0, 2.0), (3.0, 4.0)]);
        assert_eq!(ts(combine(CsgOp::Difference, &a, &b)), [(0.0, 1.0), (2.0, 3.0)]);
        // The difference's new boundaries come from b, with b's normals turned round.
        let d = combine(CsgOp::Difference, &a, &b);
        assert_eq!((d[0].n1, d[1].n0), (-(-Vec3::X), -Vec3::X));
    }
}

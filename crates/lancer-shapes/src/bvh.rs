//! A bounding volume hierarchy built with binned SAH and flattened into an array for traversal.

use glam::Vec3;

use crate::Aabb;

/// A flattened node: interior nodes have `count == 0`, their left child follows them and their
/// right child is at `start`; leaves hold `indices[start..start + count]`.
#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: Aabb,
    start: u32,
    count: u32,
    axis: u8,
}

/// A BVH over items given by their bounds; queries report item indices.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<Node>,
    indices: Vec<u32>,
}

const BINS: usize = 12;
const MAX_LEAF: usize = 4;

impl Bvh {
    /// Builds the hierarchy over `bounds` (item `i` has `bounds[i]`).
    pub fn build(bounds: &[Aabb]) -> Bvh {
        let mut bvh = Bvh { nodes: Vec::with_capacity(2 * bounds.len()), indices: (0..bounds.len() as u32).collect() };
        if !bounds.is_empty() {
            let centres: Vec<Vec3> = bounds.iter().map(|b| b.centre()).collect();
            bvh.split(bounds, &centres, 0, bounds.len());
        }
        bvh
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.indices.len()
    }

    /// Whether the hierarchy holds no item.
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    fn split(&mut self, bounds: &[Aabb], centres: &[Vec3], start: usize, end: usize) -> usize {
        let items = &self.indices[start..end];
        let node_bounds = items.iter().fold(Aabb::EMPTY, |a, &i| a.union(bounds[i as usize]));
        let cb = items
            .iter()
            .fold(Aabb::EMPTY, |a, &i| a.union(Aabb { min: centres[i as usize], max: centres[i as usize] }));
        let node = self.nodes.len();
        self.nodes.push(Node { bounds: node_bounds, start: start as u32, count: (end - start) as u32, axis: 0 });
        let n = end - start;
        let extent = cb.max - cb.min;
        let axis = extent.max_position();
        if n <= 1 || extent[axis] <= 0.0 {
            return node;
        }

        // Bin centroids along the widest axis and sweep for the cheapest SAH split.
        let scale = BINS as f32 / extent[axis];
        let bin_of = |c: Vec3| (((c[axis] - cb.min[axis]) * scale) as usize).min(BINS - 1);
        let mut bins = [(Aabb::EMPTY, 0usize); BINS];
        for &i in items {
            let b = &mut bins[bin_of(centres[i as usize])];
            b.0 = b.0.union(bounds[i as usize]);
            b.1 += 1;
        }
        let mut right_cost = [0.0f32; BINS];
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for k in (1..BINS).rev() {
            acc = acc.union(bins[k].0);
            cnt += bins[k].1;
            right_cost[k] = acc.half_area() * cnt as f32;
        }
        let (mut best, mut best_cost) = (0, f32::INFINITY);
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for k in 0..BINS - 1 {
            acc = acc.union(bins[k].0);
            cnt += bins[k].1;
            let cost = acc.half_area() * cnt as f32 + right_cost[k + 1];
            if cnt > 0 && cnt < n && cost < best_cost {
                best = k + 1;
                best_cost = cost;
            }
        }
        let leaf_cost = node_bounds.half_area() * n as f32;
        if best == 0 || (n <= MAX_LEAF && best_cost >= leaf_cost) {
            return node;
        }

        // Partition in place, in one pass (deterministic: it depends only on the input order).
        let slice = &mut self.indices[start..end];
        let mut mid = 0;
        for k in 0..slice.len() {
            if bin_of(centres[slice[k] as usize]) < best {
                slice.swap(k, mid);
                mid += 1;
            }
        }
        let mid = start + mid;
        self.split(bounds, centres, start, mid);
        let right = self.split(bounds, centres, mid, end);
        self.nodes[node].start = right as u32;
        self.nodes[node].count = 0;
        self.nodes[node].axis = axis as u8;
        node
    }

    /// Visits the items whose boxes the ray `o + t d` meets within `[0, tmax]`, nearer subtrees
    /// first. `visit(item, tmax)` returns the new `tmax` (the closest hit found so far).
    #[inline]
    pub fn traverse(&self, o: Vec3, d: Vec3, tmax: f32, visit: impl FnMut(u32, f32) -> f32) -> f32 {
        self.traverse_from(o, d, 0.0, tmax, visit)
    }

    /// As [`Bvh::traverse`], skipping boxes that end before `tmin`.
    #[inline]
    pub fn traverse_from(
        &self,
        o: Vec3,
        d: Vec3,
        tmin: f32,
        mut tmax: f32,
        mut visit: impl FnMut(u32, f32) -> f32,
    ) -> f32 {
        if self.nodes.is_empty() {
            return tmax;
        }
        let inv_d = d.recip();
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if node.bounds.hit_range(o, inv_d, tmin, tmax).is_none() {
                continue;
            }
            if node.count > 0 {
                for &i in &self.indices[node.start as usize..(node.start + node.count) as usize] {
                    tmax = visit(i, tmax);
                }
            } else {
                let left = stack[top] + 1;
                let (first, second) = if d[node.axis as usize] < 0.0 { (node.start, left) } else { (left, node.start) };
                // Push the far child first so the near one is visited next. Depth is bounded by
                // the item count's log for SAH splits, far below 64 for any scene that fits in memory.
                stack[top] = second;
                stack[top + 1] = first;
                top += 2;
            }
        }
        tmax
    }
}

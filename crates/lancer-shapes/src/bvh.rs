//! A bounding volume hierarchy built with binned SAH straight into a 4-wide tree whose nodes
//! keep their children's boxes side by side (structure of arrays), so one pass of slab
//! arithmetic tests all four children at once; traversal visits the nearer children first and
//! drops those that begin beyond the best hit found.

use glam::Vec3;
use rayon::prelude::*;
use wide::{CmpGe, CmpLe, f32x4};

use crate::Aabb;

/// A node of the 4-wide tree: up to four children, each an inner node or a run of items.
#[derive(Clone, Copy, Debug, bytemuck::Zeroable)]
struct Node4 {
    /// Children's lower (`planes[0]`) and upper (`planes[1]`) corners, per axis, one lane per
    /// child: a ray picks its near and far planes per axis by index, once.
    planes: [[f32x4; 3]; 2],
    /// An inner child's node index, or a leaf child's first position in `indices`.
    child: [u32; 4],
    /// A leaf child's item count; [`INNER`] for an inner child, 0 for an empty slot.
    count: [u32; 4],
}

/// `Node4::count` of an inner child.
const INNER: u32 = u32::MAX;

/// A BVH over items given by their bounds; queries report item indices.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<Node4>,
    /// Item of each leaf position; empty once the caller stores its items in leaf order.
    indices: Vec<u32>,
    /// Whether the caller stores its items in leaf order (see [`Bvh::into_leaf_order`]): a leaf's
    /// positions are then its items.
    ordered: bool,
    /// Number of items.
    items: usize,
    /// The root node's index.
    root: u32,
    /// The box of every item.
    bounds: Aabb,
}

const BINS: usize = 12;
const MAX_LEAF: usize = 4;
/// The greatest depth of the binary splits; the 4-wide tree is no deeper, and each of its levels leaves
/// at most three entries on the traversal stack.
const MAX_DEPTH: usize = 64;
/// The traversal stack's size: room for three entries per level, and a few more.
const STACK: usize = 3 * MAX_DEPTH + 4;

impl Bvh {
    /// Builds the hierarchy over `bounds` (item `i` has `bounds[i]`).
    /// Items costly to test (whole shapes): a range of up to [`MAX_LEAF`] is split whenever
    /// the split's expected item tests are fewer.
    pub fn build(bounds: &[Aabb]) -> Bvh {
        Bvh::build_with(bounds.len(), |i| bounds[i], 0.0)
    }

    /// Builds the hierarchy over `n` items whose bounds `bounds(i)` gives, without a list of
    /// boxes beside the build's own (a million-triangle mesh saves 24 bytes a triangle). `step`
    /// is the cost of visiting a node in item tests: a range of up to [`MAX_LEAF`] items stays
    /// one leaf unless splitting it saves more than that (cheap items such as triangles: fewer,
    /// fuller leaves and a smaller tree).
    pub fn build_with(n: usize, bounds: impl Fn(usize) -> Aabb + Sync, step: f32) -> Bvh {
        if n == 0 {
            return Bvh::default();
        }
        let mut items: Vec<Item> =
            (0..n).into_par_iter().map(|i| Item { bounds: bounds(i), index: i as u32 }).collect();
        // On every thread: unions are exact, so the extent is the same however they share it.
        let extent = items.par_chunks(PARALLEL / 2).map(Extent::of).reduce(|| Extent::EMPTY, |a, b| a.union(b));
        let (nodes, root, indices) = match plan(&mut items, extent, 0, step) {
            Some(split) => {
                // On several threads: room for the largest tree over n items (see `room`),
                // zeroed, so that where the system maps a large zeroed block lazily (Linux with
                // glibc) only the pages nodes are written on are committed, and no list of nodes
                // is ever joined to another (which held both at once, the build's peak). On one
                // thread, and in the browser (whose memory only grows), one list grown in
                // preorder: the layout the regions come to once moved together.
                let grow = cfg!(target_arch = "wasm32") || rayon::current_num_threads() == 1;
                let mut nodes: Vec<Node4> =
                    if grow { Vec::with_capacity(n * 3 / 10 + 8) } else { bytemuck::zeroed_vec(room(n)) };
                let store = if grow { Store::Grow(&mut nodes) } else { Store::Room(&mut nodes[..]) };
                let mut spans = Vec::new();
                let root = build(&mut items, 0, split, 1, step, &mut Region { store, base: 0, used: 0 }, &mut spans);
                // The item boxes go before the gaps are closed: moving a stretch writes pages
                // of the array not yet written, while (with glibc) the pages it leaves are given
                // back only once the array is cut to the tree's size.
                let indices = leaf_items(items);
                let root = compact(&mut nodes, &spans, root);
                (nodes, root, indices)
            }
            // A single leaf: one slot of the root.
            None => {
                let mut root = Node4::EMPTY;
                root.set(0, &extent.bounds, 0, n as u32);
                (vec![root], 0, leaf_items(items))
            }
        };
        Bvh { nodes, indices, ordered: false, items: n, root, bounds: extent.bounds }
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.items
    }

    /// The box of every item.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Whether the hierarchy holds no item.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The items in leaf order (position → original item), for a caller that stores its items
    /// in that order: from then on queries report positions, with no lookup per item and leaves
    /// reading memory in order.
    pub fn into_leaf_order(&mut self) -> Vec<u32> {
        self.ordered = true;
        std::mem::take(&mut self.indices)
    }
}

impl Node4 {
    /// No children: every slot's box inverted (lower corner +∞, upper −∞), which no ray meets.
    const EMPTY: Node4 = Node4 {
        planes: [[f32x4::new([f32::INFINITY; 4]); 3], [f32x4::new([f32::NEG_INFINITY; 4]); 3]],
        child: [0; 4],
        count: [0; 4],
    };

    fn set(&mut self, slot: usize, b: &Aabb, child: u32, count: u32) {
        for axis in 0..3 {
            let (mut lo, mut hi) = (self.planes[0][axis].to_array(), self.planes[1][axis].to_array());
            lo[slot] = b.min[axis];
            hi[slot] = b.max[axis];
            (self.planes[0][axis], self.planes[1][axis]) = (f32x4::new(lo), f32x4::new(hi));
        }
        self.child[slot] = child;
        self.count[slot] = count;
    }

    /// The entry distance of the ray into each child's box within `[tmin, tmax]` (`o` and
    /// `inv_d` splatted per axis), and a bit mask of the children it meets: four slab tests in
    /// one pass of SIMD arithmetic. On an axis the ray goes down (`back`), a box's upper face is
    /// the near one: the same distances as taking the smaller of both faces', and an empty slot
    /// (an inverted box) is entered at +∞, so it is not met (a ray with a NaN or infinite
    /// coordinate may 'meet' one: it holds no item, so nothing is visited). On an axis the ray does not move
    /// along (`flat`), a child is met where the origin lies within its slab, faces included.
    #[inline]
    fn enter(
        &self,
        o: &[f32x4; 3],
        inv_d: &[f32x4; 3],
        back: [bool; 3],
        flat: [bool; 3],
        tmin: f32,
        tmax: f32,
    ) -> ([f32; 4], i32) {
        let mut near = f32x4::splat(tmin);
        let mut far = f32x4::splat(tmax);
        let mut inside = 0b1111;
        for axis in 0..3 {
            let (lo, hi) = (self.planes[0][axis], self.planes[1][axis]);
            if flat[axis] {
                inside &= (lo.cmp_le(o[axis]) & hi.cmp_ge(o[axis])).move_mask();
                continue;
            }
            let (lo, hi) = if back[axis] { (hi, lo) } else { (lo, hi) };
            near = ((lo - o[axis]) * inv_d[axis]).fast_max(near);
            far = ((hi - o[axis]) * inv_d[axis]).fast_min(far);
        }
        (near.to_array(), near.cmp_le(far).move_mask() & inside)
    }

    /// [`Node4::enter`] for a ray that moves along every axis, with its near plane of each axis
    /// chosen beforehand (`near[axis]`: 1 where the ray goes down the axis, else 0): no branch.
    /// The same operations in the same order, so the same lanes as [`Node4::enter`], even where
    /// one is NaN, within one SIMD backend (`fast_max` keeps one operand or the other on NaN as
    /// the instruction set has it: a NaN lane could differ between x86 and WebAssembly; none
    /// reaches here, as flat axes take the branch above and empty slots are infinite).
    #[inline(always)]
    fn enter_steep(
        &self,
        o: &[f32x4; 3],
        inv_d: &[f32x4; 3],
        near: [usize; 3],
        tmin: f32,
        tmax: f32,
    ) -> ([f32; 4], i32) {
        let t = |axis: usize, side: usize| (self.planes[side][axis] - o[axis]) * inv_d[axis];
        let entry = t(2, near[2]).fast_max(t(1, near[1]).fast_max(t(0, near[0]).fast_max(f32x4::splat(tmin))));
        let exit =
            t(2, 1 - near[2]).fast_min(t(1, 1 - near[1]).fast_min(t(0, 1 - near[0]).fast_min(f32x4::splat(tmax))));
        (entry.to_array(), entry.cmp_le(exit).move_mask())
    }
}

/// Ranges of at least this many items are split on two threads at once.
const PARALLEL: usize = 1 << 15;
/// Ranges of at most this many items are binned by sorting them (no table of every bin).
const SMALL: usize = 15;

/// An item during the build: its box kept beside its index, so partitions read memory in order.
#[derive(Clone, Copy)]
struct Item {
    bounds: Aabb,
    index: u32,
}

impl Item {
    #[inline]
    fn centre(&self) -> Vec3 {
        self.bounds.centre()
    }

    /// `centre()[axis]`, the same bits, without the other two.
    #[inline]
    fn centre_along(&self, axis: usize) -> f32 {
        let (min, max): (&[f32; 3], &[f32; 3]) = (self.bounds.min.as_ref(), self.bounds.max.as_ref());
        0.5 * (min[axis] + max[axis])
    }
}

/// The boxes of a range of items: of the items themselves, and of their centres.
#[derive(Clone, Copy)]
struct Extent {
    bounds: Aabb,
    centres: Aabb,
}

impl Extent {
    const EMPTY: Extent = Extent { bounds: Aabb::EMPTY, centres: Aabb::EMPTY };

    fn of(items: &[Item]) -> Extent {
        items.iter().fold(Extent::EMPTY, |e, i| e.with(i))
    }

    #[inline]
    fn with(self, i: &Item) -> Extent {
        let c = i.centre();
        Extent { bounds: self.bounds.union(i.bounds), centres: self.centres.union(Aabb { min: c, max: c }) }
    }

    #[inline]
    fn union(self, o: Extent) -> Extent {
        Extent { bounds: self.bounds.union(o.bounds), centres: self.centres.union(o.centres) }
    }
}

/// The bin (of [`BINS`]) of a centre's coordinate `c` along the binned axis, whose centres start
/// at `min` and span `BINS / scale`. Cast to `i32` and clamped: for every `f32` (NaN, infinities,
/// negatives, past 2³¹) the bin a saturating cast to `usize` and `min(BINS - 1)` give, in fewer
/// instructions.
#[inline]
fn bin(c: f32, min: f32, scale: f32) -> usize {
    (((c - min) * scale) as i32).clamp(0, BINS as i32 - 1) as usize
}

/// How the items of a range (whose extent is `extent`) split: `None` for a leaf, or
/// `Some((mid, left, right))` after partitioning `items` in place, with each side's extent
/// (binned SAH along the widest axis of the centres; one pass to bin, one to partition;
/// deterministic: it depends only on the input order).
fn plan(items: &mut [Item], extent: Extent, depth: usize, step: f32) -> Option<(usize, Extent, Extent)> {
    let n = items.len();
    let cb = extent.centres;
    let size = cb.max - cb.min;
    let axis = size.max_position();
    // Deeper than MAX_DEPTH (only adversarial inputs get there) the rest is one leaf, which
    // bounds the traversal stack.
    if n <= 1 || size[axis] <= 0.0 || depth >= MAX_DEPTH {
        return None;
    }

    // Bin centres along the widest axis and sweep for the cheapest SAH split.
    let scale = BINS as f32 / size[axis];
    let bin_of = |i: &Item| bin(i.centre_along(axis), cb.min[axis], scale);
    let full = if n <= SMALL { bins_sorted(items, bin_of) } else { bins_table(items, bin_of) };
    // The sweep goes over the bins that hold items: a split after an empty bin divides the items
    // as the split after the last full bin before it does, at the same cost, and the first of
    // equal costs is kept, so skipping them changes nothing (a small range, most of whose bins
    // are empty, is swept at the cost of its items, not of all the bins).
    // right[m]: the items of the full bins from the (len − 1 − m)-th on (pushed from the last).
    let mut right: arrayvec::ArrayVec<(Extent, usize), BINS> = arrayvec::ArrayVec::new();
    let mut acc = (Extent::EMPTY, 0);
    for j in (1..full.len()).rev() {
        let bin = full[j].1;
        acc = (acc.0.union(bin.0), acc.1 + bin.1);
        right.push(acc);
    }
    let (mut best, mut best_cost, mut best_left, mut best_right) = (0, f32::INFINITY, Extent::EMPTY, Extent::EMPTY);
    let mut acc = (Extent::EMPTY, 0);
    for j in 0..full.len().saturating_sub(1) {
        let bin = full[j].1;
        acc = (acc.0.union(bin.0), acc.1 + bin.1);
        let (r, rn) = right[full.len() - 2 - j];
        let cost = acc.0.bounds.half_area() * acc.1 as f32 + r.bounds.half_area() * rn as f32;
        if acc.1 > 0 && acc.1 < n && cost < best_cost {
            (best, best_cost, best_left, best_right) = (full[j].0 + 1, cost, acc.0, r);
        }
    }
    let area = extent.bounds.half_area();
    // (`area · (n − step)`: with `step` 0, exactly the plain SAH test, also for an infinite area.)
    if best == 0 || (n <= MAX_LEAF && best_cost >= area * (n as f32 - step)) {
        return None;
    }
    // Partition in place, in one pass from both ends: only misplaced pairs are swapped.
    let left = |i: &Item| bin_of(i) < best;
    let (mut lo, mut hi) = (0, items.len());
    loop {
        while lo < hi && left(&items[lo]) {
            lo += 1;
        }
        while lo < hi && !left(&items[hi - 1]) {
            hi -= 1;
        }
        if lo >= hi {
            break;
        }
        items.swap(lo, hi - 1);
        lo += 1;
        hi -= 1;
    }
    Some((lo, best_left, best_right))
}

/// The bins that hold items, in order: (bin, its items' extent, their count); each bin's
/// extent is the union of its items' in item order.
type Full = arrayvec::ArrayVec<(usize, (Extent, usize)), BINS>;

/// [`Full`] by a table of every bin (large ranges binned on every thread: unions and counts are
/// exact, so the bins are the same however the items are shared out).
fn bins_table(items: &[Item], bin_of: impl Fn(&Item) -> usize + Sync) -> Full {
    let bin_all = |items: &[Item]| {
        let mut bins = [(Extent::EMPTY, 0usize); BINS];
        for i in items {
            let b = &mut bins[bin_of(i)];
            b.0 = b.0.with(i);
            b.1 += 1;
        }
        bins
    };
    let bins = if items.len() >= PARALLEL {
        items.par_chunks(PARALLEL / 2).map(bin_all).reduce(
            || [(Extent::EMPTY, 0usize); BINS],
            |mut a, b| {
                for (x, y) in a.iter_mut().zip(b) {
                    *x = (x.0.union(y.0), x.1 + y.1);
                }
                a
            },
        )
    } else {
        bin_all(items)
    };
    (0..BINS).filter(|&k| bins[k].1 > 0).map(|k| (k, bins[k])).collect()
}

/// [`Full`] for a range of at most [`SMALL`] items (most are: of the million ranges a million
/// triangles plan, 900,000), without a table of every bin: each item's bin, sorted.
fn bins_sorted(items: &[Item], bin_of: impl Fn(&Item) -> usize) -> Full {
    debug_assert!(items.len() <= SMALL, "a range of {} items is not small", items.len());
    let mut of: arrayvec::ArrayVec<(usize, usize), SMALL> =
        items.iter().enumerate().map(|(k, i)| (bin_of(i), k)).collect();
    // (Unstable, as each pair differs: items stay in order within a bin.)
    of.sort_unstable();
    let mut full = Full::new();
    for &(bin, k) in &of {
        match full.last_mut() {
            Some((b, e)) if *b == bin => *e = (e.0.with(&items[k]), e.1 + 1),
            _ => full.push((bin, (Extent::EMPTY.with(&items[k]), 1))),
        }
    }
    full
}

/// A child of a 4-wide node during the build: its items (a range of the node's), their extent,
/// the depth it would have in a binary tree, and its split (`None`: it is a leaf).
struct Kid {
    start: usize,
    len: usize,
    extent: Extent,
    depth: usize,
    split: Option<(usize, Extent, Extent)>,
}

/// The item of each leaf position, in a list of its own (collected in place, it would keep the
/// boxes' room: seven times its size).
fn leaf_items(items: Vec<Item>) -> Vec<u32> {
    items.iter().map(|i| i.index).collect()
}

/// The most nodes a tree over `n` (at least 2) items can have: every node has at least two
/// children and every leaf at least one item, so there are fewer nodes than items.
fn room(n: usize) -> usize {
    n - 1
}

/// Stretches of the node array in use: (start, length), in order.
type Spans = Vec<(usize, usize)>;

/// Where a subtree's nodes go, filled from the front; its first is node `base`.
struct Region<'a> {
    store: Store<'a>,
    base: usize,
    used: usize,
}

/// The memory of a [`Region`].
enum Store<'a> {
    /// A stretch of the room array with [`room`] for the subtree (`[0]` is node `base`): cut
    /// into regions for subtrees built at once.
    Room(&'a mut [Node4]),
    /// The whole node list, grown as nodes come: subtrees are built one after another.
    Grow(&'a mut Vec<Node4>),
}

impl Region<'_> {
    /// Writes `node` at the next free place; its node index.
    fn push(&mut self, node: Node4) -> u32 {
        match &mut self.store {
            Store::Room(nodes) => nodes[self.used] = node,
            Store::Grow(nodes) => nodes.push(node),
        }
        self.used += 1;
        (self.base + self.used - 1) as u32
    }

    /// Writes `node` as node `at` (one pushed before).
    fn set(&mut self, at: u32, node: Node4) {
        let nodes: &mut [Node4] = match &mut self.store {
            Store::Room(nodes) => nodes,
            Store::Grow(nodes) => nodes,
        };
        nodes[at as usize - self.base] = node;
    }

    /// The room past the nodes written, to cut into regions; `None` for a grown list.
    fn rest(&mut self) -> Option<&mut [Node4]> {
        match &mut self.store {
            Store::Room(nodes) => Some(&mut nodes[self.used..]),
            Store::Grow(_) => None,
        }
    }
}

/// Builds the 4-wide node over `items` (at `offset` in the whole item list), split as `split`
/// says, and its subtree, writing them into `out` in preorder; returns the node's index, and adds
/// the stretches of the node array it wrote (start, length) to `spans`, in order. The node's
/// children are the split's two halves, the widest (by surface area) of those that split again
/// replaced by its halves until there are four: the binary SAH tree collapsed, built without it.
/// Inner children of large nodes are built on several threads, each into its own region of the
/// node array (as much room as its subtree can take, so the regions are fixed before any is
/// built): the tree is the same whatever the number of threads, and [`compact`] closes the gaps.
fn build(
    items: &mut [Item],
    offset: usize,
    split: (usize, Extent, Extent),
    depth: usize,
    step: f32,
    out: &mut Region,
    spans: &mut Spans,
) -> u32 {
    let n = items.len();
    // The two halves of a split range, each planned (on two threads for a large range).
    let halves = |items: &mut [Item], start: usize, (mid, le, re): (usize, Extent, Extent), depth: usize| {
        let len = items.len();
        let (l, r) = items.split_at_mut(mid);
        let mut plan_l = move || plan(l, le, depth, step);
        let mut plan_r = move || plan(r, re, depth, step);
        let (sl, sr) = if len >= PARALLEL { rayon::join(plan_l, plan_r) } else { (plan_l(), plan_r()) };
        [
            Kid { start, len: mid, extent: le, depth, split: sl },
            Kid { start: start + mid, len: len - mid, extent: re, depth, split: sr },
        ]
    };
    let mut kids: arrayvec::ArrayVec<Kid, 4> = halves(items, 0, split, depth).into_iter().collect();
    while kids.len() < 4 {
        let widest = (0..kids.len())
            .filter(|&k| kids[k].split.is_some())
            .max_by(|&a, &b| kids[a].extent.bounds.half_area().total_cmp(&kids[b].extent.bounds.half_area()));
        let Some(k) = widest else { break };
        let Kid { start, len, depth, split, .. } = kids.remove(k);
        let split = split.expect("only split children are expanded");
        let [l, r] = halves(&mut items[start..start + len], start, split, depth + 1);
        kids.insert(k, r);
        kids.insert(k, l);
    }
    let mut node = Node4::EMPTY;
    let me = out.push(Node4::EMPTY);
    // Whether this node is its region's first (the region's subtree is then this node's): a large
    // range's node always is (it is the root's, or a child's of another large range, which has a
    // region of its own).
    let first = me as usize == out.base;
    let free = if n >= PARALLEL { out.rest() } else { None };
    if let Some(mut free) = free {
        // This node is its region's first stretch; each inner child's subtree is built at once
        // into a region of its own, cut from the rest of this one in slot order.
        assert!(first, "a large range starts its region");
        spans.push((me as usize, 1));
        let mut slices = Vec::with_capacity(4);
        let mut rest = items;
        for k in &kids {
            let (head, tail) = std::mem::take(&mut rest).split_at_mut(k.len);
            slices.push(head);
            rest = tail;
        }
        let mut regions = Vec::with_capacity(4);
        let mut base = me as usize + 1;
        for k in &kids {
            let take = if k.split.is_some() { room(k.len) } else { 0 };
            let (head, tail) = std::mem::take(&mut free).split_at_mut(take);
            regions.push(Region { store: Store::Room(head), base, used: 0 });
            (free, base) = (tail, base + take);
        }
        let built: Vec<Option<(u32, Spans)>> = slices
            .into_par_iter()
            .zip(regions.into_par_iter())
            .zip(kids.par_iter())
            .map(|((s, mut region), k)| {
                k.split.map(|split| {
                    let mut spans = Vec::new();
                    let root = build(s, offset + k.start, split, k.depth + 1, step, &mut region, &mut spans);
                    (root, spans)
                })
            })
            .collect();
        for (slot, (k, built)) in kids.iter().zip(built).enumerate() {
            match built {
                None => node.set(slot, &k.extent.bounds, (offset + k.start) as u32, k.len as u32),
                Some((child, theirs)) => {
                    node.set(slot, &k.extent.bounds, child, INNER);
                    spans.extend(theirs);
                }
            }
        }
    } else {
        // Preorder: this node, then each child's subtree in slot order.
        for (slot, k) in kids.iter().enumerate() {
            match k.split {
                None => node.set(slot, &k.extent.bounds, (offset + k.start) as u32, k.len as u32),
                Some(split) => {
                    // (Not its region's first: adds no stretch.)
                    let child = build(
                        &mut items[k.start..k.start + k.len],
                        offset + k.start,
                        split,
                        k.depth + 1,
                        step,
                        out,
                        spans,
                    );
                    node.set(slot, &k.extent.bounds, child, INNER);
                }
            }
        }
        if first {
            // The region's own subtree, all of it in one stretch.
            spans.push((out.base, out.used));
        }
    }
    out.set(me, node);
    me
}

/// Moves the stretches `spans` (start, length: in order, apart) of `nodes` together at its front,
/// renumbering inner children to where their nodes land, and frees the rest (glibc gives the
/// pages past the tree back to the system); returns the new index of `root`.
fn compact(nodes: &mut Vec<Node4>, spans: &[(usize, usize)], root: u32) -> u32 {
    // Where each stretch lands.
    let mut to = Vec::with_capacity(spans.len());
    let mut end = 0;
    for &(_, len) in spans {
        to.push(end);
        end += len;
    }
    let moved = |old: u32| {
        let k = spans.partition_point(|&(start, _)| start <= old as usize) - 1;
        debug_assert!((old as usize) < spans[k].0 + spans[k].1, "node {old} lies in no stretch");
        (to[k] + old as usize - spans[k].0) as u32
    };
    if spans.iter().zip(&to).all(|(&(start, _), &at)| start == at) {
        // Already together (one stretch, or a list grown in preorder): no link changes.
        nodes.truncate(end);
        nodes.shrink_to_fit();
        return root;
    }
    for (&(start, len), &at) in spans.iter().zip(&to) {
        // Each stretch lands at or before where it is, past every stretch already moved.
        if start != at {
            nodes.copy_within(start..start + len, at);
        }
        for node in &mut nodes[at..at + len] {
            for c in 0..4 {
                if node.count[c] == INNER {
                    node.child[c] = moved(node.child[c]);
                }
            }
        }
    }
    nodes.truncate(end);
    nodes.shrink_to_fit();
    moved(root)
}

impl Bvh {
    /// Visits the items whose boxes the ray `o + t d` meets within `[0, tmax]`, nearer subtrees
    /// first. `visit(item, tmax)` returns the new `tmax` (the closest hit found so far).
    #[inline]
    pub fn traverse(&self, o: Vec3, d: Vec3, tmax: f32, visit: impl FnMut(u32, f32) -> f32) -> f32 {
        self.traverse_from(o, d, 0.0, tmax, visit)
    }

    /// As [`Bvh::traverse`], skipping boxes that end before `tmin`. A subtree or leaf whose box
    /// begins beyond the best hit so far is dropped; the order of visits depends only on the ray,
    /// so the same ray always gets the same answer.
    #[inline]
    pub fn traverse_from(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32, mut visit: impl FnMut(u32, f32) -> f32) -> f32 {
        let ordered = self.ordered;
        self.traverse_leaves_from(o, d, tmin, tmax, |first, count, mut tmax| {
            if ordered {
                for i in first..first + count {
                    tmax = visit(i, tmax);
                }
            } else {
                for &i in &self.indices[first as usize..(first + count) as usize] {
                    tmax = visit(i, tmax);
                }
            }
            tmax
        })
    }

    /// As [`Bvh::traverse_from`], a leaf at a time: `visit(first, count, tmax)` gets the leaf's
    /// positions `first..first + count` in leaf order (the items themselves once the tree is in
    /// leaf order, see [`Bvh::into_leaf_order`]) and returns the new `tmax`.
    #[inline]
    pub fn traverse_leaves_from(
        &self,
        o: Vec3,
        d: Vec3,
        tmin: f32,
        tmax: f32,
        visit: impl FnMut(u32, u32, f32) -> f32,
    ) -> f32 {
        if self.nodes.is_empty() {
            return tmax;
        }
        // Axes the ray does not move along (or so little that 1/d would overflow) are tested by
        // position instead of by distance: no 0 · ∞ in the slab arithmetic, and a ray lying
        // exactly on a box's face meets the box, whichever face, on every CPU.
        let flat: [bool; 3] = d.abs().cmplt(Vec3::splat(f32::MIN_POSITIVE)).into();
        if flat.iter().any(|&f| f) {
            self.walk::<true>(o, d, flat, tmin, tmax, visit)
        } else {
            self.walk::<false>(o, d, flat, tmin, tmax, visit)
        }
    }

    /// The traversal of [`Bvh::traverse_from`]; `FLAT`: whether some axis is `flat` (the slab
    /// test then checks for it; else it is free of branches).
    #[inline(always)]
    fn walk<const FLAT: bool>(
        &self,
        o: Vec3,
        d: Vec3,
        flat: [bool; 3],
        tmin: f32,
        mut tmax: f32,
        mut visit: impl FnMut(u32, u32, f32) -> f32,
    ) -> f32 {
        let inv = d.recip();
        let back: [bool; 3] = d.cmplt(Vec3::ZERO).into();
        let near_side = back.map(usize::from);
        let o = [f32x4::splat(o.x), f32x4::splat(o.y), f32x4::splat(o.z)];
        let inv_d = [f32x4::splat(inv.x), f32x4::splat(inv.y), f32x4::splat(inv.z)];
        // (child, its item count or INNER, entry distance): children are pushed farthest first,
        // so they are visited strictly nearest first, leaves included; at most three entries
        // per level of a tree at most MAX_DEPTH deep stay behind. An `ArrayVec`: no memory to
        // clear per query.
        let mut stack: arrayvec::ArrayVec<(u32, u32, f32), STACK> = arrayvec::ArrayVec::new();
        // The nearest child met goes straight on, without a trip through the stack.
        let mut next = Some((self.root, INNER, tmin));
        while let Some((child, count, entry)) = next.take().or_else(|| stack.pop()) {
            if entry > tmax {
                continue;
            }
            if count != INNER {
                tmax = visit(child, count, tmax);
                continue;
            }
            let node = &self.nodes[child as usize];
            let (near, mask) = if FLAT {
                node.enter(&o, &inv_d, back, flat, tmin, tmax)
            } else {
                node.enter_steep(&o, &inv_d, near_side, tmin, tmax)
            };
            // The children met, farthest first (ties: later slot first, so earlier slots are
            // visited first).
            let mut order = [0usize; 4];
            let mut met = 0;
            for k in 0..4 {
                if mask & (1 << k) != 0 {
                    let mut at = met;
                    while at > 0 && near[order[at - 1]] <= near[k] {
                        order[at] = order[at - 1];
                        at -= 1;
                    }
                    order[at] = k;
                    met += 1;
                }
            }
            if let Some((&nearest, farther)) = order[..met].split_last() {
                for &k in farther {
                    stack.push((node.child[k], node.count[k], near[k]));
                }
                next = Some((node.child[nearest], node.count[nearest], near[nearest]));
            }
        }
        tmax
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bin_is_the_one_a_saturating_cast_gives_for_any_float() {
        let special = [
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            0.0,
            -0.0,
            -0.5,
            -1e30,
            0.999,
            11.99,
            12.0,
            12.5,
            2_147_483_648.0,
            1e30,
            f32::MAX,
            f32::MIN_POSITIVE,
        ];
        // And a stride through every bit pattern.
        let strided = (0..=u32::MAX).step_by(65_521).map(f32::from_bits);
        for x in special.into_iter().chain(strided) {
            assert_eq!(bin(x, 0.0, 1.0), (x as usize).min(BINS - 1), "{x} ({:#x})", x.to_bits());
        }
    }

    #[test]
    fn a_small_range_is_binned_by_sorting_as_by_the_table_of_bins() {
        // Boxes on a coarse grid (equal centres, ties, -0 corners and centres), some empty or
        // infinite (NaN centres), every size up to SMALL, binned along each axis as a range of
        // their extent would be.
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = move |below: usize| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % below as u64) as usize
        };
        let bits = |f: &Full| {
            f.iter()
                .map(|(k, (e, n))| {
                    let v = [e.bounds.min, e.bounds.max, e.centres.min, e.centres.max];
                    (*k, v.map(|p| p.to_array().map(f32::to_bits)), *n)
                })
                .collect::<Vec<_>>()
        };
        for round in 0..3000 {
            let n = 1 + round % SMALL;
            let items: Vec<Item> = (0..n)
                .map(|k| {
                    let bounds = match next(12) {
                        0 => Aabb::EMPTY,
                        1 => Aabb { min: Vec3::NEG_INFINITY, max: Vec3::INFINITY },
                        _ => {
                            let a = [(); 3].map(|_| [-0.0, 0.0, 0.5, -1.5, 2.0, 3.25][next(6)]);
                            // (No offset keeps a corner's -0: -0 + 0 would be +0.)
                            let b = a.map(|x| match next(3) {
                                0 => x,
                                d => x + d as f32 * 0.25,
                            });
                            Aabb { min: Vec3::from_array(a), max: Vec3::from_array(b) }
                        }
                    };
                    Item { bounds, index: k as u32 }
                })
                .collect();
            let cb = Extent::of(&items).centres;
            for axis in 0..3 {
                let scale = BINS as f32 / (cb.max[axis] - cb.min[axis]);
                let bin_of = |i: &Item| bin(i.centre_along(axis), cb.min[axis], scale);
                assert_eq!(bits(&bins_sorted(&items, bin_of)), bits(&bins_table(&items, bin_of)), "round {round}");
                let as_before = |i: &Item| (((i.centre()[axis] - cb.min[axis]) * scale) as usize).min(BINS - 1);
                assert!(items.iter().all(|i| bin_of(i) == as_before(i)), "round {round}: the bin of a centre");
            }
        }
    }

    #[test]
    fn a_ray_along_a_box_face_is_inside_it_on_either_face() {
        // Axis-parallel rays lying exactly on the min and on the max face of a box: both meet
        // it (with a direction component of 0, a 1/d of ∞ would make 0 · ∞ there).
        let boxes = [Aabb { min: Vec3::ZERO, max: Vec3::ONE }, Aabb { min: Vec3::splat(5.0), max: Vec3::splat(6.0) }];
        let bvh = Bvh::build(&boxes);
        for o in
            [Vec3::new(0.0, 0.5, -1.0), Vec3::new(1.0, 0.5, -1.0), Vec3::new(0.5, 0.0, -1.0), Vec3::new(0.5, 1.0, -1.0)]
        {
            let mut seen = false;
            bvh.traverse(o, Vec3::Z, f32::INFINITY, |i, tmax| {
                seen |= i == 0;
                tmax
            });
            assert!(seen, "a ray along the face through {o} misses the box");
        }
    }

    #[test]
    fn a_degenerate_hierarchy_stays_within_the_traversal_stack() {
        // Nested boxes of exponentially growing size: each SAH split peels off one box, so the
        // binary tree would be as deep as there are boxes. The depth cap keeps the traversal
        // stack bounded, and every box the ray crosses is still visited.
        let boxes: Vec<Aabb> =
            (0..200).map(|i| Aabb { min: Vec3::ZERO, max: Vec3::splat(1.5f32.powi(i / 2 + 1)) }).collect();
        let bvh = Bvh::build(&boxes);
        let mut seen = vec![false; boxes.len()];
        bvh.traverse(Vec3::new(0.5, 0.5, -1.0), Vec3::Z, f32::INFINITY, |i, tmax| {
            seen[i as usize] = true;
            tmax
        });
        assert!(seen.iter().all(|&s| s), "every box contains the ray's path");
    }

    /// The order [`Bvh::traverse_from`] promises, written plainly as a recursion with the
    /// checked slab test: the children a node's box test meets, by entry distance (ties: the
    /// earlier slot first), each dropped where it begins beyond the best hit found so far.
    fn visit_in_order(
        b: &Bvh,
        node: u32,
        ray: (Vec3, Vec3, f32),
        tmax: &mut f32,
        visit: &mut impl FnMut(u32, f32) -> f32,
    ) {
        let (o, d, tmin) = ray;
        let flat: [bool; 3] = d.abs().cmplt(Vec3::splat(f32::MIN_POSITIVE)).into();
        let inv = d.recip();
        let splat = |v: Vec3| [f32x4::splat(v.x), f32x4::splat(v.y), f32x4::splat(v.z)];
        let n = &b.nodes[node as usize];
        let (near, mask) = n.enter(&splat(o), &splat(inv), d.cmplt(Vec3::ZERO).into(), flat, tmin, *tmax);
        let mut met: Vec<usize> = (0..4).filter(|&k| mask & (1 << k) != 0).collect();
        met.sort_by(|&a, &c| near[a].total_cmp(&near[c]).then(a.cmp(&c)));
        for k in met {
            if near[k] > *tmax {
                continue;
            }
            if n.count[k] == INNER {
                visit_in_order(b, n.child[k], ray, tmax, visit);
            } else {
                for i in n.child[k]..n.child[k] + n.count[k] {
                    *tmax = visit(if b.ordered { i } else { b.indices[i as usize] }, *tmax);
                }
            }
        }
    }

    #[test]
    fn the_traversal_visits_in_the_promised_order_for_any_ray() {
        // Random boxes (some flat, some huge), rays whose direction has zero, negative zero,
        // tiny and huge components, and a visit that shortens the ray now and then: the
        // traversal (the branch-free node test for rays that move along every axis, the nearest
        // child without the stack) visits the same items in the same order as the plain
        // recursion, and ends with the same bound.
        let mut f = crate::testing::uniform(0x9E37_79B9_7F4A_7C15);
        for case in 0..40 {
            let count = 1 + case * 37 % 300;
            let boxes: Vec<Aabb> = (0..count)
                .map(|_| {
                    let c = Vec3::new(f(-20.0, 20.0), f(-20.0, 20.0), f(-20.0, 20.0));
                    let e =
                        Vec3::new(f(0.0, 3.0), f(0.0, 3.0), f(0.0, 3.0)) * if f(0.0, 1.0) < 0.1 { 0.0 } else { 1.0 };
                    Aabb { min: c - e, max: c + e }
                })
                .collect();
            let bvh = Bvh::build(&boxes);
            let specials = [0.0, -0.0, 1e-39, -1e-39, 1e-30, 3e38, -3e38];
            for r in 0..60 {
                let o = Vec3::new(f(-25.0, 25.0), f(-25.0, 25.0), f(-25.0, 25.0));
                let mut d = Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0));
                if r % 3 == 0 {
                    d[r % 3] = specials[(r / 3) % specials.len()];
                }
                if r % 7 == 0 {
                    d[(r + 1) % 3] = specials[(r / 7) % specials.len()];
                }
                let tmin = if r % 5 == 0 { f(0.0, 10.0) } else { 0.0 };
                let shorten =
                    |i: u32, tmax: f32| if i.is_multiple_of(3) { tmax.min(5.0 + (i % 17) as f32) } else { tmax };
                let (mut seen, mut expected) = (Vec::new(), Vec::new());
                let got = bvh.traverse_from(o, d, tmin, f32::INFINITY, |i, tmax| {
                    seen.push(i);
                    shorten(i, tmax)
                });
                let mut want = f32::INFINITY;
                if !bvh.nodes.is_empty() {
                    visit_in_order(&bvh, bvh.root, (o, d, tmin), &mut want, &mut |i, tmax| {
                        expected.push(i);
                        shorten(i, tmax)
                    });
                }
                assert_eq!(seen, expected, "case {case}, ray {o} {d}");
                assert_eq!(got.to_bits(), want.to_bits());
            }
        }
    }

    /// A tree as plain numbers: each node's links and box bits, the leaf items, the root.
    type Layout = (Vec<[u32; 8]>, Vec<[u32; 24]>, Vec<u32>, u32);

    /// The tree as plain numbers, for comparing two builds.
    fn layout(b: &Bvh) -> Layout {
        let links = b.nodes.iter().map(|n| [n.child, n.count].concat().try_into().unwrap()).collect();
        let boxes = b
            .nodes
            .iter()
            .map(|n| {
                let bits = n.planes.iter().flatten().flat_map(|v| v.to_array()).map(f32::to_bits);
                bits.collect::<Vec<_>>().try_into().unwrap()
            })
            .collect();
        (links, boxes, b.indices.clone(), b.root)
    }

    #[test]
    fn the_tree_is_the_same_on_any_number_of_threads_and_holds_every_item_once() {
        // Enough items that the build bins, plans and builds subtrees on several threads: pairs
        // of nearly equal boxes spread at random, as the two triangles of a mesh's quad.
        let boxes: Vec<Aabb> = (0..3 * PARALLEL as u32)
            .map(|i| {
                let h =
                    |k: u32| ((((i / 2).wrapping_mul(2_654_435_761)).wrapping_add(k * 40_503)) % 10_007) as f32 / 100.0;
                let min = Vec3::new(h(1), h(2), h(3));
                Aabb { min, max: min + Vec3::splat(0.5 + 0.01 * (i % 2) as f32) }
            })
            .collect();
        let build = |threads: usize, step: f32| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| Bvh::build_with(boxes.len(), |i| boxes[i], step))
        };
        for step in [0.0, 0.5] {
            let one = build(1, step);
            assert!(layout(&one) == layout(&build(4, step)), "step {step}: 1 and 4 threads build different trees");
            let mut seen = vec![0u32; boxes.len()];
            for n in &one.nodes {
                for k in 0..4 {
                    if n.count[k] != INNER {
                        for &i in &one.indices[n.child[k] as usize..(n.child[k] + n.count[k]) as usize] {
                            seen[i as usize] += 1;
                        }
                    }
                }
            }
            assert!(seen.iter().all(|&s| s == 1), "step {step}: every item in exactly one leaf");
        }
        // A cost per node visit keeps each pair in one leaf: fewer nodes.
        assert!(build(1, 0.5).nodes.len() < build(1, 0.0).nodes.len());
    }

    #[test]
    fn a_tree_built_in_regions_is_packed_with_every_node_reached_once() {
        // Enough items that the root's children are large too: regions within regions, each
        // with room to spare, closed up afterwards.
        let boxes: Vec<Aabb> = (0..5 * PARALLEL as u32)
            .map(|i| {
                let h = |k: u32| ((i.wrapping_mul(2_654_435_761).wrapping_add(k * 40_503)) % 10_007) as f32 / 10.0;
                let min = Vec3::new(h(1), h(2), h(3));
                Aabb { min, max: min + Vec3::splat(0.25) }
            })
            .collect();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(4).build().unwrap();
        let bvh = pool.install(|| Bvh::build_with(boxes.len(), |i| boxes[i], 0.5));
        assert_eq!(bvh.nodes.capacity(), bvh.nodes.len(), "the array is cut to the tree's size");
        // The root's children hold more than `PARALLEL` items each: regions within regions.
        let large = (0..4).filter(|&k| bvh.nodes[bvh.root as usize].count[k] == INNER).count();
        assert_eq!(large, 4, "the root's children are inner nodes");
        let mut reached = vec![0u32; bvh.nodes.len()];
        let mut stack = vec![bvh.root];
        while let Some(at) = stack.pop() {
            reached[at as usize] += 1;
            if reached[at as usize] > 1 {
                // A link back: stop before it loops.
                break;
            }
            let node = &bvh.nodes[at as usize];
            stack.extend((0..4).filter(|&k| node.count[k] == INNER).map(|k| node.child[k]));
        }
        let (missed, twice) = (reached.iter().filter(|&&r| r == 0).count(), reached.iter().filter(|&&r| r > 1).count());
        assert!(missed == 0 && twice == 0, "{missed} nodes unreached (gaps left in), {twice} reached twice");
        // And every item is found where its box is: a ray down through each box's centre.
        for (i, b) in boxes.iter().enumerate().step_by(997) {
            let c = b.centre();
            let mut found = false;
            bvh.traverse(c + Vec3::Z * 2000.0, -Vec3::Z, 4000.0, |item, tmax| {
                found |= item == i as u32;
                tmax
            });
            assert!(found, "item {i} not reached by a ray through its box");
        }
    }
}

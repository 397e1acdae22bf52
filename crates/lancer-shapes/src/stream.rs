//! Rays traced together through a small scene: object after object, eight rays at a time. A few
//! objects tested against a whole block of rays cost less than a walk down the BVH per ray:
//! spheres and planes are tested in world space with SIMD arithmetic, every other shape behind
//! a SIMD test of its world box (a torus then four rays at a time, the others one by one).
//!
//! Each ray's answer is the crossing with the smallest `t`, by the same arithmetic for each shape
//! as [`crate::Geometry::closest`] (which may pick another object only on an exact tie, two
//! surfaces at the same distance: here the first in test order wins, and for rays that see
//! through some objects, an object they do not see through). It depends on nothing but the ray,
//! so a ray traced alone or among others, on any thread, finds the same hit.

use glam::Vec3;
use wide::{CmpEq, CmpGe, CmpGt, CmpLe, CmpLt, f32x8, i32x8};

use crate::lanes::gt_max;
use crate::{Aabb, Lines, Object, ShapeHit};

/// Rays per SIMD group: eight, an AVX register (two SSE registers in the baseline x86-64
/// build, with the same results lane by lane).
const W: usize = 8;
type Fx = f32x8;
type Ix = i32x8;
/// Every lane of a group: the mask of a group whose lanes all pass.
const FULL: i32 = (1 << W) - 1;

/// The most bounded objects a scene may have for its rays to be traced object by object; more,
/// and each ray walks the BVH. Measured on a grid of spheres over a floor (640x360, one
/// thread, groups of eight rays), object by object against the BVH: 96 spheres 0.033 against
/// 0.043 s, 128 0.036 against 0.045 s, 192 0.044 against 0.047 s, 256 0.050 against 0.047 s.
pub(crate) const MOST_OBJECTS: usize = 128;

/// Rays per block: their columns stay on the stack.
const BLOCK: usize = 64;
const GROUPS: usize = BLOCK / W;
// Whole groups, and a group's lanes fit a mask.
const _: () = assert!(BLOCK.is_multiple_of(W) && W <= 32);

/// How an object is tested against a group of rays at once.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Test {
    /// A sphere scaled the same on every axis, in world space.
    Sphere { centre: Vec3, radius2: f32 },
    /// A plane in world space: unit normal and offset.
    Plane { normal: Vec3, offset: f32 },
    /// Any other object: its world box first (infinite for an unbounded one), then its own test
    /// for each ray that meets the box.
    Boxed { min: Vec3, max: Vec3 },
}

/// An object in the order rays meet them: the index it is known by, and its test.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Item {
    pub(crate) object: u32,
    pub(crate) test: Test,
    /// A sphere (centre, radius) around the object, a little larger than it; `None` when it is
    /// unbounded.
    pub(crate) bound: Option<(Vec3, f32)>,
}

/// The objects in the order they are tested: the cheapest first (planes, spheres, then the
/// others by their shape's cost), so the costly ones are reached with the nearest hit so far
/// and their box test drops most rays. Ties keep the scene's order.
pub(crate) fn plan(objects: &[Object], boxes: &[Option<Aabb>]) -> Vec<Item> {
    let mut items: Vec<(u32, Item)> = objects
        .iter()
        .zip(boxes)
        .enumerate()
        .map(|(i, (o, world))| {
            let (test, rank) = match o.world_test() {
                Some(test @ Test::Plane { .. }) => (test, 0),
                Some(test) => (test, 1),
                // The world box, widened against the slab test's rounding; infinite for an
                // unbounded object.
                None => {
                    let b = world.unwrap_or(Aabb { min: Vec3::NEG_INFINITY, max: Vec3::INFINITY });
                    let pad = Vec3::splat(b.min.abs().max(b.max.abs()).max_element() * PAD);
                    (Test::Boxed { min: b.min - pad, max: b.max + pad }, 2 + o.shape.cost_rank())
                }
            };
            // The smaller of the box's ball and the object's own (much the smaller for a
            // turned torus, whose box is loose), a little larger than it.
            let bound = world.map(|b| {
                let boxed = ((b.min + b.max) * 0.5, (b.max - b.min).length() * 0.5);
                let (centre, radius) = o.ball().filter(|own| own.1 < boxed.1).unwrap_or(boxed);
                (centre, radius * (1.0 + 1e-4) + centre.abs().max_element() * 1e-6)
            });
            (rank, Item { object: i as u32, test, bound: bound.filter(|(c, r)| c.is_finite() && r.is_finite()) })
        })
        .collect();
    items.sort_by_key(|(rank, item)| (*rank, item.object));
    items.into_iter().map(|(_, item)| item).collect()
}

/// A block's rays, [`W`] to a SIMD group, and the nearest hit of each so far.
struct Block {
    o: [[Fx; GROUPS]; 3],
    d: [[Fx; GROUPS]; 3],
    /// `1 / d`, for the box tests.
    inv: [[Fx; GROUPS]; 3],
    /// Lanes whose ray does not move along the axis (or so little that `1 / d` overflows): the
    /// box test checks their position instead of a distance.
    flat: [[Fx; GROUPS]; 3],
    /// How much wider a box is made for each lane: more than the rounding of its slab
    /// arithmetic, which grows with the origin's distance from the world's origin.
    pad: [Fx; GROUPS],
    /// The nearest hit so far (the ray's own limit to begin with; −1 on lanes past the end,
    /// which nothing passes).
    tmax: [Fx; GROUPS],
    skip: [Ix; GROUPS],
    /// Whether some lane has a flat axis.
    any_flat: bool,
    /// Whether `inv`, `flat` and `any_flat` are made for the rays loaded.
    slabs_ready: bool,
    /// Where every ray of the block stays, when they go roughly the same way.
    cone: Option<Cone>,
    best: [u32; BLOCK],
    hit: [ShapeHit; BLOCK],
    /// The nearest see-through object met (which does not shorten the ray), where it is met,
    /// and whether another see-through object is met too.
    seen: [u32; BLOCK],
    seen_hit: [ShapeHit; BLOCK],
    more: [bool; BLOCK],
}

const NONE: u32 = u32::MAX;

/// A box's widening per unit of its own largest coordinate, plus as much per unit of the ray
/// origin's: well above the relative rounding of the slab test (a few f32 epsilons), so a ray
/// the object's own test finds crossing it is never dropped at an edge or a face.
const PAD: f32 = 1e-5;

/// Every bit set: a lane's mask of "true".
const ALL: Fx = Fx::new([f32::from_bits(u32::MAX); W]);

thread_local! {
    /// Each thread's block, reused from call to call: a few kilobytes not cleared for every
    /// batch of shadow rays (only the lanes a call loads are read).
    static SCRATCH: std::cell::RefCell<Box<Block>> = std::cell::RefCell::new(Box::new(Block::new()));
}

/// For each ray `lane` of `lines`, the closest crossing with `0 < t < tmax(lane)` of any object
/// but its `skip`: `found(lane, object, crossing, alone)` for each ray that has one, in lane
/// order. The objects whose bit is set in `through` (see-through: the item at position `k` of
/// `items` is bit `k`) do not shorten a ray: every other object is tested over its whole length,
/// so `alone` tells that the ray meets nothing else than the see-through object it meets first
/// (always `false` when that object is not see-through). `toward`: the point every ray goes to
/// and stops at, when they all do (a block's cone is then made from there).
pub(crate) fn closest_each(
    objects: &[Object],
    items: &[Item],
    through: u128,
    toward: Option<Vec3>,
    lines: Lines<'_>,
    tmax: impl Fn(usize) -> f32,
    mut found: impl FnMut(usize, u32, &ShapeHit, bool),
) {
    SCRATCH.with(|cell| {
        // The thread's block, or one of its own when called again from inside `found`.
        let (mut shared, mut own);
        let block: &mut Block = match cell.try_borrow_mut() {
            Ok(b) => {
                shared = b;
                &mut shared
            }
            Err(_) => {
                own = Box::new(Block::new());
                &mut own
            }
        };
        for start in (0..lines.len()).step_by(BLOCK) {
            let n = (lines.len() - start).min(BLOCK);
            block.load(lines.range(start..start + n), |l| tmax(start + l), toward);
            if through == 0 {
                for item in items {
                    block.test::<false>(objects, item, n);
                }
                for lane in 0..n {
                    if block.best[lane] != NONE {
                        found(start + lane, block.best[lane], &block.hit[lane], false);
                    }
                }
                continue;
            }
            block.seen[..n].fill(NONE);
            block.more[..n].fill(false);
            for (k, item) in items.iter().enumerate() {
                if k < 128 && through >> k & 1 == 1 {
                    block.test::<true>(objects, item, n);
                } else {
                    block.test::<false>(objects, item, n);
                }
            }
            for lane in 0..n {
                let (best, seen) = (block.best[lane], block.seen[lane]);
                if seen != NONE && (best == NONE || block.seen_hit[lane].t < block.hit[lane].t) {
                    found(start + lane, seen, &block.seen_hit[lane], best == NONE && !block.more[lane]);
                } else if best != NONE {
                    found(start + lane, best, &block.hit[lane], false);
                }
            }
        }
    });
}

impl Block {
    fn new() -> Block {
        Block {
            o: [[Fx::ZERO; GROUPS]; 3],
            d: [[Fx::ZERO; GROUPS]; 3],
            inv: [[Fx::ZERO; GROUPS]; 3],
            flat: [[Fx::ZERO; GROUPS]; 3],
            pad: [Fx::ZERO; GROUPS],
            tmax: [Fx::ZERO; GROUPS],
            skip: [Ix::ZERO; GROUPS],
            any_flat: false,
            slabs_ready: false,
            cone: None,
            best: [NONE; BLOCK],
            hit: [ShapeHit { t: 0.0, normal: Vec3::ZERO, part: 0, bary: glam::Vec2::ZERO }; BLOCK],
            seen: [NONE; BLOCK],
            seen_hit: [ShapeHit { t: 0.0, normal: Vec3::ZERO, part: 0, bary: glam::Vec2::ZERO }; BLOCK],
            more: [false; BLOCK],
        }
    }

    /// Loads the rays of `lines` (at most [`BLOCK`]) with their limits, axis columns eight lanes
    /// at a time.
    fn load(&mut self, lines: Lines<'_>, tmax: impl Fn(usize) -> f32, toward: Option<Vec3>) {
        let n = lines.len();
        for g in 0..n.div_ceil(W) {
            let at = g * W;
            let (o, d) = (&lines.origin[g], &lines.dir[g]);
            for axis in 0..3 {
                (self.o[axis][g], self.d[axis][g]) = (Fx::new(o[axis]), Fx::new(d[axis]));
            }
            if at + W > n {
                // Lanes past the end repeat the first ray, which they never hit anything of.
                let (first_o, first_d) = (lines.origin(0), lines.dir(0));
                let past = Fx::new(std::array::from_fn(|k| if at + k < n { 0.0 } else { f32::from_bits(u32::MAX) }));
                for axis in 0..3 {
                    self.o[axis][g] = past.blend(Fx::splat(first_o[axis]), self.o[axis][g]);
                    self.d[axis][g] = past.blend(Fx::splat(first_d[axis]), self.d[axis][g]);
                }
            }
            let (mut limit, mut skipped) = ([-1.0f32; W], [NONE as i32; W]);
            for k in 0..W.min(n - at) {
                (limit[k], skipped[k]) = (tmax(at + k), lines.skip[at + k] as i32);
            }
            (self.tmax[g], self.skip[g]) = (Fx::new(limit), Ix::new(skipped));
            let [x, y, z] = [self.o[0][g].abs(), self.o[1][g].abs(), self.o[2][g].abs()];
            self.pad[g] = gt_max(x, gt_max(y, z)) * Fx::splat(PAD);
        }
        self.slabs_ready = false;
        self.best[..n].fill(NONE);
        self.cone = match toward {
            Some(target) => Cone::toward(&self.o, target, n.div_ceil(W), self.ends_from(target, n)),
            None => Cone::of_groups(&self.o, &self.d, n.div_ceil(W)),
        };
        #[cfg(debug_assertions)]
        if let Some(cone) = &self.cone {
            self.check_cone(cone, n);
        }
    }

    /// How far from `target` the first `n` rays end (`o + tmax d`): the cone from the target
    /// must reach that far around its apex. Infinite when a limit is not finite.
    fn ends_from(&self, target: Vec3, n: usize) -> f32 {
        let mut far = 0.0f32;
        for g in 0..n.div_ceil(W) {
            let (t, ox, oy, oz) =
                (self.tmax[g].to_array(), self.o[0][g].to_array(), self.o[1][g].to_array(), self.o[2][g].to_array());
            let (dx, dy, dz) = (self.d[0][g].to_array(), self.d[1][g].to_array(), self.d[2][g].to_array());
            for k in 0..W.min(n - g * W) {
                if !t[k].is_finite() {
                    return f32::INFINITY;
                }
                let end = Vec3::new(ox[k], oy[k], oz[k]) + t[k] * Vec3::new(dx[k], dy[k], dz[k]);
                far = far.max((end - target).length());
            }
        }
        far
    }

    /// The cone's contract (debug builds): every ray of the block, from its origin to its end,
    /// lies within the cone's reach, so no object a ray meets is culled.
    #[cfg(debug_assertions)]
    fn check_cone(&self, cone: &Cone, n: usize) {
        for g in 0..n.div_ceil(W) {
            let (t, o, d) = (self.tmax[g].to_array(), self.o.map(|c| c[g].to_array()), self.d.map(|c| c[g].to_array()));
            for k in 0..W.min(n - g * W) {
                let origin = Vec3::new(o[0][k], o[1][k], o[2][k]);
                let dir = Vec3::new(d[0][k], d[1][k], d[2][k]);
                for f in [0.0, 0.25, 0.5, 0.75, 1.0] {
                    let p = origin + (t[k] * f) * dir;
                    debug_assert!(
                        !p.is_finite() || cone.may_meet(p, 0.0),
                        "the block's cone leaves out ray {} at {f} of its length ({p})",
                        g * W + k
                    );
                }
            }
        }
    }

    /// What the box tests need of the first `n` rays (`1 / d` and the flat axes): made when
    /// the first box is tested, not for a block whose boxes the cone culls.
    fn prepare_slabs(&mut self, n: usize) {
        self.any_flat = false;
        for g in 0..n.div_ceil(W) {
            for axis in 0..3 {
                let d = self.d[axis][g];
                let flat = d.abs().cmp_lt(Fx::splat(f32::MIN_POSITIVE));
                self.any_flat |= flat.move_mask() != 0;
                self.flat[axis][g] = flat;
                self.inv[axis][g] = flat.blend(Fx::ZERO, Fx::ONE / d);
            }
        }
        self.slabs_ready = true;
    }

    /// Tests `item` against the first `n` rays, keeping each ray's nearest hit (with `SEE`, its
    /// nearest see-through object, which does not shorten the ray).
    #[inline(always)]
    fn test<const SEE: bool>(&mut self, objects: &[Object], item: &Item, n: usize) {
        if let (Some(cone), Some((centre, radius))) = (self.cone, item.bound)
            && !cone.may_meet(centre, radius)
        {
            return;
        }
        if !matches!(item.test, Test::Boxed { .. }) {
            self.test_groups::<false, SEE>(objects, item, n);
            return;
        }
        if !self.slabs_ready {
            self.prepare_slabs(n);
        }
        if self.any_flat {
            self.test_groups::<true, SEE>(objects, item, n);
        } else {
            self.test_groups::<false, SEE>(objects, item, n);
        }
    }

    #[inline(always)]
    fn test_groups<const FLAT: bool, const SEE: bool>(&mut self, objects: &[Object], item: &Item, n: usize) {
        let skip = Ix::splat(item.object as i32);
        for g in 0..n.div_ceil(W) {
            let (o, d) = ([self.o[0][g], self.o[1][g], self.o[2][g]], [self.d[0][g], self.d[1][g], self.d[2][g]]);
            let tmax = self.tmax[g];
            let skipped = self.skip[g].cmp_eq(skip).move_mask();
            if skipped == FULL {
                continue;
            }
            match item.test {
                Test::Sphere { centre, radius2 } => {
                    let (t, met) = sphere(o, d, centre, radius2, tmax);
                    self.keep::<SEE>(g, met & !skipped, t, item.object, Vec3::ZERO);
                }
                Test::Plane { normal, offset } => {
                    let (t, met) = plane(o, d, normal, offset, tmax);
                    self.keep::<SEE>(g, met & !skipped, t, item.object, Vec3::Y);
                }
                Test::Boxed { min, max } => {
                    let flat = [self.flat[0][g], self.flat[1][g], self.flat[2][g]];
                    let inv = [self.inv[0][g], self.inv[1][g], self.inv[2][g]];
                    let mut met = slabs::<FLAT>(o, inv, flat, min, max, self.pad[g], tmax) & !skipped;
                    let object = &objects[item.object as usize];
                    if matches!(object.shape, crate::Shape::Torus { .. }) {
                        // Four rays at a time (a torus: the checks before its quartic in SIMD).
                        while met != 0 {
                            let (mut k4, mut n) = ([0usize; 4], 0);
                            while met != 0 && n < 4 {
                                (k4[n], n) = (met.trailing_zeros() as usize, n + 1);
                                met &= met - 1;
                            }
                            let (o4, d4) = (k4.map(|k| lane_vec(&o, k)), k4.map(|k| lane_vec(&d, k)));
                            let limit = k4.map(|k| self.tmax[g].as_array_ref()[k]);
                            let found = object.intersect4(&o4, &d4, &limit, n).unwrap_or_default();
                            for (&k, c) in k4.iter().zip(found).take(n) {
                                if let Some(c) = c {
                                    self.found::<SEE>(g, k, item.object, c);
                                }
                            }
                        }
                    }
                    while met != 0 {
                        let k = met.trailing_zeros() as usize;
                        met &= met - 1;
                        let (ray_o, ray_d) = (lane_vec(&o, k), lane_vec(&d, k));
                        let limit = self.tmax[g].as_array_ref()[k];
                        if let Some(c) = object.intersect(ray_o, ray_d, 0.0, limit) {
                            self.found::<SEE>(g, k, item.object, c);
                        }
                    }
                }
            }
        }
    }

    /// Keeps the crossing `c` of `object` by the ray in lane `k` of group `g`: its nearest hit
    /// (with `SEE`, its nearest see-through object, which does not shorten the ray).
    #[inline(always)]
    fn found<const SEE: bool>(&mut self, g: usize, k: usize, object: u32, c: ShapeHit) {
        let lane = g * W + k;
        if SEE {
            self.see(lane, object, c);
        } else {
            self.tmax[g].as_array_mut()[k] = c.t;
            self.best[lane] = object;
            self.hit[lane] = c;
        }
    }

    /// Keeps the hits `t` of the lanes of group `g` set in `met` (a world-space test's: no part,
    /// its normal found later).
    #[inline(always)]
    fn keep<const SEE: bool>(&mut self, g: usize, mut met: i32, t: Fx, object: u32, normal: Vec3) {
        while met != 0 {
            let k = met.trailing_zeros() as usize;
            met &= met - 1;
            let t = t.as_array_ref()[k];
            if SEE {
                self.see(g * W + k, object, ShapeHit { t, normal, part: 0, bary: glam::Vec2::ZERO });
                continue;
            }
            self.tmax[g].as_array_mut()[k] = t;
            self.best[g * W + k] = object;
            self.hit[g * W + k] = ShapeHit { t, normal, part: 0, bary: glam::Vec2::ZERO };
        }
    }

    /// A see-through object met by ray `lane` at `c`: kept if it is the nearest such so far.
    #[inline]
    fn see(&mut self, lane: usize, object: u32, c: ShapeHit) {
        if self.seen[lane] != NONE {
            self.more[lane] = true;
            if c.t >= self.seen_hit[lane].t {
                return;
            }
        }
        (self.seen[lane], self.seen_hit[lane]) = (object, c);
    }
}

#[inline(always)]
fn lane_vec(v: &[Fx; 3], k: usize) -> Vec3 {
    Vec3::new(v[0].as_array_ref()[k], v[1].as_array_ref()[k], v[2].as_array_ref()[k])
}

/// `0 < t < tmax`, as [`Object::intersect`] accepts a crossing.
#[inline(always)]
fn within(t: Fx, tmax: Fx) -> Fx {
    t.cmp_gt(Fx::ZERO) & t.cmp_lt(tmax)
}

/// `a · b` in the order of glam's `Vec3::dot`: `(x x' + y y') + z z'`.
#[inline(always)]
fn dot(a: [Fx; 3], b: [Fx; 3]) -> Fx {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The sphere test of [`Object::intersect`] (`sphere_roots_world`, then the nearer root within
/// range, else the farther) on a group of rays: the same operations in the same order, so the same
/// bits. Returns the distances and the mask of lanes that hit.
#[inline(always)]
fn sphere(o: [Fx; 3], d: [Fx; 3], centre: Vec3, radius2: f32, tmax: Fx) -> (Fx, i32) {
    let oc = [o[0] - Fx::splat(centre.x), o[1] - Fx::splat(centre.y), o[2] - Fx::splat(centre.z)];
    let r2 = Fx::splat(radius2);
    let a = dot(d, d);
    let b = dot(oc, d);
    let s = b / a;
    let q = [oc[0] - s * d[0], oc[1] - s * d[1], oc[2] - s * d[2]];
    let disc = a * (r2 - dot(q, q));
    // No lane with real roots (the scalar test's own `disc`, so exactly the lanes it rejects):
    // no root or division more.
    if disc.cmp_ge(Fx::ZERO).move_mask() == 0 {
        return (Fx::ZERO, 0);
    }
    let c = dot(oc, oc) - r2;
    let h = (b + disc.sqrt().copysign(b)) ^ Fx::splat(-0.0);
    let (r0, r1) = (h / a, c / h);
    let ordered = r0.cmp_le(r1);
    let (t0, t1) = (ordered.blend(r0, r1), ordered.blend(r1, r0));
    let (ok0, ok1) = (within(t0, tmax), within(t1, tmax));
    let real = !a.cmp_eq(Fx::ZERO) & disc.cmp_ge(Fx::ZERO) & !h.cmp_eq(Fx::ZERO);
    (ok0.blend(t0, t1), (real & (ok0 | ok1)).move_mask())
}

/// The plane test of [`Object::intersect`] on a group of rays, with the same bits.
#[inline(always)]
fn plane(o: [Fx; 3], d: [Fx; 3], normal: Vec3, offset: f32, tmax: Fx) -> (Fx, i32) {
    let n = [Fx::splat(normal.x), Fx::splat(normal.y), Fx::splat(normal.z)];
    let along = dot(n, d);
    let t = (Fx::splat(offset) - dot(n, o)) / along;
    (t, (!along.cmp_eq(Fx::ZERO) & within(t, tmax)).move_mask())
}

/// The lanes whose ray meets the box `[min, max]`, widened by the lane's `pad`, within
/// `[0, tmax]` (faces included; a flat axis by the origin's position).
#[inline(always)]
fn slabs<const FLAT: bool>(o: [Fx; 3], inv: [Fx; 3], flat: [Fx; 3], min: Vec3, max: Vec3, pad: Fx, tmax: Fx) -> i32 {
    let mut near = Fx::ZERO;
    let mut far = tmax;
    let mut inside = ALL;
    for axis in 0..3 {
        let (lo, hi) = (Fx::splat(min[axis]) - pad, Fx::splat(max[axis]) + pad);
        let (t_lo, t_hi) = ((lo - o[axis]) * inv[axis], (hi - o[axis]) * inv[axis]);
        if FLAT {
            near = flat[axis].blend(near, near.max(t_lo.min(t_hi)));
            far = flat[axis].blend(far, far.min(t_lo.max(t_hi)));
            inside &= flat[axis].blend(lo.cmp_le(o[axis]) & hi.cmp_ge(o[axis]), inside);
        } else {
            near = near.max(t_lo.min(t_hi));
            far = far.min(t_lo.max(t_hi));
        }
    }
    (near.cmp_le(far) & inside).move_mask()
}

/// Where every ray of a block stays: within `spread` of the cone from `apex` around the unit
/// `axis` whose half-angle has sine `sin` and cosine `cos` (both a little generous, so rounding
/// never drops an object a ray meets).
#[derive(Clone, Copy, Debug)]
struct Cone {
    apex: Vec3,
    spread: f32,
    axis: Vec3,
    cos: f32,
    sin: f32,
}

/// The least of a group's lanes.
fn low(v: Fx) -> f32 {
    v.to_array().into_iter().fold(f32::INFINITY, f32::min)
}

/// The greatest of a group's lanes.
fn high(v: Fx) -> f32 {
    v.to_array().into_iter().fold(f32::NEG_INFINITY, f32::max)
}

/// The box of the origins `o` in the first `groups` groups; `None` if one is not finite.
fn origin_box(o: &[[Fx; GROUPS]; 3], groups: usize) -> Option<(Vec3, Vec3)> {
    let (mut lo, mut hi) = ([Fx::splat(f32::INFINITY); 3], [Fx::splat(f32::NEG_INFINITY); 3]);
    let mut finite = ALL;
    for axis in 0..3 {
        for &v in &o[axis][..groups] {
            // Not NaN and not infinite: `min`/`max` would pass over a NaN.
            finite &= v.abs().cmp_lt(Fx::splat(f32::INFINITY));
            (lo[axis], hi[axis]) = (lo[axis].min(v), hi[axis].max(v));
        }
    }
    if finite.move_mask() != FULL {
        return None;
    }
    Some((Vec3::new(low(lo[0]), low(lo[1]), low(lo[2])), Vec3::new(high(hi[0]), high(hi[1]), high(hi[2]))))
}

impl Cone {
    /// The cone of a block's rays `o + t d`, `t ≥ 0`, in its first `groups` groups;
    /// `None` if their directions spread over more than a half-space (or one is zero or not
    /// finite, or an origin is not finite).
    fn of_groups(o: &[[Fx; GROUPS]; 3], d: &[[Fx; GROUPS]; 3], groups: usize) -> Option<Cone> {
        let lanes = |v: Fx| v.to_array();
        let (min, max) = origin_box(o, groups)?;
        let apex = (min + max) * 0.5;
        let mut sum = [Fx::ZERO; 3];
        for (axis, sum) in sum.iter_mut().enumerate() {
            for &v in &d[axis][..groups] {
                *sum += v;
            }
        }
        // Any axis among the directions will do: the half-angle is measured from it.
        let axis = Vec3::new(lanes(sum[0]).iter().sum(), lanes(sum[1]).iter().sum(), lanes(sum[2]).iter().sum())
            .try_normalize()?;
        let (c, a) = (apex.to_array().map(Fx::splat), axis.to_array().map(Fx::splat));
        let (mut spread2, mut sin2, mut cos, mut sound) = (Fx::ZERO, Fx::ZERO, Fx::ONE, ALL);
        for g in 0..groups {
            let v = [o[0][g] - c[0], o[1][g] - c[1], o[2][g] - c[2]];
            spread2 = spread2.max(dot(v, v));
            let w = [d[0][g], d[1][g], d[2][g]];
            // sin² of the angle between `w` and the axis, and its cosine times |w|, without a
            // root; a zero, infinite or NaN direction makes `len2` unsound, and so does one so
            // short that its cross product with the axis loses its digits.
            let len2 = dot(w, w);
            sound &= len2.cmp_ge(Fx::splat(1e-30)) & len2.cmp_lt(Fx::splat(f32::INFINITY));
            let x = [w[1] * a[2] - w[2] * a[1], w[2] * a[0] - w[0] * a[2], w[0] * a[1] - w[1] * a[0]];
            sin2 = sin2.max(dot(x, x) / len2);
            cos = cos.min(dot(w, a));
        }
        // Within a half-space around the axis.
        if sound.move_mask() != FULL || cos.cmp_gt(Fx::ZERO).move_mask() != FULL {
            return None;
        }
        let sin = high(sin2).sqrt() * (1.0 + 1e-3) + 1e-6;
        let spread = high(spread2).sqrt() * (1.0 + 1e-4) + apex.abs().max_element() * 1e-6;
        let cone = Cone { apex, spread, axis, cos: (1.0 - sin * sin).max(0.0).sqrt(), sin };
        (sin < 1.0 && apex.is_finite() && spread.is_finite()).then_some(cone)
    }

    /// The cone of a block's rays that all go to `target` and stop near it, none farther from it
    /// than `ends` (shadow rays aimed at a point light from their starts): from the target,
    /// around the line to the centre of the box of their origins, wide enough for that box's
    /// ball, reaching `ends` (and a little more) around its apex and side: a ray's segment from
    /// its origin to its end is within that of the segment from its origin to the target, which
    /// the cone holds. One pass over the origins, where [`Cone::of_groups`] makes two. `None`
    /// when the target is within the ball (or anything is not finite).
    fn toward(o: &[[Fx; GROUPS]; 3], target: Vec3, groups: usize, ends: f32) -> Option<Cone> {
        let (min, max) = origin_box(o, groups)?;
        if !target.is_finite() {
            return None;
        }
        let centre = (min + max) * 0.5;
        // The box's half diagonal, a little generous: every origin is within it of the centre.
        let radius = (max - min).length() * 0.5 * (1.0 + 1e-4) + centre.abs().max_element() * 1e-6;
        let v = centre - target;
        let distance = v.length();
        let sin = radius / distance * (1.0 + 1e-3) + 1e-6;
        // Where the rays end, from the target (the rounding of each one's direction over its
        // length), measured; with a margin for the rounding of the measure, and no less than a
        // slack for rounding itself.
        let spread = (ends * (1.0 + 1e-4)).max((target.abs().max_element() + distance) * 1e-5);
        let axis = v / distance;
        let cone = Cone { apex: target, spread, axis, cos: (1.0 - sin * sin).max(0.0).sqrt(), sin };
        (sin < 1.0 && distance.is_finite() && axis.is_finite() && spread.is_finite()).then_some(cone)
    }

    /// Whether a ray of the block may meet the ball of `radius` around `centre`: the ball comes
    /// within `spread` of the cone.
    #[inline]
    fn may_meet(&self, centre: Vec3, radius: f32) -> bool {
        let v = centre - self.apex;
        let r = (radius + self.spread) * (1.0 + 1e-4) + v.length() * 1e-5;
        let vv = v.dot(v);
        if vv <= r * r {
            return true;
        }
        // In the plane of the axis and the centre: x along the axis, y away from it.
        let (x, y) = (v.dot(self.axis), v.cross(self.axis).length());
        // Beyond the apex's side (the nearest point of the cone is its apex) or within `r` of
        // its side.
        x * self.cos + y * self.sin > 0.0 && y * self.cos - x * self.sin <= r
    }
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Quat, Vec3};

    use super::{BLOCK, MOST_OBJECTS};
    use crate::{Csg, CsgNode, CsgOp, Geometry, Lines, NO_SKIP, Object, Shape, ShapeHit};

    /// A scene of `count` objects of every kind (a mesh too), `size` across, `far` away from
    /// the world's origin.
    fn scene(f: &mut impl FnMut(f32, f32) -> f32, count: usize, size: f32, far: Vec3) -> Geometry {
        let mesh = Shape::Mesh(std::sync::Arc::new(crate::mesh::tests::octahedron()));
        // A sphere minus a cube (bounded) and a sphere joined to a plane's half-space (unbounded:
        // tested behind an infinite box).
        let csg = |op: CsgOp, second: Shape| {
            let leaf = |shape: Shape, at: Vec3| CsgNode::Leaf { shape, node_from_leaf: Affine3A::from_translation(at) };
            let nodes = vec![
                leaf(Shape::Sphere, Vec3::ZERO),
                leaf(second, Vec3::new(0.5, 0.3, 0.0)),
                CsgNode::Op { op, a: 0, b: 1 },
            ];
            Shape::Csg(std::sync::Arc::new(Csg::new(nodes, 2).unwrap()))
        };
        let kinds = [
            csg(CsgOp::Difference, Shape::Cube),
            csg(CsgOp::Union, Shape::Plane),
            Shape::Sphere,
            Shape::Sphere,
            Shape::Cube,
            Shape::Plane,
            Shape::Cylinder,
            Shape::Cone,
            Shape::Torus { minor: 0.3 },
            Shape::Disk,
            mesh,
        ];
        let objects = (0..count)
            .map(|k| {
                let shape = kinds[(f(0.0, kinds.len() as f32) as usize).min(kinds.len() - 1)].clone();
                // Every other object scaled the same on every axis (a sphere's world-space test),
                // every third one not turned (boxes whose faces rays run along).
                let s = f(0.3, 1.5) * size;
                let scale =
                    if k % 2 == 0 { Vec3::splat(s) } else { Vec3::new(s, f(0.3, 1.5) * size, f(0.3, 1.5) * size) };
                let turn = if k % 3 == 0 {
                    Quat::IDENTITY
                } else {
                    Quat::from_euler(glam::EulerRot::XYZ, f(-3.0, 3.0), f(-3.0, 3.0), f(-3.0, 3.0))
                };
                let at = far + Vec3::new(f(-6.0, 6.0), f(-6.0, 6.0), f(-6.0, 6.0)) * size;
                Object::new(shape, Affine3A::from_scale_rotation_translation(scale, turn, at), 0).unwrap()
            })
            .collect();
        Geometry::new(objects)
    }

    /// The closest crossing by every object's own test, in scene order (no box, no cull).
    fn every_object(g: &Geometry, o: Vec3, d: Vec3, skip: u32, tmax: f32) -> Option<(u32, ShapeHit)> {
        let mut best = None;
        let mut tmax = tmax;
        for (i, object) in g.objects.iter().enumerate() {
            if i as u32 != skip
                && let Some(c) = object.intersect(o, d, 0.0, tmax)
            {
                tmax = c.t;
                best = Some((i as u32, c));
            }
        }
        best
    }

    #[test]
    fn rays_that_see_through_some_objects_get_the_first_crossing_and_whether_it_is_alone() {
        // Scenes of every kind of object with a random third of them see-through, and rays from
        // inside and outside them: each ray's first crossing is the closest of every object's
        // own test, and `alone` says exactly that it is a see-through object's and that no other
        // object's test finds a crossing within the ray's limit. The BVH path (a scene with too
        // many objects for blocks) gives the same answers.
        let mut f = crate::testing::uniform(0x51ED_270B_3C4A_9F17);
        let (mut alone_seen, mut crowded, mut total) = (0, 0, 0);
        for case in 0..240 {
            let count = if case % 8 == 7 { MOST_OBJECTS + 5 } else { 2 + case % 40 };
            let g = scene(&mut f, count, 1.0, Vec3::ZERO);
            let see: Vec<bool> = (0..g.objects.len()).map(|_| f(0.0, 3.0) < 1.0).collect();
            let (mut origin, mut dir, mut skip, mut limit) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
            for k in 0..100 {
                // From inside an object now and then (as a shadow ray leaving glass does).
                let o = if k % 4 == 0 {
                    let b = g.objects[k % g.objects.len()].bounds().unwrap_or(crate::Aabb::EMPTY);
                    if b.min.is_finite() && b.max.is_finite() { (b.min + b.max) * 0.5 } else { Vec3::ZERO }
                } else {
                    Vec3::new(f(-10.0, 10.0), f(-10.0, 10.0), f(-10.0, 10.0))
                };
                origin.push(o);
                dir.push(Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)).normalize_or(Vec3::X));
                skip.push(if k % 9 == 0 { (k % g.objects.len()) as u32 } else { NO_SKIP });
                limit.push(if k % 3 == 0 { f(0.0, 15.0) } else { f32::INFINITY });
            }
            let (o_packets, d_packets) = (crate::testing::packets(&origin), crate::testing::packets(&dir));
            let lines = Lines { origin: &o_packets, dir: &d_packets, skip: &skip };
            let mut got = vec![None; origin.len()];
            g.first_each_through(
                lines,
                None,
                |l| limit[l],
                |i| see[i as usize],
                |l, i, c, alone| got[l] = Some((i, *c, alone)),
            );
            for l in 0..origin.len() {
                let truth = every_object(&g, origin[l], dir[l], skip[l], limit[l]).map(|(i, c)| {
                    let others = (0..g.objects.len() as u32).any(|j| {
                        j != i
                            && j != skip[l]
                            && g.objects[j as usize].intersect(origin[l], dir[l], 0.0, limit[l]).is_some()
                    });
                    (i, c.t, see[i as usize] && !others)
                });
                let got_l = got[l].map(|(i, c, alone)| (i, c.t, alone));
                assert_eq!(got_l, truth, "case {case}, ray {l}: {} + t {}", origin[l], dir[l]);
                total += usize::from(truth.is_some());
                alone_seen += usize::from(truth.is_some_and(|t| t.2));
                crowded += usize::from(truth.is_some_and(|t| see[t.0 as usize] && !t.2));
            }
        }
        assert!(total > 5_000 && alone_seen > 500 && crowded > 500, "{total} hits, {alone_seen} alone, {crowded} not");
    }

    #[test]
    fn every_ray_gets_the_hit_of_every_objects_own_test_alone_or_in_a_block() {
        let mut f = crate::testing::uniform(0x9E37_79B9_7F4A_7C15);
        let mut hits = 0;
        for case in 0..400 {
            // Unit-sized scenes near the origin, tiny ones, and ones 10⁴ and 10⁵ units away.
            let (size, far) =
                [(1.0, Vec3::ZERO), (1e-3, Vec3::ZERO), (1.0, Vec3::splat(1e4)), (0.1, Vec3::new(-1e5, 3e4, 2e5))]
                    [case / 3 % 4];
            let g = scene(&mut f, 1 + case % MOST_OBJECTS, size, far);
            assert!(!g.stream.is_empty() || g.lone_mesh, "a small scene is traced object by object");
            let (mut origin, mut dir, mut skip, mut limit) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
            // A camera's rays (one origin, close directions, and an odd one out now and then),
            // rays grazing the objects (a bounding sphere's rim, a box's edges and faces, along
            // the axes: where a cull or a box test that is too tight would lose hits), and rays
            // in every direction.
            let eye = far + Vec3::new(f(-15.0, 15.0), f(-15.0, 15.0), f(-15.0, 15.0)) * size;
            let aim = far + Vec3::new(f(-4.0, 4.0), f(-4.0, 4.0), f(-4.0, 4.0)) * size;
            for k in 0..150 {
                let item = g.stream.get(k % g.stream.len().max(1)).copied();
                let (centre, radius) = item.and_then(|i| i.bound).unwrap_or((far, size));
                let (o, d) = match case % 3 {
                    0 if k % 32 != 31 => (eye, aim - eye + Vec3::new(f(-0.3, 0.3), f(-0.3, 0.3), f(-0.3, 0.3)) * size),
                    1 if k % 2 == 0 => {
                        let side = (centre - eye).normalize().any_orthonormal_vector();
                        (eye, centre + side * radius * (1.0 + f(-1e-3, 1e-3)) - eye)
                    }
                    1 => {
                        // Along an axis, through a corner region of the object's box.
                        let b = g.objects[item.map_or(0, |i| i.object) as usize].bounds().unwrap_or(crate::Aabb::EMPTY);
                        let axis = k / 2 % 3;
                        let mut o = Vec3::new(f(b.min.x, b.max.x), f(b.min.y, b.max.y), f(b.min.z, b.max.z));
                        let corner = if k % 4 < 2 { b.min } else { b.max };
                        o[(axis + 1) % 3] = corner[(axis + 1) % 3] * (1.0 + f(-1e-6, 1e-6));
                        o[axis] = centre[axis] - 10.0 * size;
                        (o, Vec3::AXES[axis])
                    }
                    _ => (
                        far + Vec3::new(f(-10.0, 10.0), f(-10.0, 10.0), f(-10.0, 10.0)) * size,
                        Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)),
                    ),
                };
                origin.push(o);
                dir.push(d);
                // A group's worth of rays in a row that ignore the same object (as secondary rays
                // leaving it do), now and then.
                skip.push(if (k / super::W).is_multiple_of(5) {
                    (k / super::W % g.objects.len()) as u32
                } else {
                    NO_SKIP
                });
                limit.push(if k % 5 == 0 { f(0.0, 20.0) * size } else { f32::INFINITY });
            }
            // Now and then a block with a zero, a NaN and a very short direction among the others.
            if case % 5 == 4 {
                (dir[17], dir[33], dir[49]) = (Vec3::ZERO, Vec3::NAN, dir[49] * 1e-18);
            }
            let mut each = vec![None; origin.len()];
            let (o_packets, d_packets) = (crate::testing::packets(&origin), crate::testing::packets(&dir));
            let lines = Lines { origin: &o_packets, dir: &d_packets, skip: &skip };
            g.closest_each(lines, |l| limit[l], |l, i, c| each[l] = Some((i, *c)));
            for l in 0..origin.len() {
                let truth = every_object(&g, origin[l], dir[l], skip[l], limit[l]);
                assert_eq!(each[l], truth, "case {case}, ray {l}: {} + t {}", origin[l], dir[l]);
                let mut single = None;
                let (o_alone, d_alone) =
                    (crate::testing::packets(&origin[l..=l]), crate::testing::packets(&dir[l..=l]));
                let alone = Lines { origin: &o_alone, dir: &d_alone, skip: &skip[l..=l] };
                g.closest_each(alone, |_| limit[l], |_, i, c| single = Some((i, *c)));
                assert_eq!(single, truth, "case {case}, ray {l} alone");
                hits += usize::from(truth.is_some());
            }
        }
        assert!(hits > 15_000, "{hits} hits: the cases must hit things");
    }

    #[test]
    fn a_cone_from_the_light_keeps_every_ball_a_shadow_ray_meets() {
        // Blocks of shadow rays as the visibility system makes them: from hit points (spread
        // over up to a few units, near the origin or 10⁴ away), each started a hair off its
        // point, along the unit direction from the point to the light and as long as what is
        // left of that distance. Balls on a ray's segment, their surface a millionth of their
        // radius from it, are never culled; balls elsewhere often are.
        let mut f = crate::testing::uniform(0x6A09_E667_F3BC_C908);
        let (mut met, mut culled) = (0, 0);
        for case in 0..2_000 {
            let far = if case % 4 == 0 { 1e4 } else { 1.0 };
            let base = Vec3::new(f(-20.0, 20.0), f(-20.0, 20.0), f(-20.0, 20.0)) * far;
            let spread = [1e-3, 0.3, 3.0][case % 3];
            let light =
                base + Vec3::new(f(-1.0, 1.0), f(0.2, 1.0), f(-1.0, 1.0)).normalize() * f(2.0, 40.0) * (1.0 + spread);
            let lanes = if case % 9 == 0 { 1 } else { BLOCK };
            let (mut origin, mut dir, mut left) = (Vec::new(), Vec::new(), Vec::new());
            for lane in 0..lanes {
                // Every fourth hit at a corner of the box: the ball around it is no wider.
                let sign = |x: f32| if x < 0.0 { -1.0 } else { 1.0 };
                let mut at = Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0));
                if lane % 4 == 0 {
                    at = at.map(sign);
                }
                let point = base + at * spread;
                let to = light - point;
                let (d, dist) = (to.normalize(), to.length());
                let offset = Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)) * point.abs().max_element() * 1e-6;
                origin.push(point + offset);
                dir.push(d);
                left.push(dist - offset.dot(d));
            }
            let mut block = super::Block::new();
            let (o_packets, d_packets) = (crate::testing::packets(&origin), crate::testing::packets(&dir));
            let lines = Lines { origin: &o_packets, dir: &d_packets, skip: &[super::NONE; BLOCK][..lanes] };
            block.load(lines, |l| left[l], Some(light));
            let Some(cone) = block.cone else { continue };
            for _ in 0..20 {
                // Small balls near the origins too, where a cone too narrow would show.
                let k = (f(0.0, lanes as f32) as usize).min(lanes - 1);
                let radius = if met % 2 == 0 { f(1e-3, 2.0) * far.sqrt() } else { f(1e-6, 1e-4) * spread };
                let along = origin[k] + dir[k] * f(0.0, if met % 2 == 0 { 1.0 } else { 0.05 }) * left[k];
                let off = dir[k].any_orthonormal_vector() * radius * (1.0 - 1e-6);
                assert!(cone.may_meet(along + off, radius), "case {case}: a ball on ray {k} was culled");
                met += 1;
                let away = light + (light - base).normalize() * f(1.0, 30.0) * (1.0 + spread) * far.sqrt();
                culled += usize::from(!cone.may_meet(away, 0.1));
            }
        }
        assert!(met > 30_000 && culled > 10_000, "{met} kept, {culled} culled");
    }

    #[test]
    fn regression_a_cone_from_the_light_holds_shadow_rays_spawned_off_objects_of_any_scale() {
        // Found in review: the cone assumed every shadow ray ends at the light; a ray spawned
        // off a floor scaled 10⁶ started units below it, kept its direction from the hit point
        // and ended units beside the light, and the cone culled what it met there. Here the
        // rays are made as the shading crate makes them, by `Geometry::spawn` off real hits on
        // objects scaled 10⁻³ to 10⁶, both kept along the direction from the hit point (as
        // before) and aimed at the light from their start (as now): every ray's first crossing
        // through the block tracer with the light's cone is every object's own test's.
        let mut f = crate::testing::uniform(0x3C6E_F372_FE94_F82B);
        let mut checked = 0;
        for case in 0..60 {
            let scale: f32 = [1e-3, 1.0, 1e3, 1e6][case % 4];
            let mut objects = vec![
                Object::new(
                    Shape::Cube,
                    Affine3A::from_scale_rotation_translation(
                        Vec3::splat(1e6),
                        Quat::IDENTITY,
                        Vec3::new(0.0, -1e6, 0.0),
                    ),
                    0,
                )
                .unwrap(),
            ];
            for k in 0..6 {
                let shape = [Shape::Cube, Shape::Sphere, Shape::Torus { minor: 0.3 }][k % 3].clone();
                let size = Vec3::new(f(0.2, 1.0), f(0.2, 1.0), f(0.2, 1.0)) * scale.min(3.0);
                let turn = Quat::from_euler(glam::EulerRot::XYZ, f(-3.0, 3.0), f(-3.0, 3.0), f(-3.0, 3.0));
                let at = Vec3::new(f(-6.0, 6.0), f(0.5, 4.0), f(-6.0, 6.0));
                objects.push(Object::new(shape, Affine3A::from_scale_rotation_translation(size, turn, at), 0).unwrap());
            }
            // One of the case's scale: a wall beside the others.
            let wall = Affine3A::from_scale_rotation_translation(
                Vec3::splat(scale),
                Quat::from_rotation_y(0.3),
                Vec3::new(scale * 1.5 + 7.0, 0.0, 0.0),
            );
            objects.push(Object::new(Shape::Cube, wall, 0).unwrap());
            // Small balls near where the light is, which a ray ending beside it meets.
            let light = Vec3::new(f(-3.0, 3.0), f(6.0, 12.0), f(-3.0, 3.0));
            for _ in 0..4 {
                let at = light + Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)) * 0.2;
                objects.push(
                    Object::new(
                        Shape::Sphere,
                        Affine3A::from_scale_rotation_translation(Vec3::splat(0.05), Quat::IDENTITY, at),
                        0,
                    )
                    .unwrap(),
                );
            }
            let g = Geometry::new(objects.clone());
            assert!(!g.stream.is_empty());
            let eye = Vec3::new(f(-2.0, 2.0), f(3.0, 6.0), -12.0);
            // 0: along the direction from the hit point; 1: aimed from the start; 2: started
            // units off the point (as the old offsets did beside a floor scaled 10⁶), along the
            // direction from the hit point, so it ends units beside the light.
            for style in 0..3 {
                let aimed = style == 1;
                let (mut origin, mut dir, mut skip, mut left) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
                // A tile's worth of camera rays: hits close together, as a block's are.
                let patch = Vec3::new(f(-6.0, 6.0), 0.0, f(-5.0, 5.0));
                for _ in 0..20 * BLOCK {
                    if origin.len() == BLOCK {
                        break;
                    }
                    let to = patch + Vec3::new(f(-0.3, 0.3), f(-0.05, 0.05), f(-0.3, 0.3));
                    let Some(hit) = g.closest_hit(crate::Origin::free(eye), (to - eye).normalize(), 0.0, f32::INFINITY)
                    else {
                        continue;
                    };
                    let (d0, dist) = ((light - hit.point).normalize(), (light - hit.point).length());
                    if hit.normal.dot(d0) <= 0.0 {
                        continue;
                    }
                    let mut from = g.spawn(&hit, d0);
                    if style == 2 {
                        from.point -= hit.normal * 5.7;
                    }
                    let (d, l) = if aimed {
                        ((light - from.point).normalize(), (light - from.point).length())
                    } else {
                        (d0, dist - (from.point - hit.point).dot(d0))
                    };
                    origin.push(from.point);
                    dir.push(d);
                    skip.push(from.skip);
                    left.push(l);
                }
                if origin.len() < BLOCK {
                    // The patch is in shadow from its own surface: no shadow rays to make.
                    continue;
                }
                // Tiny balls near the ends of some rays, which those rays meet.
                let mut with_balls = objects.clone();
                for l in (0..BLOCK).step_by(5) {
                    let at = origin[l] + dir[l] * left[l] * 0.97;
                    let ball = Affine3A::from_scale_rotation_translation(Vec3::splat(0.01), Quat::IDENTITY, at);
                    with_balls.push(Object::new(Shape::Sphere, ball, 0).unwrap());
                }
                let g = Geometry::new(with_balls);
                assert!(!g.stream.is_empty());
                let (o_packets, d_packets) = (crate::testing::packets(&origin), crate::testing::packets(&dir));
                let lines = Lines { origin: &o_packets, dir: &d_packets, skip: &skip };
                let mut got = vec![None; BLOCK];
                g.first_each_through(lines, Some(light), |l| left[l], |_| false, |l, i, c, _| got[l] = Some((i, c.t)));
                for l in 0..BLOCK {
                    let truth = every_object(&g, origin[l], dir[l], skip[l], left[l]).map(|(i, c)| (i, c.t));
                    assert_eq!(got[l], truth, "case {case} (scale {scale}, style {style}), ray {l}");
                    checked += usize::from(truth.is_some());
                }
            }
        }
        assert!(checked > 1000, "{checked} rays met something");
    }

    #[test]
    fn a_block_cone_keeps_every_ball_one_of_its_rays_meets() {
        let mut f = crate::testing::uniform(0x2545_F491_4F6C_DD1D);
        let (mut met, mut culled) = (0, 0);
        for case in 0..2_000 {
            // Each choice drawn on its own: spreads, widths, blocks near the origin and 10⁵ units
            // away, blocks of one ray.
            let pick = |f: &mut dyn FnMut(f32, f32) -> f32, n: usize| (f(0.0, n as f32) as usize).min(n - 1);
            let spread = [0.0, 1e-3, 0.5, 3.0][pick(&mut f, 4)];
            let far_away = if pick(&mut f, 4) == 0 { 2_000.0 } else { 1.0 };
            let base = Vec3::new(f(-50.0, 50.0), f(-50.0, 50.0), f(-50.0, 50.0)) * far_away;
            let lanes = if pick(&mut f, 8) == 0 { 1 } else { BLOCK };
            let towards = Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0));
            let width = [1e-4, 1e-2, 0.3, 1.5][pick(&mut f, 4)];
            let origin: Vec<Vec3> =
                (0..lanes).map(|_| base + Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)) * spread).collect();
            let dir: Vec<Vec3> =
                (0..lanes).map(|_| towards + Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)) * width).collect();
            let mut block = super::Block::new();
            let (o_packets, d_packets) = (crate::testing::packets(&origin), crate::testing::packets(&dir));
            let lines = Lines { origin: &o_packets, dir: &d_packets, skip: &[super::NONE; BLOCK][..lanes] };
            block.load(lines, |_| f32::INFINITY, None);
            let Some(cone) = block.cone else { continue };
            for _ in 0..20 {
                // A ball on one of the rays, just touching it or clear of all of them.
                let k = (f(0.0, lanes as f32) as usize).min(lanes - 1);
                let radius = f(1e-3, 2.0);
                let along = origin[k] + dir[k].normalize() * f(0.0, 80.0);
                // Half the balls graze the ray: their surface a millionth of the radius from it.
                let reach = if case % 2 == 0 { 1.0 - 1e-6 } else { f(0.0, 0.999) };
                let off = dir[k].normalize().any_orthonormal_vector() * radius * reach;
                assert!(cone.may_meet(along + off, radius), "case {case}: a ball on ray {k} was culled");
                met += 1;
                let far = base - towards.normalize() * f(10.0, 100.0) * (1.0 + spread) + off;
                culled += usize::from(!cone.may_meet(far, 0.5 * f(0.0, 1.0)) && spread < 1.0 && far_away == 1.0);
            }
        }
        assert!(met > 10_000 && culled > 1_000, "{met} kept, {culled} culled");
    }
}

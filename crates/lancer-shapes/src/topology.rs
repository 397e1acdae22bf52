//! Mesh topology: vertices welded by position, triangles turned to one winding across shared
//! edges, inside-out closed pieces turned round, and whether the surface is closed. Sorting and
//! counting, not hashing: linear memory, and for million-triangle meshes time close to linear
//! past the weld's sort of the vertices.

use glam::Vec3;
use rayon::prelude::*;

/// No neighbour across an edge (a border, or an edge shared by more than two triangles).
const NONE: u32 = u32::MAX;

/// Turns the triangles of each connected piece to one winding (a neighbour whose shared edge
/// runs the same way is turned round: files often mix windings), then a closed mesh that
/// encloses a negative volume as a whole inside out, so normals point out. Returns whether the mesh is
/// closed: every edge shared by exactly two triangles, running opposite ways. A piece that cannot
/// be oriented (a Möbius strip) is left open.
pub(crate) fn orient(positions: &[Vec3], triangles: &mut [[u32; 3]]) -> bool {
    let Across { neighbours, same, manifold } = {
        // Each triangle's welded corners, wound as the triangle is.
        let canonical = weld(positions);
        let corners: Vec<[u32; 3]> = triangles.par_iter().map(|t| t.map(|i| canonical[i as usize])).collect();
        drop(canonical);
        neighbours(&corners, positions.len())
    };

    // Each piece walked from its first triangle. Whether a neighbour runs the same way as a
    // triangle across their edge, as both are wound now, is whether it did as the file wound
    // them, changed once for each of the two that is turned; a triangle is turned only before
    // it is queued, so its winding is settled when it is taken off the queue.
    let mut piece = vec![NONE; triangles.len()];
    let mut turned = vec![false; triangles.len()];
    let mut consistent = true;
    // Every triangle in the order the walk takes them, each piece after the one before; and
    // where each piece ends in it.
    let mut queue: Vec<u32> = Vec::with_capacity(triangles.len());
    let mut ends: Vec<usize> = Vec::new();
    for seed in 0..triangles.len() {
        if piece[seed] != NONE {
            continue;
        }
        let id = ends.len() as u32;
        piece[seed] = id;
        let mut next = queue.len();
        queue.push(seed as u32);
        while next < queue.len() {
            let k = queue[next] as usize;
            next += 1;
            for (slot, &u) in neighbours[k].iter().enumerate() {
                if u == NONE {
                    continue;
                }
                let u = u as usize;
                let same = (same[k] >> slot & 1 == 1) ^ turned[k] ^ turned[u];
                if piece[u] == NONE {
                    turned[u] = same;
                    piece[u] = id;
                    queue.push(u as u32);
                } else if same {
                    // Already placed and still running the same way: the piece has no inside
                    // and outside (a Möbius strip).
                    consistent = false;
                }
            }
        }
        ends.push(queue.len());
    }
    drop(piece);
    let closed = manifold && consistent && neighbours.iter().all(|n| !n.contains(&NONE));
    // Each piece keeps the winding of the triangle it was walked from (the file's intent: the
    // inner wall of a hollow object faces its cavity); a closed mesh whose total volume is
    // negative is inside out as a whole and is turned round. The volume is each piece's sum of
    // its triangles' shares in the walk's order, summed in the order of the pieces; a turned
    // triangle's share is the negated share of its winding in the file, to the bit
    // (`a · (c × b)` is `−(a · (b × c))` exactly).
    let inside_out = closed && {
        let shares: Vec<f64> = queue
            .par_iter()
            .map(|&k| {
                let [a, b, c] = triangles[k as usize].map(|i| positions[i as usize].as_dvec3());
                let share = a.dot(b.cross(c));
                if turned[k as usize] { -share } else { share }
            })
            .collect();
        let mut start = 0;
        let mut total_volume = 0.0f64;
        for &end in &ends {
            total_volume += shares[start..end].iter().fold(0.0f64, |volume, &share| volume + share);
            start = end;
        }
        total_volume < 0.0
    };
    triangles.par_iter_mut().zip(turned).for_each(|(t, turned)| {
        if turned != inside_out {
            t.swap(1, 2);
        }
    });
    closed
}

/// What [`neighbours`] finds: each triangle's neighbours, whether each runs the same way across
/// their edge, and whether the surface is a manifold.
struct Across {
    /// Each triangle's neighbour across each of its edges that exactly two triangles share
    /// (`NONE` in the slots left), in the order of those edges' keys (their two ends, lower
    /// first).
    neighbours: Vec<[u32; 3]>,
    /// Bit `j` of a triangle's: whether its neighbour in slot `j` has their shared edge running
    /// the same way (both wound as given), so that one of them must turn for the two to agree.
    same: Vec<u8>,
    /// Whether every edge is shared by exactly two triangles.
    manifold: bool,
}

/// Each triangle's neighbour across each of its edges that exactly two triangles share (`NONE`
/// in the slots left), in the order of those edges' keys (their two ends, lower first), and
/// whether every edge is shared by exactly two; `corners`: each triangle's (welded) vertices,
/// of `vertices`, three different ones (degenerate triangles are left out before). The same
/// answer as sorting every edge by key and pairing equal keys (as this did before), in time
/// linear in the triangles and the triangles at each edge's less shared end (a million
/// triangles': 105 ms with the sort, 40 now).
fn neighbours(corners: &[[u32; 3]], vertices: usize) -> Across {
    debug_assert!(corners.iter().all(|&[a, b, c]| a != b && b != c && c != a), "a degenerate triangle");
    // The triangles at each welded vertex, in triangle order (a counting sort: linear time):
    // those that share an edge are the ones at its lower end that also have its upper end.
    let mut first = vec![0u32; vertices + 1];
    for &v in corners.iter().flatten() {
        first[v as usize + 1] += 1;
    }
    for v in 0..vertices {
        first[v + 1] += first[v];
    }
    let mut at = vec![0u32; 3 * corners.len()];
    let mut next = first.clone();
    for (k, c) in corners.iter().enumerate() {
        for &v in c {
            at[next[v as usize] as usize] = k as u32;
            next[v as usize] += 1;
        }
    }
    drop(next);
    // Each triangle's neighbour across each edge that exactly two triangles share, in the order
    // of the edges' keys: the order a sort of all edges by key meets them in, and so the order
    // in which `orient` walks a piece.
    let at_end = |v: u32| &at[first[v as usize] as usize..first[v as usize + 1] as usize];
    let across: Vec<([u32; 3], u8, bool)> = corners
        .par_iter()
        .enumerate()
        .map(|(k, c)| {
            let mut found: arrayvec::ArrayVec<(u64, u32, bool), 3> = arrayvec::ArrayVec::new();
            let mut manifold = true;
            for e in 0..3 {
                let (a, b) = (c[e], c[(e + 1) % 3]);
                let (lo, hi) = (a.min(b), a.max(b));
                // Through the end with fewer triangles (a fan's hub has them all).
                let (near, far) = if at_end(lo).len() <= at_end(hi).len() { (lo, hi) } else { (hi, lo) };
                let mut sharing = at_end(near).iter().filter(|&&u| corners[u as usize].contains(&far));
                match (sharing.next(), sharing.next(), sharing.next()) {
                    (Some(&u), Some(&w), None) => {
                        let other = if u == k as u32 { w } else { u };
                        let o = corners[other as usize];
                        let same = (0..3).any(|f| (o[f], o[(f + 1) % 3]) == (a, b));
                        found.push(((lo as u64) << 32 | hi as u64, other, same))
                    }
                    _ => manifold = false,
                }
            }
            found.sort_unstable();
            let mut slots = [NONE; 3];
            let mut same = 0u8;
            for (j, (slot, &(_, u, s))) in slots.iter_mut().zip(&found).enumerate() {
                *slot = u;
                same |= (s as u8) << j;
            }
            (slots, same, manifold)
        })
        .collect();
    drop((first, at));
    let same = across.par_iter().map(|&(_, s, _)| s).collect();
    let manifold = across.iter().all(|&(_, _, m)| m);
    // (In place: the neighbours take the room of what was found.)
    Across { neighbours: across.into_iter().map(|(n, _, _)| n).collect(), same, manifold }
}

/// For every vertex, the first vertex at exactly the same position: a texture seam (the same
/// point with two sets of texture coordinates) does not open the mesh.
fn weld(positions: &[Vec3]) -> Vec<u32> {
    // Each vertex's position bits beside its index: the sort compares them in place.
    let mut order: Vec<([u32; 3], u32)> =
        positions.par_iter().enumerate().map(|(i, p)| (p.to_array().map(f32::to_bits), i as u32)).collect();
    order.par_sort_unstable();
    let mut canonical = vec![0u32; positions.len()];
    let mut first = 0;
    for k in 0..order.len() {
        if order[k].0 != order[first].0 {
            first = k;
        }
        canonical[order[k].1 as usize] = order[first].1;
    }
    canonical
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weld_maps_equal_positions_to_the_first() {
        let p = [Vec3::X, Vec3::Y, Vec3::X, Vec3::Z, Vec3::Y];
        assert_eq!(weld(&p), [0, 1, 0, 3, 1]);
    }

    #[test]
    fn a_tetrahedron_wound_inside_out_with_one_face_wrong_comes_out_closed_and_outward() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        // Outward winding would be [0,2,1], [0,1,3], [0,3,2], [1,2,3]; here all are inside out
        // but the last, which is outward.
        let mut t = [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 2, 3]];
        assert!(orient(&p, &mut t));
        let volume: f32 = t.iter().map(|t| p[t[0] as usize].dot(p[t[1] as usize].cross(p[t[2] as usize]))).sum();
        assert!(volume > 0.0, "outward: {t:?}");
    }

    #[test]
    fn a_hollow_shell_keeps_its_inner_wall_facing_the_cavity() {
        // Two tetrahedra, one inside the other; the inner one wound to face inwards (a cavity).
        let outer = [
            Vec3::new(-3.0, -3.0, -3.0),
            Vec3::new(6.0, -3.0, -3.0),
            Vec3::new(-3.0, 6.0, -3.0),
            Vec3::new(-3.0, -3.0, 6.0),
        ];
        let inner = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        let p: Vec<Vec3> = outer.iter().chain(&inner).copied().collect();
        let out_faces = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let in_faces = out_faces.map(|[a, b, c]| [a + 4, c + 4, b + 4]);
        let mut t: Vec<[u32; 3]> = out_faces.iter().chain(&in_faces).copied().collect();
        let before = t.clone();
        assert!(orient(&p, &mut t));
        assert_eq!(t, before, "both walls were already right");
    }

    #[test]
    fn a_border_or_a_fin_leaves_the_mesh_open() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, -Vec3::Z];
        assert!(!orient(&p, &mut [[0, 1, 2]]));
        // Three triangles on one edge (0, 1): not a surface with an inside.
        assert!(!orient(&p, &mut [[0, 1, 2], [1, 0, 3], [1, 0, 4]]));
    }

    /// [`orient`] as it was first written: each neighbour's winding compared with its
    /// triangle's across their edge as the walk turns them.
    fn orient_as_first_written(positions: &[Vec3], triangles: &mut [[u32; 3]]) -> bool {
        // Each triangle's welded corners, wound as the triangle is (turned with it below).
        let mut corners: Vec<[u32; 3]> = {
            let canonical = weld(positions);
            triangles.par_iter().map(|t| t.map(|i| canonical[i as usize])).collect()
        };
        let Across { neighbours, manifold, .. } = neighbours(&corners, positions.len());

        // The directed edge (a, b) of `t` that it shares with `u`, as `t` is wound now.
        let shared = |t: [u32; 3], u: [u32; 3]| {
            (0..3).map(|e| (t[e], t[(e + 1) % 3])).find(|&(a, b)| u.contains(&a) && u.contains(&b))
        };
        let runs_same_way = |u: [u32; 3], (a, b): (u32, u32)| (0..3).any(|e| (u[e], u[(e + 1) % 3]) == (a, b));

        let mut piece = vec![NONE; triangles.len()];
        let mut consistent = true;
        let mut queue: Vec<u32> = Vec::new();
        let mut pieces = 0u32;
        let mut total_volume = 0.0f64;
        for seed in 0..triangles.len() {
            if piece[seed] != NONE {
                continue;
            }
            let id = pieces;
            pieces += 1;
            piece[seed] = id;
            queue.clear();
            queue.push(seed as u32);
            let mut volume = 0.0f64;
            let mut members_start = 0;
            while members_start < queue.len() {
                let k = queue[members_start] as usize;
                members_start += 1;
                // Its winding is settled (a triangle turns only before it is queued): its share of
                // the piece's volume, in queue order.
                let [a, b, c] = triangles[k].map(|i| positions[i as usize].as_dvec3());
                volume += a.dot(b.cross(c));
                let wt = corners[k];
                for &u in &neighbours[k] {
                    if u == NONE {
                        continue;
                    }
                    let Some(edge) = shared(wt, corners[u as usize]) else { continue };
                    let same = runs_same_way(corners[u as usize], edge);
                    if piece[u as usize] == NONE {
                        if same {
                            triangles[u as usize].swap(1, 2);
                            corners[u as usize].swap(1, 2);
                        }
                        piece[u as usize] = id;
                        queue.push(u);
                    } else if same {
                        // Already placed and still running the same way: the piece has no inside
                        // and outside (a Möbius strip).
                        consistent = false;
                    }
                }
            }
            total_volume += volume;
        }
        let closed = manifold && consistent && neighbours.iter().all(|n| !n.contains(&NONE));
        // Each piece keeps the winding of the triangle it was walked from (the file's intent: the
        // inner wall of a hollow object faces its cavity); a closed mesh whose total volume is
        // negative is inside out as a whole and is turned round.
        if closed && total_volume < 0.0 {
            for t in triangles.iter_mut() {
                t.swap(1, 2);
            }
        }
        closed
    }

    #[test]
    fn the_walk_turns_every_triangle_as_it_did_when_it_compared_windings() {
        // Meshes wound at random: a rippled grid with holes, fins and doubled triangles beside a
        // Möbius strip (open, and a piece with no inside), and closed ones (an octahedron and
        // a tetrahedron apart, inside out or not as the random windings add up), each turned by
        // the walk on the bits it finds and by the walk that compared the windings as it went.
        let mut state = 777u32;
        let mut random = move |n: u32| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) % n
        };
        let mut turned_some = 0;
        let mut inside_out = 0;
        for case in 0..60 {
            let (mut p, mut t): (Vec<Vec3>, Vec<[u32; 3]>) = (Vec::new(), Vec::new());
            if case % 2 == 0 {
                let side = 12u32;
                for y in 0..=side {
                    for x in 0..=side {
                        p.push(Vec3::new(x as f32, y as f32, ((x * 7 + y * 3) % 5) as f32 * 0.1));
                    }
                }
                let v = |x: u32, y: u32| y * (side + 1) + x;
                for y in 0..side {
                    for x in 0..side {
                        let [a, b, c, d] = [v(x, y), v(x + 1, y), v(x + 1, y + 1), v(x, y + 1)];
                        for tri in [[a, b, c], [a, c, d]] {
                            match random(25) {
                                0 => {}
                                1 => t.extend([tri, tri]),
                                2 => {
                                    p.push(Vec3::new(x as f32, y as f32, 2.0));
                                    t.extend([tri, [tri[0], tri[1], p.len() as u32 - 1]]);
                                }
                                _ => t.push(tri),
                            }
                        }
                    }
                }
                // A Möbius strip of 9 quads: its last joins its first with top and bottom swapped.
                let base = p.len() as u32;
                let n = 9u32;
                for i in 0..n {
                    let angle = i as f32 / n as f32 * std::f32::consts::TAU;
                    let (x, y) = (30.0 + 5.0 * angle.cos(), 5.0 * angle.sin());
                    p.extend([Vec3::new(x, y, 1.0), Vec3::new(x, y, -1.0)]);
                }
                let (top, bottom) = (|i: u32| base + 2 * (i % n), |i: u32| base + 2 * (i % n) + 1);
                for i in 0..n {
                    let (t1, b1) = if i + 1 == n { (bottom(0), top(0)) } else { (top(i + 1), bottom(i + 1)) };
                    t.extend([[top(i), bottom(i), t1], [bottom(i), b1, t1]]);
                }
            } else {
                let o = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
                p.extend(o);
                for (a, b) in [(0, 2), (2, 1), (1, 3), (3, 0)] {
                    t.extend([[a, b, 4], [b, a, 5]]);
                }
                p.extend([
                    Vec3::new(5.0, 0.0, 0.0),
                    Vec3::new(6.0, 0.0, 0.0),
                    Vec3::new(5.0, 1.0, 0.0),
                    Vec3::new(5.0, 0.0, 1.0),
                ]);
                t.extend([[6, 8, 7], [6, 7, 9], [6, 9, 8], [7, 8, 9]]);
            }
            for tri in t.iter_mut() {
                if random(2) == 0 {
                    tri.swap(1, 2);
                }
            }
            for k in (1..t.len()).rev() {
                t.swap(k, random(k as u32 + 1) as usize);
            }
            let (mut want, mut got) = (t.clone(), t.clone());
            let closed = orient_as_first_written(&p, &mut want);
            assert_eq!(orient(&p, &mut got), closed, "case {case}");
            assert_eq!(got, want, "case {case}");
            assert_eq!(closed, case % 2 == 1, "case {case}");
            turned_some += (got != t) as usize;
            let volume: f64 = got
                .iter()
                .map(|w| {
                    let [a, b, c] = w.map(|i| p[i as usize].as_dvec3());
                    a.dot(b.cross(c))
                })
                .sum();
            inside_out += (closed
                && t.iter()
                    .map(|w| {
                        let [a, b, c] = w.map(|i| p[i as usize].as_dvec3());
                        a.dot(b.cross(c))
                    })
                    .sum::<f64>()
                    < 0.0) as usize;
            if closed {
                assert!(volume > 0.0, "case {case}: outward");
            }
        }
        assert_eq!(turned_some, 60);
        assert!(inside_out > 5, "{inside_out} closed cases began inside out");
    }

    /// [`neighbours`] as it was first written: every edge sorted by key, equal keys paired.
    fn neighbours_by_sorting(corners: &[[u32; 3]]) -> (Vec<[u32; 3]>, bool) {
        let mut edges: Vec<(u64, u32)> = Vec::new();
        for (k, w) in corners.iter().enumerate() {
            for e in 0..3 {
                let (a, b) = (w[e], w[(e + 1) % 3]);
                edges.push(((a.min(b) as u64) << 32 | a.max(b) as u64, k as u32));
            }
        }
        edges.sort_unstable();
        let mut out = vec![[NONE; 3]; corners.len()];
        let mut manifold = true;
        for run in edges.chunk_by(|x, y| x.0 == y.0) {
            if let [(_, a), (_, b)] = run {
                for (x, y) in [(*a, *b), (*b, *a)] {
                    *out[x as usize].iter_mut().find(|s| **s == NONE).unwrap() = y;
                }
            } else {
                manifold = false;
            }
        }
        (out, manifold)
    }

    #[test]
    fn neighbours_are_those_a_sort_of_the_edges_pairs_in_the_same_order() {
        // A grid of quads, each split along either diagonal, with fins (a third triangle on an
        // edge), holes and triangles given twice, shuffled: borders, non-manifold edges and
        // every order of a triangle's neighbours.
        let side = 40u32;
        let vertex = |x: u32, y: u32| y * (side + 1) + x;
        let mut state = 12_345u32;
        let mut random = move |n: u32| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) % n
        };
        let mut corners = Vec::new();
        for y in 0..side {
            for x in 0..side {
                let [a, b, c, d] = [vertex(x, y), vertex(x + 1, y), vertex(x + 1, y + 1), vertex(x, y + 1)];
                let quad = if random(2) == 0 { [[a, b, c], [a, c, d]] } else { [[a, b, d], [b, c, d]] };
                for t in quad {
                    match random(20) {
                        0 => {}
                        1 => corners.extend([t, t]),
                        2 => corners.extend([t, [t[0], t[1], (side + 1) * (side + 1) + random(50)]]),
                        _ => corners.push(t),
                    }
                }
            }
        }
        // And a fan of 3,000 triangles round one hub, with a closing wedge.
        let hub = (side + 1) * (side + 1) + 50;
        for k in 0..3000 {
            corners.push([hub, hub + 1 + k, hub + 2 + k]);
        }
        corners.push([hub, hub + 3001, hub + 1]);
        for k in (1..corners.len()).rev() {
            corners.swap(k, random(k as u32 + 1) as usize);
        }
        let vertices = hub + 3002;
        let (want, want_manifold) = neighbours_by_sorting(&corners);
        let Across { neighbours: got, manifold, .. } = neighbours(&corners, vertices as usize);
        assert!(!manifold && !want_manifold);
        let differ = (0..corners.len()).filter(|&k| got[k] != want[k]).count();
        assert_eq!(differ, 0, "{differ} of {} triangles' neighbours differ", corners.len());
        // And a closed surface (a tetrahedron) is manifold both ways.
        let tetra = [[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]];
        let Across { neighbours: got, manifold, same } = neighbours(&tetra, 4);
        assert_eq!((got, manifold), neighbours_by_sorting(&tetra));
        assert!(manifold);
        assert_eq!(same, [0; 4], "a closed tetrahedron wound one way has no neighbour running the same way");
    }
}

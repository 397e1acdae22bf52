//! Mesh topology: vertices welded by position, triangles turned to one winding across shared
//! edges, inside-out closed pieces turned round, and whether the surface is closed. Sorting,
//! not hashing: linear memory and time close to a sort of the edges, for million-triangle meshes.

use glam::Vec3;

/// No neighbour across an edge (a border, or an edge shared by more than two triangles).
const NONE: u32 = u32::MAX;

/// Turns the triangles of each connected piece to one winding (a neighbour whose shared edge
/// runs the same way is turned round: files often mix windings), then a closed mesh that
/// encloses a negative volume as a whole inside out, so normals point out. Returns whether the mesh is
/// closed: every edge shared by exactly two triangles, running opposite ways. A piece that cannot
/// be oriented (a Möbius strip) is left open.
pub(crate) fn orient(positions: &[Vec3], triangles: &mut [[u32; 3]]) -> bool {
    let canonical = weld(positions);
    let welded = |t: &[u32; 3]| t.map(|i| canonical[i as usize]);

    // Every edge of every triangle, keyed by its two (welded) ends; sorted, equal keys are the
    // triangles that share that edge.
    let mut edges: Vec<(u64, u32)> = Vec::with_capacity(3 * triangles.len());
    for (k, t) in triangles.iter().enumerate() {
        let w = welded(t);
        for e in 0..3 {
            let (a, b) = (w[e], w[(e + 1) % 3]);
            edges.push(((a.min(b) as u64) << 32 | a.max(b) as u64, k as u32));
        }
    }
    rayon::slice::ParallelSliceMut::par_sort_unstable(&mut edges[..]);
    let mut neighbours = vec![[NONE; 3]; triangles.len()];
    let mut manifold = true;
    let mut run = 0;
    while run < edges.len() {
        let mut end = run + 1;
        while end < edges.len() && edges[end].0 == edges[run].0 {
            end += 1;
        }
        if end - run == 2 {
            let (a, b) = (edges[run].1, edges[run + 1].1);
            for (x, y) in [(a, b), (b, a)] {
                if let Some(slot) = neighbours[x as usize].iter_mut().find(|s| **s == NONE) {
                    *slot = y;
                }
            }
        } else {
            manifold = false;
        }
        run = end;
    }
    drop(edges);

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
            let wt = welded(&triangles[k]);
            for &u in &neighbours[k] {
                if u == NONE {
                    continue;
                }
                let Some(edge) = shared(wt, welded(&triangles[u as usize])) else { continue };
                let same = runs_same_way(welded(&triangles[u as usize]), edge);
                if piece[u as usize] == NONE {
                    if same {
                        triangles[u as usize].swap(1, 2);
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
        for &k in &queue {
            let [a, b, c] = triangles[k as usize].map(|i| positions[i as usize].as_dvec3());
            volume += a.dot(b.cross(c));
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

/// For every vertex, the first vertex at exactly the same position: a texture seam (the same
/// point with two sets of texture coordinates) does not open the mesh.
fn weld(positions: &[Vec3]) -> Vec<u32> {
    let key = |i: u32| positions[i as usize].to_array().map(f32::to_bits);
    let mut order: Vec<u32> = (0..positions.len() as u32).collect();
    rayon::slice::ParallelSliceMut::par_sort_unstable_by_key(&mut order[..], |&i| (key(i), i));
    let mut canonical = vec![0u32; positions.len()];
    let mut first = 0;
    for k in 0..order.len() {
        if key(order[k]) != key(order[first]) {
            first = k;
        }
        canonical[order[k] as usize] = order[first];
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
}

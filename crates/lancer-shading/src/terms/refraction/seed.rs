//! `refraction`, variant `seed` (the default, the handout's): light through a transparent
//! object, weighted by `alpha`.
//!
//! Formula: entering at `I` with outward normal `N`, `u_t = VctTransmis(u, −N, 1/n)` (the normal
//! on the transmission side); the ray crosses the object unshaded to the exit point `J` (normal
//! `N_j`), then `v_t = VctTransmis(u_t, N_j, n)` and `Col += alpha · Col(R_t)` with
//! `R_t = [J, v_t)`. Only when `alpha > 0`.
//! Total internal reflection at `J` (not covered by the handout): the ray reflects inside and
//! goes on to the next exit, at most `max_depth` times; a ray still trapped after that brings
//! nothing back. A ray that hits the object from inside (a camera inside glass) leaves through
//! that surface directly.
//! Reads: `alpha`, `n`. Parameters: `weight` (every term has it).
//!
//! ```toml
//! [model]
//! terms = ["ambient", "diffuse", "specular", "mirror", "refraction"]
//! ```

use glam::Vec3;

use lancer_core::rays::PACKET;
use lancer_shapes::Origin;

use super::{passage, passage_group, passage_notes};
use crate::lanes::{self, Group};
use crate::{Chunk, Note, Params, ShadeContext, Term, TermOutput, TermSpec};

/// The spec registered as `refraction`, variant `seed`.
pub const SPEC: TermSpec = TermSpec {
    name: "refraction",
    variant: "seed",
    summary: "alpha · Col(R_t): the handout's refraction through the object, weighted by alpha",
    reads: &["alpha", "n"],
    params: &[],
    build: |_: &mut Params| Ok(Box::new(Refraction)),
    mistake: None,
};

struct Refraction;

impl Term for Refraction {
    fn acts_on(&self, material: &lancer_core::Material) -> bool {
        material.alpha > 0.0
    }

    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let m = ctx.material(chunk.hits, lane);
        let mut notes = vec![Note::number("alpha (weight of R_t)", m.alpha), Note::number("n", m.n)];
        if m.alpha > 0.0 {
            notes.extend(passage_notes(ctx, &ctx.hit(chunk.hits, lane), chunk.rays.dir.at(lane), m.n));
        }
        notes
    }

    fn reads_lights(&self, _: &lancer_core::Material) -> bool {
        false
    }

    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        if ctx.reference {
            for lane in chunk.hit_lanes() {
                if !out.can_spawn(lane) {
                    continue;
                }
                if let Some((r_t, alpha)) = reference(ctx, chunk, lane) {
                    out.spawn(lane, r_t.from, r_t.dir, Vec3::splat(alpha));
                }
            }
            return;
        }
        for group in Group::all(chunk.hits) {
            // The lanes with `alpha > 0` (a NaN goes on, as lane by lane) within the depth limit.
            let (alpha, clear) = group.param(ctx, chunk.hits, |m| m.alpha, |a| a > 0.0 || a.is_nan());
            let clear = clear & group.may_spawn(chunk.rays, out.max_depth);
            if clear == 0 {
                continue;
            }
            // Eight lanes at a time where they all went into one sphere from outside (the bits
            // `reference` gives each); the rest (and any total internal reflection) by
            // `reference`, in lane order either way.
            let object = chunk.hits.object[group.base + clear.trailing_zeros() as usize];
            let fronts = lanes::flag_bits(&chunk.hits.front[group.base..group.base + group.len]);
            let objects = &chunk.hits.object[group.base..group.base + group.len];
            let one = lanes::equal_bits(objects, object) & clear == clear;
            let together = (one && clear & fronts == clear)
                .then(|| {
                    let n = ctx.material_of(object).n;
                    passage_group(ctx, chunk.hits, &group.dir(chunk.rays), group.base / PACKET, object, n)
                })
                .flatten();
            for (j, lane) in group.lanes(clear) {
                match together {
                    Some((from, skip, dir, ok)) if ok >> j & 1 == 1 => {
                        let from = Origin { point: lancer_core::rays::lane(&from, j), skip: skip[j] };
                        out.spawn(lane, from, lanes::lane(&dir, j), Vec3::splat(alpha[j]));
                    }
                    _ => {
                        if let Some((r_t, alpha)) = reference(ctx, chunk, lane) {
                            out.spawn(lane, r_t.from, r_t.dir, Vec3::splat(alpha));
                        }
                    }
                }
            }
        }
    }
}

/// The reference form, one hit at a time: entering at `I`, `u_t = VctTransmis(u, −N, 1/n)`; the
/// ray crosses the object unshaded to its exit `J` (normal `N_j`), `v_t = VctTransmis(u_t, N_j,
/// n)` (total internal reflection at `J` reflects it inside, at most `max_depth` times), and
/// `R_t = [J, v_t)` starts where [`lancer_shapes::Geometry::spawn`] says: all of it
/// [`passage`]. Its weight is `alpha`: once traced, it adds `alpha · Col(R_t)`. Nothing where
/// `alpha` is not positive or the ray never leaves.
fn reference(ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Option<(super::Passage, f32)> {
    let m = ctx.material(chunk.hits, lane);
    if m.alpha <= 0.0 {
        return None;
    }
    let r_t = passage(ctx, &ctx.hit(chunk.hits, lane), chunk.rays.dir.at(lane), m.n)?;
    Some((r_t, m.alpha))
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec3};
    use lancer_shapes::{Geometry, Hit, Object, Origin, Shape};

    use crate::ShadeContext;
    use crate::terms::refraction::passage;

    fn ctx(geometry: &Geometry) -> ShadeContext<'_> {
        ShadeContext { geometry, materials: &[], lights: &[], max_depth: 5, textures: &[], reference: false }
    }

    fn glass(shape: Shape, m: Affine3A) -> Geometry {
        Geometry::new(vec![Object::new(shape, m, 0).unwrap()])
    }

    /// The hit of the ray that arrives at `p` going `u` (from a little way back along it).
    fn arriving(g: &Geometry, p: Vec3, u: Vec3) -> Hit {
        let h = g.closest_hit(Origin::free(p - 0.1 * u), u, 0.0, f32::INFINITY).unwrap();
        assert!((h.point - p).length() < 1e-5, "{} vs {p}", h.point);
        h
    }

    #[test]
    fn eight_passages_at_once_have_the_bits_of_each_alone() {
        // Spheres (placed as they are, turned and scaled, far from the origin) of several
        // indices (below 1 too, where going in may reflect totally), entered from all around:
        // every lane `passage_group` takes leaves where `passage` says, to the bit.
        let mut f = {
            let mut state = 0x9E37_79B9_7F4A_7C15u64;
            move |lo: f32, hi: f32| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                lo + (hi - lo) * ((state >> 40) as f32 / (1u64 << 24) as f32)
            }
        };
        let turn = glam::Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 0.7);
        let placements = [
            Affine3A::IDENTITY,
            Affine3A::from_scale_rotation_translation(Vec3::splat(0.7), turn, Vec3::new(3.0, 1.0, -2.0)),
            Affine3A::from_scale_rotation_translation(Vec3::splat(40.0), turn, Vec3::new(5e3, -1e3, 2e3)),
        ];
        let (mut taken, mut lanes) = (0, 0);
        for (p, placement) in placements.iter().enumerate() {
            let g = glass(Shape::Sphere, *placement);
            let (centre, size) = (Vec3::from(placement.translation), placement.matrix3.x_axis.length());
            for round in 0..120 {
                let n = [1.5, 1.33, 2.4, 1.0001, 0.8][(round + p) % 5];
                let mut list = Vec::new();
                let mut dirs = Vec::new();
                while list.len() < 8 {
                    let from =
                        centre + Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)).normalize_or(Vec3::X) * size * 3.0;
                    let aim = centre + Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)) * size * 0.99;
                    let u = (aim - from).normalize();
                    if let Some(h) = g.closest_hit(Origin::free(from), u, 0.0, f32::INFINITY) {
                        list.push(h);
                        dirs.push(u);
                    }
                }
                let hits = crate::shadow::columns_of(&list);
                let u: crate::lanes::V3 =
                    std::array::from_fn(|a| wide::f32x8::new(std::array::from_fn(|k| dirs[k][a])));
                let (from, skip, dir, ok) =
                    crate::terms::refraction::passage_group(&ctx(&g), &hits, &u, 0, 0, n).expect("a sphere");
                for k in 0..8 {
                    lanes += 1;
                    if ok >> k & 1 == 0 {
                        continue;
                    }
                    taken += 1;
                    let want = passage(&ctx(&g), &list[k], dirs[k], n).expect("a way out");
                    let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                    assert_eq!(bits(lancer_core::rays::lane(&from, k)), bits(want.from.point), "lane {k}, n {n}");
                    assert_eq!(skip[k], want.from.skip);
                    assert_eq!(bits(crate::lanes::lane(&dir, k)), bits(want.dir), "lane {k}, n {n}");
                }
            }
        }
        assert!(taken > lanes * 3 / 4 && taken < lanes, "{taken} of {lanes} lanes taken together");
        // Any other shape is left to `passage`.
        let cube = glass(Shape::Cube, Affine3A::IDENTITY);
        let hits = crate::shadow::columns_of(&[arriving(&cube, Vec3::new(0.0, 0.0, -1.0), Vec3::Z)]);
        let u = [wide::f32x8::ZERO, wide::f32x8::ZERO, wide::f32x8::ONE];
        assert!(crate::terms::refraction::passage_group(&ctx(&cube), &hits, &u, 0, 0, 1.5).is_none());
    }

    #[test]
    fn along_a_diameter_the_ray_goes_straight_through_the_sphere() {
        let g = glass(Shape::Sphere, Affine3A::from_translation(Vec3::new(0.0, 0.0, 5.0)));
        let t = passage(&ctx(&g), &arriving(&g, Vec3::new(0.0, 0.0, 4.0), Vec3::Z), Vec3::Z, 1.5).unwrap();
        let (from, dir) = (t.from, t.dir);
        assert!((t.length - 2.0).abs() < 1e-3);
        assert!((dir - Vec3::Z).length() < 1e-6);
        assert!((from.point - Vec3::new(0.0, 0.0, 6.0)).length() < 1e-3, "leaves at the far pole: {}", from.point);
    }

    #[test]
    fn through_a_slab_the_ray_is_shifted_sideways_by_snells_amount() {
        // A slab 2 thick (the cube scaled 10 in x and z): enters at y = 1, leaves at y = -1.
        let g = glass(Shape::Cube, Affine3A::from_scale(Vec3::new(10.0, 1.0, 10.0)));
        let (n, theta) = (1.5f32, 50f32.to_radians());
        let u = Vec3::new(theta.sin(), -theta.cos(), 0.0);
        let entry = Vec3::new(0.0, 1.0, 0.0);
        let t = passage(&ctx(&g), &arriving(&g, entry, u), u, n).unwrap();
        let (from, dir) = (t.from, t.dir);
        assert!((dir - u).length() < 1e-5, "leaves parallel to itself: {dir} vs {u}");
        // Inside, sin θt = sin θ / n: 0.766 / 1.5 = 0.5107, so tan θt = 0.5940 and the exit is
        // 2 tan θt = 1.188 along x below the entry.
        assert!((from.point.x - 1.188).abs() < 2e-3, "exit x {}", from.point.x);
        assert!((from.point.y + 1.0).abs() < 1e-3);
    }

    #[test]
    fn total_internal_reflection_inside_a_cube_reflects_then_leaves() {
        // Entering the top face steeply into n = 2.4 glass, the ray meets the side face past the
        // critical angle (24.6°): it must reflect there and leave through the bottom face.
        let g = glass(Shape::Cube, Affine3A::IDENTITY);
        let u = Vec3::new(0.9, -0.2, 0.0).normalize();
        let t = passage(&ctx(&g), &arriving(&g, Vec3::new(0.5, 1.0, 0.0), u), u, 2.4).unwrap();
        let (from, dir) = (t.from, t.dir);
        assert!(dir.is_finite() && (dir.length() - 1.0).abs() < 1e-5);
        assert!(from.point.is_finite());
        // A reflection off the +x face sends it back towards -x.
        assert!(dir.x < 0.0, "{dir}");
    }

    #[test]
    fn a_ray_trapped_by_total_internal_reflection_brings_nothing() {
        // Inside a sphere every chord meets the surface at the same angle, so a ray beyond the
        // critical angle (24.6° for n = 2.4) bounces forever: it is dropped after max_depth
        // reflections instead of looping or producing a NaN.
        let g = glass(Shape::Sphere, Affine3A::IDENTITY);
        let alpha = 70f32.to_radians();
        let d = Vec3::new(alpha.cos(), alpha.sin(), 0.0);
        let inside = arriving(&g, Vec3::X, d);
        assert!(!inside.front);
        assert_eq!(passage(&ctx(&g), &inside, d, 2.4), None);
        // Below the critical angle it leaves at once.
        let d = Vec3::new(20f32.to_radians().cos(), 20f32.to_radians().sin(), 0.0);
        assert!(passage(&ctx(&g), &arriving(&g, Vec3::X, d), d, 2.4).is_some());
    }
}

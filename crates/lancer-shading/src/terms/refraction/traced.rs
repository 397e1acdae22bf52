//! `refraction`, variant `traced`: light through transparent objects as a full Whitted tracer
//! follows it, tracing the ray inside and shading every surface it meets there.
//!
//! Formula: at every surface of a transparent object the ray meets (from outside or inside),
//! `u_t = VctTransmis(u, N_t, n1/n2)` with `N_t` the normal on the side the ray goes to, and
//! `Col += alpha · Col(R_t)`, `R_t = [I, u_t)` traced through the scene like any ray: it meets
//! the inside of the surface it entered (shaded there by every term: the highlight and mirror
//! reflection inside glass), or objects inside the glass, or the glass again (a torus). `n1` is
//! the index of the medium the ray is in, `n2` of the one past the surface: each ray keeps the
//! list of transparent objects it is inside ([`lancer_core::rays::Media`]), so nested and
//! touching objects bend it by the ratio of their indices (air is 1). As in POV-Ray, a region
//! where two objects overlap belongs to the one entered last, and leaving an object that is not
//! the innermost one bends nothing. A surface with no inside (a plane, a disk, an open mesh) is a
//! thin sheet: the ray goes on straight. Total internal reflection sends `R_t` back by the mirror direction, inside,
//! with the same weight. Only when `alpha > 0`. The handout's path (`seed`) crosses the object
//! unshaded instead; both agree on a lone sphere seen through once, up to the inner surface's
//! own shading and the weight `alpha` counted once per crossing here.
//! Reads: `alpha`, `n`. Parameters: `weight` (every term has it).
//!
//! ```toml
//! [model]
//! terms = ["ambient", "diffuse", "specular", "mirror", "refraction:traced"]
//! ```

use glam::Vec3;
use lancer_core::rays::Media;
use lancer_shapes::Hit;

use super::bend;
use crate::{Chunk, Note, Params, ShadeContext, Term, TermOutput, TermSpec};

/// The spec registered as `refraction`, variant `traced`.
pub const SPEC: TermSpec = TermSpec {
    name: "refraction",
    variant: "traced",
    summary: "alpha · Col(R_t) at every surface crossed: refraction traced inside transparent objects (nested media)",
    reads: &["alpha", "n"],
    params: &[],
    build: |_: &mut Params| Ok(Box::new(Traced)),
    mistake: None,
};

struct Traced;

/// What happens to a ray at a transparent surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Crossing {
    /// The index of the medium the ray is in.
    pub n1: f32,
    /// The index of the medium past the surface.
    pub n2: f32,
    /// The objects the ray is inside once across.
    pub after: Media,
    /// What the crossing is, for `lancer explain`.
    pub kind: &'static str,
}

/// The media on each side of the surface of `hit` (object `b`, index `n_b`) for a ray inside
/// `media`. The side of the surface hit says whether the ray enters or leaves; the list gives
/// the indices (POV-Ray's rule for nested and overlapping objects). A ray that meets the inside
/// of an object it is not known to be in (a camera inside glass, or an object forgotten past
/// [`Media::DEPTH`] levels) leaves it into the innermost medium it knows; one that meets the
/// outside of an object the list says it is in (a list out of step with the geometry, as where
/// surfaces coincide) enters it afresh.
pub(crate) fn crossing(ctx: &ShadeContext<'_>, hit: &Hit, media: Media) -> Crossing {
    let b = hit.object;
    let index = |m: Media| m.innermost().map_or(1.0, |o| ctx.material_of(o).n);
    let n_b = ctx.material_of(b).n;
    let shape = &ctx.geometry.objects[b as usize].shape;
    if shape.is_flat() || !shape.is_closed() {
        let n = index(media);
        return Crossing { n1: n, n2: n, after: media, kind: "through a surface with no inside: straight on" };
    }
    if hit.front {
        let outside = media.leaving(b);
        Crossing { n1: index(outside), n2: n_b, after: outside.entering(b), kind: "entering the object" }
    } else if media.innermost() == Some(b) {
        let after = media.leaving(b);
        Crossing { n1: n_b, n2: index(after), after, kind: "leaving the object" }
    } else if media.contains(b) {
        let n = index(media);
        Crossing { n1: n, n2: n, after: media.leaving(b), kind: "leaving an object overlapped by the one it is in" }
    } else {
        Crossing { n1: n_b, n2: index(media), after: media, kind: "leaving the object (it started inside)" }
    }
}

/// The child ray at `hit` for a ray going `u` inside `media` that crosses as `c` says: its
/// direction, the media it travels in, and whether it was totally reflected (then it stays in
/// `media`). `None` where the indices are not positive.
fn transmitted(hit: &Hit, u: Vec3, media: Media, c: &Crossing) -> Option<(Vec3, Media, bool)> {
    let delta = c.n1 / c.n2;
    if !(delta.is_finite() && delta > 0.0) {
        return None;
    }
    if delta == 1.0 {
        return Some((u, c.after, false));
    }
    match bend(u, hit, delta, !hit.front) {
        Some((u_t, _)) => Some((u_t, c.after, false)),
        None => Some((crate::mirror_direction(hit, u), media, true)),
    }
}

impl Term for Traced {
    fn acts_on(&self, material: &lancer_core::Material) -> bool {
        material.alpha > 0.0
    }

    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let m = ctx.material(chunk.hits, lane);
        let mut notes = vec![Note::number("alpha (weight of R_t)", m.alpha), Note::number("n", m.n)];
        if m.alpha <= 0.0 {
            return notes;
        }
        let hit = ctx.hit(chunk.hits, lane);
        let media = chunk.rays.media[lane];
        let c = crossing(ctx, &hit, media);
        let inside = |m: Media| {
            let list: Vec<String> = m.iter().map(|o| format!("object {}", o + 1)).collect();
            if list.is_empty() { "air".to_owned() } else { list.join(" in ") }
        };
        notes.push(Note::text("crossing", c.kind));
        notes.push(Note::text("in", inside(media)));
        notes.push(Note::number("n1", c.n1));
        notes.push(Note::number("n2", c.n2));
        match transmitted(&hit, chunk.rays.dir.at(lane), media, &c) {
            Some((u_t, after, false)) => {
                notes.push(Note::vector("u_t = VctTransmis(u, N_t, n1/n2)", u_t));
                notes.push(Note::text("R_t then in", inside(after)));
            }
            Some((u_r, _, true)) => notes.push(Note::vector("total internal reflection: R_t along u − 2(N·u)N", u_r)),
            None => notes.push(Note::text("R_t", "the indices are not positive: brings nothing")),
        }
        notes
    }

    fn reads_lights(&self, _: &lancer_core::Material) -> bool {
        false
    }

    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        // One lane at a time (the reference form and the fast one are this): each lane's
        // media may differ.
        for lane in chunk.hit_lanes() {
            let m = ctx.material(chunk.hits, lane);
            if m.alpha.is_nan() || m.alpha <= 0.0 || !out.can_spawn(lane) {
                continue;
            }
            let hit = ctx.hit(chunk.hits, lane);
            let media = chunk.rays.media[lane];
            let c = crossing(ctx, &hit, media);
            if let Some((dir, media, _)) = transmitted(&hit, chunk.rays.dir.at(lane), media, &c) {
                out.spawn_in(lane, ctx.geometry.spawn(&hit, dir), dir, Vec3::splat(m.alpha), media);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec3};
    use lancer_core::Material;
    use lancer_core::rays::Media;
    use lancer_shapes::{Object, Shape};

    use crate::terms::probe;

    fn glass(n: f32) -> Material {
        Material { alpha: 0.8, n, ..Material::default() }
    }

    fn sphere(at: Vec3, radius: f32, k: u32) -> Object {
        Object::new(
            Shape::Sphere,
            Affine3A::from_scale_rotation_translation(Vec3::splat(radius), glam::Quat::IDENTITY, at),
            k,
        )
        .unwrap()
    }

    /// The one child of the ray from `from` along +z, inside `media`.
    fn child(objects: &[(Object, Material)], from: Vec3, media: Media) -> (Vec3, Vec3, Media) {
        let seen = probe::run_in("refraction", "traced", objects, &[], from, Vec3::Z, media);
        assert_eq!(seen.children.len(), 1, "{seen:?}");
        assert_eq!(seen.added, Vec3::ZERO);
        let (_, dir, weight) = seen.children[0];
        (dir, weight, seen.media[0])
    }

    /// `sin` of the angle between `dir` and the unit normal `n`, and whether `dir` goes along it.
    fn sine(dir: Vec3, n: Vec3) -> (f32, bool) {
        (dir.cross(n).length(), dir.dot(n) > 0.0)
    }

    #[test]
    fn entering_from_air_bends_by_snell_and_the_ray_is_then_inside() {
        // The unit sphere met at height 0.5: sin θ1 = 0.5, so inside sin θ2 = 0.5 / 1.5.
        let objects = [(sphere(Vec3::ZERO, 1.0, 0), glass(1.5))];
        let (dir, weight, media) = child(&objects, Vec3::new(0.0, 0.5, -5.0), Media::AIR);
        let n = Vec3::new(0.0, 0.5, -(0.75f32).sqrt());
        let (s, outward) = sine(dir, n);
        assert!((s - 0.5 / 1.5).abs() < 1e-5 && !outward, "{dir}");
        assert_eq!((weight, media.iter().collect::<Vec<_>>()), (Vec3::splat(0.8), vec![0]));
    }

    #[test]
    fn leaving_into_air_bends_away_and_leaves_the_media_empty() {
        // From inside at height 0.5: sin θ1 = 0.5 in n = 1.5 glass, sin θ2 = 0.75 outside;
        // the same whether the ray is known to be inside (it entered) or not (it started there).
        let objects = [(sphere(Vec3::ZERO, 1.0, 0), glass(1.5))];
        let n = Vec3::new(0.0, 0.5, (0.75f32).sqrt());
        for media in [Media::AIR.entering(0), Media::AIR] {
            let (dir, _, after) = child(&objects, Vec3::new(0.0, 0.5, 0.0), media);
            let (s, outward) = sine(dir, n);
            assert!((s - 0.75).abs() < 1e-5 && outward, "{dir}");
            assert_eq!(after, Media::AIR);
        }
    }

    #[test]
    fn meeting_the_outside_of_an_object_the_ray_is_said_to_be_in_enters_it_from_air() {
        // A list out of step with the geometry (the ray "inside" the ball meets its outer
        // face): the side hit decides, so the ray enters from air by Snell, and the ball is in
        // the list once.
        let objects = [(sphere(Vec3::ZERO, 1.0, 0), glass(1.5))];
        let (dir, _, media) = child(&objects, Vec3::new(0.0, 0.5, -5.0), Media::AIR.entering(0));
        let (s, outward) = sine(dir, Vec3::new(0.0, 0.5, -(0.75f32).sqrt()));
        assert!((s - 0.5 / 1.5).abs() < 1e-5 && !outward, "{dir}");
        assert_eq!(media.iter().collect::<Vec<_>>(), vec![0]);
    }

    #[test]
    fn a_ball_inside_glass_of_its_own_index_does_not_bend_the_ray() {
        // A glass cube (object 0, n = 1.5) holds a ball of the same index (object 1): from
        // inside the cube into the ball, n1 / n2 = 1.
        let cube = Object::new(Shape::Cube, Affine3A::from_scale(Vec3::splat(3.0)), 0).unwrap();
        let objects = [(cube, glass(1.5)), (sphere(Vec3::ZERO, 1.0, 1), glass(1.5))];
        let (dir, _, media) = child(&objects, Vec3::new(0.0, 0.5, -2.0), Media::AIR.entering(0));
        assert_eq!(dir, Vec3::Z);
        assert_eq!(media.iter().collect::<Vec<_>>(), vec![1, 0]);
    }

    #[test]
    fn leaving_a_ball_into_the_glass_around_it_bends_by_the_ratio_of_their_indices() {
        // A diamond-like ball (n = 2) in n = 1.5 glass: sin θ2 = (2 / 1.5) · 0.5.
        let cube = Object::new(Shape::Cube, Affine3A::from_scale(Vec3::splat(3.0)), 0).unwrap();
        let objects = [(cube, glass(1.5)), (sphere(Vec3::ZERO, 1.0, 1), glass(2.0))];
        let (dir, _, media) = child(&objects, Vec3::new(0.0, 0.5, 0.0), Media::AIR.entering(0).entering(1));
        let (s, outward) = sine(dir, Vec3::new(0.0, 0.5, (0.75f32).sqrt()));
        assert!((s - 2.0 / 1.5 * 0.5).abs() < 1e-5 && outward, "{dir}");
        assert_eq!(media.iter().collect::<Vec<_>>(), vec![0]);
    }

    #[test]
    fn past_the_critical_angle_the_ray_reflects_inside_and_stays_there() {
        // sin θ1 = 0.9 > 1 / 1.5: total internal reflection, about the normal at (0, 0.9, z).
        let objects = [(sphere(Vec3::ZERO, 1.0, 0), glass(1.5))];
        let inside = Media::AIR.entering(0);
        let (dir, weight, media) = child(&objects, Vec3::new(0.0, 0.9, 0.0), inside);
        let n = Vec3::new(0.0, 0.9, (1.0f32 - 0.81).sqrt());
        let want = Vec3::Z - 2.0 * n.dot(Vec3::Z) * n;
        assert!((dir - want).length() < 1e-5, "{dir} vs {want}");
        assert_eq!((weight, media), (Vec3::splat(0.8), inside));
    }

    #[test]
    fn leaving_an_object_that_is_not_the_innermost_bends_nothing() {
        // The ray is inside object 1 (n = 2, far away: it entered it last, where two objects
        // overlap) and meets the inside of object 0: the overlap belonged to object 1.
        let objects = [(sphere(Vec3::ZERO, 1.0, 0), glass(1.5)), (sphere(Vec3::splat(50.0), 1.0, 1), glass(2.0))];
        let (dir, _, media) = child(&objects, Vec3::new(0.0, 0.5, 0.0), Media::AIR.entering(0).entering(1));
        assert_eq!(dir, Vec3::Z);
        assert_eq!(media.iter().collect::<Vec<_>>(), vec![1]);
    }

    #[test]
    fn a_flat_glass_shape_lets_the_ray_through_straight_in_the_same_media() {
        let disk = Object::new(Shape::Disk, Affine3A::from_rotation_x(std::f32::consts::FRAC_PI_2), 0).unwrap();
        let objects = [(disk, glass(1.5))];
        let (dir, weight, media) = child(&objects, Vec3::new(0.1, 0.2, -3.0), Media::AIR);
        assert_eq!((dir, weight, media), (Vec3::Z, Vec3::splat(0.8), Media::AIR));
    }
}

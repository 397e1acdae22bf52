//! `refraction`, variant `fresnel`: the transparent surface splits light by the Fresnel
//! equations, and the glass may absorb (Beer–Lambert).
//!
//! Formula: at the entry `I`, with `R_in = F(cos θ, 1 → n)` the exact unpolarised dielectric
//! reflectance, a reflected ray `R_r` gets weight `alpha · R_in` and the refracted light
//! `alpha · (1 − R_in)`; at the exit `J` the part `1 − R_out`, `R_out = F(cos θ_J, n → 1)`, leaves
//! (total internal reflection: `R_out = 1`, the ray goes on inside as in `seed`; the internally
//! reflected part of a partial reflection is not followed). With `absorb = d > 0`, light inside is
//! filtered by the object's colour once per distance `d`: a factor `Col_Ω^(length / d)`.
//! `Col += alpha · (R_in · Col(R_r) + (1 − R_in)(1 − R_out) · absorption · Col(R_t))`.
//! Reads: `alpha`, `n`, `color` (with `absorb`). Parameters: `absorb` (default 0: off), `weight`.
//!
//! ```toml
//! [model]
//! terms = ["ambient", "diffuse", "specular", { term = "refraction", variant = "fresnel", absorb = 2.0 }]
//! ```

use glam::Vec3;
use lancer_core::optics::fresnel_dielectric;

use super::{passage, passage_notes};
use crate::term::facing;
use crate::{Chunk, Note, ParamSpec, Params, ShadeContext, Term, TermOutput, TermSpec};

/// The spec registered as `refraction`, variant `fresnel`.
pub const SPEC: TermSpec = TermSpec {
    name: "refraction",
    variant: "fresnel",
    summary: "alpha · (R·Col(R_r) + T·Col(R_t)): Fresnel split at each surface, optional absorption",
    reads: &["alpha", "n", "color"],
    params: &[ParamSpec {
        name: "absorb",
        default: "0",
        doc: "distance over which the glass filters light by its colour once (0: no absorption)",
    }],
    build: |p: &mut Params| Ok(Box::new(Fresnel { absorb: p.number("absorb", 0.0, 0.0, 1e9)? as f32 })),
    mistake: None,
};

struct Fresnel {
    absorb: f32,
}

/// The split of light arriving at a surface with `cos θ = |N·u|`, entering (`front`, from 1 into
/// `n`) or leaving (from `n` into 1): `(reflected, transmitted)`, which always sum to 1.
pub fn split(cos: f32, n: f32, front: bool) -> (f32, f32) {
    let r = if front { fresnel_dielectric(cos, 1.0, n) } else { fresnel_dielectric(cos, n, 1.0) };
    (r, 1.0 - r)
}

impl Term for Fresnel {
    fn acts_on(&self, material: &lancer_core::Material) -> bool {
        material.alpha > 0.0
    }

    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let m = ctx.material(chunk.hits, lane);
        let mut notes = vec![Note::number("alpha", m.alpha), Note::number("n", m.n)];
        if m.alpha <= 0.0 {
            return notes;
        }
        let hit = ctx.hit(chunk.hits, lane);
        let (_, n_facing) = facing(&chunk, lane);
        let u = chunk.rays.dir.at(lane);
        let (r_in, t_in) = split(n_facing.dot(u), m.n, hit.front);
        notes.push(Note::number("R_in (Fresnel at I)", r_in));
        notes.push(Note::number("T_in = 1 − R_in", t_in));
        notes.extend(passage_notes(ctx, &hit, u, m.n));
        if let Some(t) = passage(ctx, &hit, u, m.n) {
            let t_out = if hit.front { split(t.exit_cos, m.n, false).1 } else { 1.0 };
            notes.push(Note::number("T_out (Fresnel at J)", t_out));
        }
        notes
    }

    fn reads_lights(&self, _: &lancer_core::Material) -> bool {
        false
    }

    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        for lane in chunk.hit_lanes() {
            let m = ctx.material(chunk.hits, lane);
            if m.alpha <= 0.0 || !out.can_spawn(lane) {
                continue;
            }
            let hit = ctx.hit(chunk.hits, lane);
            let (_, n_facing) = facing(&chunk, lane);
            let u = chunk.rays.dir.at(lane);
            let (r_in, t_in) = split(n_facing.dot(u), m.n, hit.front);
            if hit.front && r_in > 0.0 {
                let u_r = crate::mirror_direction(&hit, u);
                out.spawn(lane, ctx.geometry.spawn(&hit, u_r), u_r, Vec3::splat(m.alpha * r_in));
            }
            let Some(t) = passage(ctx, &hit, u, m.n) else { continue };
            // Leaving from inside, the entry split already was the exit's.
            let t_out = if hit.front { split(t.exit_cos, m.n, false).1 } else { 1.0 };
            let absorption =
                // The colour is what a unit of glass lets through: at most all of it.
                if self.absorb > 0.0 {
                    ctx.color(chunk.hits, lane).min(Vec3::ONE).to_array().map(|c| libm::powf(c, t.length / self.absorb)).into()
                } else {
                    Vec3::ONE
                };
            out.spawn(lane, t.from, t.dir, m.alpha * t_in * t_out * absorption);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::split;
    use lancer_core::optics::critical_angle;

    #[test]
    fn transmitted_share_matches_the_transmission_amplitudes_and_is_reciprocal() {
        // T from the transmission amplitudes (ts = 2 cos θi / (cos θi + n cos θt), tp =
        // 2 cos θi / (n cos θi + cos θt)) and the beam's change of cross-section and speed,
        // n cos θt / cos θi: an independent route to 1 − R. Leaving at θt gives the same share.
        for n in [1.5f32, 2.4] {
            for k in 1..=100 {
                let ci = k as f32 / 100.0;
                let ct = (1.0 - (1.0 - ci * ci) / (n * n)).sqrt();
                let (ts, tp) = (2.0 * ci / (ci + n * ct), 2.0 * ci / (n * ci + ct));
                let t = n * ct / ci * 0.5 * (ts * ts + tp * tp);
                assert!((split(ci, n, true).1 - t).abs() < 1e-4, "n {n}, cos {ci}: {} vs {t}", split(ci, n, true).1);
                assert!((split(ct, n, false).1 - t).abs() < 1e-4, "n {n}, cos {ci}: leaving");
            }
        }
        assert!((split(1.0, 1.5, true).0 - 0.04).abs() < 1e-6);
    }

    #[test]
    fn past_the_critical_angle_everything_is_reflected() {
        let crit = critical_angle(1.5, 1.0).unwrap();
        assert_eq!(split((crit + 0.01).cos(), 1.5, false), (1.0, 0.0));
        assert!(split((crit - 0.01).cos(), 1.5, false).1 > 0.0);
        // Entering a denser medium there is no critical angle.
        assert!(split(0.01, 1.5, true).1 > 0.0);
    }
}

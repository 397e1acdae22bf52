//! `specular`, variant `phong` (the default: the handout's seed form): the highlight of a shiny surface.
//!
//! Formula, per visible light with `N·w > 0`: `w_r = 2 (N·w) N − w`,
//! `Col += spec · shine · max(−u·w_r, 0)^(1/(1−shine)) · Col_L`.
//! `shine = 1` means an infinite exponent: the highlight shrinks to the single mirror direction
//! and vanishes, so it contributes nothing (never a NaN). `shine = 0` gives nothing either
//! (`spec · shine = 0`).
//! Reads: `spec`, `shine`. Parameters: `weight` (every term has it).
//!
//! ```toml
//! [model]
//! terms = ["ambient", "diffuse", "specular"]
//! ```

use glam::Vec3;
use lancer_core::rays::PACKET;
use wide::{CmpLe, f32x8};

use crate::lanes::{self, Group};
use crate::term::facing;
use crate::{Chunk, Note, Params, ShadeContext, Term, TermOutput, TermSpec, lit_by};

/// The spec registered as `specular`, variant `phong`.
pub const SPEC: TermSpec = TermSpec {
    name: "specular",
    variant: "phong",
    summary: "spec · shine · (−u·w_r)^(1/(1−shine)) · Col_L: the handout's Phong highlight",
    reads: &["spec", "shine"],
    params: &[],
    build: |_: &mut Params| Ok(Box::new(Phong)),
    mistake: None,
};

struct Phong;

/// The seed highlight factor `shine · c^(1/(1−shine))` for `c = max(−u·w_r, 0)`, finite for every
/// `shine` in [0, 1].
#[inline]
pub fn phong_factor(shine: f32, c: f32) -> f32 {
    if shine <= 0.0 || shine >= 1.0 || c <= 0.0 {
        return 0.0;
    }
    shine * super::lobe(c.min(1.0), 1.0 / (1.0 - shine))
}

impl Term for Phong {
    fn acts_on(&self, material: &lancer_core::Material) -> bool {
        material.spec > 0.0 && material.shine > 0.0 && material.shine < 1.0
    }

    fn why_idle(&self, material: &lancer_core::Material) -> Option<String> {
        super::infinite_exponent(material, "1/(1 − shine)")
    }

    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let m = ctx.material(chunk.hits, lane);
        let (_, n) = facing(&chunk, lane);
        let u = chunk.rays.dir.at(lane);
        let mut notes = vec![Note::number("spec", m.spec), Note::number("shine", m.shine)];
        if m.shine < 1.0 {
            notes.push(Note::number("exponent 1/(1−shine)", 1.0 / (1.0 - m.shine)));
        }
        for (k, nw, w) in lit_by(&chunk, lane, n) {
            let c = -u.dot(2.0 * nw * n - w);
            notes.push(Note::number(format!("light {k}: −u·w_r"), c));
            notes.push(Note::number(format!("light {k}: shine·max(−u·w_r, 0)^exponent"), phong_factor(m.shine, c)));
        }
        notes
    }

    fn reads_lights(&self, material: &lancer_core::Material) -> bool {
        material.spec > 0.0 && material.shine > 0.0 && material.shine < 1.0
    }

    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        if ctx.reference {
            for lane in chunk.hit_lanes() {
                if let Some(colour) = reference(ctx, chunk, lane) {
                    out.add(lane, colour);
                }
            }
            return;
        }
        // Eight lanes at a time, the same arithmetic as `reference` lane by lane (so the same
        // bits); a lane whose exponent is not whole goes alone, by `reference`.
        // The last material's answer: neighbouring hits mostly share a material, and its
        // exponent costs a division and a rounding.
        let mut last: Option<(u32, Option<Option<u32>>)> = None;
        // The exponent of material `index` (`None` where the term skips it, `Some(None)` where
        // it is not whole).
        let mut exponent_of = |index: u32, m: &lancer_core::Material| match last {
            Some((i, e)) if i == index => e,
            _ => {
                // The scalar test, NaN included: a NaN `spec` or `shine` is not skipped.
                let skipped = m.spec <= 0.0 || m.shine <= 0.0 || m.shine >= 1.0;
                let e = (!skipped).then(|| super::whole_power(1.0 / (1.0 - m.shine)));
                last = Some((index, e));
                e
            }
        };
        for group in Group::all(chunk.hits) {
            let (mut spec, mut shine, mut power) = ([0.0f32; PACKET], [0.0f32; PACKET], [0u32; PACKET]);
            let (mut active, mut alone) = (0u8, 0u8);
            // One material for every hit lane (the usual case) is looked at once; else each.
            let indices = &chunk.hits.material[group.base..group.base + group.len];
            let (one, each) = match group.one_material(indices) {
                Some(index) => (Some(index), 0),
                None => (None, group.hit),
            };
            if let Some(index) = one {
                let m = &ctx.materials[index as usize];
                match exponent_of(index, m) {
                    Some(Some(e)) => {
                        (spec, shine, power, active) = ([m.spec; PACKET], [m.shine; PACKET], [e; PACKET], group.hit);
                    }
                    Some(None) => alone = group.hit,
                    None => {}
                }
            }
            for (j, lane) in group.lanes(each) {
                let m = ctx.material(chunk.hits, lane);
                let Some(exponent) = exponent_of(chunk.hits.material[lane], m) else { continue };
                (spec[j], shine[j]) = (m.spec, m.shine);
                match exponent {
                    Some(e) => (power[j], active) = (e, active | 1 << j),
                    None => alone |= 1 << j,
                }
            }
            if active != 0 {
                // The lanes left out take an active lane's exponent: one exponent for all, the
                // usual case, skips `powi`'s masks (their answers are not used).
                let first = power[active.trailing_zeros() as usize];
                for (j, p) in power.iter_mut().enumerate() {
                    if active >> j & 1 == 0 {
                        *p = first;
                    }
                }
                let n = group.facing(chunk.hits);
                let u = group.dir(chunk.rays);
                let shine = f32x8::new(shine);
                let sum = group.sum_lights::<true>(chunk.lights, &n, lanes::mask(active), |nw, w| {
                    let two = f32x8::splat(2.0) * nw;
                    let w_r: lanes::V3 = std::array::from_fn(|a| two * n[a] - w[a]);
                    let c = lanes::neg(lanes::dot(&u, &w_r));
                    // `phong_factor`: 0 unless −u·w_r > 0 (a NaN goes on, as there).
                    let lobe = shine * lanes::powi(c.min(f32x8::ONE), power);
                    c.cmp_le(f32x8::ZERO).blend(f32x8::ZERO, lobe)
                });
                let spec = f32x8::new(spec);
                let colour: lanes::V3 = sum.map(|c| spec * c);
                if alone == 0 {
                    out.add_lanes(group.base, active, &colour);
                    continue;
                }
                for (j, lane) in group.lanes(active | alone) {
                    let add = if active & (1 << j) != 0 {
                        lanes::lane(&colour, j)
                    } else {
                        reference(ctx, chunk, lane).unwrap_or(Vec3::ZERO)
                    };
                    out.add(lane, add);
                }
            } else {
                for (_, lane) in group.lanes(alone) {
                    out.add(lane, reference(ctx, chunk, lane).unwrap_or(Vec3::ZERO));
                }
            }
        }
    }
}

/// The reference form, one hit at a time: `Σ_lights spec · shine · max(−u·w_r, 0)^(1/(1−shine))
/// · Col_L · T` with `w_r = 2(N·w)N − w`, over the lights in front of the surface (`N·w > 0`,
/// `N` the shading normal facing the ray) that send something (`Col_L · T`, [`Chunk::lights`]),
/// summed as `spec · Σ shine · max(−u·w_r, 0)^(1/(1−shine)) · Col_L · T` ([`phong_factor`]).
/// Nothing where the material has no highlight (`spec ≤ 0`, `shine ≤ 0` or `shine ≥ 1`).
fn reference(ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Option<Vec3> {
    let m = ctx.material(chunk.hits, lane);
    if m.spec <= 0.0 || m.shine <= 0.0 || m.shine >= 1.0 {
        return None;
    }
    let n = chunk.hits.facing_normal(lane);
    let u = chunk.rays.dir.at(lane);
    let mut sum = Vec3::ZERO;
    for (w, col_l_t) in chunk.lights.lane(lane) {
        let n_dot_w = n.dot(w);
        if n_dot_w > 0.0 && col_l_t != Vec3::ZERO {
            let w_r = 2.0 * n_dot_w * n - w;
            sum += phong_factor(m.shine, -u.dot(w_r)) * col_l_t;
        }
    }
    Some(m.spec * sum)
}

#[cfg(test)]
mod tests {
    use super::phong_factor;

    #[test]
    fn handout_shine_ladder_exponents() {
        // shine 0.99, 0.8, 0.5, 0.2 → exponents 100, 5, 2, 1.25.
        for (shine, e) in [(0.99f32, 100.0f32), (0.8, 5.0), (0.5, 2.0), (0.2, 1.25)] {
            let c = 0.9f32;
            assert!((phong_factor(shine, c) - shine * c.powf(e)).abs() < 1e-5, "shine {shine}");
        }
    }

    #[test]
    fn shine_zero_and_one_are_defined_and_finite() {
        assert_eq!(phong_factor(0.0, 1.0), 0.0);
        assert_eq!(phong_factor(0.0, 0.5), 0.0);
        // An infinite exponent: no highlight at all, even dead on the mirror direction.
        assert_eq!(phong_factor(1.0, 1.0), 0.0);
        assert_eq!(phong_factor(1.0, 0.999), 0.0);
        // Rounding can push −u·w_r a hair past 1; it must not blow up.
        assert!(phong_factor(0.99, 1.000_001).is_finite());
        assert!((phong_factor(0.99, 1.0) - 0.99).abs() < 1e-6);
        // Away from the highlight, nothing.
        assert_eq!(phong_factor(0.5, -0.3), 0.0);
    }
}

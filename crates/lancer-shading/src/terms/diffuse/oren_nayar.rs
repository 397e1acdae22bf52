//! `diffuse`, variant `oren-nayar`: matte reflection from a rough surface (Oren and Nayar's
//! qualitative model). Rough clay or the Moon look flatter than Lambert: brighter towards the
//! rim when lit from behind the viewer.
//!
//! Formula, per visible light: with `σ` the roughness in radians, `A = 1 − σ²/(2(σ² + 0.33))`,
//! `B = 0.45 σ²/(σ² + 0.09)`, `θ_i = angle(N, w)`, `θ_r = angle(N, −u)`, `α = max(θ_i, θ_r)`,
//! `β = min(θ_i, θ_r)`, and `cos(φ_i − φ_r)` the cosine between `w` and `−u` projected on the
//! surface: `Col += diff · (N·w) · (A + B · max(0, cos(φ_i − φ_r)) · sin α · tan β) · Col_Ω · Col_L`.
//! `roughness = 0` is exactly Lambert.
//! Reads: `diff`, `color`. Parameters: `roughness` in degrees (default 20, in [0, 90]), `weight`.
//!
//! ```toml
//! [model]
//! terms = ["ambient", { term = "diffuse", variant = "oren-nayar", roughness = 30 }]
//! ```

use glam::Vec3;

use crate::term::facing;
use crate::{Chunk, Note, ParamSpec, Params, ShadeContext, Term, TermOutput, TermSpec, lit_by, sum_lights};

/// The spec registered as `diffuse`, variant `oren-nayar`.
pub const SPEC: TermSpec = TermSpec {
    name: "diffuse",
    variant: "oren-nayar",
    summary: "Oren–Nayar: Lambert for rough surfaces, flatter and brighter at the rim",
    reads: &["diff", "color"],
    params: &[ParamSpec { name: "roughness", default: "20", doc: "surface roughness σ in degrees (0 = Lambert)" }],
    build: |p: &mut Params| Ok(Box::new(OrenNayar::new(p.number("roughness", 20.0, 0.0, 90.0)? as f32))),
    mistake: None,
};

struct OrenNayar {
    a: f32,
    b: f32,
}

impl OrenNayar {
    /// The model for a roughness σ of `degrees`: `A = 1 − σ²/(2 (σ² + 0.33))`,
    /// `B = 0.45 σ²/(σ² + 0.09)`, σ in radians.
    fn new(degrees: f32) -> OrenNayar {
        let s2 = degrees.to_radians() * degrees.to_radians();
        OrenNayar { a: 1.0 - 0.5 * s2 / (s2 + 0.33), b: 0.45 * s2 / (s2 + 0.09) }
    }

    /// The factor on Lambert's `N·w` for light `w`, view `v = −u`, normal `n`.
    #[inline]
    fn factor(&self, n: Vec3, w: Vec3, v: Vec3, nw: f32) -> f32 {
        let nv = n.dot(v).clamp(0.0, 1.0);
        let (cos_i, cos_r) = (nw.min(1.0), nv);
        // sin α · tan β with α the larger angle (smaller cosine), β the smaller angle.
        let (cos_a, cos_b) = if cos_i < cos_r { (cos_i, cos_r) } else { (cos_r, cos_i) };
        let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
        let tan_b = if cos_b > 1e-6 { (1.0 - cos_b * cos_b).max(0.0).sqrt() / cos_b } else { 0.0 };
        let cos_phi = match ((w - n * cos_i).try_normalize(), (v - n * cos_r).try_normalize()) {
            (Some(a), Some(b)) => a.dot(b).max(0.0),
            _ => 0.0,
        };
        self.a + self.b * cos_phi * sin_a * tan_b
    }
}

impl Term for OrenNayar {
    fn acts_on(&self, material: &lancer_core::Material) -> bool {
        material.diff > 0.0
    }

    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let m = ctx.material(chunk.hits, lane);
        let (_, n) = facing(&chunk, lane);
        let v = -chunk.rays.dir.at(lane);
        let mut notes = vec![
            Note::number("diff", m.diff),
            Note::vector("Col_Ω", ctx.color(chunk.hits, lane)),
            Note::number("A", self.a),
            Note::number("B", self.b),
        ];
        for (k, nw, w) in lit_by(&chunk, lane, n) {
            notes.push(Note::number(format!("light {k}: N·w"), nw));
            notes.push(Note::number(format!("light {k}: A + B·max(0, cos φ)·sin α·tan β"), self.factor(n, w, v, nw)));
        }
        notes
    }

    fn reads_lights(&self, material: &lancer_core::Material) -> bool {
        material.diff > 0.0
    }

    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>) {
        for lane in chunk.hit_lanes() {
            let m = ctx.material(chunk.hits, lane);
            if m.diff <= 0.0 {
                continue;
            }
            let (_, n) = facing(&chunk, lane);
            let v = -chunk.rays.dir.at(lane);
            let sum = sum_lights(&chunk, lane, n, |nw, w| nw * self.factor(n, w, v, nw));
            out.add(lane, m.diff * ctx.color(chunk.hits, lane) * sum);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(deg: f64) -> OrenNayar {
        OrenNayar::new(deg as f32)
    }

    #[test]
    fn coefficients_for_twenty_degrees() {
        // σ = 20° = 0.349066 rad, σ² = 0.121847: A = 1 − 0.060924 / 0.451847, B = 0.054831 / 0.211847.
        let m = model(20.0);
        assert!((m.a - 0.865_168).abs() < 1e-5 && (m.b - 0.258_824).abs() < 1e-5, "{} {}", m.a, m.b);
        // Light and viewer both straight above: θi = θr = 0, so the factor is A.
        assert!((m.factor(Vec3::Y, Vec3::Y, Vec3::Y, 1.0) - m.a).abs() < 1e-6);
    }

    #[test]
    fn zero_roughness_is_lambert_and_rough_is_flatter() {
        let n = Vec3::Y;
        let w = Vec3::new(0.8, 0.6, 0.0);
        let v = Vec3::new(-0.6, 0.8, 0.0);
        assert_eq!(model(0.0).factor(n, w, v, n.dot(w)), 1.0);
        // Light and viewer on the same side, both oblique: backscatter brightens the rough surface.
        let v_same = Vec3::new(0.7, 0.714, 0.0).normalize();
        let rough = model(40.0);
        assert!(rough.factor(n, w, v_same, n.dot(w)) > rough.factor(n, w, v, n.dot(w)));
        // Never negative, never NaN, even straight down and at grazing angles.
        for (w, v) in [(Vec3::Y, Vec3::Y), (Vec3::X, Vec3::Y), (Vec3::Y, Vec3::X)] {
            let f = rough.factor(n, w, v, n.dot(w));
            assert!(f.is_finite() && f >= 0.0);
        }
    }
}

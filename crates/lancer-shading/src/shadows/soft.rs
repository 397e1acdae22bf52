//! `soft`: area lights cast soft shadows. A light with `size > 0` is a square of that side,
//! parallel to the xz-plane and centred on `at`; the model averages the transmissive visibility
//! of `samples` points on it, one in each cell of a √samples × √samples grid, jittered inside
//! its cell by a hash of the shaded point (deterministic: the same point always gets the same
//! pattern, whatever the thread). Transparent occluders attenuate as in `transmissive`. A point
//! light (`size = 0`) gets exactly the `transmissive` result.
//!
//! Formula: transmittance = (1/S) Σ_k T(I → L_k), `L_k` the sample points, `T` as `transmissive`.
//! Reads: `alpha`, `color` of occluders; the light's `size`. Parameters: `samples` (a square
//! number, default 16), `tint` (default `false`), `each_surface` (default `false`).
//!
//! ```toml
//! [model]
//! shadows = { model = "soft", samples = 64 }
//!
//! [[lights]]
//! at = [0, 6, 0]
//! size = 2.0
//! ```

use glam::Vec3;
use lancer_core::Light;
use lancer_shapes::Hit;

use super::transmissive::{EACH_SURFACE, Filter, TINT, through_each, through_occluders, through_occluders_each};
use crate::shadow::BLOCK;
use crate::{HitBlock, ParamError, ParamSpec, Params, ShadowContext, ShadowModel, ShadowSpec};

/// The spec registered under `soft`.
pub const SPEC: ShadowSpec = ShadowSpec {
    name: "soft",
    summary: "area lights (a light's `size`) sampled on a stratified grid: soft penumbrae",
    params: &[
        ParamSpec { name: "samples", default: "16", doc: "points sampled on each area light (a square number)" },
        TINT,
        EACH_SURFACE,
    ],
    build: |p: &mut Params| {
        let samples = p.number("samples", 16.0, 1.0, 4096.0)?;
        let side = samples.sqrt().round();
        if side * side != samples {
            return Err(ParamError {
                param: "samples".into(),
                message: format!("expected a square number such as 4, 16 or 64, found {samples}"),
            });
        }
        Ok(Box::new(Soft { side: side as u32, filter: Filter::from_params(p)? }))
    },
    mistake: None,
};

struct Soft {
    side: u32,
    filter: Filter,
}

/// A 64-bit mix (SplitMix64's finaliser): well-spread bits from any input.
#[inline]
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A number in [0, 1) from the top 24 bits of `z`.
#[inline]
fn unit(z: u64) -> f32 {
    (z >> 40) as f32 / (1u64 << 24) as f32
}

impl Soft {
    /// The sample points on `light`'s square for the point `p`: cell `(i, j)` of the grid,
    /// jittered by a hash of `p` and the cell.
    fn sample(&self, light: &Light, seed: u64, cell: u32) -> Vec3 {
        let (i, j) = (cell % self.side, cell / self.side);
        let h = mix(seed ^ (cell as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        let k = self.side as f32;
        let x = ((i as f32 + unit(h)) / k - 0.5) * light.size;
        let z = ((j as f32 + unit(mix(h))) / k - 0.5) * light.size;
        light.at + Vec3::new(x, 0.0, z)
    }
}

/// The sample sequence's seed for a hit at `p`: the same points for the same hit, whatever else
/// is rendered.
fn seed(p: Vec3) -> u64 {
    mix(((p.x.to_bits() as u64) << 32 | p.y.to_bits() as u64) ^ mix(p.z.to_bits() as u64))
}

impl ShadowModel for Soft {
    fn transmittance(&self, ctx: &ShadowContext<'_>, at: &Hit, light: &Light) -> Vec3 {
        if light.size <= 0.0 {
            return through_occluders(ctx, at, light.at, self.filter);
        }
        let seed = seed(at.local);
        let n = self.side * self.side;
        let mut sum = Vec3::ZERO;
        for cell in 0..n {
            let sample = self.sample(light, seed, cell);
            // A sample at the hit point itself lends nothing (as in the blocks below).
            if ctx.toward(at, sample).is_some() {
                sum += through_occluders(ctx, at, sample, self.filter);
            }
        }
        sum / n as f32
    }

    fn transmittance_each(&self, ctx: &ShadowContext<'_>, block: &HitBlock<'_>, light: &Light, out: &mut [Vec3]) {
        if light.size <= 0.0 {
            return through_occluders_each(ctx, block, self.filter, out);
        }
        let mut hits = [Hit::default(); BLOCK];
        for (i, hit) in hits.iter_mut().enumerate().take(block.len()) {
            *hit = block.hit(ctx, i);
        }
        let (hits, out) = (&hits[..block.len()], &mut out[..block.len()]);
        // Sample by sample, the block's rays together; each hit's sum in the order
        // `transmittance` makes it (sample 0 first).
        let n = self.side * self.side;
        out.fill(Vec3::ZERO);
        for cell in 0..n {
            through_each(
                ctx,
                hits,
                |i| self.sample(light, seed(hits[i].local), cell),
                self.filter,
                |i, through| {
                    if let Some(through) = through {
                        out[i] += through;
                    }
                },
            );
        }
        for sum in out.iter_mut() {
            *sum /= n as f32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_cover_the_square_one_per_cell() {
        let soft = Soft { side: 4, filter: Filter::default() };
        let light = Light { at: Vec3::new(1.0, 5.0, -2.0), color: Vec3::ONE, intensity: 1.0, size: 2.0 };
        let mut cells = vec![0; 16];
        for cell in 0..16 {
            let s = soft.sample(&light, 12345, cell) - light.at;
            assert_eq!(s.y, 0.0);
            assert!(s.x.abs() <= 1.0 && s.z.abs() <= 1.0, "{s}");
            let (ci, cj) = (((s.x + 1.0) / 0.5) as usize, ((s.z + 1.0) / 0.5) as usize);
            cells[cj.min(3) * 4 + ci.min(3)] += 1;
        }
        assert!(cells.iter().all(|&c| c == 1), "one sample per stratum: {cells:?}");
        // The same point and cell give the same sample; another point jitters differently.
        // The jitter fills its cell: over many points, cell 1 (x in [−0.5, 0)) is covered
        // from edge to edge and never left.
        let xs: Vec<f32> = (0..4096u64).map(|s| (soft.sample(&light, mix(s), 1) - light.at).x).collect();
        let (lo, hi) = xs.iter().fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
        assert!((-0.5..-0.49).contains(&lo) && (-0.01..0.0).contains(&hi), "{lo} .. {hi}");
        // Another point jitters differently.
        assert_ne!(soft.sample(&light, 7, 3), soft.sample(&light, 8, 3));
    }

    #[test]
    fn samples_must_be_a_square_number() {
        let r = crate::Registry::with_builtins();
        let p = Params::new([("samples".to_owned(), crate::ParamValue::Number(10.0))]);
        let e = r.build_shadow("soft", p).err().unwrap().to_string();
        assert!(e.contains("expected a square number such as 4, 16 or 64, found 10"), "{e}");
    }
}

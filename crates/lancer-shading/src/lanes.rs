//! Eight lanes of a chunk at once, for the built-in terms: groups of lanes loaded from the
//! packet columns, and the few operations whose scalar form (glam's, `f32::powi`) they must
//! match bit for bit, so a term computed eight lanes at a time adds what it adds lane by lane.

use glam::Vec3;
use lancer_core::rays::{Hits, LightSamples, NO_HIT, PACKET, Packet, Rays};
use wide::{CmpEq, f32x8};

/// Three axes of eight lanes.
pub(crate) type V3 = [f32x8; 3];

/// Every bit set: a lane's "true".
const TRUE: f32 = f32::from_bits(u32::MAX);

/// The packet as three registers.
#[inline(always)]
pub(crate) fn load(p: &Packet) -> V3 {
    p.map(f32x8::new)
}

/// `a · b` in glam's order: `(x x' + y y') + z z'`.
#[inline(always)]
pub(crate) fn dot(a: &V3, b: &V3) -> f32x8 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `-x` as scalar code negates: the sign bit flipped (wide's `-x` is `0 − x`, which turns
/// −0 into +0).
#[inline(always)]
pub(crate) fn neg(x: f32x8) -> f32x8 {
    x ^ f32x8::splat(-0.0)
}

/// The lanes whose bit is set in `bits`, as a mask.
#[inline(always)]
pub(crate) fn mask(bits: u8) -> f32x8 {
    f32x8::new(std::array::from_fn(|j| if bits & (1 << j) != 0 { TRUE } else { 0.0 }))
}

/// `v != Vec3::ZERO` lane by lane (a NaN axis is not zero).
#[inline(always)]
pub(crate) fn nonzero(v: &V3) -> f32x8 {
    !(v[0].cmp_eq(f32x8::ZERO) & v[1].cmp_eq(f32x8::ZERO) & v[2].cmp_eq(f32x8::ZERO))
}

/// `u − 2 (n·u) n` lane by lane ([`lancer_core::optics::reflect`]'s bits).
#[inline(always)]
pub(crate) fn reflect(u: &V3, n: &V3) -> V3 {
    let k = f32x8::splat(2.0) * dot(n, u);
    std::array::from_fn(|a| u[a] - k * n[a])
}

/// [`crate::mirror_direction`] lane by lane: the mirror direction about the shading normal
/// `shading`, or about the geometric `normal` where that one would not leave on the side the
/// ray came from.
#[inline(always)]
pub(crate) fn mirror_direction(u: &V3, shading: &V3, normal: &V3) -> V3 {
    use wide::{CmpGt, CmpLt};
    let r = reflect(u, shading);
    let keep = !(dot(&r, normal).cmp_gt(f32x8::ZERO) ^ dot(u, normal).cmp_lt(f32x8::ZERO));
    let about_normal = reflect(u, normal);
    std::array::from_fn(|a| keep.blend(r[a], about_normal[a]))
}

/// Lane `j` of `v`.
#[inline(always)]
pub(crate) fn lane(v: &V3, j: usize) -> Vec3 {
    Vec3::new(v[0].as_array_ref()[j], v[1].as_array_ref()[j], v[2].as_array_ref()[j])
}

/// `c^e` lane by lane for whole exponents `e` (at most 2^16): `f32::powi`'s steps (the
/// runtime's: square `c` for each bit of `e`, multiply it in where the bit is set, from 1),
/// so the same bits.
#[inline(always)]
pub(crate) fn powi(c: f32x8, e: [u32; PACKET]) -> f32x8 {
    let (mut base, mut product) = (c, f32x8::ONE);
    let top = e.iter().copied().max().unwrap_or(0);
    let mut bit = 0;
    while bit < 17 && top >> bit != 0 {
        let set = mask((0..PACKET).fold(0u8, |m, j| m | (((e[j] >> bit) & 1) as u8) << j));
        product = set.blend(product * base, product);
        base = base * base;
        bit += 1;
    }
    product
}

/// Eight lanes of a chunk: the first, how many there are (the last group may have fewer), and
/// which of them hit something.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Group {
    pub(crate) base: usize,
    pub(crate) len: usize,
    pub(crate) hit: u8,
}

impl Group {
    /// The groups of a chunk of `lanes` lanes with these hits.
    pub(crate) fn all(hits: &Hits) -> impl Iterator<Item = Group> + '_ {
        let n = hits.object.len();
        (0..n).step_by(PACKET).map(move |base| {
            let len = (n - base).min(PACKET);
            let hit = (0..len).filter(|&j| hits.object[base + j] != NO_HIT).fold(0u8, |m, j| m | 1 << j);
            Group { base, len, hit }
        })
    }

    /// The lanes set in `bits`, in order, as chunk lanes.
    #[inline(always)]
    pub(crate) fn lanes(&self, mut bits: u8) -> impl Iterator<Item = (usize, usize)> {
        let base = self.base;
        std::iter::from_fn(move || {
            (bits != 0).then(|| {
                let j = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                (j, base + j)
            })
        })
    }

    /// A material parameter of each hit lane (`param`), and the lanes where it is above 0.
    #[inline(always)]
    pub(crate) fn param(
        &self,
        ctx: &crate::ShadeContext<'_>,
        hits: &Hits,
        param: impl Fn(&lancer_core::Material) -> f32,
    ) -> ([f32; PACKET], u8) {
        let (mut value, mut above) = ([0.0f32; PACKET], 0u8);
        for (j, lane) in self.lanes(self.hit) {
            value[j] = param(ctx.material(hits, lane));
            if value[j] > 0.0 {
                above |= 1 << j;
            }
        }
        (value, above)
    }

    /// The hit points, geometric normals, error bounds and objects of the lanes (a lane past
    /// the chunk's end has no object).
    #[inline(always)]
    pub(crate) fn surface(&self, hits: &Hits) -> (V3, V3, [f32; PACKET], [u32; PACKET]) {
        let p = self.base / PACKET;
        let (mut error, mut object) = ([0.0f32; PACKET], [NO_HIT; PACKET]);
        for j in 0..self.len {
            (error[j], object[j]) = (hits.error[self.base + j], hits.object[self.base + j]);
        }
        (load(&hits.point.packets()[p]), load(&hits.normal.packets()[p]), error, object)
    }

    /// The lanes whose ray's children are within the depth limit `max_depth`.
    #[inline(always)]
    pub(crate) fn may_spawn(&self, rays: &Rays, max_depth: u8) -> u8 {
        (0..self.len).filter(|&j| rays.depth[self.base + j] < max_depth).fold(0u8, |m, j| m | 1 << j)
    }

    /// `Col_Ω` of the lanes.
    #[inline(always)]
    pub(crate) fn color(&self, hits: &Hits) -> V3 {
        load(&hits.color.packets()[self.base / PACKET])
    }

    /// The shading normals facing the rays (turned round on back-face hits).
    #[inline(always)]
    pub(crate) fn facing(&self, hits: &Hits) -> V3 {
        let shading = load(&hits.shading.packets()[self.base / PACKET]);
        let front =
            f32x8::new(std::array::from_fn(|j| if j < self.len && hits.front[self.base + j] { TRUE } else { 0.0 }));
        shading.map(|c| front.blend(c, neg(c)))
    }

    /// The rays' directions.
    #[inline(always)]
    pub(crate) fn dir(&self, rays: &Rays) -> V3 {
        load(&rays.dir.packets()[self.base / PACKET])
    }

    /// `w` and the light arriving, from light `k`.
    #[inline(always)]
    pub(crate) fn light(&self, lights: &LightSamples, k: usize) -> (V3, V3) {
        let p = self.base / PACKET;
        (load(&lights.w[k].packets()[p]), load(&lights.incoming[k].packets()[p]))
    }
}

#[cfg(test)]
mod tests {
    use wide::f32x8;

    #[test]
    fn powers_have_the_bits_of_powi() {
        let mut f = 0.37f32;
        for round in 0..2000 {
            f = (f * 3.7 + 0.11).fract();
            let c = f32x8::new(std::array::from_fn(|j| {
                (f + j as f32 * 0.119).fract() * if round % 9 == 0 { 1.3 } else { 1.0 }
            }));
            let e: [u32; 8] =
                std::array::from_fn(|j| [1, 2, 5, 20, 40, 80, 100, 1024, 3, 7, 64, 65535][(round + j * 5) % 12]);
            let got = super::powi(c, e).to_array();
            for j in 0..8 {
                let want = c.to_array()[j].powi(e[j] as i32);
                assert_eq!(got[j].to_bits(), want.to_bits(), "{}^{}", c.to_array()[j], e[j]);
            }
        }
    }
}

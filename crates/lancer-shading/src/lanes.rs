//! Eight lanes of a chunk at once, for the built-in terms: groups of lanes loaded from the
//! packet columns, and the few operations whose scalar form (glam's, `f32::powi`) they must
//! match bit for bit, so a term computed eight lanes at a time adds what it adds lane by lane.

use glam::Vec3;
use lancer_core::rays::{Hits, LightSamples, NO_HIT, PACKET, Packet, Rays};
use wide::{CmpEq, f32x8};

/// Three axes of eight lanes.
pub(crate) type V3 = [f32x8; 3];

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
    use wide::{CmpEq as _, i32x8};
    // Lane `j`'s bit picked out of the byte in every lane at once.
    let lane_bit = i32x8::new([1, 2, 4, 8, 16, 32, 64, 128]);
    bytemuck::cast((i32x8::splat(i32::from(bits)) & lane_bit).cmp_eq(lane_bit))
}

/// The lanes set in `bits`, in order.
#[inline(always)]
pub(crate) fn set(mut bits: u8) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (bits != 0).then(|| {
            let j = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            j
        })
    })
}

/// Bit `j` set where `on(j)` for the first `len` lanes, with no branch per lane (lanes whose
/// hit or miss alternates would mispredict one).
#[inline(always)]
pub(crate) fn bits(len: usize, on: impl Fn(usize) -> bool) -> u8 {
    debug_assert!(len <= PACKET, "{len} lanes in a group");
    (0..len).fold(0u8, |m, j| m | (u8::from(on(j)) << j))
}

/// Bit `j` set where `values[j] == v`, for the first `values.len()` (at most [`PACKET`])
/// lanes: one SIMD comparison for a whole group.
#[inline(always)]
pub(crate) fn equal_bits(values: &[u32], v: u32) -> u8 {
    use wide::{CmpEq as _, i32x8};
    match <&[u32; PACKET]>::try_from(values) {
        Ok(all) => i32x8::new(all.map(|x| x as i32)).cmp_eq(i32x8::splat(v as i32)).move_mask() as u8,
        Err(_) => bits(values.len(), |j| values[j] == v),
    }
}

/// Bit `j` set where `values[j] < limit`, for the first `values.len()` (at most [`PACKET`])
/// lanes: one SIMD comparison for a whole group.
#[inline(always)]
pub(crate) fn below_bits(values: &[u8], limit: u8) -> u8 {
    use wide::{CmpLt as _, i32x8};
    match <&[u8; PACKET]>::try_from(values) {
        Ok(all) => i32x8::new(all.map(i32::from)).cmp_lt(i32x8::splat(i32::from(limit))).move_mask() as u8,
        Err(_) => bits(values.len(), |j| values[j] < limit),
    }
}

/// Bit `j` set where `flags[j]`, for the first `flags.len()` (at most [`PACKET`]) lanes: a
/// whole group's flags gathered from its eight bytes at once.
#[inline(always)]
pub(crate) fn flag_bits(flags: &[bool]) -> u8 {
    match <&[bool; PACKET]>::try_from(flags) {
        Ok(all) => {
            // Each byte 0 or 1; the product gathers byte j's bit into bit 56 + j.
            let bytes = all.iter().enumerate().fold(0u64, |x, (j, &f)| x | (u64::from(f) << (8 * j)));
            (bytes.wrapping_mul(0x0102_0408_1020_4080) >> 56) as u8
        }
        Err(_) => bits(flags.len(), |j| flags[j]),
    }
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

/// [`lancer_core::optics::vct_transmis`] lane by lane, with the same bits: the direction
/// through a surface of normal `n_t` (turned to the side `u` goes to) with index ratio `delta`,
/// and the lanes with one (the others reflect totally).
#[inline(always)]
pub(crate) fn vct_transmis(u: &V3, n_t: &V3, delta: f32x8) -> (V3, f32x8) {
    use wide::{CmpGt, CmpLt};
    let back = dot(n_t, u).cmp_lt(f32x8::ZERO);
    let n_t: V3 = n_t.map(|c| back.blend(neg(c), c));
    // `clamp(-1, 1)`, a NaN kept.
    let ps = dot(&n_t, u);
    let ps = ps.cmp_lt(f32x8::splat(-1.0)).blend(f32x8::splat(-1.0), ps);
    let ps = ps.cmp_gt(f32x8::ONE).blend(f32x8::ONE, ps);
    let k = f32x8::ONE - delta * delta * (f32x8::ONE - ps * ps);
    let through = !k.cmp_lt(f32x8::ZERO);
    let s = k.sqrt() - delta * ps;
    let t: V3 = std::array::from_fn(|a| s * n_t[a] + delta * u[a]);
    // `try_normalize`, else `u`.
    let rcp = f32x8::ONE / dot(&t, &t).sqrt();
    let unit = rcp.abs().cmp_lt(f32x8::splat(f32::INFINITY)) & rcp.cmp_gt(f32x8::ZERO);
    (std::array::from_fn(|a| unit.blend(t[a] * rcp, u[a])), through)
}

/// Lane `j` of `v`.
#[inline(always)]
pub(crate) fn lane(v: &V3, j: usize) -> Vec3 {
    Vec3::from(glam::Vec3A::new(v[0].as_array_ref()[j], v[1].as_array_ref()[j], v[2].as_array_ref()[j]))
}

/// `c^e` lane by lane for whole exponents `e` (at most 2^16): `f32::powi`'s steps (the
/// runtime's: square `c` for each bit of `e`, multiply it in where the bit is set, from 1),
/// so the same bits.
#[inline(always)]
pub(crate) fn powi(c: f32x8, e: [u32; PACKET]) -> f32x8 {
    let (mut base, mut product) = (c, f32x8::ONE);
    if e.iter().all(|&x| x == e[0]) {
        // One exponent for every lane (the usual case: one material): the same steps, with no
        // mask to make for each bit.
        let mut e = e[0];
        debug_assert!(e < 1 << 17, "exponent {e}");
        while e != 0 {
            if e & 1 == 1 {
                product *= base;
            }
            base = base * base;
            e >>= 1;
        }
        return product;
    }
    let top = e.iter().copied().max().unwrap_or(0);
    debug_assert!(top < 1 << 17, "exponent {top}");
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
            let hit = !equal_bits(&hits.object[base..base + len], NO_HIT) & bits(len, |_| true);
            Group { base, len, hit }
        })
    }

    /// The lanes set in `bits`, in order, as chunk lanes.
    #[inline(always)]
    pub(crate) fn lanes(&self, bits: u8) -> impl Iterator<Item = (usize, usize)> {
        let base = self.base;
        set(bits).map(move |j| (j, base + j))
    }

    /// A material parameter of each hit lane (`param`), and the hit lanes where `acts` takes it
    /// (the term's own test, NaN included: lane by lane, the scalar code's test).
    #[inline(always)]
    pub(crate) fn param(
        &self,
        ctx: &crate::ShadeContext<'_>,
        hits: &Hits,
        param: impl Fn(&lancer_core::Material) -> f32,
        acts: impl Fn(f32) -> bool,
    ) -> ([f32; PACKET], u8) {
        let indices = &hits.material[self.base..self.base + self.len];
        if let Some(material) = self.one_material(indices) {
            // One material for every hit lane (the usual case): read once.
            let v = ctx.materials.get(material as usize).map_or(0.0, &param);
            let value = std::array::from_fn(|j| if (self.hit >> j) & 1 != 0 { v } else { 0.0 });
            return (value, if acts(v) { self.hit } else { 0 });
        }
        // Every lane, with no branch on hit or miss (a lane with no hit reads material 0, and
        // keeps 0).
        let (mut value, mut above) = ([0.0f32; PACKET], 0u8);
        for j in 0..self.len {
            let hit = (self.hit >> j) & 1 != 0;
            let material = if hit { indices[j] } else { 0 };
            let v = ctx.materials.get(material as usize).map_or(0.0, &param);
            value[j] = if hit { v } else { 0.0 };
            above |= u8::from(hit & acts(v)) << j;
        }
        (value, above)
    }

    /// The material of every hit lane, when they have one (`indices`: the group's lanes' material
    /// column), and at least one lane hit.
    #[inline(always)]
    pub(crate) fn one_material(&self, indices: &[u32]) -> Option<u32> {
        if self.hit == 0 {
            return None;
        }
        let first = indices[self.hit.trailing_zeros() as usize];
        (equal_bits(indices, first) & self.hit == self.hit).then_some(first)
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
        below_bits(&rays.depth[self.base..self.base + self.len], max_depth)
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
        let front = mask(flag_bits(&hits.front[self.base..self.base + self.len]));
        shading.map(|c| front.blend(c, neg(c)))
    }

    /// The rays' directions.
    #[inline(always)]
    pub(crate) fn dir(&self, rays: &Rays) -> V3 {
        load(&rays.dir.packets()[self.base / PACKET])
    }

    /// [`crate::sum_lights`] eight lanes at a time, for the lanes set in `on`: `Σ f(N·w, w) ·
    /// light` over the lights in front of the surface (`N·w > 0`, with `n` the normal facing
    /// the ray) that send something, in light order, with the same bits lane by lane. With
    /// `COSTLY`, a light that reaches none of the lanes is passed over before `f` (a branch
    /// worth taking only when `f` costs more than a misprediction).
    #[inline(always)]
    pub(crate) fn sum_lights<const COSTLY: bool>(
        &self,
        lights: &LightSamples,
        n: &V3,
        on: f32x8,
        f: impl Fn(f32x8, &V3) -> f32x8,
    ) -> V3 {
        use wide::CmpGt;
        let mut sum = [f32x8::ZERO; 3];
        for k in 0..lights.lights {
            let (w, light) = self.light(lights, k);
            let nw = dot(n, &w);
            let lit = on & nw.cmp_gt(f32x8::ZERO) & nonzero(&light);
            if COSTLY && lit.move_mask() == 0 {
                continue;
            }
            let f = f(nw, &w);
            for a in 0..3 {
                sum[a] = lit.blend(sum[a] + f * light[a], sum[a]);
            }
        }
        sum
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
    fn a_parameter_read_once_for_one_material_is_what_each_lane_reads() {
        // Groups of one material and of several, with misses among them, and a parameter the
        // term skips on one material: `param` gives each hit lane its material's value and
        // test, and every other lane 0 and no bit.
        let materials: Vec<lancer_core::Material> =
            [0.3, 0.0, 0.7].iter().map(|&spec| lancer_core::Material { spec, ..Default::default() }).collect();
        let geometry = lancer_shapes::Geometry::new(Vec::new());
        let ctx = crate::ShadeContext {
            geometry: &geometry,
            materials: &materials,
            lights: &[],
            max_depth: 5,
            textures: &[],
            reference: false,
        };
        let mut hits = lancer_core::rays::Hits::default();
        // Thirteen lanes: the second group is cut short.
        hits.reset(13);
        let index = [0, 0, 0, 0, 0, 0, 0, 0, 2, 1, 2, 2, 0];
        for (lane, &i) in index.iter().enumerate() {
            hits.material[lane] = i;
            hits.object[lane] = if lane % 5 == 3 { lancer_core::rays::NO_HIT } else { 0 };
        }
        let groups: Vec<_> = super::Group::all(&hits).collect();
        assert_eq!(
            groups.iter().map(|g| (g.base, g.len, g.hit)).collect::<Vec<_>>(),
            [(0, 8, 0b1111_0111), (8, 5, 0b1_1110)]
        );
        for group in groups {
            let (value, on) = group.param(&ctx, &hits, |m| m.spec, |s| s > 0.0);
            for (j, got) in value.iter().enumerate().take(group.len) {
                let lane = group.base + j;
                let hit = hits.object[lane] != lancer_core::rays::NO_HIT;
                let want = if hit { materials[index[lane] as usize].spec } else { 0.0 };
                assert_eq!(got.to_bits(), want.to_bits(), "lane {lane}");
                assert_eq!(on >> j & 1 == 1, hit && want > 0.0, "lane {lane}");
            }
        }
    }

    #[test]
    fn a_groups_bits_gathered_at_once_are_those_lane_by_lane() {
        // Every pattern of eight flags and of eight values equal or not, whole groups and cut.
        for pattern in 0..=255u8 {
            let flags: Vec<bool> = (0..8).map(|j| pattern >> j & 1 == 1).collect();
            let values: Vec<u32> = (0..8).map(|j| if pattern >> j & 1 == 1 { 7 } else { j * 3 + 100 }).collect();
            for len in 1..=8 {
                let want = super::bits(len, |j| flags[j]);
                assert_eq!(super::flag_bits(&flags[..len]), want, "{pattern:08b}, {len} lanes");
                assert_eq!(super::equal_bits(&values[..len], 7), want, "{pattern:08b}, {len} lanes");
                let depths: Vec<u8> =
                    (0..8).map(|j| if pattern >> j & 1 == 1 { j as u8 } else { 200 + j as u8 }).collect();
                assert_eq!(super::below_bits(&depths[..len], 200), want, "{pattern:08b}, {len} lanes");
            }
        }
        assert_eq!(super::equal_bits(&[u32::MAX; 8], u32::MAX), 0xFF);
        // A mask from bits: all ones where the bit is set, zero elsewhere.
        for pattern in 0..=255u8 {
            let got = super::mask(pattern).to_array().map(f32::to_bits);
            assert_eq!(got, std::array::from_fn(|j| if pattern >> j & 1 == 1 { u32::MAX } else { 0 }), "{pattern:08b}");
        }
    }

    #[test]
    fn a_group_has_one_material_only_when_every_hit_lane_has_it() {
        let group = |hit: u8, len: usize| super::Group { base: 0, len, hit };
        // Lanes with no hit do not count, whatever their stale material.
        assert_eq!(group(0b1011_0101, 8).one_material(&[3, 9, 3, 9, 3, 3, 9, 3]), Some(3));
        assert_eq!(group(0b1011_0111, 8).one_material(&[3, 9, 3, 9, 3, 3, 9, 3]), None);
        assert_eq!(group(0b0000_0100, 3).one_material(&[1, 2, 7]), Some(7));
        // No hit: no material.
        assert_eq!(group(0, 8).one_material(&[0; 8]), None);
    }

    #[test]
    fn powers_have_the_bits_of_powi() {
        // Bases near 1 for the large exponents, so the powers neither underflow to 0 nor
        // overflow (where any order of products would agree), and anywhere in [0, 1.3) for the
        // small ones.
        let mut f = 0.37f32;
        let mut seen = 0;
        for round in 0..4000 {
            f = (f * 3.7 + 0.11).fract();
            // Every third round one exponent for all lanes (powi's other path).
            let spread = if round % 3 == 0 { 0 } else { 5 };
            let e: [u32; 8] =
                std::array::from_fn(|j| [1, 2, 5, 20, 40, 80, 100, 1024, 3, 7, 64, 65535][(round + j * spread) % 12]);
            let c = f32x8::new(std::array::from_fn(|j| {
                let u = (f + j as f32 * 0.119).fract();
                if e[j] >= 64 { 1.0 + (u - 0.5) * 8.0 / e[j] as f32 } else { u * 1.3 }
            }));
            let got = super::powi(c, e).to_array();
            for j in 0..8 {
                let want = c.to_array()[j].powi(e[j] as i32);
                assert_eq!(got[j].to_bits(), want.to_bits(), "{}^{}", c.to_array()[j], e[j]);
                seen += usize::from(want.is_normal() && want != 1.0 && e[j] >= 64);
            }
        }
        assert!(seen > 5_000, "{seen} large powers of note");
    }
}

//! The colour of a surface at a point: a material's pattern (solid, 3D checker, image) evaluated
//! at the object-space hit point.

use glam::Vec3;
use lancer_core::{Material, Pattern, Texture};
use lancer_shapes::Shape;

/// `Col_Ω` of `material` at the object-space point `local` of a `shape`.
#[inline]
pub fn surface_color(
    material: &Material,
    shape: &Shape,
    local: Vec3,
    mesh_uv: glam::Vec2,
    textures: &[Texture],
) -> Vec3 {
    match material.pattern {
        Pattern::Solid => material.color,
        Pattern::Checker { other, scale } => {
            // A hair of offset keeps points on a cell boundary (a floor at y = 0, whose hit points
            // scatter around 0 by rounding) on one side of it.
            let c = local / scale + Vec3::splat(1e-4);
            if odd_cell(c) { other } else { material.color }
        }
        Pattern::Image { texture, scale } => {
            let uv = if matches!(shape, Shape::Mesh(_)) { mesh_uv } else { shape.uv(local, scale) };
            textures.get(texture as usize).map_or(material.color, |t| t.sample(uv.x, uv.y))
        }
    }
}

/// [`surface_color`] of eight hits on one object (of `material`, shaped `shape`, not a mesh)
/// at the object-space points `local`: the same colours, with the checker's parity taken eight
/// lanes at a time within 2^23 of the origin (every scene's floor: there `f`, a floor, is a
/// whole number, `f / 2` is exact, and `f` is odd where its half has a fraction), each lane by
/// [`odd_cell`] beyond. Only the lanes set in `on` are looked at; the others come out as
/// anything.
pub(crate) fn surface_colors(
    material: &Material,
    shape: &Shape,
    local: &lancer_core::rays::Packet,
    on: u8,
    textures: &[Texture],
) -> lancer_core::rays::Packet {
    use wide::{CmpEq, CmpGt, CmpLt, f32x8};
    let lane = |k: usize| Vec3::new(local[0][k], local[1][k], local[2][k]);
    let each = |out: &mut lancer_core::rays::Packet| {
        for k in crate::lanes::set(on) {
            let c = surface_color(material, shape, lane(k), glam::Vec2::ZERO, textures);
            (out[0][k], out[1][k], out[2][k]) = (c.x, c.y, c.z);
        }
    };
    let splat = |c: Vec3| c.to_array().map(|v| [v; 8]);
    match material.pattern {
        Pattern::Solid => splat(material.color),
        Pattern::Checker { other, scale } => {
            let c = local.map(|axis| f32x8::new(axis) / f32x8::splat(scale) + f32x8::splat(1e-4));
            let live = crate::lanes::mask(on);
            let near = c.iter().fold(live, |m, v| m & v.abs().cmp_lt(f32x8::splat(8_388_608.0)));
            if near.move_mask() as u8 != on {
                // A lane far away (or NaN): each lane by itself.
                let mut out = splat(material.color);
                each(&mut out);
                return out;
            }
            // `v.floor()` for |v| < 2^23 (every lane here: `near`): truncated through the
            // integers, one less where that went up; exact there, and without the eight calls
            // to `floorf` wide's floor makes on the baseline x86-64 build (a floor's sign of
            // zero may differ, which no comparison below sees).
            let floor = |v: f32x8| {
                let t = v.fast_trunc_int().round_float();
                t - (t.cmp_gt(v) & f32x8::ONE)
            };
            let odd = c.iter().fold(f32x8::ZERO, |parity, &v| {
                let half = floor(v) * f32x8::splat(0.5);
                parity ^ !floor(half).cmp_eq(half)
            });
            let (even, odd_colour) = (splat(material.color), splat(other));
            std::array::from_fn(|a| odd.blend(f32x8::new(odd_colour[a]), f32x8::new(even[a])).to_array())
        }
        Pattern::Image { .. } => {
            let mut out = splat(material.color);
            each(&mut out);
            out
        }
    }
}

/// Whether the cell of `c` is odd: the parity of the sum of its coordinates' [`cell`]s
/// (integer arithmetic, wrapping: far cells keep alternating; infinite and NaN coordinates
/// saturated as the cast saturates).
#[inline]
fn odd_cell(c: Vec3) -> bool {
    cell(c.x).wrapping_add(cell(c.y)).wrapping_add(cell(c.z)) & 1 == 1
}

/// `x.floor() as i64`, without the call to `floorf` the baseline x86-64 build makes for a
/// floor: truncated towards zero, one less where that went up. The same value for every `x`
/// (saturated beyond the range of `i64`, 0 for NaN, as the cast of the floor is).
#[inline]
fn cell(x: f32) -> i64 {
    let t = x as i64;
    if (t as f32) > x { t.saturating_sub(1) } else { t }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checker_alternates_by_cell_and_is_stable_on_a_floor() {
        let m = Material {
            color: Vec3::ONE,
            pattern: Pattern::Checker { other: Vec3::ZERO, scale: 1.0 },
            ..Material::default()
        };
        let at = |x: f32, y: f32, z: f32| surface_color(&m, &Shape::Plane, Vec3::new(x, y, z), glam::Vec2::ZERO, &[]);
        assert_eq!(at(0.5, 0.0, 0.5), Vec3::ONE);
        assert_eq!(at(1.5, 0.0, 0.5), Vec3::ZERO);
        assert_eq!(at(1.5, 0.0, 1.5), Vec3::ONE);
        assert_eq!(at(-0.5, 0.0, 0.5), Vec3::ZERO);
        // Rounding noise around y = 0 does not flip the colour.
        assert_eq!(at(0.5, -1e-6, 0.5), at(0.5, 1e-6, 0.5));
    }

    #[test]
    fn eight_colours_at_once_are_those_of_each_hit_alone() {
        // Checkers of several scales at points near and on cell boundaries, far away (past the
        // float path), NaN; a solid colour and an image; lanes left out hold anything.
        let checker = |scale: f32| Material {
            color: Vec3::new(0.9, 0.8, 0.7),
            pattern: Pattern::Checker { other: Vec3::new(0.1, 0.2, 0.3), scale },
            ..Material::default()
        };
        let image = Material { pattern: Pattern::Image { texture: 0, scale: 2.0 }, ..Material::default() };
        let textures = [Texture::linear(2, 1, vec![Vec3::X, Vec3::Z])];
        let solid = Material { color: Vec3::new(0.25, 0.5, 0.75), ..Material::default() };
        let materials = [checker(1.0), checker(0.37), checker(3.0), solid, image];
        let mut f = 0.123f32;
        let mut next = move || {
            f = (f * 7.13 + 0.37).fract();
            f
        };
        let mut odd = 0;
        for round in 0..3000 {
            let material = &materials[round % materials.len()];
            let on = (round as u8).wrapping_mul(37) | 1;
            let local: lancer_core::rays::Packet = std::array::from_fn(|a| {
                std::array::from_fn(|k| match (round / 5 + k + a) % 9 {
                    0 => (next() * 20.0 - 10.0).round() - 1e-4,
                    1 => 0.0,
                    2 => -next() * 3.0,
                    3 if round % 50 == 0 => 1e9,
                    4 if round % 70 == 0 => f32::NAN,
                    _ => next() * 40.0 - 20.0,
                })
            });
            let got = surface_colors(material, &Shape::Plane, &local, on, &textures);
            for k in (0..8).filter(|k| on >> k & 1 == 1) {
                let p = Vec3::new(local[0][k], local[1][k], local[2][k]);
                let want = surface_color(material, &Shape::Plane, p, glam::Vec2::ZERO, &textures);
                let lane = Vec3::new(got[0][k], got[1][k], got[2][k]);
                assert_eq!(lane.to_array().map(f32::to_bits), want.to_array().map(f32::to_bits), "{p} {k}");
                odd += usize::from(want == Vec3::new(0.1, 0.2, 0.3));
            }
        }
        assert!(odd > 1000, "{odd} odd cells");
    }

    #[test]
    fn the_odd_cells_are_those_whose_floors_sum_to_an_odd_number() {
        // Near and far, on cell boundaries, at the edge of the float path (2^23) and past it,
        // infinite and NaN: the same parity as the sum of the floors as integers.
        let mut values = vec![0.0f32, -0.0, 0.5, -0.5, 1.0, -1.0, 2.0, -2.0, 3.0, -3.0, 1e-4, -1e-4];
        values.extend([0.999_999_94, -0.999_999_94, 1.000_000_1, -1.000_000_1, 4_194_303.5, -4_194_303.5]);
        values.extend([8_388_607.0, -8_388_607.0, 8_388_607.5, -8_388_607.5, 8_388_608.0, -8_388_608.0]);
        values.extend([8_388_609.0, 1.6e7, -1.6e7, 9.2e18, -9.2e18, 1e30, -1e30, f32::MAX, f32::MIN]);
        values.extend([f32::INFINITY, f32::NEG_INFINITY, f32::NAN, f32::MIN_POSITIVE, -f32::MIN_POSITIVE]);
        values.extend((0..300).map(|i| (i as f32 - 150.0) * 0.137));
        let want = |c: Vec3| {
            let floor = |x: f32| x.floor() as i64;
            floor(c.x).wrapping_add(floor(c.y)).wrapping_add(floor(c.z)) & 1 == 1
        };
        let (mut odd, mut seen) = (0, 0);
        for (i, &x) in values.iter().enumerate() {
            for (j, &y) in values.iter().enumerate().step_by(7) {
                let z = values[(i * 31 + j * 17) % values.len()];
                for c in [Vec3::new(x, y, z), Vec3::new(z, x, y), Vec3::new(x, 0.0, y)] {
                    assert_eq!(odd_cell(c), want(c), "{c}");
                    (odd, seen) = (odd + usize::from(want(c)), seen + 1);
                }
            }
        }
        assert!(odd > seen / 4 && odd < seen * 3 / 4, "{odd} odd of {seen}");
    }

    #[test]
    fn the_cell_of_a_coordinate_is_its_floor() {
        let mut values = vec![0.0f32, -0.0, 0.5, -0.5, 1.0, -1.0, 1e-4, -1e-4, 0.999_999_94, -0.999_999_94];
        values.extend([8_388_607.5, -8_388_607.5, 1.6e7, -1.6e7, 9.2e18, -9.2e18, 1e30, -1e30, f32::MAX, f32::MIN]);
        values.extend([f32::INFINITY, f32::NEG_INFINITY, f32::NAN, f32::MIN_POSITIVE, -f32::MIN_POSITIVE]);
        values.extend((0..2000).map(|i| (i as f32 - 1000.0) * 0.013_7));
        for x in values {
            assert_eq!(cell(x), x.floor() as i64, "{x}");
        }
    }

    #[test]
    fn image_lookup_uses_the_shapes_uv() {
        // A 2 × 1 image: left half red, right half blue.
        let t = Texture::linear(2, 1, vec![Vec3::X, Vec3::Z]);
        let m = Material { pattern: Pattern::Image { texture: 0, scale: 2.0 }, ..Material::default() };
        // On a plane, x / scale is u: x = 0.5 → u = 0.25, the red pixel's centre.
        assert_eq!(
            surface_color(&m, &Shape::Plane, Vec3::new(0.5, 0.0, 0.3), glam::Vec2::ZERO, std::slice::from_ref(&t)),
            Vec3::X
        );
        assert_eq!(surface_color(&m, &Shape::Plane, Vec3::new(1.5, 0.0, 0.3), glam::Vec2::ZERO, &[t]), Vec3::Z);
    }
}

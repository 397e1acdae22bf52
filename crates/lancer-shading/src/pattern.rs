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
            // The parity of the cell: integer arithmetic (wrapping: far cells keep alternating).
            let parity = cell(c.x).wrapping_add(cell(c.y)).wrapping_add(cell(c.z)) & 1;
            if parity == 0 { material.color } else { other }
        }
        Pattern::Image { texture, scale } => {
            let uv = if matches!(shape, Shape::Mesh(_)) { mesh_uv } else { shape.uv(local, scale) };
            textures.get(texture as usize).map_or(material.color, |t| t.sample(uv.x, uv.y))
        }
    }
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
        let t = Texture { width: 2, height: 1, pixels: vec![Vec3::X, Vec3::Z] };
        let m = Material { pattern: Pattern::Image { texture: 0, scale: 2.0 }, ..Material::default() };
        // On a plane, x / scale is u: x = 0.5 → u = 0.25, the red pixel's centre.
        assert_eq!(
            surface_color(&m, &Shape::Plane, Vec3::new(0.5, 0.0, 0.3), glam::Vec2::ZERO, std::slice::from_ref(&t)),
            Vec3::X
        );
        assert_eq!(surface_color(&m, &Shape::Plane, Vec3::new(1.5, 0.0, 0.3), glam::Vec2::ZERO, &[t]), Vec3::Z);
    }
}

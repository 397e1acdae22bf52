//! The built-in shadow models, one file each, and their ordered table.

pub mod hard;
pub mod no_offset;
pub mod none;
pub mod past_light;
pub mod soft;
pub mod transmissive;

use crate::ShadowSpec;

/// The built-in shadow models, in the order `lancer terms` lists them. The first is not the
/// default: a model that names no shadow model gets `hard` (the handout's). The classic
/// mistakes of the course come last (their specs' `mistake` is set: `lancer terms --mistakes`
/// lists them).
pub const BUILTIN: &[ShadowSpec] =
    &[none::SPEC, hard::SPEC, transmissive::SPEC, soft::SPEC, no_offset::SPEC, past_light::SPEC];

/// The shadow model a model gets when it names none.
pub const DEFAULT: &str = "hard";

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec3};
    use lancer_core::{Light, Material};
    use lancer_shapes::{Geometry, Object, Origin, Shape};

    use crate::shadow::BLOCK;
    use crate::{HitBlock, ParamValue, Params, Registry, ShadeContext, ShadowContext};

    #[test]
    fn every_model_gives_a_block_of_hits_what_each_hit_gets_alone() {
        // Glass and opaque spheres, a glass cube, a glass disk and an opaque floor; hits all over
        // them, towards point lights above, beside and inside the glass, and an area light: a
        // block handed to `transmittance_each` gets, hit by hit and to the bit, what
        // `transmittance` gives each alone, with the same shadow-ray count.
        let glass = Material { color: Vec3::new(1.0, 0.5, 0.25), alpha: 0.5, ..Material::default() };
        let materials = [glass, Material::default()];
        let place = |shape: Shape, scale: f32, at: Vec3, material: u32| {
            let m = Affine3A::from_scale_rotation_translation(Vec3::splat(scale), glam::Quat::from_rotation_y(0.4), at);
            Object::new(shape, m, material).unwrap()
        };
        let g = Geometry::new(vec![
            place(Shape::Plane, 1.0, Vec3::ZERO, 1),
            place(Shape::Sphere, 1.0, Vec3::new(0.0, 1.0, 0.0), 0),
            place(Shape::Sphere, 0.5, Vec3::new(2.0, 0.5, 1.0), 1),
            place(Shape::Cube, 0.6, Vec3::new(-2.0, 0.6, -1.0), 0),
            place(Shape::Disk, 0.8, Vec3::new(1.0, 2.5, -1.0), 0),
            place(Shape::Sphere, 0.3, Vec3::new(-1.0, 0.3, 2.0), 1),
        ]);
        let scene = ShadeContext {
            geometry: &g,
            materials: &materials,
            lights: &[],
            max_depth: 5,
            textures: &[],
            reference: false,
        };
        let hits: Vec<_> = (0..300)
            .filter_map(|k| {
                let a = k as f32 * 0.618_034;
                let eye = Vec3::new(6.0 * a.cos(), 3.0 + 5.0 * (a * 1.3).sin().abs(), 6.0 * a.sin());
                let aim = Vec3::new(3.0 * (a * 2.1).sin(), (a * 0.7).cos().abs() * 2.0, 3.0 * (a * 1.7).cos());
                g.closest_hit(Origin::free(eye), (aim - eye).normalize(), 0.0, f32::INFINITY)
            })
            .collect();
        assert!(hits.len() > 250);
        let columns = crate::shadow::columns_of(&hits);
        let registry = Registry::with_builtins();
        let models =
            [("hard", false), ("transmissive", false), ("transmissive", true), ("soft", true), ("none", false)];
        for (name, tint) in models {
            let params = match name {
                "transmissive" | "soft" => Params::new([("tint".to_owned(), ParamValue::Bool(tint))]),
                _ => Params::default(),
            };
            let model = registry.build_shadow(name, params).unwrap().model;
            let mut seen = [0, 0, 0];
            for (at, size) in [
                (Vec3::new(3.0, 8.0, -2.0), 0.0),
                (Vec3::new(-6.0, 1.0, 0.5), 0.0),
                (Vec3::new(0.0, 1.2, 0.1), 0.0),
                // At a hit point: that hit gets all of it, with no ray.
                (hits[70].point, 0.0),
                (Vec3::new(2.0, 6.0, 2.0), 1.5),
            ] {
                let light = Light { at, color: Vec3::ONE, intensity: 1.0, size };
                let (each_ctx, alone_ctx) = (ShadowContext::new(&scene), ShadowContext::new(&scene));
                let mut each = vec![Vec3::splat(7.0); hits.len()];
                // Blocks of scattered lanes, as the visibility system makes them (the lanes a
                // light reaches): even lanes, then odd ones.
                let order: Vec<usize> = (0..hits.len()).step_by(2).chain((1..hits.len()).step_by(2)).collect();
                for lanes in order.chunks(BLOCK) {
                    let block = HitBlock::toward(&scene, &columns, lanes, light.at);
                    let mut out = [Vec3::splat(7.0); BLOCK];
                    model.transmittance_each(&each_ctx, &block, &light, &mut out[..lanes.len()]);
                    for (&lane, got) in lanes.iter().zip(out) {
                        each[lane] = got;
                    }
                }
                for (hit, got) in hits.iter().zip(&each) {
                    let alone = model.transmittance(&alone_ctx, hit, &light);
                    assert_eq!(got.to_array().map(f32::to_bits), alone.to_array().map(f32::to_bits), "{name}: {hit:?}");
                    seen[usize::from(alone != Vec3::ONE) + usize::from(alone == Vec3::ZERO)] += 1;
                }
                assert_eq!(each_ctx.rays(), alone_ctx.rays(), "{name}");
            }
            // Lit and blocked hits (and dimmed by glass, where the model lets light through it).
            assert!(name == "none" || (seen[0] > 50 && seen[2] > 20), "{name}: {seen:?}");
            assert!(!(name == "transmissive" || name == "soft") || seen[1] > 50, "{name}: {seen:?}");
        }
    }
}

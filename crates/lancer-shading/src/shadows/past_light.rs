//! `past-light`: a classic mistake of the course, kept to show it and for `lancer diagnose` to
//! recognise it (named `shadows:past-light`): the handout's hard shadows with a shadow ray that
//! does not stop at the light, so that an object beyond the light blocks it too.
//!
//! Formula: transmittance = 0 if the ray from the surface towards the light meets an object at
//! any distance (not only before the light), else 1. Surfaces lit by a light that has an object
//! behind it (a ceiling above a lamp, a wall behind it) go dark.
//! Reads no material parameter, has no parameter.
//!
//! ```toml
//! [model]
//! shadows = "past-light"
//! ```

use glam::Vec3;
use lancer_core::Light;
use lancer_shapes::Hit;

use crate::{Mistake, Params, ShadowContext, ShadowModel, ShadowSpec, aim};

/// The spec registered under `past-light` (a mistake of `hard`).
pub const SPEC: ShadowSpec = ShadowSpec {
    name: "past-light",
    summary: "the shadow ray is not stopped at the light: an object beyond the light blocks it too",
    params: &[],
    build: |_: &mut Params| Ok(Box::new(PastLight)),
    mistake: Some(Mistake {
        of: "hard",
        hint: "an object shadows the point only if it lies between I and the light: keep the hits with 0 < t < ‖L − I‖ (t < 1 with the direction L − I not normalised)",
    }),
};

struct PastLight;

impl ShadowModel for PastLight {
    fn transmittance(&self, ctx: &ShadowContext<'_>, at: &Hit, light: &Light) -> Vec3 {
        let Some((from, dir, _)) = aim(ctx.geometry, at, light.at) else { return Vec3::ONE };
        match ctx.occluder(from, dir, f32::INFINITY) {
            Some(_) => Vec3::ZERO,
            None => Vec3::ONE,
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec3};
    use lancer_core::Light;
    use lancer_shapes::{Geometry, Object, Origin, Shape};

    use crate::{Params, Registry, ShadeContext, ShadowContext};

    #[test]
    fn a_ceiling_above_the_light_shadows_the_floor() {
        // The floor y = 0 and a ceiling y = 4 (the plane turned over), a light at y = 2: the
        // floor is lit by the hard model, dark with the mistake; with no ceiling both light it.
        let floor = Object::new(Shape::Plane, Affine3A::IDENTITY, 0).unwrap();
        let ceiling = Object::new(
            Shape::Plane,
            Affine3A::from_rotation_translation(
                glam::Quat::from_rotation_x(std::f32::consts::PI),
                Vec3::new(0.0, 4.0, 0.0),
            ),
            0,
        )
        .unwrap();
        let light = Light { at: Vec3::new(1.0, 2.0, 0.5), color: Vec3::ONE, intensity: 1.0, size: 0.0 };
        let registry = Registry::with_builtins();
        let hard = registry.build_shadow("hard", Params::default()).unwrap().model;
        let past = registry.build_shadow("past-light", Params::default()).unwrap().model;
        for (objects, shadowed) in [(vec![floor.clone(), ceiling], true), (vec![floor], false)] {
            let g = Geometry::new(objects);
            let scene = ShadeContext {
                geometry: &g,
                materials: &[],
                lights: &[],
                max_depth: 0,
                textures: &[],
                reference: false,
            };
            let ctx = ShadowContext::new(&scene);
            let from = Vec3::new(-1.0, 1.0, -1.0);
            let hit = g.closest_hit(Origin::free(from), (Vec3::ZERO - from).normalize(), 0.0, f32::INFINITY).unwrap();
            assert!(hit.point.length() < 1e-4, "{}", hit.point);
            assert_eq!(hard.transmittance(&ctx, &hit, &light), Vec3::ONE);
            let want = if shadowed { Vec3::ZERO } else { Vec3::ONE };
            assert_eq!(past.transmittance(&ctx, &hit, &light), want);
        }
    }
}

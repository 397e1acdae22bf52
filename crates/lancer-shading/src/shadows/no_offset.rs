//! `no-offset`: a classic mistake of the course, kept to show it and for `lancer diagnose` to
//! recognise it (named `shadows:no-offset`): the handout's hard shadows with the shadow ray
//! started on the surface itself, at the hit point, ignoring no object.
//!
//! Formula: transmittance = 0 if the segment `[I, L]` from the hit point itself meets an
//! object (its own surface included), else 1. The hit point is rounded to the nearest floats,
//! half the time a hair inside the surface: there the shadow ray meets its own surface and
//! the point shadows itself. Lit surfaces are speckled with dark dots: shadow acne.
//! Reads no material parameter, has no parameter. It breaks on purpose the rule every other
//! shadow model keeps (shadow rays start where `Geometry::spawn` says).
//!
//! ```toml
//! [model]
//! shadows = "no-offset"
//! ```

use glam::Vec3;
use lancer_core::Light;
use lancer_shapes::{Hit, Origin};

use crate::{Mistake, Params, ShadowContext, ShadowModel, ShadowSpec};

/// The spec registered under `no-offset` (a mistake of `hard`).
pub const SPEC: ShadowSpec = ShadowSpec {
    name: "no-offset",
    summary: "shadow rays start on the surface itself, with no offset: the surface shadows itself in speckles (shadow acne)",
    params: &[],
    build: |_: &mut Params| Ok(Box::new(NoOffset)),
    mistake: Some(Mistake {
        of: "hard",
        hint: "start the shadow ray a little off the surface, on the light's side (I + ε·N, ε about 1e-4 of the scene's size), or let it ignore the object it leaves",
    }),
};

struct NoOffset;

impl ShadowModel for NoOffset {
    fn transmittance(&self, ctx: &ShadowContext<'_>, at: &Hit, light: &Light) -> Vec3 {
        let Some((dir, dist)) = ctx.toward(at, light.at) else { return Vec3::ONE };
        match ctx.occluder(Origin::free(at.point), dir, dist) {
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
    fn a_lit_sphere_shadows_itself_where_its_points_round_inwards() {
        // A sphere lit from above, hit from all around its upper half: the hard model lights
        // every such point; without the offset some of them (the ones rounded a hair inside)
        // meet their own surface, and no hit outside the sphere's reach is dark.
        let g = Geometry::new(vec![
            Object::new(Shape::Sphere, Affine3A::from_translation(Vec3::new(0.3, 0.1, 7.0)), 0).unwrap(),
        ]);
        let scene =
            ShadeContext { geometry: &g, materials: &[], lights: &[], max_depth: 0, textures: &[], reference: false };
        let ctx = ShadowContext::new(&scene);
        let light = Light { at: Vec3::new(0.3, 50.0, 7.0), color: Vec3::ONE, intensity: 1.0, size: 0.0 };
        let registry = Registry::with_builtins();
        let (hard, acne) = (
            registry.build_shadow("hard", Params::default()).unwrap().model,
            registry.build_shadow("no-offset", Params::default()).unwrap().model,
        );
        let (mut lit, mut dark) = (0, 0);
        for k in 0..400 {
            let a = k as f32 * 0.618_034 * std::f32::consts::TAU;
            let aim =
                Vec3::new(0.3 + 0.6 * a.cos() * (k as f32 / 400.0), 0.9, 7.0 + 0.6 * a.sin() * (k as f32 / 400.0));
            let from = Vec3::new(0.0, 3.0, 0.0);
            let Some(hit) = g.closest_hit(Origin::free(from), (aim - from).normalize(), 0.0, f32::INFINITY) else {
                continue;
            };
            assert_eq!(hard.transmittance(&ctx, &hit, &light), Vec3::ONE);
            match acne.transmittance(&ctx, &hit, &light) {
                t if t == Vec3::ONE => lit += 1,
                _ => dark += 1,
            }
        }
        assert!(dark > 20 && lit > 20, "{dark} self-shadowed and {lit} lit of {} hits", dark + lit);
    }
}

//! `transmissive`: transparent occluders let light through. Each object crossed on the way to the
//! light multiplies it by its `alpha` (and, with `tint = true`, by its colour); an opaque object
//! (`alpha = 0`) blocks it. So glass casts a lighter shadow.
//!
//! Formula: transmittance = Π over objects crossed of `alpha_k` (× `Col_k` with `tint`).
//! Reads: `alpha`, `color` of occluders. Parameters: `tint` (default `false`).
//!
//! ```toml
//! [model]
//! shadows = { model = "transmissive", tint = true }
//! ```

use glam::Vec3;
use lancer_core::Light;
use lancer_shapes::{Origin, offset_origin};

use crate::{ParamSpec, Params, ShadowContext, ShadowModel, ShadowSpec};

/// The spec registered under `transmissive`.
pub const SPEC: ShadowSpec = ShadowSpec {
    name: "transmissive",
    summary: "transparent occluders attenuate the light by their alpha instead of blocking it",
    params: &[TINT],
    build: |p: &mut Params| Ok(Box::new(Transmissive { tint: p.boolean(TINT.name, false)? })),
};

/// The `tint` parameter, shared with the `soft` model.
pub const TINT: ParamSpec =
    ParamSpec { name: "tint", default: "false", doc: "also filter the light by each occluder's colour" };

/// More crossings than this on one shadow ray count as fully blocked (a pathological stack of
/// thin glass); it keeps the loop bounded.
const MAX_CROSSINGS: usize = 64;

struct Transmissive {
    tint: bool,
}

impl ShadowModel for Transmissive {
    fn transmittance(&self, ctx: &ShadowContext<'_>, from: Origin, light: &Light) -> Vec3 {
        match ctx.toward(from, light.at) {
            Some((dir, dist)) => through_occluders(ctx, from, dir, dist, self.tint),
            None => Vec3::ONE,
        }
    }
}

/// The light left after crossing every object between `from` and the point at `dist` along
/// `dir`: each transparent object crossed multiplies it by its `alpha` (and colour with `tint`)
/// once; an opaque one stops it.
pub fn through_occluders(ctx: &ShadowContext<'_>, from: Origin, dir: Vec3, dist: f32, tint: bool) -> Vec3 {
    let mut light = Vec3::ONE;
    let (mut from, mut left) = (from, dist);
    for _ in 0..MAX_CROSSINGS {
        let Some(hit) = ctx.occluder(from, dir, left) else {
            return light;
        };
        let m = ctx.material(hit.object);
        if m.alpha <= 0.0 {
            return Vec3::ZERO;
        }
        let p = from.point + hit.t * dir;
        light *= if tint { m.alpha * ctx.color_at(hit.object, p) } else { Vec3::splat(m.alpha) };
        // Count each object once: jump from its entry to where the ray leaves it.
        let past = if hit.front {
            let inside = offset_origin(p, -hit.normal);
            match ctx.geometry.exit(hit.object, inside, dir) {
                Some(exit) => ctx.geometry.leave(hit.object, inside + exit.t * dir, exit.normal),
                // It never ends (a plane's half-space): the light is inside it.
                None => return light,
            }
        } else {
            ctx.geometry.leave(hit.object, p, hit.normal)
        };
        let moved = (past.point - from.point).dot(dir);
        if moved >= left {
            return light;
        }
        left -= moved;
        from = past;
    }
    Vec3::ZERO
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec3};
    use lancer_core::{Light, Material};
    use lancer_shapes::{Geometry, Object, Origin, Shape};

    use crate::{Params, ShadowContext};

    fn sphere_at(z: f32, material: u32) -> Object {
        Object::new(Shape::Sphere, Affine3A::from_translation(Vec3::new(0.0, 0.0, z)), material).unwrap()
    }

    fn transmittance(model: &str, tint: bool, objects: Vec<Object>, dist: f32) -> Vec3 {
        let glass = Material { color: Vec3::new(1.0, 0.5, 0.25), alpha: 0.5, ..Material::default() };
        let opaque = Material::default();
        let g = Geometry::new(objects);
        let materials = [glass, opaque];
        let ctx = ShadowContext::new(&g, &materials, &[]);
        let params = if model == "transmissive" {
            Params::new([("tint".to_owned(), crate::ParamValue::Bool(tint))])
        } else {
            Params::default()
        };
        let m = crate::Registry::with_builtins().build_shadow(model, params).unwrap();
        let light = Light { at: Vec3::new(0.0, 0.0, dist), color: Vec3::ONE, intensity: 1.0, size: 0.0 };
        m.model.transmittance(&ctx, Origin::free(Vec3::ZERO), &light)
    }

    #[test]
    fn each_glass_object_crossed_counts_once() {
        assert_eq!(transmittance("transmissive", false, vec![], 10.0), Vec3::ONE);
        assert_eq!(transmittance("transmissive", false, vec![sphere_at(3.0, 0)], 10.0), Vec3::splat(0.5));
        assert_eq!(
            transmittance("transmissive", false, vec![sphere_at(3.0, 0), sphere_at(6.0, 0)], 10.0),
            Vec3::splat(0.25)
        );
        // The second sphere lies beyond the light: it does not count.
        assert_eq!(
            transmittance("transmissive", false, vec![sphere_at(3.0, 0), sphere_at(6.0, 0)], 4.5),
            Vec3::splat(0.5)
        );
        // A light inside a glass sphere is dimmed by it once.
        assert_eq!(transmittance("transmissive", false, vec![sphere_at(3.0, 0)], 3.0), Vec3::splat(0.5));
    }

    #[test]
    fn opaque_blocks_and_tint_filters() {
        assert_eq!(transmittance("transmissive", false, vec![sphere_at(3.0, 0), sphere_at(6.0, 1)], 10.0), Vec3::ZERO);
        assert_eq!(transmittance("transmissive", true, vec![sphere_at(3.0, 0)], 10.0), Vec3::new(0.5, 0.25, 0.125));
    }

    #[test]
    fn hard_blocks_even_glass_and_none_blocks_nothing() {
        assert_eq!(transmittance("hard", false, vec![sphere_at(3.0, 0)], 10.0), Vec3::ZERO);
        assert_eq!(
            transmittance("hard", false, vec![sphere_at(3.0, 0)], 1.5),
            Vec3::ONE,
            "the occluder is past the light"
        );
        assert_eq!(transmittance("none", false, vec![sphere_at(3.0, 1)], 10.0), Vec3::ONE);
    }
}

//! The built-in illumination terms: a folder per term, a file per variant, and their ordered
//! table.

pub mod ambient;
pub mod diffuse;
pub mod mirror;
pub mod refraction;
pub mod specular;

use crate::TermSpec;

/// The built-in term variants. Order is meaningful: the first variant of each name is its
/// default, and a model without `terms` gets each name's default in the handout's order
/// (ambient, diffuse, specular, mirror, refraction), which golden images depend on. The
/// classic mistakes of the course come after the real variants (their specs' `mistake` is set:
/// the registry lists them apart, `lancer terms --mistakes`).
pub const BUILTIN: &[TermSpec] = &[
    ambient::SPEC,
    diffuse::lambert::SPEC,
    diffuse::oren_nayar::SPEC,
    specular::phong::SPEC,
    specular::blinn::SPEC,
    specular::blinn_normalized::SPEC,
    mirror::constant::SPEC,
    mirror::schlick::SPEC,
    refraction::seed::SPEC,
    refraction::fresnel::SPEC,
    refraction::traced::SPEC,
    specular::exponent_shine::SPEC,
    specular::sign::SPEC,
    diffuse::no_clamp::SPEC,
    mirror::sign::SPEC,
    refraction::sign_trap::SPEC,
    refraction::inverted_index::SPEC,
    refraction::no_exit_bend::SPEC,
];

/// One hit seen by one term, for the tests of the term files: what a term adds to the pixel of
/// a ray and the child rays it spawns, on a scene of a few objects and point lights with no
/// shadows (every light in front of the surface arrives whole).
#[cfg(test)]
pub(crate) mod probe {
    use glam::Vec3;
    use lancer_core::rays::{CREDIT_OWN, LightSamples, Media, Rays};
    use lancer_core::{Light, Material};
    use lancer_shapes::{Geometry, NO_SKIP, Object, Origin};

    use crate::{Chunk, Params, Registry, ShadeContext, TermOutput};

    /// What the term did for the ray.
    #[derive(Debug)]
    pub(crate) struct Seen {
        /// The colour added to the ray's pixel (term weight 1, ray weight 1).
        pub(crate) added: Vec3,
        /// The children: where each starts, its direction and weight.
        pub(crate) children: Vec<(Vec3, Vec3, Vec3)>,
        /// The objects each child is inside.
        pub(crate) media: Vec<Media>,
    }

    /// [`run_in`] for a ray in air.
    pub(crate) fn run(
        name: &str,
        variant: &str,
        objects: &[(Object, Material)],
        lights: &[Light],
        from: Vec3,
        dir: Vec3,
    ) -> Seen {
        run_in(name, variant, objects, lights, from, dir, Media::AIR)
    }

    /// Runs term `name:variant` on the first hit of the ray from `from` along `dir` (unit) in
    /// the scene of `objects` (each with its material) lit by `lights`, the ray inside the
    /// objects `media`.
    pub(crate) fn run_in(
        name: &str,
        variant: &str,
        objects: &[(Object, Material)],
        lights: &[Light],
        from: Vec3,
        dir: Vec3,
        media: Media,
    ) -> Seen {
        let geometry = Geometry::new(objects.iter().map(|(o, _)| o.clone()).collect());
        let materials: Vec<Material> = objects.iter().map(|(_, m)| *m).collect();
        let ctx = ShadeContext {
            geometry: &geometry,
            materials: &materials,
            lights,
            max_depth: 5,
            textures: &[],
            reference: false,
        };
        let hit = geometry.closest_hit(Origin::free(from), dir, 0.0, f32::INFINITY).expect("the ray hits the scene");
        let mut hits = crate::shadow::columns_of(&[hit]);
        hits.material[0] = geometry.objects[hit.object as usize].material;
        hits.color.set(0, ctx.color_at(&hit));
        let mut samples = LightSamples::default();
        samples.reset(1, lights.len());
        let n = hits.facing_normal(0);
        for (k, light) in lights.iter().enumerate() {
            let w = (light.at - hit.point).normalize();
            samples.w[k].set(0, w);
            if n.dot(w) > 0.0 {
                samples.incoming[k].set(0, light.radiance());
            }
        }
        let mut rays = Rays::default();
        rays.push(from, NO_SKIP, dir, Vec3::ONE, 0, 0, CREDIT_OWN, media);
        let term = Registry::with_builtins().build_term(name, Some(variant), Params::default()).expect("a built-in");
        let (mut accum, mut next) = (vec![vec![Vec3::ZERO]], Rays::default());
        let mut out = TermOutput {
            layer: 0,
            weight: 1.0,
            rays: &rays,
            accum: &mut accum,
            next: &mut next,
            max_depth: 5,
            record: None,
        };
        term.term.run(&ctx, Chunk { rays: &rays, hits: &hits, lights: &samples }, &mut out);
        let children = (0..next.len()).map(|i| (next.origin.at(i), next.dir.at(i), next.weight.at(i))).collect();
        Seen { added: accum[0][0], children, media: next.media.clone() }
    }

    /// A white point light of intensity 1 at `at`.
    pub(crate) fn light(at: Vec3) -> Light {
        Light { at, color: Vec3::ONE, intensity: 1.0, size: 0.0 }
    }
}

//! Prepare: flatten the scene's hecs World into read-only arrays (objects, materials, lights) and
//! build the BVH, once per render. The arrays are camera-relative, as pbrt-v4 renders in
//! camera-world space: the scene is moved so that the camera sits at the origin, in f64, before
//! any position is rounded to f32, so a scene far from the world's origin is rendered as exactly
//! as one near it.

use std::collections::HashMap;

use glam::DVec3;
use lancer_core::{Light, Material, MaterialOf, Position, Scene, Transform};
use lancer_shapes::{Geometry, Object, Shape};

/// The scene as the render loop reads it, in a frame whose origin is the world point
/// [`Prepared::origin`] (the camera's position): every position in it (objects, lights, hits,
/// rays) is measured from there.
#[derive(Clone)]
pub struct Prepared {
    /// Where the frame's origin is in world space: the camera's position, in f64. A world point
    /// `p` is `origin + p` here.
    pub origin: DVec3,
    /// Objects and their BVH.
    pub geometry: Geometry,
    /// Material table.
    pub materials: Vec<Material>,
    /// Lights, in the order they were added to the World (their `at` from [`Prepared::origin`]).
    pub lights: Vec<Light>,
    /// Images for `Pattern::Image` materials.
    pub textures: Vec<lancer_core::Texture>,
}

/// A World that cannot be rendered.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PrepareError {
    /// An object's transform cannot be inverted (a zero scale).
    #[error("object {0} has a singular transform (a zero scale?)")]
    SingularTransform(usize),
    /// An object's `MaterialOf` names an entity without a `Material`.
    #[error("object {0} refers to an entity that holds no material")]
    DanglingMaterial(usize),
}

/// Flattens `scene.world`, in the frame whose origin is the camera's position: each object's
/// translation and each light's position less the camera's, in f64, rounded to f32 once.
/// Entities are taken in creation order, so the result does not depend on how hecs stores them.
pub fn prepare(scene: &Scene) -> Result<Prepared, PrepareError> {
    let world = &scene.world;
    let origin = scene.camera.origin;
    let (materials, index) = materials_of(world);
    let default_material = materials.len() as u32 - 1;

    let mut objs: Vec<(hecs::Entity, Shape, Transform, Option<MaterialOf>)> = world
        .query::<(hecs::Entity, &Shape, &Transform, Option<&MaterialOf>)>()
        .iter()
        .map(|(e, s, t, m)| (e, s.clone(), *t, m.copied()))
        .collect();
    objs.sort_by_key(|(e, ..)| e.id());
    let mut objects = Vec::with_capacity(objs.len());
    for (i, (_, shape, transform, mat)) in objs.into_iter().enumerate() {
        let material = match mat {
            None => default_material,
            Some(MaterialOf(e)) => *index.get(&e).ok_or(PrepareError::DanglingMaterial(i))?,
        };
        objects
            .push(Object::new(shape, transform.seen_from(origin), material).ok_or(PrepareError::SingularTransform(i))?);
    }

    Ok(Prepared {
        origin,
        geometry: Geometry::new(objects),
        materials,
        lights: lights_of(world, origin),
        textures: scene.textures.clone(),
    })
}

/// The material table in entity creation order, the default material last, and each material
/// entity's index in it.
fn materials_of(world: &hecs::World) -> (Vec<Material>, HashMap<hecs::Entity, u32>) {
    let mut mats: Vec<(hecs::Entity, Material)> =
        world.query::<(hecs::Entity, &Material)>().iter().map(|(e, m)| (e, *m)).collect();
    mats.sort_by_key(|(e, _)| e.id());
    let index: HashMap<hecs::Entity, u32> = mats.iter().enumerate().map(|(i, (e, _))| (*e, i as u32)).collect();
    let mut materials: Vec<Material> = mats.into_iter().map(|(_, m)| m).collect();
    materials.push(Material::default());
    (materials, index)
}

/// The lights in entity creation order, placed from `origin`.
fn lights_of(world: &hecs::World, origin: DVec3) -> Vec<Light> {
    let mut lights: Vec<(hecs::Entity, Light)> = world
        .query::<(hecs::Entity, &Light, Option<&Position>)>()
        .iter()
        .map(|(e, l, at)| {
            let at = at.map_or(l.at.as_dvec3(), |p| p.0);
            (e, Light { at: (at - origin).as_vec3(), ..*l })
        })
        .collect();
    lights.sort_by_key(|(e, _)| e.id());
    lights.into_iter().map(|(_, l)| l).collect()
}

impl Prepared {
    /// Takes the materials and lights of `scene` again (edited in its World since `prepare`),
    /// keeping the objects and their BVH: what [`prepare`] would give when no object, no
    /// material link and not the camera's position changed. `false` (and nothing changed) when
    /// the camera moved or the World holds another number of materials or lights: prepare
    /// again then.
    pub fn refresh_shading(&mut self, scene: &Scene) -> bool {
        let (materials, _) = materials_of(&scene.world);
        let lights = lights_of(&scene.world, self.origin);
        if scene.camera.origin != self.origin
            || materials.len() != self.materials.len()
            || lights.len() != self.lights.len()
        {
            return false;
        }
        (self.materials, self.lights) = (materials, lights);
        true
    }
}

#[cfg(test)]
mod tests {
    use glam::{DVec3, Mat3A, Vec3};
    use lancer_core::{Camera, ImageSettings, Light, Material, MaterialOf, Meta, Position, Scene, Transform};
    use lancer_shapes::Shape;

    use super::prepare;

    /// A sphere with its material, a second material, a light far from the origin (its f64
    /// position beside it) and a camera away from the origin.
    fn scene() -> (Scene, hecs::Entity, hecs::Entity) {
        let mut world = hecs::World::new();
        let red = world.spawn((Material { color: Vec3::new(1.0, 0.0, 0.0), ..Material::default() },));
        world.spawn((Material { shine: 0.5, ..Material::default() },));
        world.spawn((Shape::Sphere, Transform::new(Mat3A::IDENTITY, DVec3::new(0.0, 0.0, 5.0)), MaterialOf(red)));
        let at = DVec3::new(1.0e6 + 0.25, 3.0, -2.0);
        let light =
            world.spawn((Light { at: at.as_vec3(), color: Vec3::ONE, intensity: 1.0, size: 0.0 }, Position(at)));
        let camera = Camera::look_at(DVec3::new(1.0e6, 0.0, 0.0), DVec3::new(0.0, 0.0, 5.0), Vec3::Y, 40.0).unwrap();
        let scene = Scene { world, camera, image: ImageSettings::default(), meta: Meta::default(), textures: vec![] };
        (scene, red, light)
    }

    #[test]
    fn refresh_after_editing_materials_and_lights_equals_a_new_prepare() {
        let (scene, red, light) = scene();
        let mut prepared = prepare(&scene).unwrap();
        {
            let mut m = scene.world.get::<&mut Material>(red).unwrap();
            m.spec = 0.75;
            m.color = Vec3::new(0.2, 0.4, 0.6);
        }
        scene.world.get::<&mut Light>(light).unwrap().intensity = 2.5;
        scene.world.get::<&mut Position>(light).unwrap().0 = DVec3::new(1.0e6 - 7.0, 1.0, 1.0);
        assert!(prepared.refresh_shading(&scene));
        let fresh = prepare(&scene).unwrap();
        assert_eq!(prepared.materials, fresh.materials);
        assert_eq!(prepared.lights, fresh.lights);
        assert_eq!(prepared.materials[0].spec, 0.75);
        // Placed from the camera in f64: exactly -7 from the camera's x.
        assert_eq!(prepared.lights[0].at, Vec3::new(-7.0, 1.0, 1.0));
        assert_eq!(prepared.lights[0].intensity, 2.5);
    }

    #[test]
    fn refresh_refuses_a_moved_camera_or_a_new_light_and_changes_nothing() {
        let (mut scene, _, _) = scene();
        let mut prepared = prepare(&scene).unwrap();
        let before = (prepared.materials.clone(), prepared.lights.clone());
        scene.camera = Camera::look_at(DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.0, 0.0, 5.0), Vec3::Y, 40.0).unwrap();
        assert!(!prepared.refresh_shading(&scene));
        let (mut scene, _, _) = scene_with_second_light();
        assert!(!prepared.refresh_shading(&scene));
        scene.world.spawn((Material::default(),));
        assert!(!prepared.refresh_shading(&scene));
        assert_eq!((prepared.materials, prepared.lights), before);
    }

    fn scene_with_second_light() -> (Scene, hecs::Entity, hecs::Entity) {
        let (mut scene, red, light) = scene();
        scene.world.spawn((Light { at: Vec3::new(0.0, 9.0, 0.0), color: Vec3::ONE, intensity: 1.0, size: 0.0 },));
        (scene, red, light)
    }
}

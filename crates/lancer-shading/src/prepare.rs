//! Prepare: flatten the scene's hecs World into read-only arrays (objects, materials, lights) and
//! build the BVH, once per render.

use std::collections::HashMap;

use lancer_core::{Light, Material, MaterialOf, Scene, Transform};
use lancer_shapes::{Geometry, Object, Shape};

/// The scene as the render loop reads it.
#[derive(Clone)]
pub struct Prepared {
    /// Objects and their BVH.
    pub geometry: Geometry,
    /// Material table.
    pub materials: Vec<Material>,
    /// Lights, in the order they were added to the World.
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

/// Flattens `scene.world`. Entities are taken in creation order, so the result does not depend
/// on how hecs stores them.
pub fn prepare(scene: &Scene) -> Result<Prepared, PrepareError> {
    let world = &scene.world;
    let mut mats: Vec<(hecs::Entity, Material)> =
        world.query::<(hecs::Entity, &Material)>().iter().map(|(e, m)| (e, *m)).collect();
    mats.sort_by_key(|(e, _)| e.id());
    let index: HashMap<hecs::Entity, u32> = mats.iter().enumerate().map(|(i, (e, _))| (*e, i as u32)).collect();
    let mut materials: Vec<Material> = mats.into_iter().map(|(_, m)| m).collect();
    let default_material = materials.len() as u32;
    materials.push(Material::default());

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
            .push(Object::new(shape, transform.world_from_object, material).ok_or(PrepareError::SingularTransform(i))?);
    }

    let mut lights: Vec<(hecs::Entity, Light)> =
        world.query::<(hecs::Entity, &Light)>().iter().map(|(e, l)| (e, *l)).collect();
    lights.sort_by_key(|(e, _)| e.id());
    Ok(Prepared {
        geometry: Geometry::new(objects),
        materials,
        lights: lights.into_iter().map(|(_, l)| l).collect(),
        textures: scene.textures.clone(),
    })
}

//! The scene: a `hecs::World` of objects, materials and lights, plus camera and image settings.

use glam::{Affine3A, DVec3, Mat3A, Vec3};

use crate::Camera;

/// Placement of an object: `world_from_object` (scale, then rotate, then translate), with its
/// translation kept in f64 as well: prepare takes the camera's position off it before it
/// rounds it ([`Transform::seen_from`]), so an object far from the origin is placed as exactly,
/// relative to the camera, as one near it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Object space to world space, in f32 (its translation `translation` rounded).
    pub world_from_object: Affine3A,
    /// The translation in f64, as the scene gives it.
    pub translation: DVec3,
}

impl Transform {
    /// The placement by the linear part `linear` (scale and rotation), then `translation`.
    pub fn new(linear: Mat3A, translation: DVec3) -> Transform {
        Transform {
            world_from_object: Affine3A { matrix3: linear, translation: translation.as_vec3().into() },
            translation,
        }
    }

    /// The placement `world_from_object`, its translation exactly its f32 one.
    pub fn from_affine(world_from_object: Affine3A) -> Transform {
        Transform { world_from_object, translation: Vec3::from(world_from_object.translation).as_dvec3() }
    }

    /// Object space to the frame whose origin is the world point `origin`: the translation less
    /// `origin`, in f64, rounded to f32 once.
    pub fn seen_from(&self, origin: DVec3) -> Affine3A {
        Affine3A { matrix3: self.world_from_object.matrix3, translation: (self.translation - origin).as_vec3().into() }
    }
}

/// A light's position in world space, in f64 as the scene gives it, beside its
/// [`crate::Light`] (whose `at` holds it rounded to f32): prepare places the light by this one,
/// with the camera's position taken off first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Position(pub DVec3);

/// Links an object entity to the entity holding its [`crate::Material`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MaterialOf(pub hecs::Entity);

/// Image settings of the `[image]` table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageSettings {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear RGB seen by rays that hit nothing.
    pub background: Vec3,
    /// Samples per pixel (1 with [`ImageSettings::adaptive`]: the first pass).
    pub samples: u32,
    /// Adaptive anti-aliasing: one sample at each pixel's centre, then more where a pixel
    /// differs from a neighbour; `None`, every pixel gets `samples`.
    pub adaptive: Option<Adaptive>,
}

impl Default for ImageSettings {
    fn default() -> Self {
        ImageSettings { width: 640, height: 480, background: Vec3::ZERO, samples: 1, adaptive: None }
    }
}

impl ImageSettings {
    /// Every pixel `samples` samples: adaptive anti-aliasing, if the image had it, is off.
    pub fn set_samples(&mut self, samples: u32) {
        (self.samples, self.adaptive) = (samples, None);
    }

    /// Adaptive anti-aliasing (its first pass is one sample a pixel).
    pub fn set_adaptive(&mut self, adaptive: Adaptive) {
        (self.samples, self.adaptive) = (1, Some(adaptive));
    }
}

/// Adaptive anti-aliasing, as POV-Ray's method 1 (`+A<threshold> +R<depth>`): every pixel is
/// first traced once, at its centre; a pixel whose first value differs from one of its four
/// neighbours' by `threshold` or more is traced again at its centre and at the centres of a
/// `depth` x `depth` grid of cells, and its value is the mean of those `depth² + 1` samples.
/// Two values differ by the sum over red, green and blue of their difference as a PNG stores
/// them (8-bit sRGB, in steps of 1/255), from 0 to 3.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptive {
    /// The difference from which a pixel is supersampled, in [0, 3].
    pub threshold: f32,
    /// The side of the grid of samples of a supersampled pixel, from [`Adaptive::MIN_DEPTH`] to
    /// [`Adaptive::MAX_DEPTH`].
    pub depth: u32,
}

impl Adaptive {
    /// Smallest grid side: 2 (a grid of one cell would be the centre again).
    pub const MIN_DEPTH: u32 = 2;
    /// Largest grid side: 9, as POV-Ray's `+R` (82 samples a pixel).
    pub const MAX_DEPTH: u32 = 9;
    /// Largest threshold: 3, black beside white.
    pub const MAX_THRESHOLD: f32 = 3.0;
    /// POV-Ray's usual `+A0.3 +R3`: what `--samples adaptive` and a scene's table take unless
    /// told otherwise.
    pub const DEFAULT: Adaptive = Adaptive { threshold: 0.3, depth: 3 };

    /// The samples a supersampled pixel's value is the mean of: its centre and the grid's
    /// cells (for an odd depth the middle cell is the centre again, which so counts twice).
    pub fn samples(self) -> u32 {
        self.depth * self.depth + 1
    }

    /// The camera rays of a supersampled pixel: [`Adaptive::samples`], less the middle cell of
    /// an odd depth's grid, whose ray would be the centre's again (the centre's ray counts for
    /// both).
    pub fn rays(self) -> u32 {
        self.samples() - self.depth % 2
    }

    /// Sub-pixel position of ray `s` of a supersampled pixel: ray 0 at the centre, then the
    /// grid's cell centres row by row (for an odd depth, but the middle one).
    pub fn offset(self, s: u32) -> (f32, f32) {
        if s == 0 {
            return (0.5, 0.5);
        }
        let r = self.depth.max(1);
        let middle = if r % 2 == 1 { (r * r) / 2 } else { u32::MAX };
        let k = if s > middle { s } else { s - 1 };
        (((k % r) as f32 + 0.5) / r as f32, ((k / r) as f32 + 0.5) / r as f32)
    }

    /// The weight of ray `s` of a supersampled pixel: `1 / samples`, twice that for the centre's
    /// ray of an odd depth (it stands for the middle cell too).
    pub fn weight(self, s: u32) -> f32 {
        let one = 1.0 / self.samples() as f32;
        if s == 0 && self.depth % 2 == 1 { 2.0 * one } else { one }
    }

    /// A pixel's value as it is compared: the bytes a PNG stores for it ([`crate::srgb8`]).
    pub fn shown(v: Vec3) -> [u8; 3] {
        v.to_array().map(crate::srgb8)
    }

    /// Whether two pixels' [`Adaptive::shown`] values differ by the threshold or more: the sum
    /// over red, green and blue of their differences, in steps of 1/255, from 0 to 3.
    pub fn differ(self, a: [u8; 3], b: [u8; 3]) -> bool {
        let steps: u32 = (0..3).map(|i| a[i].abs_diff(b[i]) as u32).sum();
        steps as f32 / 255.0 >= self.threshold
    }
}

/// Optional human-facing description of a scene (`[meta]`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Meta {
    /// Short title.
    pub title: Option<String>,
    /// What the scene shows.
    pub description: Option<String>,
}

/// A loaded scene. Objects are entities with a shape component (from the shapes crate), a
/// [`Transform`] and a [`MaterialOf`]; materials are entities with a [`crate::Material`]; lights
/// are entities with a [`crate::Light`] and, when their position needs more than f32, a
/// [`Position`].
pub struct Scene {
    /// The scene's entities.
    pub world: hecs::World,
    /// The camera, in world space (its position in f64).
    pub camera: Camera,
    /// Image size, background, samples.
    pub image: ImageSettings,
    /// Title and description.
    pub meta: Meta,
    /// Images used by `Pattern::Image` materials.
    pub textures: Vec<crate::Texture>,
}

#[cfg(test)]
mod tests {
    use super::Adaptive;

    #[test]
    fn a_supersampled_pixel_has_the_centre_and_every_grid_cell_with_weights_that_sum_to_one() {
        for depth in Adaptive::MIN_DEPTH..=Adaptive::MAX_DEPTH {
            let a = Adaptive { threshold: 0.3, depth };
            let rays: Vec<(f32, f32)> = (0..a.rays()).map(|s| a.offset(s)).collect();
            // The cells' centres, and the pixel's centre once more, as the rays stand for them.
            let mut stood_for: Vec<(f32, f32)> = rays.clone();
            if depth % 2 == 1 {
                stood_for.push((0.5, 0.5));
            }
            let mut cells: Vec<(f32, f32)> = (0..depth * depth)
                .map(|k| (((k % depth) as f32 + 0.5) / depth as f32, ((k / depth) as f32 + 0.5) / depth as f32))
                .collect();
            cells.push((0.5, 0.5));
            let key = |v: &mut Vec<(f32, f32)>| v.sort_by(|p, q| p.partial_cmp(q).unwrap());
            key(&mut stood_for);
            key(&mut cells);
            assert_eq!(stood_for, cells, "depth {depth}");
            let one = 1.0 / a.samples() as f32;
            for s in 0..a.rays() {
                // The centre's ray of an odd depth stands for the middle cell too.
                let want = if s == 0 && depth % 2 == 1 { 2.0 * one } else { one };
                assert_eq!(a.weight(s), want, "depth {depth}, ray {s}");
            }
            assert_eq!(rays[0], (0.5, 0.5));
        }
    }
}

//! The `Term` trait: an illumination term is a system run over every ray chunk of a generation.

use glam::Vec3;
use lancer_core::rays::{CREDIT_OWN, Hits, LightSamples, Media, NO_HIT, Rays};
use lancer_core::{Light, Material, Texture};
use lancer_shapes::{Geometry, Hit, Origin};

/// Read-only scene data every term may use.
pub struct ShadeContext<'a> {
    /// The scene's objects.
    pub geometry: &'a Geometry,
    /// The material table (`Object::material` indexes it).
    pub materials: &'a [Material],
    /// The point lights, in scene order (the order of `LightSamples` entries).
    pub lights: &'a [Light],
    /// The recursion limit (`max_depth`).
    pub max_depth: u8,
    /// Images for `Pattern::Image` materials.
    pub textures: &'a [Texture],
    /// Render by the reference path ([`crate::RenderOptions::reference`]): every system one ray
    /// at a time in plain code, and each built-in term by its reference form (the formula of
    /// docs/model.md, one hit at a time) instead of eight lanes at once.
    pub reference: bool,
}

impl ShadeContext<'_> {
    /// The material of object `object`.
    #[inline]
    pub fn material_of(&self, object: u32) -> &Material {
        &self.materials[self.material_index(object)]
    }

    /// The index in [`ShadeContext::materials`] of object `object`'s material.
    #[inline]
    pub fn material_index(&self, object: u32) -> usize {
        self.geometry.objects[object as usize].material as usize
    }

    /// `Col_Ω` at a hit: the material's pattern evaluated at its object-space point (or its mesh
    /// texture coordinates). The one colour lookup, for terms and shadow models alike.
    #[inline]
    pub fn color_at(&self, hit: &Hit) -> Vec3 {
        self.surface_color(hit.object, hit.local, hit.uv)
    }

    /// The material of the object hit in `lane` (which must have a hit).
    #[inline]
    pub fn material(&self, hits: &Hits, lane: usize) -> &Material {
        &self.materials[hits.material[lane] as usize]
    }

    /// `Col_Ω` at the hit of `lane`, as the trace system found it ([`ShadeContext::surface_color`]).
    #[inline]
    pub fn color(&self, hits: &Hits, lane: usize) -> Vec3 {
        hits.color.at(lane)
    }

    /// `Col_Ω` of object `object` at a hit at `local` (object space) with texture coordinates
    /// `uv`: the trace system's one evaluation per hit.
    #[inline]
    pub fn surface_color(&self, object: u32, local: Vec3, uv: glam::Vec2) -> Vec3 {
        let object = &self.geometry.objects[object as usize];
        crate::surface_color(&self.materials[object.material as usize], &object.shape, local, uv, self.textures)
    }

    /// The hit of `lane` (which must have one) as the geometry describes hits: what
    /// [`Geometry::spawn`] and the refraction path take.
    #[inline(always)]
    pub fn hit(&self, hits: &Hits, lane: usize) -> Hit {
        Hit {
            t: hits.t[lane],
            object: hits.object[lane],
            point: hits.point.at(lane),
            local: hits.local[lane],
            normal: hits.normal.at(lane),
            shading: hits.shading.at(lane),
            uv: hits.uv[lane],
            error: hits.error[lane],
            front: hits.front[lane],
        }
    }
}

/// One chunk of the ray world as a term sees it: rays, their closest hits, the light at each hit.
#[derive(Clone, Copy)]
pub struct Chunk<'a> {
    /// The rays.
    pub rays: &'a Rays,
    /// Their hits.
    pub hits: &'a Hits,
    /// Light reaching each hit.
    pub lights: &'a LightSamples,
}

impl Chunk<'_> {
    /// Lanes whose ray hit something.
    #[inline]
    pub fn hit_lanes(&self) -> impl Iterator<Item = usize> + '_ {
        self.hits.object.iter().enumerate().filter(|(_, o)| **o != NO_HIT).map(|(i, _)| i)
    }
}

/// Where a term puts its results: colour added at a lane's pixel, and child rays for the next
/// generation. Credit follows the handout's five-summand formula: a camera ray's contributions go
/// to the term's own image; a child ray's go to the image of the term that spawned the camera
/// ray's child (mirror or refraction), whatever term produces them deeper down.
pub struct TermOutput<'a> {
    pub(crate) layer: u16,
    pub(crate) weight: f32,
    pub(crate) rays: &'a Rays,
    pub(crate) accum: &'a mut [Vec<Vec3>],
    pub(crate) next: &'a mut Rays,
    pub(crate) max_depth: u8,
    /// While explaining a pixel: every `add`, as (the term's colour, what reached the pixel).
    pub(crate) record: Option<&'a mut Vec<(Vec3, Vec3)>>,
}

impl TermOutput<'_> {
    #[inline]
    fn credit(&self, lane: usize) -> u16 {
        match self.rays.credit[lane] {
            CREDIT_OWN => self.layer,
            c => c,
        }
    }

    /// Adds `colour` (before the ray's weight) to the pixel of `lane`.
    #[inline(always)]
    pub fn add(&mut self, lane: usize, colour: Vec3) {
        let added = self.weight * self.rays.weight.at(lane) * colour;
        self.put(lane, colour, added);
    }

    /// `added` (`colour` times the weights) into the image `lane` credits, at its pixel.
    #[inline(always)]
    fn put(&mut self, lane: usize, colour: Vec3, added: Vec3) {
        let layer = self.credit(lane) as usize;
        self.accum[layer][self.rays.pixel[lane] as usize] += added;
        if let Some(record) = self.record.as_deref_mut() {
            record.push((colour, added));
        }
    }

    /// The term's weight times the ray weights of the group from `base` times `x`, eight lanes
    /// at a time: `self.weight * rays.weight[lane] * x` lane by lane, the same bits.
    #[inline(always)]
    fn weighted(&self, base: usize, x: &crate::lanes::V3) -> crate::lanes::V3 {
        let weight = crate::lanes::load(&self.rays.weight.packets()[base / lancer_core::rays::PACKET]);
        let term = wide::f32x8::splat(self.weight);
        std::array::from_fn(|a| term * weight[a] * x[a])
    }

    /// [`TermOutput::add`] for the lanes of the group from `base` (a packet's first lane) set in
    /// `bits`, in lane order: `colour` eight lanes at a time, times the ray weights with the
    /// same bits as lane by lane.
    #[inline(always)]
    pub(crate) fn add_lanes(&mut self, base: usize, bits: u8, colour: &crate::lanes::V3) {
        let added = self.weighted(base, colour);
        for j in crate::lanes::set(bits) {
            self.put(base + j, crate::lanes::lane(colour, j), crate::lanes::lane(&added, j));
        }
    }

    /// [`TermOutput::spawn`] for the lanes of the group from `base` (a packet's first lane) set
    /// in `bits`, in lane order: children from `origin` (and ignoring `skip`) along `dir`, their
    /// weights `factor` times the parents' made eight lanes at a time, with the same bits.
    #[inline(always)]
    pub(crate) fn spawn_lanes(
        &mut self,
        base: usize,
        bits: u8,
        origin: &lancer_core::rays::Packet,
        skip: &[u32; 8],
        dir: &crate::lanes::V3,
        factor: &crate::lanes::V3,
    ) {
        let weight = self.weighted(base, factor);
        for j in crate::lanes::set(bits) {
            let from = Origin { point: lancer_core::rays::lane(origin, j), skip: skip[j] };
            let lane = base + j;
            self.queue(lane, from, crate::lanes::lane(dir, j), crate::lanes::lane(&weight, j), self.rays.media[lane]);
        }
    }

    /// Whether a child of `lane` would be within the depth limit.
    #[inline]
    pub fn can_spawn(&self, lane: usize) -> bool {
        self.rays.depth[lane] < self.max_depth
    }

    /// Queues a child ray of `lane` from `origin` (see [`Geometry::spawn`]) whose colour counts
    /// `factor` times in the parent's. Does nothing past the depth limit or for a zero factor.
    #[inline(always)]
    pub fn spawn(&mut self, lane: usize, origin: Origin, dir: Vec3, factor: Vec3) {
        self.spawn_in(lane, origin, dir, factor, self.rays.media[lane]);
    }

    /// [`TermOutput::spawn`] for a ray that crosses a surface into other media (the objects it
    /// is inside, [`lancer_core::rays::Media`]); `spawn`'s rays stay in their parent's.
    #[inline(always)]
    pub fn spawn_in(&mut self, lane: usize, origin: Origin, dir: Vec3, factor: Vec3, media: Media) {
        let weight = self.weight * self.rays.weight.at(lane) * factor;
        self.queue(lane, origin, dir, weight, media);
    }

    /// Queues a child of `lane` of this `weight` (its factor times the weights), unless past
    /// the depth limit or of zero weight.
    #[inline(always)]
    fn queue(&mut self, lane: usize, origin: Origin, dir: Vec3, weight: Vec3, media: Media) {
        if !self.can_spawn(lane) || weight == Vec3::ZERO {
            return;
        }
        let credit = self.credit(lane);
        self.next.push(
            origin.point,
            origin.skip,
            dir,
            weight,
            self.rays.pixel[lane],
            self.rays.depth[lane] + 1,
            credit,
            media,
        );
    }
}

/// An illumination term: a system that runs over every chunk of rays of each generation and adds
/// its summand of the model to the chunk's pixels (and may spawn child rays).
///
/// Implement it in your own crate and register it with [`crate::Registry::register_term`].
pub trait Term: Send + Sync {
    /// Adds this term's contribution for every lane of `chunk`.
    ///
    /// Finish a lane's `add`s before the next lane's (lanes in order, as the built-in terms
    /// do): a pixel's sums are then made in the same order whatever the chunk size, which keeps
    /// renders the same for any thread count and `lancer explain`'s values equal to the frame's.
    fn run(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, out: &mut TermOutput<'_>);

    /// Whether the term reads the light arriving at a surface of this material
    /// ([`Chunk::lights`]). The light visibility system traces shadow rays only for hits on
    /// which some term of the model reads them. The default, `true`, is always right; a term
    /// that never looks at lights (ambient, mirror) or ignores a material (zero `diff`) says
    /// `false` and saves the shadow rays.
    fn reads_lights(&self, material: &Material) -> bool {
        let _ = material;
        true
    }

    /// Whether the term can add anything on a surface of this material (not all of the material
    /// parameters it reads are zero). `lancer check` warns about a term that acts on no material
    /// of the scene. The default, `true`, is always safe.
    fn acts_on(&self, material: &Material) -> bool {
        let _ = material;
        true
    }

    /// Why the term adds nothing on a surface of `material` where [`Term::acts_on`] is false, as
    /// a clause ("`shine = 1` makes its exponent infinite..."), when the reason is not that a
    /// field it reads is zero (what `lancer check` says by default, naming the field).
    fn why_idle(&self, material: &Material) -> Option<String> {
        let _ = material;
        None
    }

    /// The exponent a half-vector highlight (Blinn's) raises `N·h` to on a surface of
    /// `material`, `None` where none is defined (`shine ≥ 1` with no `exponent` given); `lancer
    /// export pov` writes it as POV-Ray's `roughness 1/e`. `None` for every other term (the
    /// default).
    fn highlight_exponent(&self, material: &Material) -> Option<f32> {
        let _ = material;
        None
    }

    /// The inputs of the term's formula at `lane` of `chunk`, for `lancer explain` (called after
    /// [`Term::run`], on one-lane chunks, only while a pixel is explained). The default says
    /// nothing; the built-in terms list what their formula reads (e.g. `−u·w_r` and the
    /// exponent for each light of the Phong highlight).
    fn explain(&self, ctx: &ShadeContext<'_>, chunk: Chunk<'_>, lane: usize) -> Vec<Note> {
        let _ = (ctx, chunk, lane);
        Vec::new()
    }
}

/// One named input of a term's formula, as `lancer explain` shows it.
#[derive(Clone, Debug, PartialEq)]
pub struct Note {
    /// What it is, in the model's notation (`N·w`, `u_t`, `exponent`, ...), prefixed by
    /// `light K: ` when it belongs to one light.
    pub name: String,
    /// Its value.
    pub value: NoteValue,
}

/// The value of a [`Note`].
#[derive(Clone, Debug, PartialEq)]
pub enum NoteValue {
    /// A number.
    Number(f32),
    /// A vector or a colour.
    Vector(Vec3),
    /// A point: in the prepared frame (from [`crate::Prepared::origin`]) as a term makes it
    /// ([`Note::point`]), in world space in a [`crate::PixelExplanation`].
    Point(glam::DVec3),
    /// Anything else, in words.
    Text(String),
}

impl Note {
    /// A numeric note.
    pub fn number(name: impl Into<String>, value: f32) -> Note {
        Note { name: name.into(), value: NoteValue::Number(value) }
    }

    /// A vector (or colour) note.
    pub fn vector(name: impl Into<String>, value: Vec3) -> Note {
        Note { name: name.into(), value: NoteValue::Vector(value) }
    }

    /// A point note: `at` is a point of the prepared frame, such as a hit point
    /// ([`crate::explain_pixel`] gives it in world space).
    pub fn point(name: impl Into<String>, at: Vec3) -> Note {
        Note { name: name.into(), value: NoteValue::Point(at.as_dvec3()) }
    }

    /// A note in words.
    pub fn text(name: impl Into<String>, value: impl Into<String>) -> Note {
        Note { name: name.into(), value: NoteValue::Text(value.into()) }
    }
}

/// For each light that reaches the hit of `lane` (`N·w > 0`, not fully shadowed), with `n` the
/// normal facing the ray: its number (from 1, in scene order), `N·w` and `w`. The lights
/// [`sum_lights`] adds, for a term's [`Term::explain`].
pub fn lit_by<'a>(chunk: &Chunk<'a>, lane: usize, n: Vec3) -> impl Iterator<Item = (usize, f32, Vec3)> + 'a {
    chunk.lights.lane(lane).enumerate().filter_map(move |(k, (w, light))| {
        let nw = n.dot(w);
        (nw > 0.0 && light != Vec3::ZERO).then_some((k + 1, nw, w))
    })
}

/// The point and surface normal terms shade with: the normal faces the incoming ray.
#[inline]
pub(crate) fn facing(chunk: &Chunk<'_>, lane: usize) -> (Vec3, Vec3) {
    (chunk.hits.point.at(lane), chunk.hits.facing_normal(lane))
}

/// The mirror direction of the ray `u` at `hit`: `u − 2 (N·u) N` about the shading normal, or
/// about the geometric normal where a smooth mesh's interpolated normal would send it below the
/// actual surface (near a silhouette), so a reflected ray always leaves on the side it came from.
#[inline]
pub fn mirror_direction(hit: &lancer_shapes::Hit, u: Vec3) -> Vec3 {
    let r = lancer_core::optics::reflect(u, hit.shading);
    // The side the ray arrived on is where it must go back to.
    if (r.dot(hit.normal) > 0.0) == (u.dot(hit.normal) < 0.0) { r } else { lancer_core::optics::reflect(u, hit.normal) }
}

/// `Σ f(N·w, w) · light` over the lights that reach the hit of `lane` (in front of the surface,
/// not fully shadowed), with `n` the normal facing the ray: the loop every light-driven term
/// needs.
#[inline]
pub fn sum_lights(chunk: &Chunk<'_>, lane: usize, n: Vec3, mut f: impl FnMut(f32, Vec3) -> f32) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for (w, light) in chunk.lights.lane(lane) {
        let nw = n.dot(w);
        if nw > 0.0 && light != Vec3::ZERO {
            sum += f(nw, w) * light;
        }
    }
    sum
}

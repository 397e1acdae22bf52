//! Explaining one pixel: the pixel rendered alone through the same systems, every ray its own
//! chunk, with everything the systems find about each ray kept as a tree (`lancer explain`).
//! Points are given in world space: the prepared frame's, moved back by its origin.

use glam::{DVec3, Vec3};
use lancer_core::frame::BACKGROUND;
use lancer_core::rays::{CREDIT_OWN, Hits, LightSamples, NO_HIT, Rays};
use lancer_core::{Camera, ImageSettings};

use crate::render::{Scratch, Tile, render_tile, shade_context};
use crate::{Note, NoteValue, Pipeline, Prepared, ShadeContext};

/// Everything the render did for one pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct PixelExplanation {
    /// Column, from the left.
    pub x: u32,
    /// Row, from the top.
    pub y: u32,
    /// Every ray traced for the pixel, parents before their children; the camera rays (one per
    /// sample) have no parent.
    pub rays: Vec<RayNode>,
    /// The pixel's value in every layer, in frame order (the terms in model order, then
    /// [`BACKGROUND`]): the same bits as the full render's layers at this pixel.
    pub layers: Vec<(String, Vec3)>,
    /// The sum of the layers, in layer order: the beauty image's value.
    pub beauty: Vec3,
}

/// One ray of a pixel's tree.
#[derive(Clone, Debug, PartialEq)]
pub struct RayNode {
    /// The ray that spawned it and the term (index in the model) that did; `None` for a camera
    /// ray.
    pub parent: Option<(usize, usize)>,
    /// Which of the pixel's samples it belongs to.
    pub sample: u32,
    /// Its generation (0 for camera rays).
    pub depth: u8,
    /// Where it starts, in world space.
    pub origin: DVec3,
    /// Its unit direction `u`.
    pub dir: Vec3,
    /// What its colour is multiplied by on its way to the pixel.
    pub weight: Vec3,
    /// The layer its contributions go to; `None` for a camera ray (each term's own image).
    pub credit: Option<usize>,
    /// What it hit.
    pub hit: Option<HitNode>,
    /// The light arriving at its hit, one entry per light of the scene.
    pub lights: Vec<LightNode>,
    /// What each term of the model did with it, in model order.
    pub terms: Vec<TermNode>,
    /// What it added to the pixel seeing the background (a miss).
    pub background: Option<Vec3>,
    /// Its children, in the order they were spawned.
    pub children: Vec<usize>,
}

/// Where a ray hit.
#[derive(Clone, Debug, PartialEq)]
pub struct HitNode {
    /// The object's number, from 1, in the order of the scene file.
    pub object: u32,
    /// Its shape's name.
    pub shape: &'static str,
    /// The material's number in the prepared table, from 1.
    pub material: u32,
    /// Distance along the ray.
    pub t: f32,
    /// The hit point `I`, in world space.
    pub point: DVec3,
    /// The shading normal `N`, facing the ray.
    pub normal: Vec3,
    /// Whether the ray arrived from outside.
    pub front: bool,
    /// `Col_Ω` there.
    pub color: Vec3,
}

/// One light as seen from a hit.
#[derive(Clone, Debug, PartialEq)]
pub struct LightNode {
    /// Unit direction `w` towards the light.
    pub w: Vec3,
    /// `N·w`.
    pub n_dot_w: f32,
    /// Whether some term of the model reads lights on this material.
    pub read: bool,
    /// Whether a shadow ray was traced (the light is in front of the surface and some term
    /// reads lights on this material).
    pub traced: bool,
    /// The transmittance the render used: what the shadow model gave the visibility system for
    /// this hit and light, read back from the light it stored ([`transmittance_of`]; zero when
    /// not traced).
    pub transmittance: Vec3,
    /// The light terms receive: `Col_L` times the transmittance, as the visibility system
    /// stored it.
    pub incoming: Vec3,
}

/// What one term did with one ray.
#[derive(Clone, Debug, PartialEq)]
pub struct TermNode {
    /// The term's index in the model.
    pub term: usize,
    /// The colour the term computed (before the ray's weight and the term's `weight`).
    pub colour: Vec3,
    /// What that added to the pixel (in the ray's credited layer).
    pub added: Vec3,
    /// The inputs of its formula ([`crate::Term::explain`]).
    pub notes: Vec<Note>,
}

/// Renders pixel (`x`, `y`) of the image alone and explains it (panics for a pixel outside the
/// image: callers check it first, with their own message). The pixel's values are the
/// same, to the bit, as in a render of the whole frame with the same settings. `camera` is in
/// world space, as for [`crate::render_prepared`]; so are the explanation's points.
pub fn explain_pixel(
    prepared: &Prepared,
    camera: &Camera,
    image: &ImageSettings,
    pipeline: &Pipeline,
    x: u32,
    y: u32,
) -> PixelExplanation {
    assert!(x < image.width && y < image.height, "pixel {x},{y} is outside the {}x{} image", image.width, image.height);
    let ctx = shade_context(prepared, pipeline);
    let lit = crate::render::lit_materials(&ctx, pipeline);
    let mut scratch = Scratch::new(pipeline);
    let mut recorder = Recorder { origin: prepared.origin, ..Recorder::default() };
    let tile = Tile { x0: x, y0: y, w: 1, h: 1 };
    let mut stats = lancer_core::RenderStats::default();
    let camera = &camera.seen_from(prepared.origin);
    render_tile(&ctx, &lit, camera, image, pipeline, tile, &mut scratch, Some(&mut recorder), false, &mut stats);
    let mut names: Vec<String> = pipeline.terms.iter().map(|t| t.name.clone()).collect();
    names.push(BACKGROUND.to_owned());
    let layers: Vec<(String, Vec3)> = names.into_iter().zip(scratch.accum.iter().map(|acc| acc[0])).collect();
    // As the render sums a tile into the beauty image: from zero, layer after layer.
    let mut beauty = Vec3::ZERO;
    for (_, v) in &layers {
        beauty += *v;
    }
    PixelExplanation { x, y, rays: recorder.rays, layers, beauty }
}

/// The transmittance by which the visibility system multiplied `radiance` (`Col_L`) into
/// `incoming`, the light it stored for terms, channel by channel: where the light has some of a
/// channel, the f32 nearest `incoming / radiance` whose product with `radiance` is `incoming`
/// (the shadow model's answer is one); where it has none, nothing told the channels apart, so
/// the others' value when they agree (every built-in model but `tint`ed ones gives the three
/// channels alike), else 0.
pub(crate) fn transmittance_of(incoming: Vec3, radiance: Vec3) -> Vec3 {
    let channel = |i: f32, r: f32| {
        (r != 0.0).then(|| {
            let t = i / r;
            [t, t.next_up(), t.next_down(), t.next_up().next_up(), t.next_down().next_down()]
                .into_iter()
                .find(|&c| r * c == i)
                .unwrap_or(t)
        })
    };
    let known: [Option<f32>; 3] = std::array::from_fn(|a| channel(incoming[a], radiance[a]));
    let mut seen = known.iter().flatten();
    let fill = match seen.next() {
        Some(&first) if seen.all(|&t| t == first) => first,
        _ => 0.0,
    };
    Vec3::from(known.map(|t| t.unwrap_or(fill)))
}

/// Collects the tree while [`render_tile`] runs with one ray per chunk.
#[derive(Default)]
pub(crate) struct Recorder {
    /// The prepared frame's origin in world space: what is added to its points.
    origin: DVec3,
    rays: Vec<RayNode>,
    /// The rays of the generation being run, in chunk order.
    current: Vec<usize>,
    /// For each ray queued for the next generation, in order: its parent and term (none for a
    /// camera ray) and its sample.
    pending: Vec<(Option<(usize, usize)>, u32)>,
}

impl Recorder {
    /// A wave of camera rays, samples `range` of the one-pixel tile, has been queued.
    pub(crate) fn camera_rays(&mut self, range: std::ops::Range<usize>, spp: usize) {
        self.pending.extend(range.map(|k| (None, (k % spp) as u32)));
    }

    /// The generation's rays are traced and their lights found: one node per chunk.
    pub(crate) fn generation(
        &mut self,
        world: &hecs::World,
        ctx: &ShadeContext<'_>,
        pipeline: &Pipeline,
        background: Vec3,
    ) {
        self.current.clear();
        let pending = std::mem::take(&mut self.pending);
        // hecs iterates an archetype in spawn order, and the world was emptied before this
        // generation's chunks were spawned in `next`'s order: chunk i is pending ray i.
        let mut chunks = world.query::<(&Rays, &Hits, &LightSamples)>();
        assert_eq!(chunks.iter().count(), pending.len(), "one chunk per queued ray");
        for ((rays, hits, samples), (parent, sample)) in chunks.iter().zip(pending) {
            let id = self.rays.len();
            if let Some((p, _)) = parent {
                self.rays[p].children.push(id);
            }
            let missed = hits.object[0] == NO_HIT;
            let credit = (rays.credit[0] != CREDIT_OWN).then_some(rays.credit[0] as usize);
            let mut node = RayNode {
                parent,
                sample,
                depth: rays.depth[0],
                origin: self.origin + rays.origin.at(0).as_dvec3(),
                dir: rays.dir.at(0),
                weight: rays.weight.at(0),
                credit,
                hit: None,
                lights: Vec::new(),
                terms: Vec::new(),
                background: (missed && background != Vec3::ZERO).then(|| rays.weight.at(0) * background),
                children: Vec::new(),
            };
            if !missed {
                let hit = ctx.hit(hits, 0);
                let n = hits.facing_normal(0);
                let material = ctx.material(hits, 0);
                let reads = crate::render::reads_lights(pipeline, material);
                let object = &ctx.geometry.objects[hit.object as usize];
                node.hit = Some(HitNode {
                    object: hit.object + 1,
                    shape: object.shape.name(),
                    material: object.material + 1,
                    t: hit.t,
                    point: self.origin + hit.point.as_dvec3(),
                    normal: n,
                    front: hit.front,
                    color: ctx.color(hits, 0),
                });
                // The visibility system's light entries, and the transmittance it multiplied in:
                // read back from them, what the shadow model gave this hit in the render (asking
                // the model again, one ray at a time, need not give the same: its blocks of rays
                // take other paths).
                for (k, (w, incoming)) in samples.lane(0).enumerate() {
                    // The visibility system leaves `w` unset where no term reads lights.
                    let w = if reads { w } else { (ctx.lights[k].at - hit.point).normalize_or_zero() };
                    let n_dot_w = n.dot(w);
                    let traced = reads && w != Vec3::ZERO && n_dot_w > 0.0;
                    let transmittance =
                        if traced { transmittance_of(incoming, ctx.lights[k].radiance()) } else { Vec3::ZERO };
                    node.lights.push(LightNode { w, n_dot_w, read: reads, traced, transmittance, incoming });
                }
            }
            self.current.push(id);
            self.rays.push(node);
        }
    }

    /// Term `term` ran on chunk `chunk` of the generation: its notes, its `add`s (colour,
    /// added), and the rays it queued (`spawned`, positions in the next generation).
    pub(crate) fn term_ran(
        &mut self,
        chunk: usize,
        term: usize,
        notes: Vec<Note>,
        added: Vec<(Vec3, Vec3)>,
        spawned: std::ops::Range<usize>,
    ) {
        let id = self.current[chunk];
        let sample = self.rays[id].sample;
        let notes = notes
            .into_iter()
            .map(|note| match note.value {
                NoteValue::Point(p) => Note { value: NoteValue::Point(self.origin + p), ..note },
                _ => note,
            })
            .collect();
        let (colour, sum) = added.iter().fold((Vec3::ZERO, Vec3::ZERO), |(c, s), (a, b)| (c + *a, s + *b));
        self.rays[id].terms.push(TermNode { term, colour, added: sum, notes });
        debug_assert_eq!(self.pending.len(), spawned.start);
        self.pending.extend(spawned.map(|_| (Some((id, term)), sample)));
    }
}

//! The render loop: rayon over tiles; per tile a hecs ray world whose entities are chunks of rays,
//! run generation by generation through the systems (camera → trace → light visibility →
//! background → terms in model order → child rays), until no ray is left.

use glam::Vec3;
use lancer_core::frame::BACKGROUND;
use lancer_core::rays::{CHUNK_LANES, CREDIT_OWN, Hits, LightSamples, NO_HIT, PACKET, Rays};
use lancer_core::{Camera, Frame, ImageSettings, Layer, RenderStats, Scene};
use lancer_shapes::{Lines, NO_SKIP};
use rayon::prelude::*;

use crate::{Chunk, Pipeline, PrepareError, Prepared, ShadeContext, ShadowContext, TermOutput, prepare};

/// Height of a tile, in pixels (and of the bands of rows a part render takes, see
/// [`part_bands`]).
pub const TILE: u32 = 16;

/// Width of a tile, in pixels: a tile's rays stay in cache across generations, and each
/// generation's fixed costs (its chunk entities, one pass of every system) are shared by more
/// rays. Measured on the anchor (one thread): 16 wide 0.268 s, 64 wide 0.262 s, 128 no better.
pub const TILE_WIDTH: u32 = 64;

// A tile's camera rays at one sample per pixel make one chunk (with adaptive anti-aliasing's
// one-pixel border, 66 x 18 rays, two).
const _: () = assert!((TILE_WIDTH * TILE) as usize <= CHUNK_LANES);

/// Side of the square cells a tile's camera rays go through one after the other: a block of
/// rays traced together ([`lancer_shapes::Geometry::closest_each`]) is then a compact patch of
/// the image, not a strip, and its rays stay within a narrow cone.
const CELL: u32 = 8;

/// The tile-local pixels `(x, y)` of a `w` x `h` tile in the order its camera rays are made:
/// [`CELL`]-square cells row by row, each cell's pixels row by row (cells cut at the tile's
/// right and bottom edges). Every pixel once. A pixel's rays, and the rays they spawn, keep
/// their order among themselves whatever the order of the pixels, so its sums are the same.
fn cell_order(w: u32, h: u32, out: &mut Vec<(u32, u32)>) {
    out.clear();
    for cy in (0..h).step_by(CELL as usize) {
        for cx in (0..w).step_by(CELL as usize) {
            for y in cy..(cy + CELL).min(h) {
                out.extend((cx..(cx + CELL).min(w)).map(|x| (x, y)));
            }
        }
    }
}

/// Knobs of a render that are not part of the scene.
#[derive(Clone, Copy, Default)]
pub struct RenderOptions<'a> {
    /// Called once per finished tile with (tiles done, tiles in all), from any thread.
    pub progress: Option<&'a (dyn Fn(usize, usize) + Sync)>,
    /// Measure the time spent in each system ([`RenderStats::times`]); it costs a clock reading
    /// per system and generation.
    pub timing: bool,
    /// Render only part `I` of `N` (`Some((I, N))`): the bands of [`TILE`] rows whose index is
    /// `I` modulo `N` ([`part_bands`]); the rest of the frame stays black. The bands rendered
    /// are the same bits as in a whole render.
    pub part: Option<(u32, u32)>,
    /// With [`RenderOptions::part`]: the frame holds only the part's bands, one under the
    /// other from the top (its height is their rows; the last band of the image may be shorter
    /// than [`TILE`]), the same bits as in a whole render. Without it a part's frame is the
    /// whole image, black outside the part.
    pub compact: bool,
    /// Checked before each tile: once it is set the remaining tiles are skipped (the frame is
    /// then incomplete; the caller that set it throws it away).
    pub cancel: Option<&'a std::sync::atomic::AtomicBool>,
    /// Keep every term's image ([`Frame::layers`]); without it (the default) the frame holds
    /// only the beauty image, the same bits, in a seventh of the memory for a five-term model
    /// (five terms and the background, and the beauty image).
    pub layers: bool,
    /// Render by the reference path: every system one ray at a time in plain code (camera rays
    /// by [`Camera::direction`], closest hits by [`lancer_shapes::Geometry::closest`] and
    /// [`lancer_shapes::Object::hit`], each hit's light by [`crate::ShadowModel::transmittance`],
    /// each built-in term by its reference form), with no block tracer, no cones, no eight-lane
    /// groups and no one-material shortcuts. Slower; the same images to the bit but where the
    /// block tracer and the BVH break an exact tie between two surfaces differently.
    pub reference: bool,
    /// Scratch buffers to take the workers' from, and to give them back to after the render
    /// (a caller rendering band after band, as a browser worker does, grows them once);
    /// without it each render makes its own. The image is the same bits either way.
    pub scratch: Option<&'a Scratches>,
}

/// The workers' scratch buffers (each a tile's hecs world, chunk columns, next generation and
/// accumulators) kept between renders: [`RenderOptions::scratch`]. A render takes one per
/// worker and gives it back; buffers made for a model with another number of terms are
/// dropped, not reused.
#[derive(Default)]
pub struct Scratches(std::sync::Mutex<Vec<Scratch>>);

impl Scratches {
    /// A scratch for `pipeline`: a kept one when there is one of its shape, else a new one.
    fn take(&self, pipeline: &Pipeline) -> Scratch {
        let mut kept = lock(&self.0);
        kept.retain(|s| s.accum.len() == pipeline.terms.len() + 1);
        kept.pop().unwrap_or_else(|| Scratch::new(pipeline))
    }

    fn give_back(&self, scratch: Scratch) {
        lock(&self.0).push(scratch);
    }
}

/// The bands (rows of tiles, [`TILE`] pixels high, from the top) of part `index` of `count` of
/// an image `height` rows high: every `count`-th band from band `index`, so the parts share out
/// costly and cheap regions alike.
pub fn part_bands(height: u32, index: u32, count: u32) -> impl Iterator<Item = u32> {
    (index..height.div_ceil(TILE)).step_by(count.max(1) as usize)
}

/// A stopwatch that charges the time since its last reading to a system, when timing is on.
struct Lap(Option<std::time::Instant>);

impl Lap {
    fn new(on: bool) -> Lap {
        Lap(on.then(std::time::Instant::now))
    }

    /// Adds the time since the last reading to `into`.
    #[inline]
    fn charge(&mut self, into: &mut std::time::Duration) {
        if let Some(last) = self.0 {
            let now = std::time::Instant::now();
            *into += now - last;
            self.0 = Some(now);
        }
    }
}

/// Prepares `scene` and renders it with `pipeline` on the current rayon pool. The per-term
/// images are kept only with [`RenderOptions::layers`].
pub fn render(scene: &Scene, pipeline: &Pipeline, options: RenderOptions<'_>) -> Result<Frame, PrepareError> {
    let prepared = prepare(scene)?;
    Ok(render_prepared(&prepared, &scene.camera, &scene.image, pipeline, options))
}

/// Renders an already prepared scene. The result is the same, bit for bit, whatever the number
/// of threads: tiles are independent and each is processed in a fixed order. `camera` is in
/// world space (a scene's): its rays start at its position less [`Prepared::origin`].
///
/// The beauty image (and the layers, when kept) are allocated once and each tile writes its own
/// pixels of them (through its band's rows: a row of tiles is a contiguous run of each image),
/// the beauty image as the tile's layers summed in layer order. One worker per thread takes
/// tiles one at a time and keeps its scratch buffers (the tile's hecs world, chunk columns, the
/// next generation's rays, the tile's accumulators) from tile to tile, so the steady state
/// allocates nothing.
pub fn render_prepared(
    prepared: &Prepared,
    camera: &Camera,
    image: &ImageSettings,
    pipeline: &Pipeline,
    options: RenderOptions<'_>,
) -> Frame {
    let (width, height) = (image.width, image.height);
    let camera = &camera.seen_from(prepared.origin);
    let ctx = ShadeContext { reference: options.reference, ..shade_context(prepared, pipeline) };
    let lit = lit_materials(&ctx, pipeline);
    let bands_count = height.div_ceil(TILE) as usize;
    // The bands rendered, and for each band of the image where its rows are kept: the image's
    // own rows, or with `compact` one band under the other.
    let mut bands: Vec<usize> = (0..bands_count).collect();
    if let Some((index, count)) = options.part {
        bands.retain(|b| *b as u32 % count.max(1) == index);
    }
    let compact = options.compact && options.part.is_some();
    let band_rows = |b: usize| TILE.min(height - b as u32 * TILE);
    let kept_rows: u32 = if compact { bands.iter().map(|&b| band_rows(b)).sum() } else { height };
    let mut slot_of: Vec<usize> = (0..bands_count).collect();
    if compact {
        for (slot, &b) in bands.iter().enumerate() {
            slot_of[b] = slot;
        }
    }
    let pixels = (width * kept_rows) as usize;
    // Zeroed by the system, page by page as the tiles first write them: no pass over the whole
    // frame before the render.
    let mut layers: Vec<Layer> = if options.layers {
        let mut names: Vec<String> = pipeline.terms.iter().map(|t| t.name.clone()).collect();
        names.push(BACKGROUND.to_owned());
        names.into_iter().map(|name| Layer { name, pixels: bytemuck::zeroed_vec(pixels) }).collect()
    } else {
        Vec::new()
    };
    let mut beauty: Vec<Vec3> = bytemuck::zeroed_vec(pixels);

    if width == 0 || height == 0 {
        return Frame { width, height: kept_rows, layers, beauty, stats: RenderStats::default() };
    }
    let band_len = (TILE * width) as usize;
    let mut per_layer: Vec<_> = layers.iter_mut().map(|l| l.pixels.chunks_mut(band_len)).collect();
    // Each band's rows of the beauty image and of every layer kept, behind a lock a tile holds
    // only to copy its pixels in: the tiles of one band may be rendered on different threads.
    let rows: Vec<std::sync::Mutex<BandRows<'_>>> = beauty
        .chunks_mut(band_len)
        .map(|sum| {
            let layers = per_layer.iter_mut().map(|chunks| chunks.next().expect("one chunk per band")).collect();
            std::sync::Mutex::new((sum, layers))
        })
        .collect();
    // Bands in a spread order (each band still writes only its own rows, so the frame is the
    // same): the tiles done at any moment sample the whole image, and the progress estimate
    // does not trust an easy sky for a costly floor.
    // One contiguous run of bands per thread, each run in a spread order: the tiles done at any
    // moment sample the whole image, and until one thread runs out of work and takes tiles
    // from the other's run, no two threads fault in pages of the same part of a layer at once
    // (interleaving bands across threads cost 5 % at 2 threads, in page-table locks).
    let runs = rayon::current_num_threads().clamp(1, bands_count.max(1));
    let run_of = |b: usize| b * runs / bands_count;
    let run_start = |r: usize| (r * bands_count).div_ceil(runs);
    let ranks: Vec<Vec<usize>> = (0..runs).map(|r| spread_order(run_start(r + 1) - run_start(r))).collect();
    bands.sort_by_key(|b| {
        let r = run_of(*b);
        (r, ranks[r][*b - run_start(r)])
    });
    // The unit of work is a tile, not a band: a worker that has finished its run takes single
    // tiles from the back of the fullest other run, so neither waits long for the last band
    // (the anchor cut to 80 rows, five bands, renders on 2 threads in 0.0095 s against 0.0110 s
    // by bands).
    let tiles: Vec<(usize, u32)> =
        bands.iter().flat_map(|&b| (0..width).step_by(TILE_WIDTH as usize).map(move |x0| (b, x0))).collect();
    let tiles_count = tiles.len();
    let queues: Vec<std::sync::Mutex<std::ops::Range<usize>>> = (0..runs)
        .map(|r| {
            let first = tiles.partition_point(|t| run_of(t.0) < r);
            let end = tiles.partition_point(|t| run_of(t.0) <= r);
            std::sync::Mutex::new(first..end)
        })
        .collect();
    let done = std::sync::atomic::AtomicUsize::new(0);
    // One worker per run, each with its own scratch buffers for the whole render (rayon's own
    // splitting of a tile list made a new scratch at every steal: 28 of them in a 2-thread
    // render of the anchor, each growing its buffers and faulting in their pages afresh).
    let worker = |me: usize| {
        let mut scratch = match options.scratch {
            Some(kept) => kept.take(pipeline),
            None => Scratch::new(pipeline),
        };
        let mut stats = RenderStats::default();
        while let Some(i) = next_tile(&queues, me) {
            if options.cancel.is_some_and(|c| c.load(std::sync::atomic::Ordering::Relaxed)) {
                break;
            }
            let (band, x0) = tiles[i];
            let y0 = band as u32 * TILE;
            let tile = Tile { x0, y0, w: TILE_WIDTH.min(width - x0), h: TILE.min(height - y0) };
            render_tile(&ctx, &lit, camera, image, pipeline, tile, &mut scratch, None, options.timing, &mut stats);
            let mut lap = Lap::new(options.timing);
            // The tile's pixels into the band's rows of every layer kept, and their sum, in
            // layer order, into the beauty image.
            let mut guard = rows[slot_of[band]].lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            let (sum, out) = &mut *guard;
            for row in 0..tile.h as usize {
                let (at, from) = (row * width as usize + x0 as usize, row * tile.w as usize);
                let span = from..from + tile.w as usize;
                for (layer, acc) in out.iter_mut().zip(&scratch.accum) {
                    layer[at..at + tile.w as usize].copy_from_slice(&acc[span.clone()]);
                }
                // The layers added one after the other, a row at a time as plain floats (the
                // same sums, in the same order, as pixel by pixel: `0 + l0 + l1 + ...`).
                let sum: &mut [f32] = bytemuck::cast_slice_mut(&mut sum[at..at + tile.w as usize]);
                sum.fill(0.0);
                for acc in &scratch.accum {
                    for (s, a) in sum.iter_mut().zip(bytemuck::cast_slice::<Vec3, f32>(&acc[span.clone()])) {
                        *s += *a;
                    }
                }
            }
            drop(guard);
            lap.charge(&mut stats.times.chunks);
            if let Some(progress) = options.progress {
                progress(done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1, tiles_count);
            }
        }
        if let Some(kept) = options.scratch {
            kept.give_back(scratch);
        }
        stats
    };
    let stats = (0..runs).into_par_iter().map(worker).reduce(RenderStats::default, |mut a, b| {
        a += b;
        a
    });
    drop(rows);
    Frame { width, height: kept_rows, layers, beauty, stats }
}

/// The next tile for worker `me`: the front of its own run (`queues[me]`, indices into the tile
/// list), or once that is empty the back of the fullest other run; `None` when every run is
/// empty. Runs only shrink, so a run seen empty stays empty.
fn next_tile(queues: &[std::sync::Mutex<std::ops::Range<usize>>], me: usize) -> Option<usize> {
    if let Some(i) = lock(&queues[me]).next() {
        return Some(i);
    }
    loop {
        let (fullest, left) = queues.iter().map(|q| (q, lock(q).len())).max_by_key(|&(_, left)| left)?;
        if left == 0 {
            return None;
        }
        if let Some(i) = lock(fullest).next_back() {
            return Some(i);
        }
    }
}

/// Locks one run of [`next_tile`], or the kept [`Scratches`]. Neither is ever left
/// half-updated, so a panic elsewhere cannot spoil it.
fn lock<T>(q: &std::sync::Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    q.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A band of tiles' rows of the beauty image, and of each layer kept.
type BandRows<'a> = (&'a mut [Vec3], Vec<&'a mut [Vec3]>);

/// For each of `n` items, its rank in an order that spreads over them (bit-reversed indices:
/// 0, n/2, n/4, 3n/4, ...), so any prefix of the order samples the whole range.
fn spread_order(n: usize) -> Vec<usize> {
    let bits = usize::BITS - n.saturating_sub(1).leading_zeros();
    let reversed = |i: usize| if bits == 0 { 0 } else { i.reverse_bits() >> (usize::BITS - bits) };
    let mut by_key: Vec<usize> = (0..n).collect();
    by_key.sort_by_key(|&i| reversed(i));
    let mut rank = vec![0; n];
    for (r, i) in by_key.into_iter().enumerate() {
        rank[i] = r;
    }
    rank
}

/// What the terms of `pipeline` see of `prepared`.
pub(crate) fn shade_context<'a>(prepared: &'a Prepared, pipeline: &Pipeline) -> ShadeContext<'a> {
    ShadeContext {
        geometry: &prepared.geometry,
        materials: &prepared.materials,
        lights: &prepared.lights,
        max_depth: pipeline.max_depth,
        textures: &prepared.textures,
        reference: false,
    }
}

/// A rectangle of the image, in pixels.
#[derive(Clone, Copy)]
pub(crate) struct Tile {
    pub(crate) x0: u32,
    pub(crate) y0: u32,
    pub(crate) w: u32,
    pub(crate) h: u32,
}

/// Most camera rays traced together in one tile: the samples of a tile are traced in waves of
/// this many, so memory does not grow with the number of samples per pixel.
pub const WAVE: usize = 4096;

/// The waves of a tile of `pixels` pixels with `spp` samples each, as ranges of its samples
/// (pixel-major). A wave never splits a pixel's samples unless they are more than [`WAVE`]:
/// then each pixel is cut at multiples of `WAVE` from its first sample. So a pixel's samples go
/// through the same waves whatever tile it is rendered in (a whole frame or the pixel alone, as
/// [`crate::explain_pixel`] does), and its sums are made in the same order, to the bit.
pub(crate) fn waves(pixels: usize, spp: usize) -> impl Iterator<Item = std::ops::Range<usize>> {
    let total = pixels * spp;
    let mut start = 0;
    std::iter::from_fn(move || {
        if start >= total {
            return None;
        }
        let end = if spp <= WAVE {
            start + (WAVE / spp) * spp
        } else {
            let pixel_end = (start / spp + 1) * spp;
            (start + WAVE).min(pixel_end)
        };
        let range = start..end.min(total);
        start = range.end;
        Some(range)
    })
}

/// A thread's buffers, kept from tile to tile.
pub(crate) struct Scratch {
    world: hecs::World,
    entities: Vec<hecs::Entity>,
    /// Chunk columns whose entities were despawned, ready for the next generation.
    pool: Vec<(Rays, Hits, LightSamples)>,
    /// The rays of the next generation (the camera rays of a wave to begin with).
    next: Rays,
    /// The tile's pixels, per layer (terms in model order, then the background).
    pub(crate) accum: Vec<Vec<Vec3>>,
    /// The order of the tile's pixels for its camera rays ([`cell_order`]), and the tile size
    /// it was made for.
    order: (Vec<(u32, u32)>, (u32, u32)),
    /// The same for a tile with its border, in adaptive anti-aliasing ([`adaptive_tile`]).
    border_order: (Vec<(u32, u32)>, (u32, u32)),
    /// Adaptive anti-aliasing: the first values of a tile and its border, and the tile's pixels
    /// to supersample.
    first: Vec<Vec3>,
    shown: Vec<[u8; 3]>,
    refined: Vec<(u32, u32)>,
}

/// Whether some term of `pipeline` reads the light arriving on a surface of `material`: where
/// the visibility system traces shadow rays.
pub(crate) fn reads_lights(pipeline: &Pipeline, material: &lancer_core::Material) -> bool {
    pipeline.terms.iter().any(|t| t.term.reads_lights(material))
}

/// [`reads_lights`] for every material of the scene, by material index: asked once per render,
/// not per hit.
pub(crate) fn lit_materials(ctx: &ShadeContext<'_>, pipeline: &Pipeline) -> Vec<bool> {
    ctx.materials.iter().map(|m| reads_lights(pipeline, m)).collect()
}

impl Scratch {
    pub(crate) fn new(pipeline: &Pipeline) -> Scratch {
        let layers = pipeline.terms.len() + 1;
        Scratch {
            world: hecs::World::new(),
            entities: Vec::new(),
            pool: Vec::new(),
            next: Rays::with_capacity(WAVE),
            accum: vec![Vec::with_capacity((TILE_WIDTH * TILE) as usize); layers],
            order: (Vec::with_capacity((TILE_WIDTH * TILE) as usize), (0, 0)),
            border_order: (Vec::new(), (0, 0)),
            first: Vec::new(),
            shown: Vec::new(),
            refined: Vec::new(),
        }
    }

    /// Every layer's accumulator set to `tile`'s pixels, all zero.
    fn clear_accum(&mut self, tile: Tile) {
        for acc in &mut self.accum {
            acc.clear();
            acc.resize((tile.w * tile.h) as usize, Vec3::ZERO);
        }
    }

    /// `pixels` of `tile` set to zero in every layer.
    fn zero_pixels(&mut self, tile: Tile, pixels: &[(u32, u32)]) {
        for acc in &mut self.accum {
            for &(i, row) in pixels {
                acc[(row * tile.w + i) as usize] = Vec3::ZERO;
            }
        }
    }

    /// Splits `next` into chunk entities of at most `lanes` rays (each spawned with all its
    /// components, from pooled columns), leaving `next` empty.
    fn spawn_chunks(&mut self, lights: usize, lanes: usize) {
        let n = self.next.len();
        for start in (0..n).step_by(lanes) {
            let range = start..(start + lanes).min(n);
            let (mut rays, mut hits, mut samples) = self.pool.pop().unwrap_or_default();
            rays.copy_from(&self.next, range.clone());
            hits.reset(range.len());
            samples.reset(range.len(), lights);
            self.entities.push(self.world.spawn((rays, hits, samples)));
        }
        self.next.clear();
    }

    /// Takes every chunk's columns back into the pool and empties the world.
    fn recycle(&mut self) {
        for e in self.entities.drain(..) {
            if let Ok(columns) = self.world.remove::<(Rays, Hits, LightSamples)>(e) {
                self.pool.push(columns);
            }
        }
        self.world.clear();
    }
}

/// Sub-pixel position of sample `s` of `n`: the centre for one sample, else the R2
/// low-discrepancy sequence (deterministic, well spread for any count).
fn sample_offset(s: u32, n: u32) -> (f32, f32) {
    if n == 1 {
        return (0.5, 0.5);
    }
    const G: f64 = 1.324_717_957_244_746;
    let i = s as f64 + 0.5;
    (((i / G).fract()) as f32, ((i / (G * G)).fract()) as f32)
}

/// Renders one tile into `scratch.accum` (tile-local rows), wave by wave of camera rays: every
/// pixel's `samples`, or with [`ImageSettings::adaptive`] as [`adaptive_tile`] does. With a
/// `recorder`, every ray is its own chunk and everything the systems find about it is kept (the
/// sums are made in the same order as with full chunks: terms run chunk after chunk, lane after
/// lane, either way).
#[allow(clippy::too_many_arguments)]
pub(crate) fn render_tile(
    ctx: &ShadeContext<'_>,
    lit: &[bool],
    camera: &Camera,
    image: &ImageSettings,
    pipeline: &Pipeline,
    tile: Tile,
    scratch: &mut Scratch,
    recorder: Option<&mut crate::explain::Recorder>,
    timing: bool,
    stats: &mut RenderStats,
) {
    stats.spawned.resize(pipeline.terms.len(), 0);
    stats.times.terms.resize(pipeline.terms.len(), Default::default());
    let pass = Pass { ctx, lit, camera, image, pipeline, timing };
    if let Some(adaptive) = image.adaptive {
        return adaptive_tile(&pass, tile, adaptive, scratch, recorder, stats);
    }
    let order = cell_order_of(&mut scratch.order, tile);
    scratch.clear_accum(tile);
    let spp = image.samples.max(1) as usize;
    pass.trace(tile, Shots { pixels: &order, spp, pattern: Pattern::Uniform }, scratch, recorder, stats);
    scratch.order.0 = order;
}

/// The tile's pixels in [`cell_order`], taken out of `kept` (made again only when the tile's
/// size changed); give it back after use.
fn cell_order_of(kept: &mut (Vec<(u32, u32)>, (u32, u32)), tile: Tile) -> Vec<(u32, u32)> {
    if kept.1 != (tile.w, tile.h) {
        cell_order(tile.w, tile.h, &mut kept.0);
        kept.1 = (tile.w, tile.h);
    }
    std::mem::take(&mut kept.0)
}

/// Adaptive anti-aliasing of one tile ([`lancer_core::Adaptive`]). First every pixel of the
/// tile and of the one-pixel border around it (within the image) is traced once, at its
/// centre: a pixel's first value is then known with all four of its neighbours' whatever tile
/// it is in, so which pixels are supersampled does not depend on the tiles (nor on the
/// threads, the parts or [`crate::explain_pixel`], which renders a pixel alone). The tile's own
/// pixels keep their first values, layer by layer; those that differ from a neighbour by the
/// threshold or more are traced again, [`lancer_core::Adaptive::rays`] rays each of the weight
/// [`lancer_core::Adaptive::weight`] gives, and these replace them. Every layer is made so, and
/// the beauty image is still their sum.
fn adaptive_tile(
    pass: &Pass<'_, '_>,
    tile: Tile,
    adaptive: lancer_core::Adaptive,
    scratch: &mut Scratch,
    recorder: Option<&mut crate::explain::Recorder>,
    stats: &mut RenderStats,
) {
    let image = pass.image;
    let (x0, y0) = (tile.x0.saturating_sub(1), tile.y0.saturating_sub(1));
    let (x1, y1) = ((tile.x0 + tile.w + 1).min(image.width), (tile.y0 + tile.h + 1).min(image.height));
    let border = Tile { x0, y0, w: x1 - x0, h: y1 - y0 };
    let (dx, dy) = (tile.x0 - x0, tile.y0 - y0);
    let order = cell_order_of(&mut scratch.border_order, border);
    scratch.clear_accum(border);
    let before = stats.camera_rays;
    pass.trace(border, Shots { pixels: &order, spp: 1, pattern: Pattern::Uniform }, scratch, None, stats);
    stats.border_rays += stats.camera_rays - before - (tile.w * tile.h) as u64;
    scratch.border_order.0 = order;
    let mut lap = Lap::new(pass.timing);
    // The first values (the layers' sum, as the beauty image is made) and as they are compared,
    // then the tile's own pixels' layers moved to the tile's rows (each row moves towards the
    // front, never over a row still to move).
    let mut first = std::mem::take(&mut scratch.first);
    first.clear();
    first.resize((border.w * border.h) as usize, Vec3::ZERO);
    for acc in &scratch.accum {
        for (f, a) in first.iter_mut().zip(acc) {
            *f += *a;
        }
    }
    let mut shown = std::mem::take(&mut scratch.shown);
    shown.clear();
    shown.extend(first.iter().map(|&f| lancer_core::Adaptive::shown(f)));
    for acc in &mut scratch.accum {
        for row in 0..tile.h {
            let from = ((row + dy) * border.w + dx) as usize;
            acc.copy_within(from..from + tile.w as usize, (row * tile.w) as usize);
        }
        acc.truncate((tile.w * tile.h) as usize);
    }
    let order = cell_order_of(&mut scratch.order, tile);
    let mut refined = std::mem::take(&mut scratch.refined);
    refined.clear();
    let value = |x: u32, y: u32| shown[(y * border.w + x) as usize];
    refined.extend(order.iter().copied().filter(|&(i, row)| {
        let (x, y) = (i + dx, row + dy);
        let here = value(x, y);
        let differs = |nx: u32, ny: u32| adaptive.differ(here, value(nx, ny));
        (x > 0 && differs(x - 1, y))
            || (x + 1 < border.w && differs(x + 1, y))
            || (y > 0 && differs(x, y - 1))
            || (y + 1 < border.h && differs(x, y + 1))
    }));
    scratch.order.0 = order;
    (scratch.first, scratch.shown) = (first, shown);
    stats.supersampled += refined.len() as u64;
    lap.charge(&mut stats.times.chunks);
    let shots = Shots { pixels: &refined, spp: adaptive.rays() as usize, pattern: Pattern::Adaptive(adaptive) };
    if recorder.is_some() && refined.is_empty() {
        // Explaining a pixel that keeps its first value: its one ray again, recorded (the same
        // ray of the same weight, so the same bits). An explained pixel is a tile of its own.
        debug_assert!(tile.w == 1 && tile.h == 1);
        let centre = [(0, 0)];
        scratch.zero_pixels(tile, &centre);
        pass.trace(tile, Shots { pixels: &centre, spp: 1, pattern: Pattern::Uniform }, scratch, recorder, stats);
    } else if !refined.is_empty() {
        scratch.zero_pixels(tile, &refined);
        pass.trace(tile, shots, scratch, recorder, stats);
    }
    scratch.refined = refined;
}

/// What every pass of camera rays through a tile shares.
struct Pass<'a, 'c> {
    ctx: &'a ShadeContext<'c>,
    lit: &'a [bool],
    camera: &'a Camera,
    image: &'a ImageSettings,
    pipeline: &'a Pipeline,
    timing: bool,
}

/// Where a camera ray's sample falls in its pixel.
#[derive(Clone, Copy)]
enum Pattern {
    /// [`sample_offset`]: the centre for one sample, else the R2 sequence.
    Uniform,
    /// [`lancer_core::Adaptive::offset`]: the centre, then a grid's cell centres.
    Adaptive(lancer_core::Adaptive),
}

/// The camera rays of one pass: `spp` rays for each of `pixels` (tile-local, in this order),
/// each of weight `1 / spp` ([`Pattern::Uniform`]) or as [`lancer_core::Adaptive::weight`] says.
struct Shots<'a> {
    pixels: &'a [(u32, u32)],
    spp: usize,
    pattern: Pattern,
}

impl Shots<'_> {
    fn offset(&self, s: u32) -> (f32, f32) {
        match self.pattern {
            Pattern::Uniform => sample_offset(s, self.spp as u32),
            Pattern::Adaptive(a) => a.offset(s),
        }
    }
}

impl Pass<'_, '_> {
    /// Traces `shots` through `tile`, wave by wave, adding what they bring to `scratch.accum`
    /// (which holds `tile`'s pixels).
    fn trace(
        &self,
        tile: Tile,
        shots: Shots<'_>,
        scratch: &mut Scratch,
        mut recorder: Option<&mut crate::explain::Recorder>,
        stats: &mut RenderStats,
    ) {
        let Pass { ctx, lit, camera, image, pipeline, timing } = *self;
        let background_layer = pipeline.terms.len();
        let shadow_ctx = ShadowContext::new(ctx);
        let mut lap = Lap::new(timing);
        let times = &mut stats.times;
        let spp = shots.spp;
        let lanes = if recorder.is_some() { 1 } else { CHUNK_LANES };
        for wave in waves(shots.pixels.len(), spp) {
            camera_system(camera, image, tile, &shots, wave.clone(), ctx.reference, &mut scratch.next);
            stats.camera_rays += scratch.next.len() as u64;
            if let Some(r) = recorder.as_deref_mut() {
                r.camera_rays(wave, spp);
            }
            lap.charge(&mut times.camera);
            for level in 0u8.. {
                stats.max_level = stats.max_level.max(level);
                stats.peak_lanes = stats.peak_lanes.max(scratch.next.len() as u64);
                scratch.spawn_chunks(ctx.lights.len(), lanes);
                lap.charge(&mut times.chunks);
                let Scratch { world, next, accum, .. } = scratch;
                trace_system(world, ctx);
                lap.charge(&mut times.trace);
                crate::visibility::visibility_system(world, ctx, &shadow_ctx, pipeline, lit);
                lap.charge(&mut times.visibility);
                if let Some(r) = recorder.as_deref_mut() {
                    r.generation(world, ctx, pipeline, image.background);
                }
                background_system(world, image.background, background_layer, accum);
                lap.charge(&mut times.background);
                for (layer, named) in pipeline.terms.iter().enumerate() {
                    let queued = next.len();
                    for (c, (rays, hits, lights)) in world.query::<(&Rays, &Hits, &LightSamples)>().iter().enumerate() {
                        let before = next.len();
                        let mut added = Vec::new();
                        let mut out = TermOutput {
                            layer: layer as u16,
                            weight: named.weight,
                            rays,
                            accum,
                            next,
                            max_depth: pipeline.max_depth,
                            record: recorder.is_some().then_some(&mut added),
                        };
                        let chunk = Chunk { rays, hits, lights };
                        named.term.run(ctx, chunk, &mut out);
                        if let Some(r) = recorder.as_deref_mut() {
                            let notes =
                                if hits.object[0] != NO_HIT { named.term.explain(ctx, chunk, 0) } else { Vec::new() };
                            r.term_ran(c, layer, notes, added, before..next.len());
                        }
                    }
                    stats.spawned[layer] += (next.len() - queued) as u64;
                    lap.charge(&mut times.terms[layer]);
                }
                scratch.recycle();
                lap.charge(&mut times.chunks);
                if scratch.next.is_empty() {
                    break;
                }
                stats.secondary_rays += scratch.next.len() as u64;
            }
        }
        stats.shadow_rays += shadow_ctx.rays();
    }
}

/// Generation 0: the camera rays of `shots`' samples `range` (pixel-major), each of weight
/// `1 / spp` or [`lancer_core::Adaptive::weight`]; with `reference`, each direction by itself
/// ([`Camera::direction`]).
fn camera_system(
    camera: &Camera,
    image: &ImageSettings,
    tile: Tile,
    shots: &Shots<'_>,
    range: std::ops::Range<usize>,
    reference: bool,
    out: &mut Rays,
) {
    // Eight rays at a time; the columns start empty, so each eight fill a packet.
    assert!(out.is_empty(), "camera rays go into empty columns");
    // The pixel and sample of lane `range.start`, then one sample after another.
    let spp = shots.spp;
    let even = 1.0 / spp as f32;
    let (mut at, mut s) = (range.start / spp, range.start % spp);
    for start in range.clone().step_by(PACKET) {
        let lanes = (range.end - start).min(PACKET);
        let (mut px, mut py, mut pixels) = ([0.0f32; PACKET], [0.0f32; PACKET], [0u32; PACKET]);
        let mut weight = [0.0f32; PACKET];
        for j in 0..lanes {
            let (i, row) = shots.pixels[at];
            let (ox, oy) = shots.offset(s as u32);
            weight[j] = match shots.pattern {
                Pattern::Uniform => even,
                Pattern::Adaptive(a) => a.weight(s as u32),
            };
            (px[j], py[j], pixels[j]) = ((tile.x0 + i) as f32 + ox, (tile.y0 + row) as f32 + oy, row * tile.w + i);
            s += 1;
            if s == spp {
                (at, s) = (at + 1, 0);
            }
        }
        let dirs = if reference {
            let mut dirs = [[0.0; PACKET]; 3];
            for j in 0..lanes {
                let d = camera.direction(px[j], py[j], image.width, image.height);
                (dirs[0][j], dirs[1][j], dirs[2][j]) = (d.x, d.y, d.z);
            }
            dirs
        } else {
            camera.directions(px, py, image.width, image.height)
        };
        let splat = |v: Vec3| v.to_array().map(|c| [c; PACKET]);
        out.dir.push_packet(&dirs, lanes);
        out.origin.push_packet(&splat(camera.origin.as_vec3()), lanes);
        out.weight.push_packet(&[weight; 3], lanes);
        out.skip.extend_from_slice(&[NO_SKIP; PACKET][..lanes]);
        out.pixel.extend_from_slice(&pixels[..lanes]);
        out.depth.extend_from_slice(&[0; PACKET][..lanes]);
        out.credit.extend_from_slice(&[CREDIT_OWN; PACKET][..lanes]);
        out.media.extend_from_slice(&[lancer_core::rays::Media::AIR; PACKET][..lanes]);
    }
}

/// Closest hit of every ray, with everything terms need about the surface there. Hits on
/// evenly scaled spheres, planes and tori wait for the rest of their group of eight lanes: where they are all
/// on one object, they are described eight at a time ([`lancer_shapes::Object::hit_group`], the
/// bits of one at a time).
fn trace_system(world: &mut hecs::World, ctx: &ShadeContext<'_>) {
    if ctx.reference {
        return trace_reference(world, ctx);
    }
    let objects = &ctx.geometry.objects;
    for (rays, hits) in world.query_mut::<(&Rays, &mut Hits)>() {
        let mut waiting = [0u8; CHUNK_LANES / PACKET];
        let found = |lane: usize, i: u32, c: &lancer_shapes::ShapeHit| {
            if objects[i as usize].hits_in_groups() {
                (hits.t[lane], hits.object[lane]) = (c.t, i);
                waiting[lane / PACKET] |= 1 << (lane % PACKET);
            } else {
                describe(ctx, rays, hits, lane, i, c);
            }
        };
        let lines = Lines { origin: rays.origin.packets(), dir: rays.dir.packets(), skip: &rays.skip };
        ctx.geometry.closest_each(lines, |_| f32::INFINITY, found);
        for (g, &lanes) in waiting.iter().enumerate().take(rays.len().div_ceil(PACKET)) {
            if lanes == 0 {
                continue;
            }
            let base = g * PACKET;
            let object = hits.object[base + lanes.trailing_zeros() as usize];
            let t: [f32; PACKET] = std::array::from_fn(|k| hits.t.get(base + k).copied().unwrap_or(0.0));
            let one =
                crate::lanes::equal_bits(&hits.object[base..(base + PACKET).min(rays.len())], object) & lanes == lanes;
            let (origin, dir) = (&rays.origin.packets()[g], &rays.dir.packets()[g]);
            let together = if one { objects[object as usize].hit_group(origin, dir, &t, lanes) } else { None };
            match together {
                Some(h) => describe_group(ctx, hits, g, lanes, object, &h),
                None => {
                    for k in crate::lanes::set(lanes) {
                        let (lane, i) = (base + k, hits.object[base + k]);
                        let h = objects[i as usize].hit_at(i, rays.origin.at(lane), rays.dir.at(lane), t[k]);
                        store(ctx, hits, lane, i, &h);
                    }
                }
            }
        }
    }
}

/// The reference form of [`trace_system`]: each ray alone, its closest crossing by the BVH walk
/// ([`lancer_shapes::Geometry::closest`]), the surface there by [`lancer_shapes::Object::hit`]
/// and `Col_Ω` by [`ShadeContext::surface_color`].
fn trace_reference(world: &mut hecs::World, ctx: &ShadeContext<'_>) {
    for (rays, hits) in world.query_mut::<(&Rays, &mut Hits)>() {
        for lane in 0..rays.len() {
            let from = lancer_shapes::Origin { point: rays.origin.at(lane), skip: rays.skip[lane] };
            if let Some((i, c)) = ctx.geometry.closest(from, rays.dir.at(lane), 0.0, f32::INFINITY) {
                describe(ctx, rays, hits, lane, i, &c);
            }
        }
    }
}

/// The hit of `lane` on object `i` at the crossing `c`, into the hit columns.
#[inline(always)]
fn describe(ctx: &ShadeContext<'_>, rays: &Rays, hits: &mut Hits, lane: usize, i: u32, c: &lancer_shapes::ShapeHit) {
    let h = ctx.geometry.objects[i as usize].hit(i, rays.origin.at(lane), rays.dir.at(lane), c);
    store(ctx, hits, lane, i, &h);
}

/// The hit `h` of `lane` on object `i`, into the hit columns.
#[inline(always)]
fn store(ctx: &ShadeContext<'_>, hits: &mut Hits, lane: usize, i: u32, h: &lancer_shapes::Hit) {
    let object = &ctx.geometry.objects[i as usize];
    hits.t[lane] = h.t;
    hits.point.set(lane, h.point);
    hits.local[lane] = h.local;
    hits.uv[lane] = h.uv;
    hits.normal.set(lane, h.normal);
    hits.shading.set(lane, h.shading);
    hits.error[lane] = h.error;
    hits.front[lane] = h.front;
    hits.object[lane] = h.object;
    hits.material[lane] = object.material;
    hits.color.set(lane, ctx.surface_color(i, h.local, h.uv));
}

/// The hits `h` of the lanes set in `lanes` of group `g`, all on `object`, into the hit columns:
/// what [`describe`] writes for each of them.
#[inline(always)]
fn describe_group(
    ctx: &ShadeContext<'_>,
    hits: &mut Hits,
    g: usize,
    lanes: u8,
    object: u32,
    h: &lancer_shapes::HitGroup,
) {
    let o = &ctx.geometry.objects[object as usize];
    let material = &ctx.materials[o.material as usize];
    let color = crate::pattern::surface_colors(material, &o.shape, &h.local, lanes, ctx.textures);
    let on = crate::lanes::mask(lanes);
    let put = |column: &mut lancer_core::rays::Vec3s, v: &lancer_core::rays::Packet| {
        let packet = &mut column.packets_mut()[g];
        *packet = std::array::from_fn(|a| on.blend(wide::f32x8::new(v[a]), wide::f32x8::new(packet[a])).to_array());
    };
    put(&mut hits.point, &h.point);
    put(&mut hits.normal, &h.normal);
    put(&mut hits.shading, &h.normal);
    put(&mut hits.color, &color);
    let base = g * PACKET;
    for k in crate::lanes::set(lanes) {
        let lane = base + k;
        hits.local[lane] = lancer_core::rays::lane(&h.local, k);
        hits.uv[lane] = glam::Vec2::ZERO;
        hits.error[lane] = h.error[k];
        hits.front[lane] = h.front >> k & 1 == 1;
        hits.material[lane] = o.material;
    }
}

/// Rays that hit nothing see the background: a camera ray's goes to the background layer, a
/// child ray's to the term that spawned its line.
fn background_system(world: &hecs::World, background: Vec3, background_layer: usize, accum: &mut [Vec<Vec3>]) {
    if background == Vec3::ZERO {
        return;
    }
    for (rays, hits) in world.query::<(&Rays, &Hits)>().iter() {
        for lane in 0..rays.len() {
            if hits.object[lane] == NO_HIT {
                let layer = if rays.credit[lane] == CREDIT_OWN { background_layer } else { rays.credit[lane] as usize };
                accum[layer][rays.pixel[lane] as usize] += rays.weight.at(lane) * background;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{CELL, TILE, TILE_WIDTH, WAVE, cell_order, next_tile, sample_offset, spread_order, waves};

    #[test]
    fn waves_cover_every_sample_once_and_keep_a_pixels_samples_together() {
        for (pixels, spp) in [(256, 1), (256, 3), (256, 17), (256, 4096), (7, 5000), (3, 9000), (1, 1)] {
            let list: Vec<_> = waves(pixels, spp).collect();
            assert_eq!(list.first().map(|w| w.start), Some(0));
            assert_eq!(list.last().map(|w| w.end), Some(pixels * spp));
            for pair in list.windows(2) {
                assert_eq!(pair[0].end, pair[1].start, "{pixels} x {spp}: contiguous");
            }
            for w in &list {
                assert!(!w.is_empty() && w.len() <= WAVE, "{pixels} x {spp}: {w:?}");
                if spp <= WAVE {
                    assert!(w.start % spp == 0 && w.end % spp == 0, "{pixels} x {spp}: {w:?} splits a pixel");
                } else {
                    // Cut only at multiples of WAVE from the pixel's first sample.
                    assert_eq!((w.start % spp) % WAVE, 0, "{pixels} x {spp}: {w:?}");
                    assert_eq!(w.start / spp, (w.end - 1) / spp, "{pixels} x {spp}: one pixel per wave");
                }
            }
        }
    }

    #[test]
    fn the_band_order_spreads_every_prefix_over_the_image() {
        for n in [1, 2, 3, 23, 45, 64, 68] {
            let rank = spread_order(n);
            let mut seen = rank.clone();
            seen.sort();
            assert_eq!(seen, (0..n).collect::<Vec<_>>(), "a permutation of {n}");
            // The first quarter of the order has bands in every quarter of the image.
            if n >= 8 {
                let first: Vec<usize> = (0..n).filter(|&b| rank[b] < n.div_ceil(4)).collect();
                for q in 0..4 {
                    assert!(first.iter().any(|&b| b * 4 / n == q), "{n} bands: quarter {q} missing from {first:?}");
                }
            }
        }
    }

    #[test]
    fn a_worker_takes_its_own_run_first_then_the_back_of_the_fullest_other() {
        let queues: Vec<_> = [0..3, 3..10, 10..12].into_iter().map(std::sync::Mutex::new).collect();
        let mut taken = Vec::new();
        // Worker 0 empties its run from the front, then takes from the back of run 1 (7 left)
        // until run 1 is no fuller than run 2.
        for _ in 0..3 {
            taken.push(next_tile(&queues, 0));
        }
        assert_eq!(taken, [Some(0), Some(1), Some(2)]);
        assert_eq!(next_tile(&queues, 0), Some(9));
        // Worker 2 still starts at its run's front.
        assert_eq!(next_tile(&queues, 2), Some(10));
        // Every index is handed out once, whatever worker asks.
        let mut all = vec![0, 1, 2, 9, 10];
        let mut who = 0;
        while let Some(i) = next_tile(&queues, who % 3) {
            all.push(i);
            who += 1;
        }
        all.sort();
        assert_eq!(all, (0..12).collect::<Vec<_>>());
        assert!((0..3).all(|me| next_tile(&queues, me).is_none()), "stays empty");
    }

    #[test]
    fn the_cell_order_visits_every_pixel_of_a_tile_once_cell_by_cell() {
        let mut order = Vec::new();
        for w in 1..=TILE_WIDTH {
            for h in 1..=TILE {
                cell_order(w, h, &mut order);
                let mut seen: Vec<u32> = order.iter().map(|&(x, y)| y * w + x).collect();
                seen.sort();
                assert_eq!(seen, (0..w * h).collect::<Vec<_>>(), "{w} x {h}");
                assert!(order.iter().all(|&(x, y)| x < w && y < h), "{w} x {h}");
                // Each run of a cell's pixels stays within one cell.
                let cell = |p: (u32, u32)| (p.0 / CELL, p.1 / CELL);
                let changes = order.windows(2).filter(|p| cell(p[0]) != cell(p[1])).count();
                assert_eq!(changes + 1, (w.div_ceil(CELL) * h.div_ceil(CELL)) as usize, "{w} x {h}: cells");
            }
        }
    }

    #[test]
    fn sample_offsets_stay_inside_the_pixel_and_differ() {
        assert_eq!(sample_offset(0, 1), (0.5, 0.5));
        let pts: Vec<_> = (0..16).map(|s| sample_offset(s, 16)).collect();
        for (i, p) in pts.iter().enumerate() {
            assert!((0.0..1.0).contains(&p.0) && (0.0..1.0).contains(&p.1));
            assert!(pts[..i].iter().all(|q| q != p));
        }
    }
}

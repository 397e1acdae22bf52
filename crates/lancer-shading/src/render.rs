//! The render loop: rayon over tiles; per tile a hecs ray world whose entities are chunks of rays,
//! run generation by generation through the systems (camera → trace → light visibility →
//! background → terms in model order → child rays), until no ray is left.

use glam::Vec3;
use lancer_core::frame::BACKGROUND;
use lancer_core::rays::{CHUNK_LANES, CREDIT_OWN, Hits, LightSamples, NO_HIT, Rays};
use lancer_core::{Camera, Frame, ImageSettings, Layer, RenderStats, Scene};
use lancer_shapes::{NO_SKIP, Origin};
use rayon::prelude::*;

use crate::{Chunk, Pipeline, PrepareError, Prepared, ShadeContext, ShadowContext, TermOutput, prepare};

/// Side of a square tile, in pixels: a tile's rays stay in cache across generations.
pub const TILE: u32 = 16;

/// Knobs of a render that are not part of the scene.
#[derive(Clone, Copy, Default)]
pub struct RenderOptions<'a> {
    /// Called once per finished tile with (tiles done, tiles in all), from any thread.
    pub progress: Option<&'a (dyn Fn(usize, usize) + Sync)>,
}

/// Prepares `scene` and renders it with `pipeline` on the current rayon pool.
pub fn render(scene: &Scene, pipeline: &Pipeline, options: RenderOptions<'_>) -> Result<Frame, PrepareError> {
    let prepared = prepare(scene)?;
    Ok(render_prepared(&prepared, &scene.camera, &scene.image, pipeline, options))
}

/// Renders an already prepared scene. The result is the same, bit for bit, whatever the number
/// of threads: tiles are independent and each is processed in a fixed order.
pub fn render_prepared(
    prepared: &Prepared,
    camera: &Camera,
    image: &ImageSettings,
    pipeline: &Pipeline,
    options: RenderOptions<'_>,
) -> Frame {
    let (width, height) = (image.width, image.height);
    let tiles: Vec<(u32, u32)> = (0..height.div_ceil(TILE))
        .flat_map(|ty| (0..width.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
        .collect();
    let ctx = ShadeContext {
        geometry: &prepared.geometry,
        materials: &prepared.materials,
        lights: &prepared.lights,
        max_depth: pipeline.max_depth,
        textures: &prepared.textures,
    };
    let done = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<(Vec<Vec<Vec3>>, RenderStats)> = tiles
        .par_iter()
        .map(|&(x0, y0)| {
            let tile = Tile { x0, y0, w: TILE.min(width - x0), h: TILE.min(height - y0) };
            let out = render_tile(&ctx, camera, image, pipeline, tile);
            if let Some(progress) = options.progress {
                progress(done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1, tiles.len());
            }
            out
        })
        .collect();

    let mut names: Vec<String> = pipeline.terms.iter().map(|t| t.name.clone()).collect();
    names.push(BACKGROUND.to_owned());
    let mut layers: Vec<Layer> =
        names.into_iter().map(|name| Layer { name, pixels: vec![Vec3::ZERO; (width * height) as usize] }).collect();
    let mut stats = RenderStats::default();
    for (&(x0, y0), (tile, tile_stats)) in tiles.iter().zip(results) {
        stats += tile_stats;
        let w = TILE.min(width - x0) as usize;
        for (layer, buf) in layers.iter_mut().zip(tile) {
            for (row, src) in buf.chunks_exact(w).enumerate() {
                let start = (y0 as usize + row) * width as usize + x0 as usize;
                layer.pixels[start..start + w].copy_from_slice(src);
            }
        }
    }
    Frame { width, height, layers, stats }
}

#[derive(Clone, Copy)]
struct Tile {
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
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

fn render_tile(
    ctx: &ShadeContext<'_>,
    camera: &Camera,
    image: &ImageSettings,
    pipeline: &Pipeline,
    tile: Tile,
) -> (Vec<Vec<Vec3>>, RenderStats) {
    let pixels = (tile.w * tile.h) as usize;
    let background_layer = pipeline.terms.len();
    let mut accum = vec![vec![Vec3::ZERO; pixels]; background_layer + 1];
    let shadow_ctx = ShadowContext::new(ctx);
    let mut world = hecs::World::new();
    let mut stats = RenderStats::default();

    let primary = camera_system(camera, image, tile);
    stats.camera_rays = primary.len() as u64;
    spawn_chunks(&mut world, primary, ctx.lights.len());
    loop {
        trace_system(&mut world, ctx);
        visibility_system(&mut world, ctx, &shadow_ctx, pipeline);
        background_system(&world, image.background, background_layer, &mut accum);
        let mut next = Rays::default();
        for (layer, named) in pipeline.terms.iter().enumerate() {
            for (rays, hits, lights) in world.query::<(&Rays, &Hits, &LightSamples)>().iter() {
                let mut out = TermOutput {
                    layer: layer as u16,
                    weight: named.weight,
                    rays,
                    accum: &mut accum,
                    next: &mut next,
                    max_depth: pipeline.max_depth,
                };
                named.term.run(ctx, Chunk { rays, hits, lights }, &mut out);
            }
        }
        world.clear();
        if next.is_empty() {
            stats.shadow_rays = shadow_ctx.rays();
            return (accum, stats);
        }
        stats.secondary_rays += next.len() as u64;
        spawn_chunks(&mut world, next, ctx.lights.len());
    }
}

/// Generation 0: one ray per pixel sample, weight `1 / samples`.
fn camera_system(camera: &Camera, image: &ImageSettings, tile: Tile) -> Rays {
    let spp = image.samples.max(1);
    let weight = Vec3::splat(1.0 / spp as f32);
    let mut rays = Rays::with_capacity((tile.w * tile.h * spp) as usize);
    for j in 0..tile.h {
        for i in 0..tile.w {
            for s in 0..spp {
                let (ox, oy) = sample_offset(s, spp);
                let (px, py) = ((tile.x0 + i) as f32 + ox, (tile.y0 + j) as f32 + oy);
                let dir = camera.direction(px, py, image.width, image.height);
                rays.push(camera.origin, NO_SKIP, dir, weight, j * tile.w + i, 0, CREDIT_OWN);
            }
        }
    }
    rays
}

/// Splits a generation's rays into chunk entities, each spawned with all its components.
fn spawn_chunks(world: &mut hecs::World, mut rays: Rays, lights: usize) {
    while !rays.is_empty() {
        let rest = if rays.len() > CHUNK_LANES { split_off(&mut rays, CHUNK_LANES) } else { Rays::default() };
        let n = rays.len();
        world.spawn((rays, Hits::misses(n), LightSamples::dark(n, lights)));
        rays = rest;
    }
}

fn split_off(r: &mut Rays, at: usize) -> Rays {
    Rays {
        origin: r.origin.split_off(at),
        skip: r.skip.split_off(at),
        dir: r.dir.split_off(at),
        weight: r.weight.split_off(at),
        pixel: r.pixel.split_off(at),
        depth: r.depth.split_off(at),
        credit: r.credit.split_off(at),
    }
}

/// Closest hit of every ray, with everything terms need about the surface there.
fn trace_system(world: &mut hecs::World, ctx: &ShadeContext<'_>) {
    for (rays, hits) in world.query_mut::<(&Rays, &mut Hits)>() {
        for lane in 0..rays.len() {
            let from = Origin { point: rays.origin[lane], skip: rays.skip[lane] };
            if let Some(h) = ctx.geometry.closest_hit(from, rays.dir[lane], 0.0, f32::INFINITY) {
                hits.t[lane] = h.t;
                hits.point[lane] = h.point;
                hits.local[lane] = h.local;
                hits.uv[lane] = h.uv;
                hits.normal[lane] = h.normal;
                hits.shading[lane] = h.shading;
                hits.error[lane] = h.error;
                hits.front[lane] = h.front;
                hits.object[lane] = h.object;
            }
        }
    }
}

/// For every hit on which some term reads lights ([`crate::Term::reads_lights`]) and every
/// light: the direction to the light and the light arriving through the pipeline's shadow
/// model. Lights behind the surface (`N·w <= 0`) send nothing.
fn visibility_system(
    world: &mut hecs::World,
    ctx: &ShadeContext<'_>,
    shadow_ctx: &ShadowContext<'_>,
    pipeline: &Pipeline,
) {
    let shadows = &pipeline.shadows.model;
    for (hits, samples) in world.query_mut::<(&Hits, &mut LightSamples)>() {
        for lane in 0..hits.object.len() {
            if hits.object[lane] == NO_HIT {
                continue;
            }
            let material = ctx.material(hits, lane);
            if !pipeline.terms.iter().any(|t| t.term.reads_lights(material)) {
                continue;
            }
            let hit = ctx.hit(hits, lane);
            let n = hits.facing_normal(lane);
            for (k, light) in ctx.lights.iter().enumerate() {
                let slot = lane * ctx.lights.len() + k;
                let Some(w) = (light.at - hit.point).try_normalize() else {
                    continue;
                };
                samples.w[slot] = w;
                if n.dot(w) <= 0.0 {
                    continue;
                }
                samples.incoming[slot] = light.radiance() * shadows.transmittance(shadow_ctx, &hit, light);
            }
        }
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
                accum[layer][rays.pixel[lane] as usize] += rays.weight[lane] * background;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::sample_offset;

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

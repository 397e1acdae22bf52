//! The light visibility system: for every hit some term reads lights on, and every light, the
//! direction to the light and the light arriving through the shadow model, eight lanes at once.

use glam::Vec3;
use lancer_core::rays::{CHUNK_LANES, Hits, LightSamples, PACKET};
use lancer_shapes::Origin;
use wide::{CmpGt, CmpLe, CmpLt, f32x8};

use crate::lanes::{self, Group, V3};

use crate::shadow::BLOCK;
use crate::{HitBlock, Pipeline, ShadeContext, ShadowContext};

/// For every hit on which some term reads lights ([`crate::Term::reads_lights`], by material:
/// `lit`) and every light: the direction to the light and the light arriving through the
/// pipeline's shadow model. Lights behind the surface (`N·w <= 0`, the normal facing the ray)
/// send nothing. Block by block and light by light, so a shadow model traces a block's shadow
/// rays towards one light together.
pub(crate) fn visibility_system(
    world: &mut hecs::World,
    ctx: &ShadeContext<'_>,
    shadow_ctx: &ShadowContext<'_>,
    pipeline: &Pipeline,
    lit: &[bool],
) {
    if ctx.reference {
        return visibility_reference(world, ctx, shadow_ctx, pipeline, lit);
    }
    let mut out = [Vec3::ZERO; BLOCK];
    for (hits, samples) in world.query_mut::<(&Hits, &mut LightSamples)>() {
        let n = hits.object.len();
        // The lanes with a hit some term reads lights on, a bit per lane of each group. (No
        // branch per lane: a lane with no hit reads whatever its material column holds, through
        // `get`, and the hit bits drop it.)
        let mut alive = [0u8; CHUNK_LANES / PACKET];
        for (g, group) in Group::all(hits).enumerate() {
            let indices = &hits.material[group.base..group.base + group.len];
            alive[g] = match group.one_material(indices) {
                // One material for every hit lane (the usual case): looked up once.
                Some(material) => {
                    if lit.get(material as usize).copied().unwrap_or(false) {
                        group.hit
                    } else {
                        0
                    }
                }
                None => group.hit & lanes::bits(group.len, |j| lit.get(indices[j] as usize).copied().unwrap_or(false)),
            };
        }
        let mut block = HitBlock::empty(hits, Vec3::ZERO);
        for (k, light) in ctx.lights.iter().enumerate() {
            // The hits the light reaches the front of, gathered over the chunk into blocks as
            // full as they go (each hit gets the same answer in any block).
            block.clear(light.at);
            for (g, &alive) in alive.iter().enumerate().take(n.div_ceil(PACKET)) {
                if alive == 0 {
                    continue;
                }
                let base = g * PACKET;
                let surface = Surface::of(Group { base, len: (n - base).min(PACKET), hit: 0 }, alive, hits);
                toward_light(ctx, &surface, light.at, samples, k, &mut block);
                if block.len() > BLOCK - PACKET {
                    shade(shadow_ctx, pipeline, &block, light, samples, k, &mut out);
                    block.clear(light.at);
                }
            }
            shade(shadow_ctx, pipeline, &block, light, samples, k, &mut out);
        }
    }
}

/// The reference form of [`visibility_system`]: one hit at a time, one light at a time. For a
/// hit some term reads lights on, `w = normalize(L − I)`; a light in front of the surface
/// (`N·w > 0`, `N` the shading normal facing the ray) sends `Col_L · T`, with `T` what the
/// shadow model's [`crate::ShadowModel::transmittance`] gives that hit alone.
fn visibility_reference(
    world: &mut hecs::World,
    ctx: &ShadeContext<'_>,
    shadow_ctx: &ShadowContext<'_>,
    pipeline: &Pipeline,
    lit: &[bool],
) {
    for (hits, samples) in world.query_mut::<(&Hits, &mut LightSamples)>() {
        for lane in 0..hits.object.len() {
            if hits.object[lane] == lancer_core::rays::NO_HIT || !lit[hits.material[lane] as usize] {
                continue;
            }
            let (at, n) = (ctx.hit(hits, lane), hits.facing_normal(lane));
            for (k, light) in ctx.lights.iter().enumerate() {
                let Some(w) = (light.at - at.point).try_normalize() else { continue };
                samples.w[k].set(lane, w);
                if n.dot(w) > 0.0 {
                    let t = pipeline.shadows.model.transmittance(shadow_ctx, &at, light);
                    samples.incoming[k].set(lane, light.radiance() * t);
                }
            }
        }
    }
}

/// The light arriving at each hit of `block` through the pipeline's shadow model, into the
/// samples of light `k`.
#[inline]
fn shade(
    shadow_ctx: &ShadowContext<'_>,
    pipeline: &Pipeline,
    block: &HitBlock<'_>,
    light: &lancer_core::Light,
    samples: &mut LightSamples,
    k: usize,
    out: &mut [Vec3; BLOCK],
) {
    if block.is_empty() {
        return;
    }
    let reached = block.len();
    pipeline.shadows.model.transmittance_each(shadow_ctx, block, light, &mut out[..reached]);
    for (i, through) in out[..reached].iter().enumerate() {
        samples.incoming[k].set(block.lane(i), light.radiance() * *through);
    }
}

/// Eight lanes of hits as the visibility system needs them, whatever the light.
#[derive(Clone, Copy)]
struct Surface {
    base: usize,
    /// The lanes some term reads lights on.
    alive: u8,
    point: V3,
    normal: V3,
    /// The shading normal facing the ray.
    facing: V3,
    error: [f32; PACKET],
    object: [u32; PACKET],
}

impl Surface {
    #[inline(always)]
    fn of(group: Group, alive: u8, hits: &Hits) -> Surface {
        let (point, normal, error, object) = group.surface(hits);
        Surface { base: group.base, alive, point, normal, facing: group.facing(hits), error, object }
    }
}

/// The lanes of `s` some term reads lights on, towards the light at `target`: `w`, the unit
/// direction to the light (`try_normalize`'s bits), into the samples of light `k`; and each
/// lane the light reaches the front of (`N·w > 0`), with its straight shadow ray (`toward` and
/// `Geometry::spawn`'s bits), into `block`.
#[inline(always)]
fn toward_light(
    ctx: &ShadeContext<'_>,
    s: &Surface,
    target: Vec3,
    samples: &mut LightSamples,
    k: usize,
    block: &mut HitBlock<'_>,
) {
    let live = lanes::mask(s.alive);
    let d: V3 = std::array::from_fn(|a| f32x8::splat(target[a]) - s.point[a]);
    let length = lanes::dot(&d, &d).sqrt();
    // `try_normalize`: the reciprocal of the length, finite and positive.
    let rcp = f32x8::ONE / length;
    let normal_ok = rcp.abs().cmp_lt(f32x8::splat(f32::INFINITY)) & rcp.cmp_gt(f32x8::ZERO);
    let w = d.map(|c| c * rcp);
    let away = lanes::dot(&s.facing, &w).cmp_le(f32x8::ZERO);
    let with_w = live & normal_ok;
    if with_w.move_mask() != 0 {
        // The other lanes keep the zero `reset` gave them.
        samples.w[k].packets_mut()[s.base / PACKET] = w.map(|c| with_w.blend(c, f32x8::ZERO).to_array());
    }
    let reached = (with_w & !away).move_mask();
    if reached == 0 {
        return;
    }
    // `toward`: the distance is the same length; the direction `d / length`.
    let dir = d.map(|c| c / length);
    let dir_lanes = dir.map(|c| c.to_array());
    let (origin, skip) = ctx.geometry.spawn_packet(
        &s.point.map(|c| c.to_array()),
        &s.normal.map(|c| c.to_array()),
        &s.error,
        &s.object,
        &dir_lanes,
    );
    // `aim_from`: each ray aimed at the light from where it starts, as long as that; a light
    // that lies behind the start (within its offset) gets no ray: nothing left, the direction
    // it left along.
    let from = origin.map(f32x8::new);
    let to: V3 = std::array::from_fn(|a| f32x8::splat(target[a]) - from[a]);
    let reach = lanes::dot(&to, &to).sqrt();
    let aimed = to.map(|c| c / reach);
    let ahead = reach.cmp_gt(f32x8::ZERO)
        & reach.cmp_lt(f32x8::splat(f32::INFINITY))
        & lanes::dot(&aimed, &dir).cmp_gt(f32x8::ZERO);
    let dir_lanes = std::array::from_fn(|a| ahead.blend(aimed[a], dir[a]).to_array());
    let left = ahead.blend(reach, f32x8::ZERO).to_array();
    let length = length.to_array();
    for j in lanes::set(reached as u8) {
        let from = Origin { point: lancer_core::rays::lane(&origin, j), skip: skip[j] };
        block.push(s.base + j, from, lancer_core::rays::lane(&dir_lanes, j), length[j], left[j]);
    }
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec3};
    use lancer_core::Material;
    use lancer_core::rays::{LightSamples, NO_HIT, PACKET};
    use lancer_shapes::{Geometry, Object, Origin, Shape};

    use crate::shadow::{BLOCK, columns_of};
    use crate::{HitBlock, ShadeContext};

    #[test]
    fn eight_lanes_at_once_give_each_hit_the_bits_it_gets_alone() {
        // Hits on a floor, spheres (from outside and, through the glass one, from inside), a
        // cube and a disk, among lanes with no hit and lanes no term lights; lights above, below
        // the floor and at a hit point. `w` and the straight shadow rays made eight lanes at a
        // time are, lane by lane and to the bit, those of the scalar arithmetic.
        let place = |shape: Shape, scale: f32, at: Vec3| {
            let m = Affine3A::from_scale_rotation_translation(Vec3::splat(scale), glam::Quat::from_rotation_y(0.4), at);
            Object::new(shape, m, 0).unwrap()
        };
        let g = Geometry::new(vec![
            place(Shape::Plane, 1.0, Vec3::ZERO),
            place(Shape::Sphere, 1.0, Vec3::new(0.0, 1.0, 0.0)),
            place(Shape::Cube, 0.6, Vec3::new(-2.0, 0.6, -1.0)),
            place(Shape::Disk, 0.8, Vec3::new(1.0, 2.5, -1.0)),
            place(Shape::Sphere, 0.5, Vec3::new(2.0, 0.5, 1.0)),
        ]);
        let materials = [Material::default()];
        let scene = ShadeContext {
            geometry: &g,
            materials: &materials,
            lights: &[],
            max_depth: 5,
            textures: &[],
            reference: false,
        };
        let list: Vec<_> = (0..200)
            .filter_map(|k| {
                let a = k as f32 * 0.618_034;
                let eye = if k % 7 == 0 {
                    Vec3::new(0.1 * a.cos(), 1.0, 0.1 * a.sin())
                } else {
                    Vec3::new(6.0 * a.cos(), 3.0 + 5.0 * (a * 1.3).sin().abs(), 6.0 * a.sin())
                };
                let aim = Vec3::new(3.0 * (a * 2.1).sin(), (a * 0.7).cos().abs() * 2.0, 3.0 * (a * 1.7).cos());
                g.closest_hit(Origin::free(eye), (aim - eye).normalize(), 0.0, f32::INFINITY)
            })
            .collect();
        assert!(list.iter().any(|h| !h.front) && list.len() > 150);
        let mut hits = columns_of(&list);
        // Lanes with no hit: their columns keep stale values.
        for lane in (5..hits.object.len()).step_by(11) {
            hits.object[lane] = NO_HIT;
        }
        let n = hits.object.len();
        let mut lit = 0;
        // (Lane 10 is alive: the last light sits on its hit point.)
        for target in [Vec3::new(3.0, 8.0, -2.0), Vec3::new(-1.0, -4.0, 0.5), list[10].point] {
            let mut samples = LightSamples::default();
            samples.reset(n, 2);
            let mut got = Vec::new();
            for start in (0..n).step_by(BLOCK) {
                let mut block = HitBlock::empty(&hits, target);
                for base in (start..(start + BLOCK).min(n)).step_by(PACKET) {
                    // Every lane with a hit but every third, as if no term read lights there.
                    let len = PACKET.min(n - base);
                    let alive = crate::lanes::bits(len, |j| hits.object[base + j] != NO_HIT && (base + j) % 3 != 0);
                    if alive != 0 {
                        let surface = super::Surface::of(crate::lanes::Group { base, len, hit: 0 }, alive, &hits);
                        super::toward_light(&scene, &surface, target, &mut samples, 1, &mut block);
                    }
                }
                got.extend((0..block.len()).map(|i| {
                    let (p, k) = (i / PACKET, i % PACKET);
                    let origin = Vec3::new(block.origin[p][0][k], block.origin[p][1][k], block.origin[p][2][k]);
                    (block.lane(i), origin, block.skip[i], block.dir(i), block.dist(i), block.left(i))
                }));
            }
            // Lanes no term lights keep no direction, and light 0's samples are untouched.
            for lane in (0..n).filter(|&l| hits.object[l] == NO_HIT || l % 3 == 0) {
                assert_eq!(samples.w[1].at(lane), Vec3::ZERO, "lane {lane}: not lit, yet a direction");
            }
            assert!(samples.w[0].iter().chain(samples.incoming[0].iter()).all(|v| v == Vec3::ZERO));
            let mut want = Vec::new();
            let mut at_light = 0;
            for lane in (0..n).filter(|&l| hits.object[l] != NO_HIT && l % 3 != 0) {
                let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                let Some(w) = (target - hits.point.at(lane)).try_normalize() else {
                    assert_eq!(samples.w[1].at(lane), Vec3::ZERO, "lane {lane}: no direction");
                    at_light += 1;
                    continue;
                };
                assert_eq!(bits(samples.w[1].at(lane)), bits(w), "lane {lane}");
                if hits.facing_normal(lane).dot(w) <= 0.0 {
                    continue;
                }
                let alone = HitBlock::toward(&scene, &hits, &[lane], target);
                let origin = Vec3::new(alone.origin[0][0][0], alone.origin[0][1][0], alone.origin[0][2][0]);
                want.push((lane, origin, alone.skip[0], alone.dir(0), alone.dist(0), alone.left(0)));
            }
            lit += want.len();
            assert_eq!(at_light, usize::from(target == list[10].point), "hits at the light");
            let bits = |e: &(usize, Vec3, u32, Vec3, f32, f32)| {
                (
                    e.0,
                    e.1.to_array().map(f32::to_bits),
                    e.2,
                    e.3.to_array().map(f32::to_bits),
                    e.4.to_bits(),
                    e.5.to_bits(),
                )
            };
            assert_eq!(got.iter().map(bits).collect::<Vec<_>>(), want.iter().map(bits).collect::<Vec<_>>());
        }
        assert!(lit > 100, "{lit} lit");
    }
}

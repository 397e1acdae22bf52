//! Components of the per-tile ray world: each entity is a *chunk* of rays stored as SoA columns
//! (an entity per ray would cost more in bookkeeping than tracing it).

use glam::Vec3;

/// Most lanes one chunk holds (the renderer's tiles, 64 x 16 pixels, fit their camera rays at
/// one sample per pixel in one chunk). Measured on the benchmark scene (one thread): 256 lanes
/// 0.262 s, 1024 lanes 0.258 s, 2048 no better.
pub const CHUNK_LANES: usize = 1024;

/// `Rays::credit` of a primary ray: each term credits its own image.
pub const CREDIT_OWN: u16 = u16::MAX;

/// `Hits::object` of a lane whose ray hit nothing.
pub const NO_HIT: u32 = u32::MAX;

/// The rays of a chunk, one entry per lane.
#[derive(Clone, Debug, Default)]
pub struct Rays {
    /// Ray origins.
    pub origin: Vec<Vec3>,
    /// An object index the ray ignores (the convex object it leaves), or `u32::MAX`.
    pub skip: Vec<u32>,
    /// Unit directions.
    pub dir: Vec<Vec3>,
    /// Throughput: what this ray's colour is multiplied by before it reaches its pixel.
    pub weight: Vec<Vec3>,
    /// Pixel index inside the tile.
    pub pixel: Vec<u32>,
    /// Recursion depth (0 for camera rays).
    pub depth: Vec<u8>,
    /// Which image (layer index) receives this ray's contributions; [`CREDIT_OWN`] for camera rays.
    pub credit: Vec<u16>,
}

impl Rays {
    /// Number of lanes.
    #[inline]
    pub fn len(&self) -> usize {
        self.origin.len()
    }

    /// Whether the chunk has no lanes.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.origin.is_empty()
    }

    /// An empty chunk with room for `n` lanes.
    pub fn with_capacity(n: usize) -> Rays {
        Rays {
            origin: Vec::with_capacity(n),
            skip: Vec::with_capacity(n),
            dir: Vec::with_capacity(n),
            weight: Vec::with_capacity(n),
            pixel: Vec::with_capacity(n),
            depth: Vec::with_capacity(n),
            credit: Vec::with_capacity(n),
        }
    }

    /// Removes every lane, keeping the capacity.
    pub fn clear(&mut self) {
        self.origin.clear();
        self.skip.clear();
        self.dir.clear();
        self.weight.clear();
        self.pixel.clear();
        self.depth.clear();
        self.credit.clear();
    }

    /// Replaces the lanes with `src`'s lanes `range`, reusing this chunk's capacity.
    pub fn copy_from(&mut self, src: &Rays, range: std::ops::Range<usize>) {
        self.clear();
        self.origin.extend_from_slice(&src.origin[range.clone()]);
        self.skip.extend_from_slice(&src.skip[range.clone()]);
        self.dir.extend_from_slice(&src.dir[range.clone()]);
        self.weight.extend_from_slice(&src.weight[range.clone()]);
        self.pixel.extend_from_slice(&src.pixel[range.clone()]);
        self.depth.extend_from_slice(&src.depth[range.clone()]);
        self.credit.extend_from_slice(&src.credit[range]);
    }

    /// Appends one lane.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn push(&mut self, origin: Vec3, skip: u32, dir: Vec3, weight: Vec3, pixel: u32, depth: u8, credit: u16) {
        self.origin.push(origin);
        self.skip.push(skip);
        self.dir.push(dir);
        self.weight.push(weight);
        self.pixel.push(pixel);
        self.depth.push(depth);
        self.credit.push(credit);
    }
}

/// Closest hits of a chunk's rays, one entry per lane (written by the trace system; a lane's columns
/// other than `object` mean something only where it hit).
#[derive(Clone, Debug, Default)]
pub struct Hits {
    /// Distance along the ray.
    pub t: Vec<f32>,
    /// Hit point in world space.
    pub point: Vec<Vec3>,
    /// Hit point in the object's own space (for patterns and texture coordinates).
    pub local: Vec<Vec3>,
    /// Texture coordinates interpolated from a mesh's vertices (zero for other shapes, whose
    /// coordinates follow from `local`).
    pub uv: Vec<glam::Vec2>,
    /// Unit outward geometric normal (the side the shape calls outside): decides front and back
    /// and where secondary rays start.
    pub normal: Vec<Vec3>,
    /// Unit outward shading normal: interpolated from the vertex normals on smooth meshes (on
    /// the geometric normal's side), else the geometric normal. Terms shade with it.
    pub shading: Vec<Vec3>,
    /// A bound on the hit point's distance from the true surface (world units, along `normal`).
    pub error: Vec<f32>,
    /// Whether the ray arrived from outside (`normal · dir < 0`, geometric normal).
    pub front: Vec<bool>,
    /// Object index in the prepared scene, or [`NO_HIT`].
    pub object: Vec<u32>,
    /// The object's material (an index into the prepared material table).
    pub material: Vec<u32>,
    /// `Col_Ω`: the material's colour at the hit (its pattern or texture evaluated there), found
    /// once for every term that reads it.
    pub color: Vec<Vec3>,
}

impl Hits {
    /// Makes these columns `n` lanes of misses, reusing their capacity. Only `object` is
    /// rewritten in full ([`NO_HIT`]); the other columns keep whatever their lanes held, as a
    /// lane's values mean something only once the trace system has written its hit.
    pub fn reset(&mut self, n: usize) {
        self.t.resize(n, f32::INFINITY);
        self.point.resize(n, Vec3::ZERO);
        self.local.resize(n, Vec3::ZERO);
        self.uv.resize(n, glam::Vec2::ZERO);
        self.normal.resize(n, Vec3::ZERO);
        self.shading.resize(n, Vec3::ZERO);
        self.error.resize(n, 0.0);
        self.front.resize(n, true);
        self.material.resize(n, 0);
        self.color.resize(n, Vec3::ZERO);
        if cfg!(debug_assertions) {
            // Debug builds (the test suite) fill every lane with values no hit has, so a reader
            // of a lane without a hit shows up as a change between thread counts or chunk sizes.
            self.poison();
        }
        self.object.clear();
        self.object.resize(n, NO_HIT);
    }

    /// NaN and out-of-range values in every column but `object`.
    fn poison(&mut self) {
        self.t.fill(f32::NAN);
        self.point.fill(Vec3::NAN);
        self.local.fill(Vec3::NAN);
        self.uv.fill(glam::Vec2::NAN);
        self.normal.fill(Vec3::NAN);
        self.shading.fill(Vec3::NAN);
        self.error.fill(f32::NAN);
        self.material.fill(u32::MAX);
        self.color.fill(Vec3::NAN);
    }

    /// The shading normal facing the incoming ray (the outward one turned round on a back-face
    /// hit).
    #[inline]
    pub fn facing_normal(&self, lane: usize) -> Vec3 {
        if self.front[lane] { self.shading[lane] } else { -self.shading[lane] }
    }
}

/// Light arriving at each lane's hit, `lights` entries per lane (written by the visibility system).
#[derive(Clone, Debug, Default)]
pub struct LightSamples {
    /// Number of lights (entries per lane).
    pub lights: usize,
    /// Unit direction from the hit towards each light (`w`).
    pub w: Vec<Vec3>,
    /// Light colour reaching the hit: `Col_L` times the shadow model's transmittance; zero when the
    /// light is hidden, behind the surface (`N·w <= 0`), or the lane has no hit.
    pub incoming: Vec<Vec3>,
}

impl LightSamples {
    /// Makes these columns `lanes` lanes of darkness for `lights` lights, reusing their capacity.
    pub fn reset(&mut self, lanes: usize, lights: usize) {
        self.lights = lights;
        self.w.clear();
        self.w.resize(lanes * lights, Vec3::ZERO);
        self.incoming.clear();
        self.incoming.resize(lanes * lights, Vec3::ZERO);
    }

    /// The `(w, incoming)` pairs of one lane.
    #[inline]
    pub fn lane(&self, lane: usize) -> impl Iterator<Item = (Vec3, Vec3)> + '_ {
        let r = lane * self.lights..(lane + 1) * self.lights;
        self.w[r.clone()].iter().copied().zip(self.incoming[r].iter().copied())
    }
}

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

/// The transparent objects a ray is inside, innermost first: what `refraction:traced` reads to
/// know the index on each side of a surface (POV-Ray keeps the same list per ray). A camera
/// ray is in none; a refracted ray's list is its parent's with the object it enters added or the
/// one it leaves taken off; every other child ray (a reflection, a total internal reflection)
/// keeps its parent's. Up to [`Media::DEPTH`] nested objects are remembered: entering one more
/// forgets the outermost.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Media {
    /// Object indices, innermost first; [`Media::NONE`] past the last.
    inside: [u32; Media::DEPTH],
}

impl Default for Media {
    fn default() -> Media {
        Media::AIR
    }
}

impl Media {
    /// How many nested objects a ray remembers being inside.
    pub const DEPTH: usize = 3;
    /// An unused slot.
    const NONE: u32 = u32::MAX;
    /// Inside nothing: the ray travels in air (index 1).
    pub const AIR: Media = Media { inside: [Media::NONE; Media::DEPTH] };

    /// The innermost object the ray is inside, if any.
    #[inline]
    pub fn innermost(self) -> Option<u32> {
        (self.inside[0] != Media::NONE).then_some(self.inside[0])
    }

    /// Whether the ray is inside `object`.
    #[inline]
    pub fn contains(self, object: u32) -> bool {
        object != Media::NONE && self.inside.contains(&object)
    }

    /// The objects, innermost first.
    pub fn iter(self) -> impl Iterator<Item = u32> {
        self.inside.into_iter().take_while(|&o| o != Media::NONE)
    }

    /// These media with `object` entered (innermost now); the outermost is forgotten when
    /// [`Media::DEPTH`] are already remembered.
    #[inline]
    #[must_use]
    pub fn entering(self, object: u32) -> Media {
        let mut inside = [Media::NONE; Media::DEPTH];
        inside[0] = object;
        inside[1..].copy_from_slice(&self.inside[..Media::DEPTH - 1]);
        Media { inside }
    }

    /// These media with `object` left (taken off wherever it is in the list).
    #[inline]
    #[must_use]
    pub fn leaving(self, object: u32) -> Media {
        let mut inside = [Media::NONE; Media::DEPTH];
        for (slot, o) in inside.iter_mut().zip(self.iter().filter(|&o| o != object)) {
            *slot = o;
        }
        Media { inside }
    }
}

/// Lanes per [`Packet`]: eight, one SIMD group.
pub const PACKET: usize = 8;

/// Eight lanes of vectors axis by axis: `[x; 8]`, `[y; 8]`, `[z; 8]`.
pub type Packet = [[f32; PACKET]; 3];

/// Lane `k` of a packet. (Made in a vector register: stored in memory, it is then written as
/// eight bytes and four, which a later eight-byte load of its `x, y` can be served from; three
/// separate stores would make that load wait for them.)
#[inline(always)]
pub fn lane(packet: &Packet, k: usize) -> Vec3 {
    Vec3::from(glam::Vec3A::new(packet[0][k], packet[1][k], packet[2][k]))
}

/// A column of vectors stored eight lanes to a [`Packet`], axis by axis within it: a system
/// loads an axis of eight lanes at once, and one lane's three coordinates still sit together
/// (one bounds check, one cache line). [`Vec3s::at`] reads a lane as a `Vec3`. The lanes of the
/// last packet past [`Vec3s::len`] hold no meaning.
#[derive(Clone, Debug, Default)]
pub struct Vec3s {
    packets: Vec<Packet>,
    len: usize,
}

impl Vec3s {
    /// An empty column with room for `n` lanes.
    pub fn with_capacity(n: usize) -> Vec3s {
        Vec3s { packets: Vec::with_capacity(n.div_ceil(PACKET)), len: 0 }
    }

    /// Number of lanes.
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the column has no lanes.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The vector of `lane`. (A lane past the end panics where it is past the last packet;
    /// within the last packet only debug builds check it.)
    #[inline(always)]
    pub fn at(&self, lane: usize) -> Vec3 {
        debug_assert!(lane < self.len, "lane {lane} of {}", self.len);
        self::lane(&self.packets[lane / PACKET], lane % PACKET)
    }

    /// Writes the vector of `lane` (checked as [`Vec3s::at`] is).
    #[inline(always)]
    pub fn set(&mut self, lane: usize, v: Vec3) {
        debug_assert!(lane < self.len, "lane {lane} of {}", self.len);
        let (p, k) = (&mut self.packets[lane / PACKET], lane % PACKET);
        (p[0][k], p[1][k], p[2][k]) = (v.x, v.y, v.z);
    }

    /// Appends one lane.
    #[inline(always)]
    pub fn push(&mut self, v: Vec3) {
        let k = self.len % PACKET;
        if k == 0 {
            self.packets.push([[v.x; PACKET], [v.y; PACKET], [v.z; PACKET]]);
        } else {
            let p = &mut self.packets[self.len / PACKET];
            (p[0][k], p[1][k], p[2][k]) = (v.x, v.y, v.z);
        }
        self.len += 1;
    }

    /// Appends the first `lanes` lanes of `packet` (1 to [`PACKET`]) to a column that ends at a
    /// packet's end.
    #[inline]
    pub fn push_packet(&mut self, packet: &Packet, lanes: usize) {
        assert!(self.len.is_multiple_of(PACKET) && (1..=PACKET).contains(&lanes), "{lanes} lanes after {}", self.len);
        self.packets.push(*packet);
        self.len += lanes;
    }

    /// Removes every lane, keeping the capacity.
    pub fn clear(&mut self) {
        self.packets.clear();
        self.len = 0;
    }

    /// Makes the column `n` lanes long, new lanes `v`.
    pub fn resize(&mut self, n: usize, v: Vec3) {
        if n <= self.len {
            self.packets.truncate(n.div_ceil(PACKET));
            self.len = n;
            return;
        }
        while !self.len.is_multiple_of(PACKET) && self.len < n {
            self.push(v);
        }
        let whole = [[v.x; PACKET], [v.y; PACKET], [v.z; PACKET]];
        self.packets.resize(n.div_ceil(PACKET), whole);
        self.len = n;
    }

    /// Sets every lane to `v`.
    pub fn fill(&mut self, v: Vec3) {
        self.packets.fill([[v.x; PACKET], [v.y; PACKET], [v.z; PACKET]]);
    }

    /// Appends `src`'s lanes `range`: packet by packet where both sides start a packet.
    pub fn extend_from(&mut self, src: &Vec3s, range: std::ops::Range<usize>) {
        assert!(range.end <= src.len, "lanes {range:?} of {}", src.len);
        if self.len.is_multiple_of(PACKET) && range.start.is_multiple_of(PACKET) {
            let packets = &src.packets[range.start / PACKET..range.end.div_ceil(PACKET)];
            self.packets.extend_from_slice(packets);
            self.len += range.len();
        } else {
            for lane in range {
                self.push(src.at(lane));
            }
        }
    }

    /// The packets: lane `l` is `packets()[l / PACKET][axis][l % PACKET]`.
    #[inline]
    pub fn packets(&self) -> &[Packet] {
        &self.packets
    }

    /// The packets, to write eight lanes at once (lanes past [`Vec3s::len`] mean nothing).
    #[inline]
    pub fn packets_mut(&mut self) -> &mut [Packet] {
        &mut self.packets
    }

    /// Every lane, in order.
    pub fn iter(&self) -> impl Iterator<Item = Vec3> + '_ {
        (0..self.len).map(|lane| self.at(lane))
    }
}

/// The rays of a chunk, one entry per lane.
#[derive(Clone, Debug, Default)]
pub struct Rays {
    /// Ray origins.
    pub origin: Vec3s,
    /// An object index the ray ignores (the convex object it leaves), or `u32::MAX`.
    pub skip: Vec<u32>,
    /// Unit directions.
    pub dir: Vec3s,
    /// Throughput: what this ray's colour is multiplied by before it reaches its pixel.
    pub weight: Vec3s,
    /// Pixel index inside the tile.
    pub pixel: Vec<u32>,
    /// Recursion depth (0 for camera rays).
    pub depth: Vec<u8>,
    /// Which image (layer index) receives this ray's contributions; [`CREDIT_OWN`] for camera rays.
    pub credit: Vec<u16>,
    /// The transparent objects the ray is inside ([`Media`]).
    pub media: Vec<Media>,
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
            origin: Vec3s::with_capacity(n),
            skip: Vec::with_capacity(n),
            dir: Vec3s::with_capacity(n),
            weight: Vec3s::with_capacity(n),
            pixel: Vec::with_capacity(n),
            depth: Vec::with_capacity(n),
            credit: Vec::with_capacity(n),
            media: Vec::with_capacity(n),
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
        self.media.clear();
    }

    /// Replaces the lanes with `src`'s lanes `range`, reusing this chunk's capacity.
    pub fn copy_from(&mut self, src: &Rays, range: std::ops::Range<usize>) {
        self.clear();
        self.origin.extend_from(&src.origin, range.clone());
        self.skip.extend_from_slice(&src.skip[range.clone()]);
        self.dir.extend_from(&src.dir, range.clone());
        self.weight.extend_from(&src.weight, range.clone());
        self.pixel.extend_from_slice(&src.pixel[range.clone()]);
        self.depth.extend_from_slice(&src.depth[range.clone()]);
        self.credit.extend_from_slice(&src.credit[range.clone()]);
        self.media.extend_from_slice(&src.media[range]);
    }

    /// Appends one lane.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn push(
        &mut self,
        origin: Vec3,
        skip: u32,
        dir: Vec3,
        weight: Vec3,
        pixel: u32,
        depth: u8,
        credit: u16,
        media: Media,
    ) {
        // The three vector columns are as long as each other: where the lane goes is worked out
        // once for all three.
        let len = self.origin.len;
        assert!(self.dir.len == len && self.weight.len == len, "vector columns of different lengths");
        let k = len % PACKET;
        let columns = [(&mut self.origin, origin), (&mut self.dir, dir), (&mut self.weight, weight)];
        for (column, v) in columns {
            if k == 0 {
                column.packets.push([[v.x; PACKET], [v.y; PACKET], [v.z; PACKET]]);
            } else {
                let p = &mut column.packets[len / PACKET];
                (p[0][k], p[1][k], p[2][k]) = (v.x, v.y, v.z);
            }
            column.len = len + 1;
        }
        self.skip.push(skip);
        self.pixel.push(pixel);
        self.depth.push(depth);
        self.credit.push(credit);
        self.media.push(media);
    }
}

/// Closest hits of a chunk's rays, one entry per lane (written by the trace system; a lane's columns
/// other than `object` mean something only where it hit).
#[derive(Clone, Debug, Default)]
pub struct Hits {
    /// Distance along the ray.
    pub t: Vec<f32>,
    /// Hit point in world space.
    pub point: Vec3s,
    /// Hit point in the object's own space (for patterns and texture coordinates).
    pub local: Vec<Vec3>,
    /// Texture coordinates interpolated from a mesh's vertices (zero for other shapes, whose
    /// coordinates follow from `local`).
    pub uv: Vec<glam::Vec2>,
    /// Unit outward geometric normal (the side the shape calls outside): decides front and back
    /// and where secondary rays start.
    pub normal: Vec3s,
    /// Unit outward shading normal: interpolated from the vertex normals on smooth meshes (on
    /// the geometric normal's side), else the geometric normal. Terms shade with it.
    pub shading: Vec3s,
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
    pub color: Vec3s,
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
    #[inline(always)]
    pub fn facing_normal(&self, lane: usize) -> Vec3 {
        if self.front[lane] { self.shading.at(lane) } else { -self.shading.at(lane) }
    }
}

/// Light arriving at each lane's hit from each light: a packet column per light (written by the
/// visibility system).
#[derive(Clone, Debug, Default)]
pub struct LightSamples {
    /// Number of lights (the length of `w` and of `incoming`).
    pub lights: usize,
    /// Per light (in scene order), each lane's unit direction from its hit towards the light
    /// (`w`).
    pub w: Vec<Vec3s>,
    /// Per light, the light colour reaching each lane's hit: `Col_L` times the shadow model's
    /// transmittance; zero when the light is hidden, behind the surface (`N·w <= 0`), or the
    /// lane has no hit.
    pub incoming: Vec<Vec3s>,
}

impl LightSamples {
    /// Makes these columns `lanes` lanes of darkness for `lights` lights, reusing their capacity.
    pub fn reset(&mut self, lanes: usize, lights: usize) {
        self.lights = lights;
        for columns in [&mut self.w, &mut self.incoming] {
            columns.resize_with(lights, Vec3s::default);
            for column in columns.iter_mut() {
                column.clear();
                column.resize(lanes, Vec3::ZERO);
            }
        }
    }

    /// The `(w, incoming)` pairs of one lane, light by light.
    #[inline]
    pub fn lane(&self, lane: usize) -> impl Iterator<Item = (Vec3, Vec3)> + '_ {
        self.w.iter().zip(&self.incoming).map(move |(w, incoming)| (w.at(lane), incoming.at(lane)))
    }
}

#[cfg(test)]
mod tests {
    use super::{Media, PACKET, Vec3, Vec3s};

    fn lane(i: usize) -> Vec3 {
        Vec3::new(i as f32, -(i as f32), 0.5 * i as f32)
    }

    #[test]
    fn a_ray_pushed_whole_lands_where_its_columns_pushed_one_by_one_put_it() {
        // Across several packets and their boundaries: `Rays::push` against each column's own.
        let mut rays = super::Rays::default();
        let (mut origin, mut dir, mut weight) = (Vec3s::default(), Vec3s::default(), Vec3s::default());
        for i in 0..27u32 {
            let v = |k: f32| Vec3::new(i as f32 + k, -(i as f32) * k, 0.5 * k);
            rays.push(v(1.0), i, v(2.0), v(3.0), i * 7, (i % 5) as u8, i as u16, Media::AIR.entering(i));
            origin.push(v(1.0));
            dir.push(v(2.0));
            weight.push(v(3.0));
        }
        assert_eq!((rays.origin.packets(), rays.origin.len()), (origin.packets(), origin.len()));
        assert_eq!((rays.dir.packets(), rays.dir.len()), (dir.packets(), dir.len()));
        assert_eq!((rays.weight.packets(), rays.weight.len()), (weight.packets(), weight.len()));
        assert_eq!((rays.skip[26], rays.pixel[26], rays.depth[26], rays.credit[26]), (26, 182, 1, 26));
        assert_eq!(rays.media[26].innermost(), Some(26));
    }

    #[test]
    fn media_enter_innermost_first_leave_from_anywhere_and_forget_the_outermost() {
        let m = Media::AIR.entering(4).entering(7);
        assert_eq!((m.innermost(), m.iter().collect::<Vec<_>>()), (Some(7), vec![7, 4]));
        assert!(m.contains(4) && m.contains(7) && !m.contains(5));
        // Leaving the outer one of two (overlapping objects) keeps the inner one.
        assert_eq!(m.leaving(4).iter().collect::<Vec<_>>(), vec![7]);
        assert_eq!(m.leaving(7).leaving(4), Media::AIR);
        // Leaving an object the ray is not inside changes nothing.
        assert_eq!(m.leaving(9), m);
        // A fourth level forgets the first object entered.
        let deep = m.entering(1).entering(2);
        assert_eq!(deep.iter().collect::<Vec<_>>(), vec![2, 1, 7]);
        assert_eq!((Media::AIR.innermost(), Media::AIR.contains(u32::MAX)), (None, false));
    }
    #[test]
    fn lanes_keep_their_vectors_across_packets_whatever_the_way_in() {
        let mut v = Vec3s::default();
        for i in 0..29 {
            v.push(lane(i));
        }
        assert_eq!(v.len(), 29);
        assert_eq!(v.packets().len(), 29usize.div_ceil(PACKET));
        assert!(v.iter().enumerate().all(|(i, got)| got == lane(i)));
        // Copies from a packet's start (whole packets) and from inside one (lane by lane),
        // onto an empty column and onto one that ends inside a packet.
        for (range, before) in [(8..29, 0), (3..20, 0), (16..17, 5), (0..29, 3)] {
            let mut w = Vec3s::default();
            for i in 0..before {
                w.push(lane(100 + i));
            }
            w.extend_from(&v, range.clone());
            assert_eq!(w.len(), before + range.len());
            let want: Vec<Vec3> = (0..before).map(|i| lane(100 + i)).chain(range.map(lane)).collect();
            assert_eq!(w.iter().collect::<Vec<_>>(), want);
        }
        // Onto a column that ends at a packet's end: whole packets, lane by lane, a packet.
        let mut w = Vec3s::default();
        (0..8).for_each(|i| w.push(lane(100 + i)));
        w.extend_from(&v, 8..21);
        w.extend_from(&v, 0..3);
        w.push_packet(&[[1.0; PACKET], [2.0; PACKET], [3.0; PACKET]], 5);
        let want: Vec<Vec3> = (0..8)
            .map(|i| lane(100 + i))
            .chain((8..21).map(lane))
            .chain((0..3).map(lane))
            .chain([Vec3::new(1.0, 2.0, 3.0); 5])
            .collect();
        assert_eq!(w.iter().collect::<Vec<_>>(), want);
        // Shrunk inside a packet and grown again: the lanes past the cut are the new value, not
        // what they held.
        w.resize(10, Vec3::ZERO);
        w.resize(12, Vec3::NEG_ONE);
        assert_eq!(w.iter().skip(10).collect::<Vec<_>>(), [Vec3::NEG_ONE; 2]);
        // Growing fills new lanes, shrinking keeps the first ones, `set` writes one lane.
        v.resize(40, Vec3::ONE);
        assert!((0..29).all(|i| v.at(i) == lane(i)) && (29..40).all(|i| v.at(i) == Vec3::ONE));
        v.resize(10, Vec3::ZERO);
        v.set(9, Vec3::X);
        assert_eq!(v.iter().collect::<Vec<_>>(), (0..9).map(lane).chain([Vec3::X]).collect::<Vec<_>>());
        v.fill(Vec3::Y);
        assert!(v.iter().all(|got| got == Vec3::Y) && v.len() == 10);
        v.clear();
        assert!(v.is_empty() && v.packets().is_empty());
    }
}

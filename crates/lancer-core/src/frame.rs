//! The rendered frame: the beauty image and, when kept, one linear float image per term (plus the
//! background seen by camera rays), whose exact sum the beauty image is.

use std::time::Duration;

use glam::Vec3;

/// Name of the layer holding what camera rays that hit nothing see.
pub const BACKGROUND: &str = "background";

/// One per-term image, linear RGB, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Layer {
    /// The term's name (or [`BACKGROUND`]).
    pub name: String,
    /// `width * height` pixels.
    pub pixels: Vec<Vec3>,
}

/// Ray counts of a render (the same for any thread count), and where the time went when asked.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RenderStats {
    /// Rays from the camera.
    pub camera_rays: u64,
    /// Child rays (mirror, refraction), traced from generation 1 on.
    pub secondary_rays: u64,
    /// Shadow rays the shadow model traced (one per light in front of a hit for `hard`; one per
    /// occluder crossed for `transmissive`; per sample for `soft`).
    pub shadow_rays: u64,
    /// The most ray lanes alive at once in one tile's generation: bounded by the size of a wave
    /// of camera rays (and its children), whatever the number of samples per pixel.
    pub peak_lanes: u64,
    /// Child rays queued by each term, in model order (mirror: reflected rays; refraction:
    /// refracted ones).
    pub spawned: Vec<u64>,
    /// The deepest generation traced (0: camera rays only).
    pub max_level: u8,
    /// Pixels supersampled by adaptive anti-aliasing ([`crate::Adaptive`]).
    pub supersampled: u64,
    /// Of the camera rays, those adaptive anti-aliasing traced again for the pixels around a
    /// tile (the neighbours its pixels are compared with).
    pub border_rays: u64,
    /// Time spent in each system, summed over threads (zero unless the render was asked to
    /// time itself).
    pub times: SystemTimes,
}

/// Thread time per system of the render loop.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SystemTimes {
    /// Making camera rays.
    pub camera: Duration,
    /// Closest hits (the trace system).
    pub trace: Duration,
    /// Light visibility (the shadow model's rays).
    pub visibility: Duration,
    /// The background seen by rays that hit nothing.
    pub background: Duration,
    /// Each term, in model order.
    pub terms: Vec<Duration>,
    /// Building and recycling ray chunks between generations, copying tiles into the frame.
    pub chunks: Duration,
}

impl SystemTimes {
    /// Every system together.
    pub fn total(&self) -> Duration {
        self.camera + self.trace + self.visibility + self.background + self.chunks + self.terms.iter().sum::<Duration>()
    }
}

/// `a[i] += b[i]`, growing `a` to `b`'s length.
fn add_each<T: Copy + Default + std::ops::AddAssign>(a: &mut Vec<T>, b: &[T]) {
    if a.len() < b.len() {
        a.resize(b.len(), T::default());
    }
    for (x, y) in a.iter_mut().zip(b) {
        *x += *y;
    }
}

impl RenderStats {
    /// Camera, secondary and shadow rays together.
    pub fn total(&self) -> u64 {
        self.camera_rays + self.secondary_rays + self.shadow_rays
    }
}

impl std::ops::AddAssign for RenderStats {
    fn add_assign(&mut self, o: RenderStats) {
        self.camera_rays += o.camera_rays;
        self.secondary_rays += o.secondary_rays;
        self.shadow_rays += o.shadow_rays;
        self.peak_lanes = self.peak_lanes.max(o.peak_lanes);
        add_each(&mut self.spawned, &o.spawned);
        self.max_level = self.max_level.max(o.max_level);
        self.supersampled += o.supersampled;
        self.border_rays += o.border_rays;
        let (t, u) = (&mut self.times, &o.times);
        t.camera += u.camera;
        t.trace += u.trace;
        t.visibility += u.visibility;
        t.background += u.background;
        t.chunks += u.chunks;
        add_each(&mut t.terms, &u.terms);
    }
}

/// A rendered frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The terms' images in model order, then the background layer; empty when the render was
    /// not asked to keep them (`RenderOptions::layers` of the shading crate).
    pub layers: Vec<Layer>,
    /// The beauty image: the sum of every layer, in layer order, in linear float.
    pub beauty: Vec<Vec3>,
    /// How many rays the render traced.
    pub stats: RenderStats,
}

impl Frame {
    /// A frame of these layers, with the beauty image summed from them.
    pub fn from_layers(width: u32, height: u32, layers: Vec<Layer>, stats: RenderStats) -> Frame {
        let mut beauty: Vec<Vec3> = bytemuck::zeroed_vec((width * height) as usize);
        for layer in &layers {
            for (o, p) in beauty.iter_mut().zip(&layer.pixels) {
                *o += *p;
            }
        }
        Frame { width, height, layers, beauty, stats }
    }

    /// The layer with this name.
    pub fn layer(&self, name: &str) -> Option<&Layer> {
        self.layers.iter().find(|l| l.name == name)
    }
}

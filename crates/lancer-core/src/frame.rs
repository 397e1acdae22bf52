//! The rendered frame: one linear float image per term (plus the background seen by camera rays),
//! whose exact sum is the beauty image.

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

/// Ray counts of a render (the same for any thread count).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
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
    }
}

/// A rendered frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The terms' images in model order, then the background layer.
    pub layers: Vec<Layer>,
    /// How many rays the render traced.
    pub stats: RenderStats,
}

impl Frame {
    /// The beauty image: the sum of every layer, in layer order, in linear float.
    pub fn beauty(&self) -> Vec<Vec3> {
        let mut out: Vec<Vec3> = bytemuck::zeroed_vec((self.width * self.height) as usize);
        for layer in &self.layers {
            for (o, p) in out.iter_mut().zip(&layer.pixels) {
                *o += *p;
            }
        }
        out
    }

    /// The layer with this name.
    pub fn layer(&self, name: &str) -> Option<&Layer> {
        self.layers.iter().find(|l| l.name == name)
    }
}

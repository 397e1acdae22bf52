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

/// A rendered frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The terms' images in model order, then the background layer.
    pub layers: Vec<Layer>,
}

impl Frame {
    /// The beauty image: the sum of every layer, in layer order, in linear float.
    pub fn beauty(&self) -> Vec<Vec3> {
        let mut out = vec![Vec3::ZERO; (self.width * self.height) as usize];
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

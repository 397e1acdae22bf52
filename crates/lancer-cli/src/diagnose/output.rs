//! The output mistakes of the catalogue: what a student's image writer gets wrong after the
//! render is right (the sRGB curve left out, the rows upside down, the channels in BGR order),
//! as transforms of the linear image. `lancer render --output-mistake NAME` writes an image
//! through one, `lancer diagnose` tries each.

use glam::Vec3;
use lancer_core::{Frame, srgb_decode};

/// A mistake of the image writer, named `output:NAME` in the catalogue.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum OutputMistake {
    /// Linear values written as if they were sRGB (no sRGB curve): too dark.
    Gamma,
    /// Rows written bottom to top: upside down.
    Flipped,
    /// Channels written blue, green, red.
    Bgr,
}

impl OutputMistake {
    /// Every output mistake, in the catalogue's order.
    pub(crate) const ALL: [OutputMistake; 3] = [OutputMistake::Gamma, OutputMistake::Flipped, OutputMistake::Bgr];

    /// Its name after `output:`, as `--output-mistake` takes it.
    pub(crate) fn name(self) -> &'static str {
        match self {
            OutputMistake::Gamma => "gamma",
            OutputMistake::Flipped => "flipped",
            OutputMistake::Bgr => "bgr",
        }
    }

    /// What it is, in one line.
    pub(crate) fn summary(self) -> &'static str {
        match self {
            OutputMistake::Gamma => {
                "linear values written to the file as if they were sRGB (no sRGB curve): the image is too dark, its shadows crushed"
            }
            OutputMistake::Flipped => "rows written bottom to top: the image is upside down",
            OutputMistake::Bgr => "channels written blue, green, red: red and blue swapped",
        }
    }

    /// What to check in the code.
    pub(crate) fn hint(self) -> &'static str {
        match self {
            OutputMistake::Gamma => {
                "encode each channel with the sRGB curve before writing it in 8 bits: 12.92·c for c ≤ 0.0031308, else 1.055·c^(1/2.4) − 0.055, then round(255·value)"
            }
            OutputMistake::Flipped => {
                "write the rows from the top of the image down: row 0 of the file is the top of the screen, and the camera's vertical axis points up while image rows go down"
            }
            OutputMistake::Bgr => "write each pixel's channels in the order red, green, blue",
        }
    }

    /// The linear image a writer with this mistake gives for `pixels` (`width` × `height`, row 0
    /// at the top), as a viewer sees it back: for `gamma`, each channel `c` (clamped to [0, 1])
    /// written where its sRGB encoding belongs, so seen as `srgb_decode(c)`.
    pub(crate) fn apply(self, width: u32, pixels: &mut [Vec3]) {
        match self {
            OutputMistake::Gamma => {
                for p in pixels.iter_mut() {
                    *p = Vec3::from_array(
                        p.to_array().map(|c| srgb_decode(if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) })),
                    );
                }
            }
            OutputMistake::Flipped => {
                let w = width.max(1) as usize;
                let rows = pixels.len() / w;
                for y in 0..rows / 2 {
                    let (top, bottom) = pixels.split_at_mut((rows - 1 - y) * w);
                    top[y * w..(y + 1) * w].swap_with_slice(&mut bottom[..w]);
                }
            }
            OutputMistake::Bgr => {
                for p in pixels.iter_mut() {
                    *p = Vec3::new(p.z, p.y, p.x);
                }
            }
        }
    }

    /// [`OutputMistake::apply`] to the beauty image and every layer of `frame`.
    pub(crate) fn apply_to_frame(self, frame: &mut Frame) {
        self.apply(frame.width, &mut frame.beauty);
        for layer in &mut frame.layers {
            self.apply(frame.width, &mut layer.pixels);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(w: u32, h: u32) -> Vec<Vec3> {
        (0..w * h).map(|i| Vec3::new(i as f32 / 100.0, 0.5, 1.0 - i as f32 / 100.0)).collect()
    }

    #[test]
    fn flipped_reverses_the_rows_and_twice_gives_the_image_back() {
        for (w, h) in [(4, 3), (3, 4), (5, 1), (1, 6)] {
            let mut img = grid(w, h);
            OutputMistake::Flipped.apply(w, &mut img);
            let orig = grid(w, h);
            for y in 0..h {
                for x in 0..w {
                    assert_eq!(img[(y * w + x) as usize], orig[((h - 1 - y) * w + x) as usize], "{w}x{h} at {x},{y}");
                }
            }
            OutputMistake::Flipped.apply(w, &mut img);
            assert_eq!(img, orig);
        }
    }

    #[test]
    fn bgr_swaps_red_and_blue_and_gamma_shows_linear_values_as_encoded_ones() {
        let mut p = vec![Vec3::new(0.1, 0.2, 0.3)];
        OutputMistake::Bgr.apply(1, &mut p);
        assert_eq!(p, [Vec3::new(0.3, 0.2, 0.1)]);
        // A linear 0.5 written as the stored value 0.5 is seen as sRGB 0.5: linear 0.214.
        let mut p = vec![Vec3::new(0.5, 2.0, -1.0)];
        OutputMistake::Gamma.apply(1, &mut p);
        assert!((p[0].x - 0.214_041).abs() < 1e-5 && p[0].y == 1.0 && p[0].z == 0.0, "{:?}", p[0]);
        assert_eq!(OutputMistake::ALL.map(OutputMistake::name), ["gamma", "flipped", "bgr"]);
    }
}

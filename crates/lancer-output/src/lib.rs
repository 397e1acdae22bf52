//! What a render becomes outside the renderer, as bytes and text (no files: the CLI writes them,
//! the studio sends them, the browser build downloads them): PNG and OpenEXR encoders with the
//! sRGB curve ([`encode`]), and a pixel's explanation as text or JSON ([`explain`]).

pub mod encode;
pub mod explain;

pub use encode::{EncodeError, encode_exr, encode_png, srgb_encode, to_srgb8, write_exr, write_png};
pub use explain::Report;

use serde::Serialize;

/// Pairs as a JSON object, in order (a map would sort them).
pub struct Ordered<'a, T>(Vec<(&'a str, T)>);

impl<T: Serialize> Serialize for Ordered<'_, T> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            map.serialize_entry(k, v)?;
        }
        map.end()
    }
}

impl<'a, T> FromIterator<(&'a str, T)> for Ordered<'a, T> {
    fn from_iter<I: IntoIterator<Item = (&'a str, T)>>(iter: I) -> Self {
        Ordered(iter.into_iter().collect())
    }
}

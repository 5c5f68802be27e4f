//! Raster types shared by forest, labelgen and planner: RGB images, label
//! images, confidence images, and the triangulation-angle bins that tie the
//! last two together.
//!
//! Pixel coordinates follow [`crate::camera`]: continuous, top-left corner of
//! the image at (0, 0), the centre of pixel (i, j) at (i + 0.5, j + 0.5).
//!
//! # File formats
//!
//! Both binary formats are little-endian and end with the 64-bit FNV-1a hash
//! ([`crate::binfile`]) of every byte before it, so truncation and bit rot are caught.
//!
//! Label image (`.vplabel`, written by labelgen, read by the forest):
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `VPLABEL\0` |
//! | 4 | format version (u32, currently 1) |
//! | 4 + 4 | width, height (u32) |
//! | width x height | label per pixel, row-major: 0 unlabelled, 1 positive, 2 negative |
//! | 4 x n | triangulation angle (f32, degrees) of each of the n labelled pixels, row-major order |
//! | 8 | FNV-1a 64 of all preceding bytes |
//!
//! Confidence image (`.vpconf`, written by the forest, read by the planner):
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `VPCONF\0\0` |
//! | 4 | format version (u32, currently 1) |
//! | 4 x 3 | image width, image height, grid step (u32) |
//! | 4 | b, number of angle bins (u32) |
//! | 4 x (b + 1) | bin edges in degrees (f32) |
//! | 4 x gw x gh x b | values (f32), grid row-major, bins innermost |
//! | 8 | FNV-1a 64 of all preceding bytes |
//!
//! The grid size (gw, gh) = (ceil(width / step), ceil(height / step)) is
//! derived, not stored.

mod bins;
mod confidence;
mod label;
mod preview;
mod text;

use std::io::{Cursor, Write};
use std::path::Path;

use crate::error::{Result, SceneError};
use crate::fsio::{read_file, write_atomic};

pub use bins::AngleBins;
pub use confidence::ConfidenceImage;
pub use image::RgbImage;
pub use label::{Label, LabelImage};
pub use preview::{confidence_preview, viridis, PreviewLayout, PANEL_WIDTH};
pub use text::{draw_text, text_width, GLYPH_PX};

/// Format version of both binary raster formats.
const FORMAT_VERSION: u32 = 1;

/// Loads an image in any format the `image` crate decodes (PNG, JPEG, TIFF)
/// as 8-bit RGB.
pub fn load_rgb(path: &Path) -> Result<RgbImage> {
    let bytes = read_file(path)?;
    let image_error = |source| SceneError::Image {
        path: path.to_path_buf(),
        source,
    };
    let reader = image::ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| SceneError::io(path, e))?;
    Ok(reader.decode().map_err(image_error)?.to_rgb8())
}

/// Saves an RGB image in the format its extension names, atomically.
pub fn save_rgb(image: &RgbImage, path: &Path) -> Result<()> {
    let image_error = |source| SceneError::Image {
        path: path.to_path_buf(),
        source,
    };
    let format = image::ImageFormat::from_path(path).map_err(image_error)?;
    let mut buf = Cursor::new(Vec::new());
    image.write_to(&mut buf, format).map_err(image_error)?;
    write_atomic(path, |w| w.write_all(buf.get_ref()))
}

/// Encodes an RGB image as PNG bytes; `path` only names the file in errors.
pub fn encode_png(image: &RgbImage, path: &Path) -> Result<Vec<u8>> {
    png_bytes(image, path)
}

/// Encodes an 8-bit grey image as PNG and writes it atomically.
pub(crate) fn save_gray_png(image: &image::GrayImage, path: &Path) -> Result<()> {
    let bytes = png_bytes(image, path)?;
    write_atomic(path, |w| w.write_all(&bytes))
}

/// PNG bytes of an 8-bit image of any pixel type the encoder takes.
fn png_bytes<P>(image: &image::ImageBuffer<P, Vec<u8>>, path: &Path) -> Result<Vec<u8>>
where
    P: image::PixelWithColorType<Subpixel = u8>,
{
    let mut buf = Cursor::new(Vec::new());
    image
        .write_to(&mut buf, image::ImageFormat::Png)
        .map_err(|source| SceneError::Image {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(buf.into_inner())
}

#[cfg(test)]
mod tests;

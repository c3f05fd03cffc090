//! PNG files, written with one encoder wherever the pipeline writes images: colour camera
//! images, and 16-bit depth (1/256 m) and instance ids.

use std::path::Path;

use anyhow::Context as _;
use image::{ImageBuffer, Luma, RgbImage};

/// Writes RGB pixels (`width * height * 3` bytes, rows top to bottom) as a PNG.
///
/// # Errors
/// A buffer of the wrong size, or a file that cannot be written, named.
pub fn write_rgb(path: &Path, rgb: Vec<u8>, (width, height): (usize, usize)) -> anyhow::Result<()> {
    let image = RgbImage::from_raw(dimension(width)?, dimension(height)?, rgb)
        .with_context(|| format!("{}: the pixels are not {width} x {height} RGB", path.display()))?;
    save(path, image.save_with_format(path, image::ImageFormat::Png))
}

/// Writes 16-bit grey values (`width * height`, rows top to bottom) as a PNG.
///
/// # Errors
/// A buffer of the wrong size, or a file that cannot be written, named.
pub fn write_u16(path: &Path, values: Vec<u16>, (width, height): (usize, usize)) -> anyhow::Result<()> {
    let image = ImageBuffer::<Luma<u16>, Vec<u16>>::from_raw(dimension(width)?, dimension(height)?, values)
        .with_context(|| format!("{}: the values are not {width} x {height}", path.display()))?;
    save(path, image.save_with_format(path, image::ImageFormat::Png))
}

/// What saving gave, the file named on failure.
pub(crate) fn save(path: &Path, result: image::ImageResult<()>) -> anyhow::Result<()> {
    result.with_context(|| format!("writing {}", path.display()))
}

fn dimension(pixels: usize) -> anyhow::Result<u32> {
    u32::try_from(pixels).with_context(|| format!("an image {pixels} pixels wide or high"))
}

//! A bag's images as the pixels the layout stores: colour or grey camera images, 16-bit depth
//! in 1/256 m, 16-bit instance ids; errors name the message field at fault.

use std::path::Path;

use image::{DynamicImage, GrayImage, ImageBuffer, Luma, RgbImage};

use super::Role;
use crate::ros2::{CompressedImage, Image};

/// Pixels in the form the layout stores them.
pub(super) enum Pixels {
    Rgb(RgbImage),
    Grey(GrayImage),
    Wide(ImageBuffer<Luma<u16>, Vec<u16>>),
}

impl Pixels {
    pub(super) fn size(&self) -> (u32, u32) {
        match self {
            Self::Rgb(i) => i.dimensions(),
            Self::Grey(i) => i.dimensions(),
            Self::Wide(i) => i.dimensions(),
        }
    }

    pub(super) fn save(&self, path: &Path) -> anyhow::Result<()> {
        let r = match self {
            Self::Rgb(i) => i.save_with_format(path, image::ImageFormat::Png),
            Self::Grey(i) => i.save_with_format(path, image::ImageFormat::Png),
            Self::Wide(i) => i.save_with_format(path, image::ImageFormat::Png),
        };
        crate::png::save(path, r)
    }
}

/// Depth in the layout's units (1/256 m) from millimetres or metres; 0 where unknown.
pub(super) fn depth_units(metres: f64) -> u16 {
    if metres.is_finite() && metres > 0.0 { (metres * 256.0).round().min(65535.0) as u16 } else { 0 }
}

/// A raw image's pixels for `role`; errors name the field.
pub(super) fn raw_pixels(m: &Image, role: Role) -> Result<Pixels, String> {
    let (w, h) = (m.width as usize, m.height as usize);
    ensure_field(w > 0 && h > 0, || {
        format!("fields `width`, `height`: {w} x {h}: expected an image of at least one pixel")
    })?;
    ensure_field(m.width <= MAX_IMAGE_SIDE && m.height <= MAX_IMAGE_SIDE, || {
        format!("fields `width`, `height`: {w} x {h}: expected at most {MAX_IMAGE_SIDE} pixels a side")
    })?;
    let bytes_per_pixel = match m.encoding.as_str() {
        "rgb8" | "bgr8" => 3,
        "rgba8" | "bgra8" => 4,
        "mono8" | "8UC1" => 1,
        "mono16" | "16UC1" => 2,
        "32FC1" => 4,
        e => {
            return Err(format!(
                "field `encoding`: `{e}` is not one of rgb8, bgr8, rgba8, bgra8, mono8, 8UC1, mono16, 16UC1, 32FC1"
            ));
        }
    };
    let step = m.step as usize;
    ensure_field(step >= w * bytes_per_pixel, || {
        format!("field `step`: {step} bytes for {w} pixels of {bytes_per_pixel} bytes")
    })?;
    ensure_field(m.data.len() >= step * h, || {
        format!("field `data`: {} bytes, expected step {step} x height {h} = {}", m.data.len(), step * h)
    })?;
    let row = |y: usize| m.data.get(y * step..y * step + w * bytes_per_pixel).unwrap_or_default();
    let u16_at = |px: &[u8]| {
        let b = [px.first().copied().unwrap_or(0), px.get(1).copied().unwrap_or(0)];
        if m.is_bigendian == 0 { u16::from_le_bytes(b) } else { u16::from_be_bytes(b) }
    };
    let (w32, h32) = (m.width, m.height);
    let wide = |f: &dyn Fn(&[u8]) -> u16| {
        let v: Vec<u16> =
            (0..h).flat_map(|y| row(y).chunks_exact(bytes_per_pixel).map(f).collect::<Vec<_>>()).collect();
        ImageBuffer::from_raw(w32, h32, v).map(Pixels::Wide).ok_or_else(|| "field `data`: too few pixels".to_string())
    };
    match (role, m.encoding.as_str()) {
        (Role::Depth, "16UC1" | "mono16") => wide(&|px| depth_units(f64::from(u16_at(px)) / 1000.0)),
        (Role::Depth, "32FC1") => wide(&|px| {
            let b: [u8; 4] = px.try_into().unwrap_or_default();
            let v = if m.is_bigendian == 0 { f32::from_le_bytes(b) } else { f32::from_be_bytes(b) };
            depth_units(f64::from(v))
        }),
        (Role::Depth, e) => {
            Err(format!("field `encoding`: a depth image must be 16UC1 (mm) or 32FC1 (m), found `{e}`"))
        }
        (Role::Mask, "16UC1" | "mono16") => wide(&|px| u16_at(px)),
        (Role::Mask, "mono8" | "8UC1") => wide(&|px| u16::from(px.first().copied().unwrap_or(0))),
        (Role::Mask, e) => {
            Err(format!("field `encoding`: an instance mask must be mono8, 8UC1, mono16 or 16UC1, found `{e}`"))
        }
        (_, "mono8" | "8UC1") => {
            let v: Vec<u8> = (0..h).flat_map(|y| row(y).to_vec()).collect();
            GrayImage::from_raw(w32, h32, v).map(Pixels::Grey).ok_or_else(|| "field `data`: too few pixels".into())
        }
        (_, e @ ("rgb8" | "bgr8" | "rgba8" | "bgra8")) => {
            let bgr = e.starts_with('b');
            let v: Vec<u8> = (0..h)
                .flat_map(|y| {
                    row(y)
                        .chunks_exact(bytes_per_pixel)
                        .flat_map(|p| {
                            let (r, g, b) = (p.first(), p.get(1), p.get(2));
                            let (r, b) = if bgr { (b, r) } else { (r, b) };
                            [r, g, b].map(|c| c.copied().unwrap_or(0))
                        })
                        .collect::<Vec<_>>()
                })
                .collect();
            RgbImage::from_raw(w32, h32, v).map(Pixels::Rgb).ok_or_else(|| "field `data`: too few pixels".into())
        }
        (_, e) => {
            Err(format!("field `encoding`: a camera image must be rgb8, bgr8, rgba8, bgra8 or mono8, found `{e}`"))
        }
    }
}

pub(super) fn ensure_field(ok: bool, message: impl FnOnce() -> String) -> Result<(), String> {
    if ok { Ok(()) } else { Err(message()) }
}

/// The widest and tallest image this build decodes, pixels: an 8K camera's, with room to spare.
pub const MAX_IMAGE_SIDE: u32 = 8192;

/// The most memory one decoded image may take, bytes (an 8192 x 8192 RGBA image at 16 bits).
const MAX_IMAGE_ALLOC: u64 = 8192 * 8192 * 8;

/// Decodes a PNG or JPEG after its header's size is checked against [`MAX_IMAGE_SIDE`]: a 4 KB
/// file can claim 20000 x 20000 pixels, which would be allocated before anything is refused.
pub(super) fn decode_bounded(bytes: &[u8]) -> image::ImageResult<DynamicImage> {
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    limits.max_alloc = Some(MAX_IMAGE_ALLOC);
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format()?;
    reader.limits(limits);
    reader.decode()
}

/// A compressed image's pixels for `role`; errors name the field.
pub(super) fn compressed_pixels(m: &CompressedImage, role: Role) -> Result<Pixels, String> {
    let format = m.format.to_lowercase();
    if format.contains("compresseddepth") {
        return Err(format!(
            "field `format`: `{}` (compressed_depth_image_transport) is not supported: record depth as sensor_msgs/Image 16UC1 or 32FC1",
            m.format
        ));
    }
    ensure_field(format.contains("png") || format.contains("jpeg") || format.contains("jpg"), || {
        format!("field `format`: `{}`: expected png or jpeg", m.format)
    })?;
    let decoded = decode_bounded(&m.data).map_err(|e| format!("field `data`: not a {} image: {e}", m.format))?;
    ensure_field(decoded.width() > 0 && decoded.height() > 0, || {
        format!("field `data`: a {} x {} image: expected at least one pixel", decoded.width(), decoded.height())
    })?;
    Ok(match role {
        Role::Left | Role::Right => Pixels::Rgb(decoded.to_rgb8()),
        Role::Mask => Pixels::Wide(decoded.to_luma16()),
        Role::Depth => match decoded {
            DynamicImage::ImageLuma16(d) => {
                let (w, h) = d.dimensions();
                let v = d.pixels().map(|p| depth_units(f64::from(p.0[0]) / 1000.0)).collect();
                Pixels::Wide(ImageBuffer::from_raw(w, h, v).ok_or_else(|| "field `data`: too few pixels".to_string())?)
            }
            _ => return Err("field `data`: a compressed depth image must be a 16-bit PNG in millimetres".into()),
        },
    })
}

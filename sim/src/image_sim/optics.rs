//! The camera's optics on a radiance image: the lens's blur and the exposure's gain.

use super::Camera;
use super::texture::hash;
use super::tiles::{TILE_ROWS, in_tiles};

/// One pass of a separable blur of an RGB image of `(w, h)` pixels from `src` into the rows
/// from `y0` that `dst` holds, along rows (`along_rows`) or columns; the border repeats the
/// edge pixel.
fn blur_pass(src: &[f32], dst: &mut [f32], y0: usize, (w, h): (usize, usize), kernel: &[f32], along_rows: bool) {
    let radius = kernel.len() / 2;
    for (dy, row) in dst.chunks_exact_mut(3 * w).enumerate() {
        let y = y0 + dy;
        for x in 0..w {
            for c in 0..3 {
                row[3 * x + c] = kernel
                    .iter()
                    .enumerate()
                    .map(|(k, g)| {
                        let (sx, sy) = if along_rows {
                            ((x + k).saturating_sub(radius).min(w - 1), y)
                        } else {
                            (x, (y + k).saturating_sub(radius).min(h - 1))
                        };
                        g * src[3 * (sy * w + sx) + c]
                    })
                    .sum();
            }
        }
    }
}

/// The lens's blur on a radiance image (RGB, row-major), on `threads` threads.
pub(super) fn apply_optics(rgb: &mut [f32], cam: &Camera, threads: usize) {
    let blur_sigma = cam.optics.blur_sigma;
    let (w, h) = (cam.width, cam.height);
    if blur_sigma > 0.0 {
        let radius = (3.0 * blur_sigma).ceil() as usize;
        let kernel: Vec<f32> = (0..=2 * radius)
            .map(|k| (-((k as f32 - radius as f32).powi(2)) / (2.0 * blur_sigma * blur_sigma)).exp())
            .collect();
        let total: f32 = kernel.iter().sum();
        let kernel: Vec<f32> = kernel.iter().map(|k| k / total).collect();
        // Separable: rows, then columns; the border repeats the edge pixel.
        let tile = (3 * TILE_ROWS * w).max(1);
        let mut tmp = vec![0f32; rgb.len()];
        let src: &[f32] = rgb;
        in_tiles(
            tmp.chunks_mut(tile).enumerate(),
            threads,
            || (),
            |(k, dst), ()| {
                blur_pass(src, dst, k * TILE_ROWS, (w, h), &kernel, true);
            },
        );
        in_tiles(
            rgb.chunks_mut(tile).enumerate(),
            threads,
            || (),
            |(k, dst), ()| {
                blur_pass(&tmp, dst, k * TILE_ROWS, (w, h), &kernel, false);
            },
        );
    }
}

/// The exposure's gain, drawn from the frame seed.
pub(super) fn gain(cam: &Camera, frame_seed: u32) -> f32 {
    1.0 + cam.optics.gain_jitter * (2.0 * (hash(frame_seed ^ 0x6a09_e667) >> 8) as f32 / (1u32 << 24) as f32 - 1.0)
}

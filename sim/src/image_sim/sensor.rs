//! The simulated sensor: a pixel's bytes from its radiance, with deterministic per-pixel noise
//! drawn from the frame seed, then quantised.

use super::Camera;
use super::texture::hash;

/// The sensor: its noise, from the frame seed, and quantisation.
#[derive(Debug, Clone, Copy)]
pub(super) struct Sensor {
    /// Noise amplitude, grey levels.
    noise: i32,
    frame_seed: u32,
    /// The number of noise levels, `2 noise + 1`.
    levels: u32,
    /// `2^64 / levels` rounded up: the remainder by `levels` without a division.
    magic: u64,
}

impl Sensor {
    pub(super) fn new(cam: &Camera, frame_seed: u32) -> Self {
        let levels = if cam.noise > 0 { 2 * cam.noise as u32 + 1 } else { 1 };
        Self { noise: cam.noise, frame_seed, levels, magic: (u64::MAX / u64::from(levels)).wrapping_add(1) }
    }

    /// `a % self.levels`, exactly for every `a` and odd `levels` (Lemire, Kaser and Kurz,
    /// "Faster remainder by direct computation", 2019); a division per pixel costs as much as
    /// the rest of the sensor. The 64 x 64-bit products go in 32 x 32-bit pieces, as vector
    /// registers multiply.
    fn remainder(&self, a: u32) -> u32 {
        const LOW: u64 = 0xffff_ffff;
        let a = u64::from(a);
        let fraction = ((self.magic & LOW) * a).wrapping_add(((self.magic >> 32) * a) << 32);
        let levels = u64::from(self.levels);
        (((fraction >> 32) * levels + (((fraction & LOW) * levels) >> 32)) >> 32) as u32
    }

    /// The noise of pixel `i`, grey levels.
    pub(super) fn noise(&self, i: usize) -> i32 {
        if self.noise > 0 { self.remainder(hash(self.frame_seed ^ hash(i as u32))) as i32 - self.noise } else { 0 }
    }

    /// The bytes of pixel `i` from its radiance: noise, then quantisation.
    pub(super) fn bytes(&self, i: usize, radiance: [f32; 3], out: &mut [u8]) {
        let noise = self.noise(i);
        for (o, x) in out.iter_mut().zip(radiance) {
            *o = (x as i32 + noise).clamp(0, 255) as u8;
        }
    }

    /// [`Sensor::bytes`] of the pixels from `i0` with radiance `radiance` (RGB) into `out`;
    /// `noise` is scratch. The noise of every pixel first, then the bytes: loops without
    /// branches, which the compiler runs over several pixels at a time.
    #[inline(always)]
    pub(super) fn row_bytes(&self, i0: usize, radiance: &[f32], noise: &mut Vec<i32>, out: &mut [u8]) {
        let n = radiance.len() / 3;
        noise.resize(4 * n, 0);
        let (pixel, channel) = noise.split_at_mut(n);
        // Without noise, `levels` is 1 and every remainder 0.
        let amplitude = self.noise.max(0);
        for (k, v) in pixel.iter_mut().enumerate() {
            *v = self.remainder(hash(self.frame_seed ^ hash((i0 + k) as u32))) as i32 - amplitude;
        }
        for (c, v) in channel.chunks_exact_mut(3).zip(pixel.iter()) {
            c.fill(*v);
        }
        let (radiance, out) = (&radiance[..3 * n], &mut out[..3 * n]);
        // NaN counts as tame: `truncate` takes it as the cast does.
        let tame = radiance.iter().fold(true, |tame, x| tame & (x.abs() <= 1024.0 || x.is_nan()));
        if tame && amplitude <= 255 {
            for ((o, &x), &v) in out.iter_mut().zip(radiance).zip(channel.iter()) {
                *o = (truncate(x) + v).clamp(0, 255) as u8;
            }
        } else {
            for ((o, &x), &v) in out.iter_mut().zip(radiance).zip(channel.iter()) {
                *o = (x as i32 + v).clamp(0, 255) as u8;
            }
        }
    }
}

/// `x as i32` for `|x| <= 1024` or NaN, with float arithmetic and bit operations only, which
/// run over several values at a time, unlike the saturating cast: adding 1.5 * 2^23 rounds to
/// the nearest integer, which the low bits of the sum hold, and the comparisons turn rounding
/// into truncation.
#[inline(always)]
pub(super) fn truncate(x: f32) -> i32 {
    const MAGIC: f32 = 12_582_912.0;
    let x = if x.is_nan() { 0.0 } else { x };
    let big = x + MAGIC;
    let nearest = big - MAGIC;
    let rounded = big.to_bits() as i32 - MAGIC.to_bits() as i32;
    rounded - i32::from(x >= 0.0 && nearest > x) + i32::from(x < 0.0 && nearest < x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sensor_remainder_is_the_remainder() {
        let mut a = 1u32;
        for noise in [0, 1, 2, 3, 7, 50, 1000, 1 << 20, i32::MAX] {
            let cam = Camera { noise, ..Camera::kitti(0.1) };
            let sensor = Sensor::new(&cam, 0);
            for edge in [0, 1, u32::MAX, u32::MAX - 1, sensor.levels, sensor.levels - 1, sensor.levels.wrapping_mul(3)]
            {
                assert_eq!(sensor.remainder(edge), edge % sensor.levels, "{edge} % {}", sensor.levels);
            }
            for _ in 0..100_000 {
                a = hash(a);
                assert_eq!(sensor.remainder(a), a % sensor.levels, "{a} % {}", sensor.levels);
            }
        }
    }

    #[test]
    fn the_sensor_gives_a_row_the_bytes_of_its_pixels() {
        let mut a = 7u32;
        let mut tame = vec![0.0f32, -0.0, 0.5, -0.5, 0.9999, -0.9999, 1.0, -1.0, 254.5, 255.0, 255.99, 256.0, 767.5];
        tame.extend([1023.9, 1024.0, -1024.0, f32::NAN, f32::MIN_POSITIVE, -1e-40]);
        for _ in 0..30_000 {
            a = hash(a);
            tame.push((f64::from(a) / f64::from(u32::MAX) * 2048.0 - 1024.0) as f32);
        }
        let wild = [1024.5, -1024.5, 1e9, -1e9, 2.2e9, f32::INFINITY, f32::NEG_INFINITY, 3e38];
        for noise in [0, 1, 2, 255, 256, 1 << 20] {
            let sensor = Sensor::new(&Camera { noise, ..Camera::kitti(0.1) }, 9);
            // A whole row of tame values, then rows with one wild value each (where the cast plus
            // the noise does not overflow).
            let mut rows = vec![tame.clone()];
            for w in
                wild.into_iter().filter(|&w| (w as i32).checked_add(noise).and((w as i32).checked_sub(noise)).is_some())
            {
                let mut row = tame[..300].to_vec();
                row[100] = w;
                rows.push(row);
            }
            for row in &rows {
                let n = row.len() / 3;
                let mut out = vec![0u8; 3 * n];
                sensor.row_bytes(1000, row, &mut Vec::new(), &mut out);
                for k in 0..n {
                    let mut want = [0u8; 3];
                    sensor.bytes(1000 + k, [row[3 * k], row[3 * k + 1], row[3 * k + 2]], &mut want);
                    assert_eq!(out[3 * k..3 * k + 3], want, "{noise} {:?}", &row[3 * k..3 * k + 3]);
                }
            }
        }
    }
}

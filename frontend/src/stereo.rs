//! Depth from a rectified stereo pair with OpenCV's semi-global matcher, and the KITTI D1
//! disparity error.
//!
//! # Parameters ([`StereoParams::kitti`])
//!
//! | parameter | value | why |
//! |---|---|---|
//! | mode | `SGBM_3WAY` | OpenCV's fastest SGBM variant (3 paths instead of 5/8); measured in docs/results.md |
//! | block size | 5 | small enough for thin structures, large enough for KITTI's noise |
//! | P1, P2 | 8 x 5^2 = 200, 32 x 5^2 = 800 | OpenCV's recommended smoothness penalties for one channel |
//! | disparities | 128 at full resolution | KITTI: `f b` = 387.6 px m, so 128 px reaches 3 m |
//! | uniqueness | 10 % | rejects ambiguous matches (repeated texture, sky) |
//! | left-right check | 1 px | rejects occlusions |
//! | speckle filter | window 100 px, range 2 px | removes small islands of wrong disparity |
//! | pre-filter cap | 63 | OpenCV default (clips the x-derivative pre-filter) |
//! | downscale | 1 (full resolution) or 2 | at 2 the matcher runs on half-size images with 64 disparities, about 4x faster; disparities are then multiplied by 2 |
//!
//! Disparity `d` gives depth `f b / d`; pixels the matcher leaves invalid have no depth.

use opencv::calib3d::{StereoSGBM, StereoSGBM_MODE_SGBM_3WAY};
use opencv::core::{CV_32F, Mat, Size};
use opencv::prelude::*;

use super::error::{FrontEndError, cv};

/// Parameters of the stereo stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StereoParams {
    /// Disparity search range at full resolution, pixels (a multiple of 16 x downscale).
    pub num_disparities: i32,
    /// Matching block size, pixels (odd).
    pub block_size: i32,
    /// Uniqueness margin, percent.
    pub uniqueness: i32,
    /// Images are shrunk by this factor (1 or 2) before matching.
    pub downscale: i32,
    /// Where the masks need no depth, no dense map at all: each sent point is matched along its
    /// row over the same range ([`crate::subpixel::match_along_row`]).
    pub row_match: bool,
}

impl StereoParams {
    /// The values of the table above, at full resolution.
    #[must_use]
    pub const fn kitti() -> Self {
        Self { num_disparities: 128, block_size: 5, uniqueness: 10, downscale: 1, row_match: false }
    }

    /// [`StereoParams::kitti`] for images scaled by `scale`: the disparity range scales with
    /// the image (128 at full resolution reaches 3 m), in multiples of 16.
    #[must_use]
    pub fn kitti_at_scale(scale: f64) -> Self {
        Self { num_disparities: ((128.0 * scale / 16.0).ceil() as i32 * 16).max(16), ..Self::kitti() }
    }
}

/// A dense disparity map (full-resolution pixels; 0 or less: no match).
#[derive(Debug, Clone)]
pub struct DisparityMap {
    /// Disparity per pixel of the (possibly shrunk) left image, `f32`, in full-resolution
    /// pixels.
    pub disparity: Mat,
    /// The shrink factor between the full image and `disparity`.
    pub downscale: i32,
}

impl DisparityMap {
    /// The disparity at full-resolution pixel `(u, v)`, if the matcher found one.
    #[must_use]
    pub fn at(&self, u: f32, v: f32) -> Option<f32> {
        let s = self.downscale.max(1) as f32;
        let (x, y) = ((u / s).round() as i32, (v / s).round() as i32);
        if x < 0 || y < 0 || x >= self.disparity.cols() || y >= self.disparity.rows() {
            return None;
        }
        let d = *self.disparity.at_2d::<f32>(y, x).ok()?;
        (d.is_finite() && d > 0.0).then_some(d)
    }

    /// The median disparity of the map's pixels whose centres lie within `radius` full-resolution
    /// pixels of `(u, v)` (per axis) and whose whole footprint at full resolution `keep` accepts;
    /// `None` without such a pixel. Near a mask's edge the nearest pixel of a downscaled map often
    /// straddles the edge and carries the other surface's disparity.
    #[must_use]
    pub fn median_within(&self, u: f32, v: f32, radius: f32, keep: impl Fn(i64, i64) -> bool) -> Option<f32> {
        let s = self.downscale.max(1);
        let sf = s as f32;
        // Map pixel x covers full-resolution pixels s x .. s x + s - 1, centre s x + (s - 1) / 2.
        let c = (sf - 1.0) / 2.0;
        let range = |p: f32, len: i32| {
            let lo = ((p - radius - c) / sf).ceil().max(0.0) as i32;
            let hi = ((p + radius - c) / sf).floor().min(len as f32 - 1.0) as i32;
            lo..=hi
        };
        let mut found = Vec::new();
        for y in range(v, self.disparity.rows()) {
            let Ok(row) = self.disparity.at_row::<f32>(y) else { continue };
            for x in range(u, self.disparity.cols()) {
                let Some(&d) = row.get(x as usize) else { continue };
                if !(d.is_finite() && d > 0.0) {
                    continue;
                }
                let (x0, y0) = (i64::from(x * s), i64::from(y * s));
                let s = i64::from(s);
                if (0..s).all(|dy| (0..s).all(|dx| keep(x0 + dx, y0 + dy))) {
                    found.push(d);
                }
            }
        }
        found.sort_by(f32::total_cmp);
        let m = found.len() / 2;
        match found.len() {
            0 => None,
            n if n % 2 == 1 => found.get(m).copied(),
            _ => Some(0.5 * (found.get(m - 1)? + found.get(m)?)),
        }
    }
}

/// The semi-global matcher of [`StereoParams`].
pub struct Stereo {
    matcher: opencv::core::Ptr<StereoSGBM>,
    params: StereoParams,
}

impl std::fmt::Debug for Stereo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Stereo").field("params", &self.params).finish_non_exhaustive()
    }
}

impl Stereo {
    /// A matcher with `params`.
    ///
    /// # Errors
    /// OpenCV refusing the parameters.
    pub fn new(params: StereoParams) -> Result<Self, FrontEndError> {
        let s = params.downscale.clamp(1, 2);
        let nd = (params.num_disparities / s).max(16) / 16 * 16;
        let bs = params.block_size | 1;
        let area = bs * bs;
        let matcher = StereoSGBM::create(
            0,
            nd,
            bs,
            8 * area,
            32 * area,
            1,
            63,
            params.uniqueness,
            100,
            2,
            StereoSGBM_MODE_SGBM_3WAY,
        )
        .map_err(cv("creating StereoSGBM"))?;
        Ok(Self { matcher, params: StereoParams { downscale: s, ..params } })
    }

    /// The shrink factor it matches at (1 or 2).
    #[must_use]
    pub const fn downscale(&self) -> i32 {
        self.params.downscale
    }

    /// The row search that replaces the dense map where the masks need no depth, if asked for.
    #[must_use]
    pub const fn row_search(&self) -> Option<crate::subpixel::RowSearch> {
        if self.params.row_match { Some(crate::subpixel::RowSearch::up_to(self.params.num_disparities)) } else { None }
    }

    /// The disparity map of a rectified grey pair of equal size.
    ///
    /// # Errors
    /// An OpenCV failure.
    pub fn disparity(&mut self, left: &Mat, right: &Mat) -> Result<DisparityMap, FrontEndError> {
        let s = self.params.downscale;
        let (l, r) = if s > 1 {
            let half = |m: &Mat| -> Result<Mat, FrontEndError> {
                let mut out = Mat::default();
                opencv::imgproc::resize(
                    m,
                    &mut out,
                    Size::new(m.cols() / s, m.rows() / s),
                    0.0,
                    0.0,
                    opencv::imgproc::INTER_AREA,
                )
                .map_err(cv("shrinking a stereo image"))?;
                Ok(out)
            };
            (half(left)?, half(right)?)
        } else {
            (left.clone(), right.clone())
        };
        let mut fixed = Mat::default();
        self.matcher.compute(&l, &r, &mut fixed).map_err(cv("StereoSGBM::compute"))?;
        // SGBM returns 16 x disparity in i16 (invalid: negative); scale to full-res pixels.
        let mut disparity = Mat::default();
        fixed.convert_to(&mut disparity, CV_32F, f64::from(s) / 16.0, 0.0).map_err(cv("converting disparity"))?;
        Ok(DisparityMap { disparity, downscale: s })
    }
}

/// KITTI's D1 error of an estimate against a ground-truth disparity image (uint16, value/256
/// px, 0 = no ground truth).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct D1 {
    /// Pixels with ground truth.
    pub pixels: usize,
    /// Of those, pixels off by more than 3 px and 5 % (or with no estimate).
    pub bad: usize,
    /// Of those, pixels the matcher left without a disparity.
    pub missing: usize,
}

impl D1 {
    /// Share of bad pixels (KITTI's D1-all when run over all pixels).
    #[must_use]
    pub fn share(&self) -> f64 {
        if self.pixels == 0 { 0.0 } else { self.bad as f64 / self.pixels as f64 }
    }

    /// Share of ground-truth pixels with an estimate.
    #[must_use]
    pub fn density(&self) -> f64 {
        if self.pixels == 0 { 0.0 } else { 1.0 - self.missing as f64 / self.pixels as f64 }
    }
}

/// D1 of `est` against `truth` (a KITTI uint16 disparity image of the same full size). Pixels
/// without an estimate count as bad: KITTI's devkit instead fills them by interpolation, so this
/// is the stricter figure; [`D1::density`] says how many there were.
///
/// # Errors
/// An OpenCV failure reading the truth.
pub fn d1_error(est: &DisparityMap, truth: &Mat) -> Result<D1, FrontEndError> {
    let mut out = D1 { pixels: 0, bad: 0, missing: 0 };
    for v in 0..truth.rows() {
        let row = truth.at_row::<u16>(v).map_err(cv("reading ground-truth disparity"))?;
        for (u, &g) in row.iter().enumerate() {
            if g == 0 {
                continue;
            }
            out.pixels += 1;
            let gt = f32::from(g) / 256.0;
            match est.at(u as f32, v as f32) {
                Some(d) => {
                    let e = (d - gt).abs();
                    if e > 3.0 && e > 0.05 * gt {
                        out.bad += 1;
                    }
                }
                None => {
                    out.bad += 1;
                    out.missing += 1;
                }
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use opencv::core::Scalar;

    #[test]
    fn the_median_over_the_instance_leaves_out_map_pixels_straddling_its_edge() {
        // A half-size map, 10 x 6: the other surface's 30 px up to map column 4 (image columns
        // 0-9), the instance's 8 px beyond; the instance starts at image column 9.
        let mut m = Mat::new_rows_cols_with_default(6, 10, CV_32F, Scalar::all(8.0)).unwrap();
        for y in 0..6 {
            for x in 0..5 {
                *m.at_2d_mut::<f32>(y, x).unwrap() = 30.0;
            }
        }
        let map = DisparityMap { disparity: m, downscale: 2 };
        let own = |x: i64, _: i64| x >= 9;
        assert_eq!(map.at(8.6, 5.0), Some(30.0));
        assert_eq!(map.median_within(8.6, 5.0, 3.0, own), Some(8.0));
        assert_eq!(map.median_within(8.6, 5.0, 3.0, |_, _| false), None);
        // Without the instance, the median over the window: columns 3-5 of three rows, 30 twice.
        assert_eq!(map.median_within(8.6, 5.0, 3.0, |_, _| true), Some(30.0));
    }
}

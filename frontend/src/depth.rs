//! Per-pixel depth for the front-end: from a stereo disparity map, or from a given depth map
//! (an RGB-D sensor, or the simulator's exact depth).

use opencv::core::{CV_32F, Mat};
use opencv::prelude::*;

use super::error::{FrontEndError, cv};
use super::stereo::DisparityMap;
use super::subpixel::{
    GreyView, Refused, RowSearch, SubpixelParams, match_along_row, refine_disparity, refine_from_coarse_start,
};

/// Where a frame's depth comes from.
#[derive(Debug, Clone)]
pub enum DepthMap {
    /// Stereo: depth = `fb / disparity`.
    Stereo {
        /// The disparity map.
        disparity: DisparityMap,
        /// Baseline x focal length, pixel metres.
        fb: f32,
        /// The rectified grey pair the map was computed from, for sub-pixel refinement at
        /// points (`None`: the map alone).
        pair: Option<(Mat, Mat)>,
    },
    /// Stereo without a dense map: each point's disparity is searched for along its row
    /// ([`match_along_row`]); no depth at other pixels.
    Rows {
        /// Baseline x focal length, pixel metres.
        fb: f32,
        /// The rectified grey pair.
        pair: (Mat, Mat),
        /// The disparities searched.
        search: RowSearch,
    },
    /// A depth map in metres (`f32`; 0 = unknown).
    Given(Mat),
}

impl DepthMap {
    /// A given depth map from a KITTI-style 16-bit PNG (value / 256 = metres, 0 = unknown).
    ///
    /// # Errors
    /// An OpenCV failure.
    pub fn from_u16_png(m: &Mat) -> Result<Self, FrontEndError> {
        let mut out = Mat::default();
        m.convert_to(&mut out, CV_32F, 1.0 / 256.0, 0.0).map_err(cv("converting a depth map"))?;
        Ok(Self::Given(out))
    }

    /// Depth at full-resolution pixel `(u, v)`, metres, if known.
    #[must_use]
    pub fn at(&self, u: f32, v: f32) -> Option<f32> {
        match self {
            Self::Stereo { disparity, fb, .. } => disparity.at(u, v).map(|d| fb / d),
            Self::Rows { .. } => None,
            Self::Given(m) => {
                let (x, y) = (u.round() as i32, v.round() as i32);
                if x < 0 || y < 0 || x >= m.cols() || y >= m.rows() {
                    return None;
                }
                let z = *m.at_2d::<f32>(y, x).ok()?;
                (z.is_finite() && z > 0.0).then_some(z)
            }
        }
    }

    /// Depth at a tracked point `(u, v)`, metres, and how it was found: with stereo and
    /// `params`, the dense map's disparity refined to sub-pixel by [`refine_disparity`] over the
    /// patch pixels that `same_instance` accepts; the dense value where the patch is too flat or
    /// small to refine; nothing, or the dense value without
    /// [`SubpixelParams::drop_refused`], where the refinement was refused. From a downscaled
    /// map, the start is the median over the instance ([`DisparityMap::median_within`]), the
    /// refinement is [`refine_from_coarse_start`] and a patch too small to refine counts as
    /// refused. Without a dense map ([`Self::Rows`]), [`match_along_row`] (with `params`, or
    /// the defaults), and nothing where it finds nothing. Otherwise (a given depth map, no parameters, no dense value) as [`Self::at`].
    pub fn at_point(
        &self,
        u: f32,
        v: f32,
        same_instance: impl Fn(i64, i64) -> bool,
        params: Option<&SubpixelParams>,
    ) -> (Option<f32>, PointDepthOutcome) {
        let dense = || (self.at(u, v), PointDepthOutcome::Dense);
        if let Self::Rows { fb, pair: (left, right), search } = self {
            let (Some(l), Some(r)) = (grey_view(left), grey_view(right)) else {
                return (None, PointDepthOutcome::Refused);
            };
            let defaults = SubpixelParams::default();
            return match match_along_row(&l, &r, u, v, same_instance, params.unwrap_or(&defaults), search) {
                Ok(d) => ((d > 0.0).then(|| fb / d), PointDepthOutcome::Refined),
                Err(_) => (None, PointDepthOutcome::Refused),
            };
        }
        let Self::Stereo { disparity, fb, pair: Some((left, right)) } = self else { return dense() };
        let (Some(p), Some(start)) = (params, disparity.at(u, v)) else { return dense() };
        let (Some(l), Some(r)) = (grey_view(left), grey_view(right)) else { return dense() };
        if disparity.downscale > 1 {
            let start = disparity.median_within(u, v, p.coarse.radius_px, &same_instance).unwrap_or(start);
            return match refine_from_coarse_start(&l, &r, u, v, start, same_instance, p) {
                Ok(d) => ((d > 0.0).then(|| fb / d), PointDepthOutcome::Refined),
                Err(Refused::Flat) => (Some(fb / start), PointDepthOutcome::KeptDense),
                // A patch too small is mostly a sliver of the instance (too few of its pixels the
                // point's own), narrower than what a downscaled map resolves, so the map's value
                // there is the neighbouring surface's as often as not.
                Err(Refused::SmallPatch | Refused::Diverged | Refused::Mismatch) => {
                    ((!p.drop_refused).then(|| fb / start), PointDepthOutcome::Refused)
                }
            };
        }
        match refine_disparity(&l, &r, u, v, start, same_instance, p) {
            Ok(d) => ((d > 0.0).then(|| fb / d), PointDepthOutcome::Refined),
            Err(Refused::Flat | Refused::SmallPatch) => (Some(fb / start), PointDepthOutcome::KeptDense),
            Err(Refused::Diverged | Refused::Mismatch) => {
                ((!p.drop_refused).then(|| fb / start), PointDepthOutcome::Refused)
            }
        }
    }
}

/// How [`DepthMap::at_point`] found a point's depth.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PointDepthOutcome {
    /// The map's value, no refinement asked for or possible.
    Dense,
    /// Refined to sub-pixel.
    Refined,
    /// The dense value: the patch was too flat or small to refine (from a downscaled map: too
    /// flat).
    KeptDense,
    /// The refinement was refused (diverged or mismatched; from a downscaled map also a patch
    /// too small).
    Refused,
}

/// A continuous 8-bit single-channel `Mat` as a [`GreyView`].
fn grey_view(m: &Mat) -> Option<GreyView<'_>> {
    if m.typ() != opencv::core::CV_8UC1 || !m.is_continuous() {
        return None;
    }
    let (width, height) = (usize::try_from(m.cols()).ok()?, usize::try_from(m.rows()).ok()?);
    Some(GreyView { data: m.data_bytes().ok()?, width, height })
}

//! Per-pixel depth for the front-end: from a stereo disparity map, or from a given depth map
//! (an RGB-D sensor, or the simulator's exact depth).

use opencv::core::{CV_32F, Mat};
use opencv::prelude::*;

use super::error::{FrontEndError, cv};
use super::stereo::DisparityMap;

/// Where a frame's depth comes from.
#[derive(Debug, Clone)]
pub enum DepthMap {
    /// Stereo: depth = `fb / disparity`.
    Stereo {
        /// The disparity map.
        disparity: DisparityMap,
        /// Baseline x focal length, pixel metres.
        fb: f32,
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
            Self::Stereo { disparity, fb } => disparity.at(u, v).map(|d| fb / d),
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
}

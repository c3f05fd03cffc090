//! Pyramidal Lucas-Kanade tracking with a forward-backward check (Kalal et al. 2010): a point is
//! kept only when tracking it back from the new frame lands within `fb_max_px` of where it
//! started, which rejects most drift onto occluding edges and repeated texture.

use opencv::core::{Mat, Point2f, Size, TermCriteria, TermCriteria_COUNT, TermCriteria_EPS, Vector};
use opencv::prelude::*;
use opencv::video::{build_optical_flow_pyramid, calc_optical_flow_pyr_lk};

use super::error::{FrontEndError, cv};

/// KLT parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KltParams {
    /// Search window side, pixels.
    pub window: i32,
    /// Pyramid levels above the image (3: motions up to about 8 x window / 2 pixels).
    pub levels: i32,
    /// Iterations per level.
    pub iterations: i32,
    /// Forward-backward tolerance, pixels.
    pub fb_max_px: f32,
}

impl Default for KltParams {
    fn default() -> Self {
        Self { window: 21, levels: 3, iterations: 30, fb_max_px: 1.0 }
    }
}

/// What became of one tracked point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Tracked {
    /// Found, at this position.
    At(Point2f),
    /// The tracker lost it (or it left the image).
    Lost,
    /// Found, but the backward track did not come back.
    FailedCheck,
}

/// An image pyramid built once per frame and reused by the forward and backward passes.
#[derive(Debug)]
pub struct Pyramid {
    levels: Vector<Mat>,
    size: Size,
}

impl Pyramid {
    /// The pyramid of `grey` for `p`.
    ///
    /// # Errors
    /// An OpenCV failure.
    pub fn new(grey: &Mat, p: &KltParams) -> Result<Self, FrontEndError> {
        let mut levels = Vector::<Mat>::new();
        build_optical_flow_pyramid(
            grey,
            &mut levels,
            Size::new(p.window, p.window),
            p.levels,
            true,
            opencv::core::BORDER_REFLECT_101,
            opencv::core::BORDER_CONSTANT,
            true,
        )
        .map_err(cv("building an optical-flow pyramid"))?;
        Ok(Self { levels, size: grey.size().map_err(cv("image size"))? })
    }
}

/// Tracks `points` from `prev` to `cur`.
///
/// # Errors
/// An OpenCV failure.
pub fn track(prev: &Pyramid, cur: &Pyramid, points: &[Point2f], p: &KltParams) -> Result<Vec<Tracked>, FrontEndError> {
    if points.is_empty() {
        return Ok(Vec::new());
    }
    let criteria =
        TermCriteria::new(TermCriteria_COUNT + TermCriteria_EPS, p.iterations, 0.01).map_err(cv("KLT criteria"))?;
    let win = Size::new(p.window, p.window);
    let src = Vector::<Point2f>::from_slice(points);
    let (mut fwd, mut st, mut err) = (Vector::<Point2f>::new(), Vector::<u8>::new(), Vector::<f32>::new());
    calc_optical_flow_pyr_lk(
        &prev.levels,
        &cur.levels,
        &src,
        &mut fwd,
        &mut st,
        &mut err,
        win,
        p.levels,
        criteria,
        0,
        1e-4,
    )
    .map_err(cv("KLT forward"))?;
    let (mut back, mut st_b) = (Vector::<Point2f>::new(), Vector::<u8>::new());
    calc_optical_flow_pyr_lk(
        &cur.levels,
        &prev.levels,
        &fwd,
        &mut back,
        &mut st_b,
        &mut err,
        win,
        p.levels,
        criteria,
        0,
        1e-4,
    )
    .map_err(cv("KLT backward"))?;
    let (w, h) = (cur.size.width as f32, cur.size.height as f32);
    let out = points
        .iter()
        .enumerate()
        .map(|(i, p0)| {
            let (Ok(f), Ok(b), Ok(s), Ok(sb)) = (fwd.get(i), back.get(i), st.get(i), st_b.get(i)) else {
                return Tracked::Lost;
            };
            if s == 0 || !(0.0..w - 1.0).contains(&f.x) || !(0.0..h - 1.0).contains(&f.y) {
                return Tracked::Lost;
            }
            if sb == 0 || (b.x - p0.x).hypot(b.y - p0.y) > p.fb_max_px {
                return Tracked::FailedCheck;
            }
            Tracked::At(f)
        })
        .collect();
    Ok(out)
}

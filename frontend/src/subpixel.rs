//! Sub-pixel disparity at a tracked point: a patch of the left image around the point is aligned
//! along the row with the right image by Gauss-Newton on the disparity alone (a one-dimensional
//! Lucas-Kanade), starting from the dense matcher's value.
//!
//! - Both images are sampled bilinearly half a disparity away from the point, one each way, so
//!   the smoothing of interpolation falls on both sides alike and does not pull the result
//!   towards whole pixels (the pixel-locking of a one-sided fit or of a cost parabola).
//! - Patch pixels of another instance than the point's are left out (weight 0), so an object
//!   point near its mask's edge is not dragged towards the background's disparity, and a static
//!   point not towards an object's.
//! - Each side's patch is taken relative to its own mean and scaled by its own spread, so a gain
//!   or offset between the two cameras does not bias the fit.
//! - The result is refused (the caller keeps nothing) when the patch has too little texture
//!   along the row, when the fit moves further than `max_shift_px` from the start (it left the
//!   start's basin) or when the aligned patches still differ by more than `max_residual`.
//! - A start from a downscaled matcher ([`refine_from_coarse_start`]) can lie a pixel or more
//!   off, outside the true match's basin. Where the fit from it is refused, the disparities
//!   around it are scored by the same normalised patch difference and the fit is run again from
//!   the best, if that one is unambiguous. The search is kept for refused fits only: run on
//!   every point it also moves starts that were good onto neighbouring texture edges.

/// A grey image borrowed as rows of bytes.
#[derive(Debug, Clone, Copy)]
pub struct GreyView<'a> {
    /// Pixels, row-major.
    pub data: &'a [u8],
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
}

impl GreyView<'_> {
    fn at(&self, x: usize, y: usize) -> f32 {
        self.data.get(y * self.width + x).map_or(0.0, |p| f32::from(*p))
    }

    /// Bilinear intensity and its x-derivative at `(x, y)`; `None` outside the image.
    fn sample(&self, x: f32, y: f32) -> Option<(f32, f32)> {
        if !(x >= 0.0 && y >= 0.0) {
            return None;
        }
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        if x0 + 1 >= self.width || y0 + 1 >= self.height {
            return None;
        }
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let top = (self.at(x0, y0), self.at(x0 + 1, y0));
        let bottom = (self.at(x0, y0 + 1), self.at(x0 + 1, y0 + 1));
        let a = top.0 + fy * (bottom.0 - top.0);
        let b = top.1 + fy * (bottom.1 - top.1);
        Some((a + fx * (b - a), b - a))
    }
}

/// Parameters of the refinement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SubpixelParams {
    /// Half width of the patch, pixels (the patch is `2 half_width + 1` wide).
    pub half_width: i32,
    /// Half height of the patch, pixels.
    pub half_height: i32,
    /// Gauss-Newton iterations at most.
    pub iterations: u32,
    /// Farthest the result may lie from the starting disparity, pixels.
    pub max_shift_px: f32,
    /// Least mean squared x-gradient over the patch's pixels, grey levels squared.
    pub min_texture: f32,
    /// Largest mean squared difference of the normalised patches once aligned (0: identical, 2:
    /// uncorrelated).
    pub max_residual: f32,
    /// Fewest patch pixels of the point's own instance.
    pub min_pixels: usize,
    /// What the tracker does with a point whose refinement diverged or mismatched: send nothing
    /// (true) or the dense value (false).
    pub drop_refused: bool,
    /// How a start from a downscaled dense matcher is used.
    pub coarse: CoarseStart,
}

/// How the refinement treats a start from a dense matcher run on downscaled images: one map pixel
/// spans several image pixels, so its value is off by up to a couple of pixels and, near a mask's
/// edge, often belongs to the other surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoarseStart {
    /// The start is the median of the map's pixels within this many image pixels of the point
    /// (per axis) that lie wholly on the point's instance, pixels.
    pub radius_px: f32,
    /// Where the fit from the start is refused, disparities up to this far from it are scored,
    /// pixels.
    pub search_px: f32,
    /// Spacing of the scored disparities, pixels.
    pub step_px: f32,
    /// The best score must be below this fraction of the best score a pixel or more away from
    /// it, else the search gives nothing (repeated or ambiguous texture).
    pub uniqueness: f32,
}

impl Default for CoarseStart {
    fn default() -> Self {
        Self { radius_px: 3.0, search_px: 1.0, step_px: 0.5, uniqueness: 0.5 }
    }
}

impl Default for SubpixelParams {
    fn default() -> Self {
        Self {
            half_width: 5,
            half_height: 3,
            iterations: 10,
            max_shift_px: 1.5,
            min_texture: 9.0,
            max_residual: 0.5,
            min_pixels: 24,
            drop_refused: true,
            coarse: CoarseStart::default(),
        }
    }
}

/// Why a refinement gave nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refused {
    /// Too few pixels of the point's instance, or the patch leaves the image.
    SmallPatch,
    /// Too little texture along the row.
    Flat,
    /// The fit moved too far from the start.
    Diverged,
    /// The aligned patches still differ.
    Mismatch,
}

/// The sub-pixel disparity of left pixel `(u, v)` starting from `start`, using only patch pixels
/// whose `same_instance(x, y)` is true (whole pixels of the left image).
///
/// # Errors
/// Why no disparity was found ([`Refused`]).
pub fn refine_disparity(
    left: &GreyView<'_>,
    right: &GreyView<'_>,
    u: f32,
    v: f32,
    start: f32,
    same_instance: impl Fn(i64, i64) -> bool,
    p: &SubpixelParams,
) -> Result<f32, Refused> {
    let offsets = patch(u, v, same_instance, p)?;
    align(left, right, &offsets, start, p)
}

/// As [`refine_disparity`] from a downscaled matcher's `start`: where the fit from it diverges or
/// mismatches, it is run again from the best-scoring disparity within
/// [`CoarseStart::search_px`] of the start (module docs).
///
/// # Errors
/// Why no disparity was found ([`Refused`]); [`Refused::Mismatch`] also when the search's best
/// is not unique.
pub fn refine_from_coarse_start(
    left: &GreyView<'_>,
    right: &GreyView<'_>,
    u: f32,
    v: f32,
    start: f32,
    same_instance: impl Fn(i64, i64) -> bool,
    p: &SubpixelParams,
) -> Result<f32, Refused> {
    let offsets = patch(u, v, same_instance, p)?;
    match align(left, right, &offsets, start, p) {
        Err(Refused::Diverged | Refused::Mismatch) => {
            let best = search(left, right, &offsets, start, &p.coarse)?;
            align(left, right, &offsets, best, p)
        }
        done => done,
    }
}

/// How a point's disparity is searched for without a dense matcher ([`match_along_row`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowSearch {
    /// Smallest whole disparity tried, pixels.
    pub min_disparity: i32,
    /// Largest whole disparity tried, pixels (the dense matcher's range: 128 at KITTI's full
    /// size reaches 3 m).
    pub max_disparity: i32,
    /// The best score must be below this fraction of the best score two or more pixels away
    /// from it, else the point gets no depth (repeated or ambiguous texture).
    pub uniqueness: f32,
}

impl RowSearch {
    /// The search over the disparities a dense matcher with `num_disparities` would try.
    #[must_use]
    pub const fn up_to(num_disparities: i32) -> Self {
        Self { min_disparity: 1, max_disparity: num_disparities - 1, uniqueness: 0.4 }
    }
}

/// The sub-pixel disparity of left pixel `(u, v)` without a dense map: every whole disparity of
/// `search` is scored by the zero-mean normalised correlation of the point's patch (pixels
/// whose `same_instance(x, y)` is true, at whole pixels) with the right image, and the best, if
/// unique, is refined as [`refine_disparity`] refines a dense matcher's value.
///
/// # Errors
/// Why no disparity was found ([`Refused`]; [`Refused::Mismatch`] also when the best score is
/// not unique or no disparity fits in the image).
pub fn match_along_row(
    left: &GreyView<'_>,
    right: &GreyView<'_>,
    u: f32,
    v: f32,
    same_instance: impl Fn(i64, i64) -> bool,
    p: &SubpixelParams,
    search: &RowSearch,
) -> Result<f32, Refused> {
    let offsets = patch(u, v, same_instance, p)?;
    let pixels: Vec<(usize, usize)> = offsets
        .iter()
        .map(|(x, y)| {
            let (x, y) = (x.round(), y.round());
            (x >= 0.0 && y >= 0.0 && (x as usize) < left.width && (y as usize) < left.height)
                .then_some((x as usize, y as usize))
        })
        .collect::<Option<_>>()
        .ok_or(Refused::SmallPatch)?;
    let n = pixels.len() as f32;
    let a: Vec<f32> = pixels.iter().map(|(x, y)| left.at(*x, *y)).collect();
    let (ma, sa) = mean_spread(&a, n);
    if sa * sa < p.min_texture {
        return Err(Refused::Flat);
    }
    let a: Vec<f32> = a.iter().map(|i| (i - ma) / sa).collect();
    let min_x = pixels.iter().map(|(x, _)| *x).min().unwrap_or(0);
    let mut scores: Vec<(i32, f32)> = Vec::with_capacity(search.max_disparity.max(0) as usize);
    for d in search.min_disparity.max(0)..=search.max_disparity {
        let Some(shift) = usize::try_from(d).ok().filter(|d| *d <= min_x) else { break };
        let (mut sb, mut sbb, mut sab) = (0.0f32, 0.0f32, 0.0f32);
        for ((x, y), ai) in pixels.iter().zip(&a) {
            let b = right.at(x - shift, *y);
            sb += b;
            sbb += b * b;
            sab += ai * b;
        }
        let var = (sbb / n - (sb / n).powi(2)).max(1e-6);
        // Mean squared difference of the normalised patches, 2 (1 - correlation): the score the
        // refinement's residual is measured in.
        scores.push((d, 2.0 * (1.0 - sab / (n * var.sqrt()))));
    }
    let &(best, score) = scores.iter().min_by(|a, b| a.1.total_cmp(&b.1)).ok_or(Refused::Mismatch)?;
    let rival = scores.iter().filter(|(d, _)| (d - best).abs() >= 2).map(|s| s.1).fold(f32::INFINITY, f32::min);
    // A NaN score is no match either.
    if score.partial_cmp(&(search.uniqueness * rival)) != Some(std::cmp::Ordering::Less) {
        return Err(Refused::Mismatch);
    }
    // The patch was scored at whole pixels; the refinement samples at the point's own offsets.
    align(left, right, &offsets, best as f32, p)
}

/// The disparity `start + k step` within `search_px` of `start` whose normalised patch
/// difference is least, if it is unique ([`CoarseStart::uniqueness`]).
fn search(
    left: &GreyView<'_>,
    right: &GreyView<'_>,
    offsets: &[(f32, f32)],
    start: f32,
    c: &CoarseStart,
) -> Result<f32, Refused> {
    let n = offsets.len() as f32;
    let steps = if c.step_px > 0.0 { (c.search_px / c.step_px).floor() as i32 } else { 0 };
    let left_s: Vec<f32> = offsets
        .iter()
        .map(|(x, y)| left.sample(*x, *y).map(|s| s.0))
        .collect::<Option<_>>()
        .ok_or(Refused::SmallPatch)?;
    let (ml, sl) = mean_spread(&left_s, n);
    let mut right_s = vec![0.0f32; offsets.len()];
    let mut scored = Vec::with_capacity((2 * steps + 1) as usize);
    'candidates: for k in -steps..=steps {
        let d = start + k as f32 * c.step_px;
        for ((x, y), r) in offsets.iter().zip(right_s.iter_mut()) {
            let Some((i, _)) = right.sample(x - d, *y) else { continue 'candidates };
            *r = i;
        }
        let (mr, sr) = mean_spread(&right_s, n);
        let cost: f32 = left_s.iter().zip(&right_s).map(|(l, r)| ((r - mr) / sr - (l - ml) / sl).powi(2)).sum();
        scored.push((cost, d));
    }
    // The least cost; of equal costs, the disparity nearest the start.
    let best = scored
        .iter()
        .copied()
        .min_by(|a, b| a.0.total_cmp(&b.0).then((a.1 - start).abs().total_cmp(&(b.1 - start).abs())))
        .ok_or(Refused::SmallPatch)?;
    let rival =
        scored.iter().filter(|(_, d)| (d - best.1).abs() >= 0.99).map(|(cost, _)| *cost).fold(f32::INFINITY, f32::min);
    if best.0 >= c.uniqueness * rival {
        return Err(Refused::Mismatch);
    }
    Ok(best.1)
}

/// The patch's pixel positions around `(u, v)` that `same_instance` accepts.
fn patch(
    u: f32,
    v: f32,
    same_instance: impl Fn(i64, i64) -> bool,
    p: &SubpixelParams,
) -> Result<Vec<(f32, f32)>, Refused> {
    let mut offsets = Vec::with_capacity(((2 * p.half_width + 1) * (2 * p.half_height + 1)) as usize);
    for dy in -p.half_height..=p.half_height {
        for dx in -p.half_width..=p.half_width {
            let (x, y) = (u + dx as f32, v + dy as f32);
            if same_instance(x.round() as i64, y.round() as i64) {
                offsets.push((x, y));
            }
        }
    }
    if offsets.len() < p.min_pixels.max(2) {
        return Err(Refused::SmallPatch);
    }
    Ok(offsets)
}

/// Mean and spread (standard deviation, at least 1e-3) of intensities.
fn mean_spread(s: &[f32], n: f32) -> (f32, f32) {
    let mean = s.iter().sum::<f32>() / n;
    let var = s.iter().map(|i| (i - mean).powi(2)).sum::<f32>() / n;
    (mean, var.max(1e-6).sqrt())
}

/// Gauss-Newton on the disparity of the patch `offsets` from `start` (module docs).
fn align(
    left: &GreyView<'_>,
    right: &GreyView<'_>,
    offsets: &[(f32, f32)],
    start: f32,
    p: &SubpixelParams,
) -> Result<f32, Refused> {
    let n = offsets.len() as f32;
    let mut d = start;
    let mut residual = f32::INFINITY;
    let mut left_s = vec![(0.0f32, 0.0f32); offsets.len()];
    let mut right_s = vec![(0.0f32, 0.0f32); offsets.len()];
    for _ in 0..p.iterations.max(1) {
        for ((x, y), (l, r)) in offsets.iter().zip(left_s.iter_mut().zip(right_s.iter_mut())) {
            *l = left.sample(x + 0.5 * d - 0.5 * start, *y).ok_or(Refused::SmallPatch)?;
            *r = right.sample(x - 0.5 * d - 0.5 * start, *y).ok_or(Refused::SmallPatch)?;
        }
        let stats = |s: &[(f32, f32)]| {
            let mean = s.iter().map(|p| p.0).sum::<f32>() / n;
            let var = s.iter().map(|p| (p.0 - mean).powi(2)).sum::<f32>() / n;
            (mean, var.max(1e-6).sqrt())
        };
        let ((ml, sl), (mr, sr)) = (stats(&left_s), stats(&right_s));
        let texture = left_s.iter().map(|p| p.1 * p.1).sum::<f32>() / n;
        if texture < p.min_texture {
            return Err(Refused::Flat);
        }
        // r = R(x - d/2)/sr - L(x + d/2)/sl (each centred); dr/dd = -(R_x/sr + L_x/sl) / 2.
        let (mut jtj, mut jtr, mut rr) = (0.0f32, 0.0f32, 0.0f32);
        for (l, r) in left_s.iter().zip(&right_s) {
            let res = (r.0 - mr) / sr - (l.0 - ml) / sl;
            let j = -0.5 * (r.1 / sr + l.1 / sl);
            jtj += j * j;
            jtr += j * res;
            rr += res * res;
        }
        residual = rr / n;
        if jtj <= 1e-9 {
            return Err(Refused::Flat);
        }
        let step = -jtr / jtj;
        d += step.clamp(-1.0, 1.0);
        if (d - start).abs() > p.max_shift_px {
            return Err(Refused::Diverged);
        }
        if step.abs() < 1e-3 {
            break;
        }
    }
    if residual > p.max_residual {
        return Err(Refused::Mismatch);
    }
    Ok(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth random texture shifted by `shift` pixels (right = left moved left by `shift`).
    /// The images of texture `tex`, the right one moved by `shift` under a gain and an offset.
    fn shifted(width: usize, height: usize, shift: f32, tex: impl Fn(f32, f32) -> f32) -> (Vec<u8>, Vec<u8>) {
        let mut l = vec![0u8; width * height];
        let mut r = vec![0u8; width * height];
        for y in 0..height {
            for x in 0..width {
                l[y * width + x] = tex(x as f32, y as f32).round().clamp(0.0, 255.0) as u8;
                r[y * width + x] = (0.8 * tex(x as f32 + shift, y as f32) + 10.0).round().clamp(0.0, 255.0) as u8;
            }
        }
        (l, r)
    }

    fn pair(width: usize, height: usize, shift: f32) -> (Vec<u8>, Vec<u8>) {
        let tex = |x: f32, y: f32| {
            128.0
                + 50.0 * (0.7 * x + 0.3 * y).sin()
                + 30.0 * (0.23 * x - 0.5 * y + 1.0).sin()
                + 20.0 * (1.3 * x + 0.1).cos()
        };
        shifted(width, height, shift, tex)
    }

    #[test]
    fn a_fractional_shift_is_found_to_a_few_hundredths_under_gain_and_offset() {
        for shift in [5.0f32, 5.25, 5.5, 5.8, 6.1] {
            let (l, r) = pair(80, 30, shift);
            let left = GreyView { data: &l, width: 80, height: 30 };
            let right = GreyView { data: &r, width: 80, height: 30 };
            let start = shift.round() + 0.4 * (shift - shift.round()).signum();
            let d =
                refine_disparity(&left, &right, 40.0, 15.0, start, |_, _| true, &SubpixelParams::default()).unwrap();
            assert!((d - shift).abs() < 0.03, "shift {shift}: {d}");
        }
    }

    #[test]
    fn other_instances_are_left_out_and_flat_patches_refused() {
        let (l, r) = pair(80, 30, 5.3);
        let left = GreyView { data: &l, width: 80, height: 30 };
        let right = GreyView { data: &r, width: 80, height: 30 };
        let p = SubpixelParams::default();
        assert_eq!(refine_disparity(&left, &right, 40.0, 15.0, 5.0, |x, _| x > 43, &p), Err(Refused::SmallPatch));
        let d = refine_disparity(&left, &right, 40.0, 15.0, 5.0, |x, _| x > 38, &p).unwrap();
        assert!((d - 5.3).abs() < 0.05, "{d}");
        let flat = vec![100u8; 80 * 30];
        let flat = GreyView { data: &flat, width: 80, height: 30 };
        assert_eq!(refine_disparity(&flat, &flat, 40.0, 15.0, 5.0, |_, _| true, &p), Err(Refused::Flat));
        assert_eq!(refine_disparity(&left, &right, 78.0, 15.0, 5.0, |_, _| true, &p), Err(Refused::SmallPatch));
    }

    #[test]
    fn a_start_two_pixels_off_is_refused_alone_and_found_by_the_search() {
        let p = SubpixelParams::default();
        for shift in [5.0f32, 5.25, 5.5, 5.8, 6.1, 7.3] {
            let (l, r) = pair(80, 30, shift);
            let left = GreyView { data: &l, width: 80, height: 30 };
            let right = GreyView { data: &r, width: 80, height: 30 };
            for off in [-2.0f32, -1.75, 1.75, 2.0] {
                let start = shift + off;
                let alone = refine_disparity(&left, &right, 40.0, 15.0, start, |_, _| true, &p);
                assert!(alone.is_err(), "shift {shift}, start {start}: {alone:?}");
                let d = refine_from_coarse_start(&left, &right, 40.0, 15.0, start, |_, _| true, &p).unwrap();
                assert!((d - shift).abs() < 0.03, "shift {shift}, start {start}: {d}");
            }
        }
    }

    #[test]
    fn the_search_gives_nothing_where_two_disparities_match_alike() {
        let c = CoarseStart::default();
        let offsets: Vec<(f32, f32)> =
            (-5..=5).flat_map(|dx| (-3..=3).map(move |dy| (40.0 + dx as f32, 15.0 + dy as f32))).collect();
        // Columns alternating bright and dark, the same in both images: from a start of 5, the
        // disparities 4 and 6 match alike.
        let stripes: Vec<u8> = (0..80 * 30).map(|i| if i % 2 == 0 { 190 } else { 60 }).collect();
        let view = GreyView { data: &stripes, width: 80, height: 30 };
        assert_eq!(search(&view, &view, &offsets, 5.0, &c), Err(Refused::Mismatch));
        let (l, r) = pair(80, 30, 5.0);
        let left = GreyView { data: &l, width: 80, height: 30 };
        let right = GreyView { data: &r, width: 80, height: 30 };
        assert_eq!(search(&left, &right, &offsets, 6.0, &c), Ok(5.0));
    }

    /// A smooth texture without repeats over a wide image: noise on a 3-pixel grid, bilinear
    /// in between; the right image is the left moved by `shift`, under a gain and an offset.
    fn wide_pair(width: usize, height: usize, shift: f32) -> (Vec<u8>, Vec<u8>) {
        let grid =
            |i: i64, j: i64| ((i.wrapping_mul(73_856_093) ^ j.wrapping_mul(19_349_663)).rem_euclid(9973) % 200) as f32;
        let tex = |x: f32, y: f32| {
            let (gx, gy) = (x / 3.0, y / 3.0);
            let (i, j) = (gx.floor() as i64, gy.floor() as i64);
            let (fx, fy) = (gx - gx.floor(), gy - gy.floor());
            let top = grid(i, j) + fx * (grid(i + 1, j) - grid(i, j));
            let bottom = grid(i, j + 1) + fx * (grid(i + 1, j + 1) - grid(i, j + 1));
            28.0 + top + fy * (bottom - top)
        };
        shifted(width, height, shift, tex)
    }

    #[test]
    fn a_disparity_is_found_along_the_row_without_a_start() {
        let p = SubpixelParams::default();
        let search = RowSearch::up_to(128);
        for shift in [3.4f32, 20.3, 47.5, 90.8, 120.2] {
            let (l, r) = wide_pair(260, 30, shift);
            let left = GreyView { data: &l, width: 260, height: 30 };
            let right = GreyView { data: &r, width: 260, height: 30 };
            let d = match_along_row(&left, &right, 200.0, 15.0, |_, _| true, &p, &search).unwrap();
            assert!((d - shift).abs() < 0.1, "shift {shift}: {d}");
        }
    }

    #[test]
    fn a_row_match_refuses_flat_repeated_and_out_of_range_patches() {
        let p = SubpixelParams::default();
        let flat = vec![100u8; 260 * 30];
        let flat = GreyView { data: &flat, width: 260, height: 30 };
        assert_eq!(
            match_along_row(&flat, &flat, 200.0, 15.0, |_, _| true, &p, &RowSearch::up_to(128)),
            Err(Refused::Flat)
        );
        // A texture that repeats every 8 pixels matches at every eighth disparity alike.
        let stripes: Vec<u8> = (0..260 * 30)
            .map(|i| (128.0 + 60.0 * ((i % 260) as f32 * std::f32::consts::TAU / 8.0).sin()) as u8)
            .collect();
        let stripes = GreyView { data: &stripes, width: 260, height: 30 };
        assert_eq!(
            match_along_row(&stripes, &stripes, 200.0, 15.0, |_, _| true, &p, &RowSearch::up_to(128)),
            Err(Refused::Mismatch)
        );
        // A true disparity beyond the range searched is not taken for another.
        let (l, r) = wide_pair(260, 30, 60.0);
        let left = GreyView { data: &l, width: 260, height: 30 };
        let right = GreyView { data: &r, width: 260, height: 30 };
        let near = RowSearch { max_disparity: 30, ..RowSearch::up_to(128) };
        assert!(match_along_row(&left, &right, 200.0, 15.0, |_, _| true, &p, &near).is_err());
    }
}

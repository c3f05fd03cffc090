//! The front-end's disparity measured against a rendering's exact depth, at the points it sends:
//! how far the depth of each tracked object point and static point is off, by range band, by the
//! sub-pixel fraction of the true disparity and by distance to the nearest mask edge.
//!
//! The true disparity at a sub-pixel point is `fb / z` with `1 / z` interpolated bilinearly over
//! the four pixel centres around it when they lie on one surface (one id, depths within 5 %):
//! inverse depth is affine in the image over a plane, so this is exact inside a face. Where the
//! four disagree (an edge), the nearest pixel's depth is used and the point is counted at edge
//! distance 0.

use dynotraj_core::wire::STATIC_OBJECT_ID;

/// What kind of point a sample is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum PointKind {
    /// A point of a moving object's mask.
    Object,
    /// A static corner.
    Static,
}

/// One sent point's disparity against the truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DisparitySample {
    /// Object or static point.
    pub kind: PointKind,
    /// True depth, metres.
    pub true_depth_m: f32,
    /// True disparity, pixels.
    pub true_disparity: f32,
    /// Sent disparity minus true disparity, pixels.
    pub error_px: f32,
    /// Distance to the nearest pixel of another id, pixels (capped at [`EDGE_SEARCH_PX`]).
    pub edge_px: u8,
}

/// How far from a point the mask-edge search looks, pixels.
pub const EDGE_SEARCH_PX: i32 = 8;

/// An error larger than this is an outlier, pixels.
pub const OUTLIER_PX: f32 = 1.0;

/// The rendered truth of one frame: depth along the optical axis (metres, 0 for sky) and the
/// instance id of every pixel, row-major.
#[derive(Debug, Clone, Copy)]
pub struct FrameTruth<'a> {
    /// Depth per pixel, metres (0: none).
    pub depth: &'a [f32],
    /// Instance id per pixel (0: static scene).
    pub ids: &'a [u16],
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
}

impl FrameTruth<'_> {
    fn index(&self, x: i64, y: i64) -> Option<usize> {
        (x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height)
            .then(|| y as usize * self.width + x as usize)
    }

    fn id_at(&self, x: i64, y: i64) -> Option<u16> {
        self.ids.get(self.index(x, y)?).copied()
    }

    fn depth_at(&self, x: i64, y: i64) -> Option<f32> {
        self.depth.get(self.index(x, y)?).copied().filter(|z| z.is_finite() && *z > 0.0)
    }

    /// The true depth at sub-pixel `(u, v)` and whether the four pixels around it lie on one
    /// surface (module docs).
    #[must_use]
    pub fn depth_at_point(&self, u: f32, v: f32) -> Option<(f32, bool)> {
        let (x0, y0) = (u.floor() as i64, v.floor() as i64);
        let (fx, fy) = (u - u.floor(), v - v.floor());
        let corners = [(x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1)];
        let id = self.id_at(x0, y0);
        let zs: Option<Vec<f32>> =
            corners.iter().map(|&(x, y)| self.depth_at(x, y).filter(|_| self.id_at(x, y) == id)).collect();
        if let Some(zs) = zs {
            let (lo, hi) = zs.iter().fold((f32::MAX, 0.0f32), |(lo, hi), z| (lo.min(*z), hi.max(*z)));
            if hi <= 1.05 * lo {
                let w = [(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy];
                let inv: f32 = zs.iter().zip(w).map(|(z, w)| w / z).sum();
                return (inv > 0.0).then(|| (1.0 / inv, true));
            }
        }
        self.depth_at(u.round() as i64, v.round() as i64).map(|z| (z, false))
    }

    /// Distance from pixel `(u, v)` to the nearest pixel of another id, pixels, capped at
    /// [`EDGE_SEARCH_PX`].
    #[must_use]
    pub fn edge_distance(&self, u: f32, v: f32) -> u8 {
        let (x, y) = (u.round() as i64, v.round() as i64);
        let Some(own) = self.id_at(x, y) else { return 0 };
        let mut best = EDGE_SEARCH_PX;
        for dy in -EDGE_SEARCH_PX..=EDGE_SEARCH_PX {
            for dx in -EDGE_SEARCH_PX..=EDGE_SEARCH_PX {
                let r = dx.abs().max(dy.abs());
                if r < best && self.id_at(x + i64::from(dx), y + i64::from(dy)).is_some_and(|id| id != own) {
                    best = r;
                }
            }
        }
        best as u8
    }
}

/// One object's points in one frame: the mean of their disparity errors, which is what moves the
/// object's centroid (errors shared by the points do not average out).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectMean {
    /// Median true depth of the points, metres.
    pub true_depth_m: f32,
    /// True disparity at that depth, pixels.
    pub true_disparity: f32,
    /// Mean disparity error of the points, pixels.
    pub error_px: f32,
    /// Points averaged.
    pub points: u32,
}

/// One tracked point as sent: pixel, depth and the object it belongs to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SentPoint {
    /// Pixel column.
    pub u: f32,
    /// Pixel row.
    pub v: f32,
    /// Depth sent, metres.
    pub depth_m: f32,
    /// The wire object id ([`STATIC_OBJECT_ID`] for static points).
    pub object_id: u16,
}

/// Range bands of the table, metres (the error budget's).
pub const BANDS: [(f32, f32); 3] = [(0.0, 20.0), (20.0, 40.0), (40.0, 80.0)];

/// Disparity errors gathered over frames.
#[derive(Debug, Clone, Default)]
pub struct DisparityErrors {
    /// Every sample.
    pub samples: Vec<DisparitySample>,
    /// Sent points with no truth under them (sky, outside the image).
    pub without_truth: u64,
    /// Per object and frame, its points' mean error (objects with at least
    /// [`MIN_POINTS_FOR_MEAN`] scored points).
    pub object_means: Vec<ObjectMean>,
}

/// Fewest scored points of an object in a frame for its mean error to be kept.
pub const MIN_POINTS_FOR_MEAN: usize = 5;

/// One row of the table.
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorRow {
    /// What the row groups.
    pub group: String,
    /// Points.
    pub points: usize,
    /// Mean signed error (sent minus true), pixels.
    pub bias_px: f64,
    /// Median absolute error, pixels.
    pub median_abs_px: f64,
    /// Share of points off by more than [`OUTLIER_PX`].
    pub outlier_share: f64,
    /// Median absolute depth error, metres.
    pub median_abs_depth_m: f64,
}

impl ErrorRow {
    /// The row of `errors` (disparity error, true disparity, true depth), counting errors
    /// larger than `outlier_px` as outliers.
    fn of(group: String, errors: &[[f32; 3]], outlier_px: f32) -> Self {
        let n = errors.len();
        let median = |mut xs: Vec<f64>| -> f64 {
            xs.sort_by(f64::total_cmp);
            xs.get(xs.len() / 2).copied().unwrap_or(f64::NAN)
        };
        let share = |count: usize| if n == 0 { f64::NAN } else { count as f64 / n as f64 };
        let depth_errors = errors
            .iter()
            .map(|[e, d, z]| {
                let sent = f64::from(d + e);
                let (d, z) = (f64::from(*d), f64::from(*z));
                if sent > 0.0 { (d * z / sent - z).abs() } else { f64::INFINITY }
            })
            .collect();
        Self {
            group,
            points: n,
            bias_px: if n == 0 { f64::NAN } else { errors.iter().map(|[e, ..]| f64::from(*e)).sum::<f64>() / n as f64 },
            median_abs_px: median(errors.iter().map(|[e, ..]| f64::from(e.abs())).collect()),
            outlier_share: share(errors.iter().filter(|[e, ..]| e.abs() > outlier_px).count()),
            median_abs_depth_m: median(depth_errors),
        }
    }
}

impl DisparityErrors {
    /// Adds one frame's sent points, scored against `truth`, for a camera of stereo `fb`.
    pub fn add_frame(&mut self, points: &[SentPoint], truth: &FrameTruth<'_>, fb: f32) {
        let first = self.samples.len();
        let mut owners = Vec::new();
        for p in points {
            let Some((z, _)) = truth.depth_at_point(p.u, p.v) else {
                self.without_truth += 1;
                continue;
            };
            if p.depth_m <= 0.0 || !p.depth_m.is_finite() {
                continue;
            }
            let true_disparity = fb / z;
            self.samples.push(DisparitySample {
                kind: if p.object_id == STATIC_OBJECT_ID { PointKind::Static } else { PointKind::Object },
                true_depth_m: z,
                true_disparity,
                error_px: fb / p.depth_m - true_disparity,
                edge_px: truth.edge_distance(p.u, p.v),
            });
            owners.push(p.object_id);
        }
        let scored = self.samples.get(first..).unwrap_or_default();
        let mut ids: Vec<u16> = owners.iter().copied().filter(|id| *id != STATIC_OBJECT_ID).collect();
        ids.sort_unstable();
        ids.dedup();
        for id in ids {
            let mine: Vec<&DisparitySample> =
                scored.iter().zip(&owners).filter(|(_, o)| **o == id).map(|(s, _)| s).collect();
            if mine.len() < MIN_POINTS_FOR_MEAN {
                continue;
            }
            let mut zs: Vec<f32> = mine.iter().map(|s| s.true_depth_m).collect();
            zs.sort_by(f32::total_cmp);
            let z = zs.get(zs.len() / 2).copied().unwrap_or(0.0);
            self.object_means.push(ObjectMean {
                true_depth_m: z,
                true_disparity: if z > 0.0 { fb / z } else { 0.0 },
                error_px: mine.iter().map(|s| s.error_px).sum::<f32>() / mine.len() as f32,
                points: mine.len() as u32,
            });
        }
    }

    /// Adds every sample of `other`.
    pub fn merge(&mut self, other: Self) {
        self.samples.extend(other.samples);
        self.without_truth += other.without_truth;
        self.object_means.extend(other.object_means);
    }

    /// The row of the samples `keep` selects.
    #[must_use]
    pub fn row(&self, group: impl Into<String>, keep: impl Fn(&DisparitySample) -> bool) -> ErrorRow {
        let errors: Vec<[f32; 3]> =
            self.samples.iter().filter(|s| keep(s)).map(|s| [s.error_px, s.true_disparity, s.true_depth_m]).collect();
        ErrorRow::of(group.into(), &errors, OUTLIER_PX)
    }

    /// The row of the objects' per-frame mean errors in range band `(lo, hi)`: the bias and
    /// median absolute error of the means, the share of means off by more than a quarter pixel.
    #[must_use]
    pub fn object_mean_row(&self, (lo, hi): (f32, f32)) -> ErrorRow {
        let errors: Vec<[f32; 3]> = self
            .object_means
            .iter()
            .filter(|m| (lo..hi).contains(&m.true_depth_m))
            .map(|m| [m.error_px, m.true_disparity, m.true_depth_m])
            .collect();
        ErrorRow::of(format!("object means per frame, {lo}-{hi} m"), &errors, 0.25)
    }

    /// The table's rows: each kind by range band; object points at 40-80 m by the sub-pixel
    /// fraction of their true disparity; object points by distance to the mask edge.
    #[must_use]
    pub fn rows(&self) -> Vec<ErrorRow> {
        let band_of = |s: &DisparitySample, (lo, hi): (f32, f32)| (lo..hi).contains(&s.true_depth_m);
        let mut out = Vec::new();
        for (kind, name) in [(PointKind::Object, "object"), (PointKind::Static, "static")] {
            for band in BANDS {
                out.push(
                    self.row(format!("{name} points, {}-{} m", band.0, band.1), |s| s.kind == kind && band_of(s, band)),
                );
            }
        }
        for band in BANDS {
            out.push(self.object_mean_row(band));
        }
        let far = BANDS[2];
        for q in 0..4 {
            let (lo, hi) = (q as f32 * 0.25, (q + 1) as f32 * 0.25);
            out.push(self.row(format!("object points, {}-{} m, fraction {lo:.2}-{hi:.2}", far.0, far.1), |s| {
                let f = s.true_disparity - s.true_disparity.floor();
                s.kind == PointKind::Object && band_of(s, far) && (lo..hi).contains(&f)
            }));
        }
        for (lo, hi) in [(0u8, 2u8), (2, 4), (4, 8), (8, u8::MAX)] {
            let name = match (lo, hi) {
                (0, _) => "object points, 1 px from the mask edge".to_string(),
                (_, u8::MAX) => format!("object points, {lo}+ px from the mask edge"),
                _ => format!("object points, {lo}-{} px from the mask edge", hi - 1),
            };
            out.push(self.row(name, |s| s.kind == PointKind::Object && s.edge_px >= lo && s.edge_px < hi));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plane(width: usize, height: usize) -> (Vec<f32>, Vec<u16>) {
        // A plane whose inverse depth is affine in the image: 1/z = 0.02 + 0.001 u.
        let depth = (0..width * height).map(|i| 1.0 / (0.02 + 0.001 * (i % width) as f32)).collect();
        let mut ids = vec![0u16; width * height];
        for v in 0..height {
            for u in 10..width {
                ids[v * width + u] = 3;
            }
        }
        (depth, ids)
    }

    #[test]
    fn inverse_depth_is_interpolated_exactly_inside_a_surface_and_edges_are_found() {
        let (depth, ids) = plane(40, 20);
        let truth = FrameTruth { depth: &depth, ids: &ids, width: 40, height: 20 };
        let (z, inside) = truth.depth_at_point(20.3, 5.6).unwrap();
        assert!(inside);
        assert!((1.0 / z - (0.02 + 0.001 * 20.3)).abs() < 1e-6, "{z}");
        assert_eq!(truth.edge_distance(20.0, 5.0), 8);
        assert_eq!(truth.edge_distance(12.0, 5.0), 3);
        assert_eq!(truth.edge_distance(10.0, 5.0), 1);
        assert!(truth.depth_at_point(-3.0, 5.0).is_none());
    }

    #[test]
    fn a_constant_disparity_offset_shows_as_bias_and_outliers_are_counted() {
        let (depth, ids) = plane(40, 20);
        let truth = FrameTruth { depth: &depth, ids: &ids, width: 40, height: 20 };
        let fb = 400.0;
        let points: Vec<SentPoint> = (12..38)
            .map(|u| {
                let (z, _) = truth.depth_at_point(u as f32, 7.0).unwrap();
                // 0.2 px too much disparity everywhere, 2 px on one point.
                let extra = if u == 20 { 2.0 } else { 0.2 };
                SentPoint { u: u as f32, v: 7.0, depth_m: fb / (fb / z + extra), object_id: 3 }
            })
            .collect();
        let mut e = DisparityErrors::default();
        e.add_frame(&points, &truth, fb);
        let all = e.row("all", |_| true);
        assert_eq!(all.points, 26);
        assert!((all.median_abs_px - 0.2).abs() < 1e-4, "{all:?}");
        assert!((all.bias_px - (25.0 * 0.2 + 2.0) / 26.0).abs() < 1e-4, "{all:?}");
        assert!((all.outlier_share - 1.0 / 26.0).abs() < 1e-9);
        assert!(e.rows().iter().any(|r| r.group.contains("40-80") && r.points == 0));
        // One object in one frame: its mean error is the points' mean.
        assert_eq!(e.object_means.len(), 1);
        assert!((f64::from(e.object_means[0].error_px) - all.bias_px).abs() < 1e-4);
    }
}

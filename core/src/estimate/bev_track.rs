//! The bird's-eye track an object's forecast reads: a constant-velocity Kalman filter on the
//! world bird's-eye plane that fuses two measurements of different strengths.
//!
//! - The centroid of the object's points each frame: an absolute position whose error along the
//!   viewing ray grows with depth squared (stereo) and is small across it. It cannot drift.
//! - The velocity of the smoothed SE(3) motion: smooth, but along the ray of a far object a
//!   frame's motion moves the disparity by hundredths of a pixel, and the chained motions there
//!   lag and drift (docs/decisions.md "Following the object").
//!
//! The centroid's geometry weights it: near objects follow their motion, far ones are held to
//! their points. Fixed size: 4 states, a 4 x 4 covariance.

use nalgebra::{Matrix2, Matrix2x4, Matrix4, Vector2, Vector4};

use crate::geometry::BevState;

/// Noise of a [`BevTrack`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BevTrackParams {
    /// White acceleration of the constant-velocity model, m/s^2 (per axis).
    pub accel_sigma: f32,
    /// The centroid's position error across the ray and the floor along it, metres: the
    /// visible surface moves over the body as the object turns and its mask changes.
    pub centroid_sigma_m: f32,
    /// The disparity error shared by an object's points in one frame, pixels: the centroid's
    /// depth error is `depth^2 * this / (f b)`.
    pub centroid_disparity_px: f32,
    /// The motion velocity's error, m/s (per axis). A bound growing with depth along the ray
    /// was tried and chosen away on training sequences (docs/decisions.md).
    pub motion_sigma_mps: f32,
}

impl BevTrackParams {
    /// Defaults for road scenes at KITTI's geometry, chosen on the renderings of the sequences
    /// outside the paper's test split (docs/decisions.md "Following the object").
    pub const ROAD: Self =
        Self { accel_sigma: 2.0, centroid_sigma_m: 0.3, centroid_disparity_px: 0.15, motion_sigma_mps: 0.7 };
}

/// A constant-velocity Kalman filter on one object's bird's-eye position; see the module docs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BevTrack {
    /// `[x, y, vx, vy]`, metres and m/s (bird's-eye plane: world x, world z).
    state: Vector4<f32>,
    /// The covariance's upper triangle, row by row (the edge keeps one track per run).
    cov: [f32; 10],
    started: bool,
}

/// Index into the packed upper triangle of a symmetric 4 x 4 matrix, for `r <= c`.
const PACKED: [[usize; 4]; 4] = [[0, 1, 2, 3], [1, 4, 5, 6], [2, 5, 7, 8], [3, 6, 8, 9]];

fn unpack(p: &[f32; 10]) -> Matrix4<f32> {
    Matrix4::from_fn(|r, c| PACKED.get(r).and_then(|row| row.get(c)).and_then(|&i| p.get(i)).copied().unwrap_or(0.0))
}

fn pack(m: &Matrix4<f32>) -> [f32; 10] {
    let mut out = [0.0; 10];
    for (r, row) in PACKED.iter().enumerate() {
        for (c, &i) in row.iter().enumerate().skip(r) {
            if let Some(o) = out.get_mut(i) {
                *o = m[(r, c)];
            }
        }
    }
    out
}

/// The variance a fresh track gives its unknown velocity, (m/s)^2.
const START_VELOCITY_VAR: f32 = 100.0;
/// Speed from which a reported heading is the track's direction of travel rather than the
/// one given, m/s: slower, the direction of a filtered velocity is noise.
pub const TRAVEL_HEADING_MIN_SPEED: f32 = 1.0;

impl Default for BevTrack {
    fn default() -> Self {
        Self::new()
    }
}

/// The 2 x 2 covariance with standard deviation `along` on the unit direction `ray` and
/// `across` perpendicular to it.
fn ray_covariance(ray: &Vector2<f32>, along: f32, across: f32) -> Matrix2<f32> {
    let n = ray.norm();
    let u = if n > 0.0 && n.is_finite() { ray / n } else { Vector2::new(1.0, 0.0) };
    let (a2, c2) = (along * along, across * across);
    let outer = u * u.transpose();
    outer * a2 + (Matrix2::identity() - outer) * c2
}

impl BevTrack {
    /// No track yet.
    #[must_use]
    pub const fn new() -> Self {
        Self { state: Vector4::new(0.0, 0.0, 0.0, 0.0), cov: [0.0; 10], started: false }
    }

    /// Whether a measurement has started the track.
    #[must_use]
    pub const fn started(&self) -> bool {
        self.started
    }

    /// Position `[x, y]`, metres.
    #[must_use]
    pub fn position(&self) -> Vector2<f32> {
        Vector2::new(self.state.x, self.state.y)
    }

    /// Velocity `[vx, vy]`, m/s.
    #[must_use]
    pub fn velocity(&self) -> Vector2<f32> {
        Vector2::new(self.state.z, self.state.w)
    }

    /// Writes the track into `state` once it has started: its position and speed, and its
    /// direction of travel as the heading from [`TRAVEL_HEADING_MIN_SPEED`] (below it `state`'s
    /// heading stays).
    pub fn report(&self, state: &mut BevState) {
        if !self.started {
            return;
        }
        let (at, v) = (self.position(), self.velocity());
        let speed = v.norm();
        (state.x, state.y, state.speed) = (at.x, at.y, speed);
        if speed >= TRAVEL_HEADING_MIN_SPEED {
            state.heading = libm::atan2f(v.y, v.x);
        }
    }

    /// Moves the track `dt` seconds on (nothing before it has started).
    pub fn predict(&mut self, dt: f32, p: &BevTrackParams) {
        if !(self.started && dt > 0.0 && dt.is_finite()) {
            return;
        }
        let f = Matrix4::new(1.0, 0.0, dt, 0.0, 0.0, 1.0, 0.0, dt, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
        let q = p.accel_sigma * p.accel_sigma;
        let (a, b, c) = (dt * dt * dt * dt / 4.0 * q, dt * dt * dt / 2.0 * q, dt * dt * q);
        let noise = Matrix4::new(a, 0.0, b, 0.0, 0.0, a, 0.0, b, b, 0.0, c, 0.0, 0.0, b, 0.0, c);
        self.state = f * self.state;
        self.cov = pack(&(f * unpack(&self.cov) * f.transpose() + noise));
    }

    /// Takes the centroid `at` (bird's-eye, metres), seen along the bird's-eye direction `ray`
    /// from the camera with the depth error `depth_sigma` metres (of a disparity error of
    /// [`BevTrackParams::centroid_disparity_px`]).
    pub fn update_position(&mut self, at: &Vector2<f32>, ray: &Vector2<f32>, depth_sigma: f32, p: &BevTrackParams) {
        let r = ray_covariance(ray, p.centroid_sigma_m.max(depth_sigma), p.centroid_sigma_m);
        if !self.started {
            if at.iter().all(|v| v.is_finite()) && r.iter().all(|v| v.is_finite()) {
                self.state = Vector4::new(at.x, at.y, 0.0, 0.0);
                self.cov = [r.m11, r.m12, 0.0, 0.0, r.m22, 0.0, 0.0, START_VELOCITY_VAR, 0.0, START_VELOCITY_VAR];
                self.started = true;
            }
            return;
        }
        let h = Matrix2x4::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0);
        self.update(&h, at, &r);
    }

    /// Takes the motion's velocity `v` (bird's-eye, m/s).
    pub fn update_velocity(&mut self, v: &Vector2<f32>, p: &BevTrackParams) {
        if !self.started {
            return;
        }
        let r = Matrix2::identity() * (p.motion_sigma_mps * p.motion_sigma_mps);
        let h = Matrix2x4::new(0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
        self.update(&h, v, &r);
    }

    /// The Kalman update with measurement `z = h x + noise(r)`; skipped when anything is not
    /// finite or the innovation's covariance is singular.
    fn update(&mut self, h: &Matrix2x4<f32>, z: &Vector2<f32>, r: &Matrix2<f32>) {
        let p = unpack(&self.cov);
        let s = h * p * h.transpose() + r;
        let Some(s_inv) = s.try_inverse() else { return };
        let k = p * h.transpose() * s_inv;
        let state = self.state + k * (z - h * self.state);
        let cov = (Matrix4::identity() - k * h) * p;
        let cov = (cov + cov.transpose()) * 0.5;
        if state.iter().all(|v| v.is_finite()) && cov.iter().all(|v| v.is_finite()) {
            self.state = state;
            self.cov = pack(&cov);
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    /// A deterministic value in [-1, 1).
    fn jitter(seed: &mut u32) -> f32 {
        *seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
        ((*seed >> 16) % 1000) as f32 / 500.0 - 1.0
    }

    #[test]
    fn a_far_object_is_held_to_its_centroids() {
        let p = BevTrackParams::ROAD;
        let (mut t, mut seed, dt) = (BevTrack::new(), 7u32, 0.1);
        let ray = Vector2::new(0.0, 1.0);
        // A car 60 m ahead driving away at 15 m/s: its centroid jumps by up to 1.5 m along the
        // ray each frame, and its motion's velocity by up to 1 m/s.
        let mut truth = 0.0;
        for k in 0..100 {
            truth = 60.0 + 15.0 * dt * k as f32;
            t.predict(dt, &p);
            let at = Vector2::new(0.0, truth + 1.5 * jitter(&mut seed));
            t.update_position(&at, &ray, truth * truth * p.centroid_disparity_px / 387.6, &p);
            t.update_velocity(&Vector2::new(0.2 * jitter(&mut seed), 15.0 + jitter(&mut seed)), &p);
        }
        assert!((t.velocity() - Vector2::new(0.0, 15.0)).norm() < 1.0, "{:?}", t.velocity());
        assert!((t.position().y - truth).abs() < 1.0, "{:?} against {truth}", t.position());
        // Without the motion, the centroids alone still give the speed.
        let mut alone = BevTrack::new();
        for k in 0..100 {
            let y = 60.0 + 15.0 * dt * k as f32;
            alone.predict(dt, &p);
            let at = Vector2::new(0.0, y + 1.5 * jitter(&mut seed));
            alone.update_position(&at, &ray, y * y * p.centroid_disparity_px / 387.6, &p);
        }
        assert!((alone.velocity().y - 15.0).abs() < 2.0, "{:?}", alone.velocity());
    }

    #[test]
    fn a_near_object_follows_its_motion() {
        let p = BevTrackParams::ROAD;
        let mut t = BevTrack::new();
        for k in 0..30 {
            t.predict(0.1, &p);
            let x = 0.8 * k as f32;
            let ray = Vector2::new(1.0, 1.0);
            t.update_position(&Vector2::new(x + 5.0, 10.0), &ray, 0.05, &p);
            t.update_velocity(&Vector2::new(8.0, 0.0), &p);
        }
        assert!((t.velocity() - Vector2::new(8.0, 0.0)).norm() < 0.3, "{:?}", t.velocity());
    }

    #[test]
    fn the_packed_covariance_round_trips() {
        let m = Matrix4::from_fn(|r, c| (r.min(c) * 10 + r.max(c)) as f32);
        assert_eq!(unpack(&pack(&m)), m);
    }

    #[test]
    fn bad_numbers_leave_the_track_as_it_was() {
        let p = BevTrackParams::ROAD;
        let mut t = BevTrack::new();
        t.update_velocity(&Vector2::new(1.0, 1.0), &p);
        assert!(!t.started(), "a velocity alone starts nothing");
        t.update_position(&Vector2::new(f32::NAN, 1.0), &Vector2::new(0.0, 1.0), 0.04, &p);
        assert!(!t.started());
        t.update_position(&Vector2::new(1.0, 1.0), &Vector2::new(0.0, 1.0), 0.04, &p);
        let before = t;
        t.update_position(&Vector2::new(f32::INFINITY, 1.0), &Vector2::new(0.0, 1.0), 0.04, &p);
        t.predict(f32::NAN, &p);
        assert_eq!(t, before);
    }
}

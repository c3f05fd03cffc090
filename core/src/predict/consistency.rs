//! Consistent forecasts: an object's forecast carries part of its previous one, so that it
//! changes from frame to frame only as much as its evidence does.
//!
//! A forecaster that reads each frame's history afresh re-estimates acceleration and turn rate
//! from scratch every frame, and on noisy tracks the forecasts of consecutive frames disagree
//! (the paper's ACE). Here the fresh forecast made at frame s is blended with the forecast made
//! at frame s - 1 carried one frame on: point k of the result is
//! `(1 - carry) * fresh[k] + carry * previous[k + 1]`, the previous forecast's last step
//! extended by its own last displacement. The result is what is kept for the next frame, so the
//! carried part fades geometrically (`carry^n` after n frames). A forecast whose object has no
//! forecast at the frame before is left as it is.

use super::Forecast;
use crate::geometry::Point2;
use crate::limits::HORIZON;

/// The largest share of the previous forecast a blend carries: above it, a forecast would
/// hardly follow its evidence at all.
pub const MAX_CARRY: f32 = 0.9;

/// The share of the previous forecast carried, 0 (none: every forecast as made) ..=
/// [`MAX_CARRY`]; anything else (negative, larger, not finite) is read as the nearest valid
/// value, NaN as 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Carry(f32);

impl Carry {
    /// No blending: every forecast as its predictor made it.
    pub const NONE: Self = Self(0.0);

    /// `share`, limited to 0..=[`MAX_CARRY`] (NaN: 0).
    #[must_use]
    pub fn new(share: f32) -> Self {
        if share.is_nan() { Self::NONE } else { Self(share.clamp(0.0, MAX_CARRY)) }
    }

    /// The share carried.
    #[must_use]
    pub const fn share(self) -> f32 {
        self.0
    }
}

/// A forecast as kept for the next frame: its first point, and each point's offset from it in
/// whole centimetres (128 bytes instead of 240; an offset beyond +-327 m saturates). What a
/// blend carries is read back from this, on the host as on the edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KeptForecast {
    origin_cm: [i32; 2],
    offsets_cm: [[i16; 2]; HORIZON],
}

impl KeptForecast {
    /// `forecast`, kept to the centimetre (non-finite coordinates are kept as 0).
    #[must_use]
    pub fn keep(forecast: &Forecast) -> Self {
        let cm = |v: f32| libm::roundf(v * 100.0);
        let first = forecast[0];
        let origin_cm = [cm(first.x) as i32, cm(first.y) as i32];
        let mut offsets_cm = [[0i16; 2]; HORIZON];
        for (o, p) in offsets_cm.iter_mut().zip(forecast) {
            *o = [(cm(p.x) - origin_cm[0] as f32) as i16, (cm(p.y) - origin_cm[1] as f32) as i16];
        }
        Self { origin_cm, offsets_cm }
    }

    /// Point `k` (0 = the first step), metres.
    fn point(&self, k: usize) -> Point2 {
        let [dx, dy] = self.offsets_cm.get(k).copied().unwrap_or([0, 0]);
        let at = |origin: i32, offset: i16| (origin as f32 + f32::from(offset)) / 100.0;
        Point2::new(at(self.origin_cm[0], dx), at(self.origin_cm[1], dy))
    }
}

/// Blends `fresh` (made at frame s) with `previous` (made at frame s - 1) in place, as the
/// module docs say, reading `previous` to the centimetre as [`ForecastMemory`] keeps it.
pub fn carry_forward(previous: &Forecast, carry: Carry, fresh: &mut Forecast) {
    if carry.share() > 0.0 {
        carry_kept(&KeptForecast::keep(previous), carry, fresh);
    }
}

/// [`carry_forward`] from a kept forecast.
fn carry_kept(previous: &KeptForecast, carry: Carry, fresh: &mut Forecast) {
    let c = carry.share();
    if c <= 0.0 {
        return;
    }
    let (last, before) = (previous.point(HORIZON - 1), previous.point(HORIZON - 2));
    let extended = Point2::new(2.0 * last.x - before.x, 2.0 * last.y - before.y);
    let carried = (1..HORIZON).map(|k| previous.point(k)).chain(core::iter::once(extended));
    for (f, p) in fresh.iter_mut().zip(carried) {
        *f = Point2::new((1.0 - c) * f.x + c * p.x, (1.0 - c) * f.y + c * p.y);
    }
}

/// One object's last forecast.
#[derive(Debug, Clone, Copy)]
struct Kept {
    object: u32,
    frame: u32,
    forecast: KeptForecast,
}

/// The last forecast of up to `N` objects, for [`carry_forward`] across frames without a heap.
///
/// When all `N` places hold objects, a new object takes the place of the one forecast longest
/// ago (counted in [`Self::replaced`]); a caller that forecasts at most `N` objects per frame
/// never loses one forecast at the frame before.
#[derive(Debug, Clone)]
pub struct ForecastMemory<const N: usize> {
    kept: [Option<Kept>; N],
    replaced: u32,
}

impl<const N: usize> Default for ForecastMemory<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> ForecastMemory<N> {
    /// Empty.
    #[must_use]
    pub const fn new() -> Self {
        Self { kept: [None; N], replaced: 0 }
    }

    /// Blends `forecast`, made for `object` at `frame`, with that object's forecast at
    /// `frame - 1` when one is kept ([`carry_forward`]), and keeps the result for the next frame.
    pub fn blend(&mut self, object: u32, frame: u32, carry: Carry, forecast: &mut Forecast) {
        let slot = self.kept.iter().position(|k| k.is_some_and(|k| k.object == object));
        if let Some(prev) = slot.and_then(|i| self.kept.get(i)).copied().flatten()
            && prev.frame.checked_add(1) == Some(frame)
        {
            carry_kept(&prev.forecast, carry, forecast);
        }
        let slot = slot.or_else(|| self.kept.iter().position(Option::is_none)).or_else(|| {
            self.replaced = self.replaced.saturating_add(1);
            (0..N).min_by_key(|&i| self.kept.get(i).copied().flatten().map_or(0, |k| k.frame))
        });
        if let Some(place) = slot.and_then(|i| self.kept.get_mut(i)) {
            *place = Some(Kept { object, frame, forecast: KeptForecast::keep(forecast) });
        }
    }

    /// Forgets every object (a new stream).
    pub fn clear(&mut self) {
        // In place: a fresh array would be built on the stack first.
        for k in &mut self.kept {
            *k = None;
        }
    }

    /// Objects whose place a new object took while all places were held.
    #[must_use]
    pub const fn replaced(&self) -> u32 {
        self.replaced
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(start: f32, step: f32) -> Forecast {
        core::array::from_fn(|k| Point2::new(start + step * (k + 1) as f32, 0.0))
    }

    #[test]
    fn a_kept_forecast_reads_back_to_the_centimetre() {
        let f: Forecast = core::array::from_fn(|k| Point2::new(1234.567 + 0.731 * k as f32, -88.123 - 1.3 * k as f32));
        let kept = KeptForecast::keep(&f);
        for (k, p) in f.iter().enumerate() {
            assert!(kept.point(k).distance(p) < 0.0075, "{k}: {:?} vs {p:?}", kept.point(k));
        }
        let wild: Forecast =
            core::array::from_fn(|k| if k == 3 { Point2::new(f32::NAN, 1e9) } else { Point2::new(0.0, 0.0) });
        let kept = KeptForecast::keep(&wild);
        assert!(kept.point(3).x == 0.0 && kept.point(3).y > 300.0, "saturated, not wrapped: {:?}", kept.point(3));
    }

    #[test]
    fn a_forecast_that_agrees_with_the_last_is_unchanged() {
        // Constant velocity, 1 m per frame: the forecast at s - 1 carried on is the one at s.
        let previous = line(0.0, 1.0);
        let mut fresh = line(1.0, 1.0);
        let expected = fresh;
        carry_forward(&previous, Carry::new(0.5), &mut fresh);
        assert_eq!(fresh, expected);
    }

    #[test]
    fn a_jump_is_carried_by_the_share_and_fades() {
        let mut memory = ForecastMemory::<2>::new();
        let carry = Carry::new(0.5);
        let mut a = line(0.0, 1.0);
        memory.blend(7, 10, carry, &mut a);
        assert_eq!(a, line(0.0, 1.0), "the first forecast of an object is as made");
        // The fresh forecast at frame 11 says 2 m per frame: half of the change is taken.
        let mut b = line(1.0, 2.0);
        memory.blend(7, 11, carry, &mut b);
        let k = HORIZON - 1;
        let (fresh, carried) = (1.0 + 2.0 * 30.0, 31.0);
        assert!((b[k].x - 0.5 * (fresh + carried)).abs() < 1e-4, "{:?}", b[k]);
        // A gap of a frame: nothing is carried.
        let mut c = line(3.0, 2.0);
        memory.blend(7, 13, carry, &mut c);
        assert_eq!(c, line(3.0, 2.0));
    }

    #[test]
    fn carry_is_bounded_and_none_changes_nothing() {
        assert_eq!(Carry::new(f32::NAN), Carry::NONE);
        assert_eq!(Carry::new(-1.0), Carry::NONE);
        assert_eq!(Carry::new(5.0).share(), MAX_CARRY);
        let mut fresh = line(1.0, 3.0);
        carry_forward(&line(0.0, 1.0), Carry::NONE, &mut fresh);
        assert_eq!(fresh, line(1.0, 3.0));
    }

    #[test]
    fn a_full_memory_gives_the_oldest_place_to_a_new_object() {
        let mut memory = ForecastMemory::<2>::new();
        let carry = Carry::new(0.5);
        let mut f = line(0.0, 1.0);
        memory.blend(1, 10, carry, &mut f);
        memory.blend(2, 11, carry, &mut f);
        memory.blend(3, 11, carry, &mut f);
        assert_eq!(memory.replaced(), 1);
        // Object 2 (frame 11) is still kept: its next forecast is blended.
        let mut g = line(5.0, 3.0);
        memory.blend(2, 12, carry, &mut g);
        assert_ne!(g, line(5.0, 3.0));
        // Object 1 was the oldest and is gone.
        let mut h = line(5.0, 3.0);
        memory.blend(1, 11, carry, &mut h);
        assert_eq!(h, line(5.0, 3.0));
    }

    #[test]
    fn size_is_bounded_by_the_capacity() {
        assert!(core::mem::size_of::<KeptForecast>() <= 8 + HORIZON * 4);
        assert!(core::mem::size_of::<ForecastMemory<16>>() <= 16 * (8 + HORIZON * 4 + 12) + 8);
    }
}

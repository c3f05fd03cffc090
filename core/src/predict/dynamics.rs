//! How a forecast moves under the decoder's two outputs: Trajectron++'s two agent dynamics.
//!
//! - [`Dynamics::Unicycle`] (vehicles, cyclists): the outputs are a turn rate and an
//!   acceleration added to the motion prior's controls, clamped to the paper's limits, and
//!   integrated by the unicycle.
//! - [`Dynamics::SingleIntegrator`] (pedestrians): the outputs are a velocity in the agent frame
//!   (x along the current heading) added to the prior's; positions are the prior's path plus
//!   the integrated residual velocity. A walker stops, starts and turns on the spot, which a
//!   unicycle with bounded turn rate cannot follow.
//!
//! At a zero output both forecast the motion prior, bit for bit.

use crate::class::ObjectClass;
use crate::limits::{MAX_ACCEL, MAX_TURN_RATE};

/// Standardised turn-rate output times this is rad/s.
pub const TURN_RATE_SCALE: f32 = MAX_TURN_RATE;
/// Standardised acceleration output times this is m/s^2.
pub const ACCEL_SCALE: f32 = MAX_ACCEL;

/// Standard deviation of a pedestrian's residual velocity the decoder's outputs are scaled by,
/// m/s per unit output.
pub const VELOCITY_RESIDUAL_SCALE: f32 = 1.0;

/// Bound on each component of a pedestrian's residual velocity, m/s: a sprint's speed, so no
/// forecast runs off with an untrained output.
pub const MAX_VELOCITY_RESIDUAL: f32 = 4.0;

/// An agent's dynamics (the model blob's header holds its code).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Dynamics {
    /// Turn rate and acceleration (the paper's, and every vehicle's).
    #[default]
    Unicycle,
    /// Velocity (Trajectron++'s pedestrians).
    SingleIntegrator,
}

impl Dynamics {
    /// Every dynamics, in code order.
    pub const ALL: [Self; 2] = [Self::Unicycle, Self::SingleIntegrator];

    /// The code the blob header stores.
    #[must_use]
    pub const fn code(self) -> u8 {
        match self {
            Self::Unicycle => 0,
            Self::SingleIntegrator => 1,
        }
    }

    /// The dynamics of a header code.
    #[must_use]
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(Self::Unicycle),
            1 => Some(Self::SingleIntegrator),
            _ => None,
        }
    }

    /// The dynamics an object of `class` is forecast with: the single integrator for people
    /// (pedestrians, sitting persons), the unicycle for everything else. The class every wire
    /// track and object state carries is the agent type: host and edge route by it, and a blob
    /// forecasts only the objects of its own dynamics.
    #[must_use]
    pub const fn of_class(class: ObjectClass) -> Self {
        if class.is_person() { Self::SingleIntegrator } else { Self::Unicycle }
    }

    /// Index of this dynamics in [`Self::ALL`] (a slot per dynamics, as the edge keeps).
    #[must_use]
    pub const fn index(self) -> usize {
        self.code() as usize
    }

    /// The agent type's name in reports and file names: `vehicles` (and cyclists) or
    /// `pedestrians`.
    #[must_use]
    pub const fn agents(self) -> &'static str {
        match self {
            Self::Unicycle => "vehicles",
            Self::SingleIntegrator => "pedestrians",
        }
    }

    /// Physical units per unit of the decoder's two standardised outputs.
    #[must_use]
    pub const fn residual_scales(self) -> [f32; 2] {
        match self {
            Self::Unicycle => [TURN_RATE_SCALE, ACCEL_SCALE],
            Self::SingleIntegrator => [VELOCITY_RESIDUAL_SCALE, VELOCITY_RESIDUAL_SCALE],
        }
    }

    /// The name reports and errors use.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Unicycle => "unicycle",
            Self::SingleIntegrator => "single integrator",
        }
    }
}

/// A pedestrian's residual velocity component clamped to [`MAX_VELOCITY_RESIDUAL`].
#[must_use]
pub fn clamp_velocity_residual(v: f32) -> f32 {
    v.clamp(-MAX_VELOCITY_RESIDUAL, MAX_VELOCITY_RESIDUAL)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip_and_unknown_codes_are_refused() {
        for d in Dynamics::ALL {
            assert_eq!(Dynamics::from_code(d.code()), Some(d));
        }
        assert_eq!(Dynamics::from_code(2), None);
        assert_eq!(Dynamics::default(), Dynamics::Unicycle, "a header's zero byte is the unicycle");
        for (i, d) in Dynamics::ALL.into_iter().enumerate() {
            assert_eq!(d.index(), i);
        }
    }

    #[test]
    fn people_walk_and_everything_else_drives() {
        for c in ObjectClass::ALL {
            let want = if c.is_person() { Dynamics::SingleIntegrator } else { Dynamics::Unicycle };
            assert_eq!(Dynamics::of_class(c), want, "{c:?}");
        }
    }
}

//! The arguments that describe a model: its widths and its agent type's dynamics.

use dynotraj_core::predict::Dynamics;

/// `Dims::DEFAULT` (the ECU setting) as the commands' `--dims` default; a test holds the two
/// together.
pub const DEFAULT_DIMS: &str = "8,8,3,8";

/// `--dynamics` values: an agent type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DynamicsArg {
    /// Turn rate and acceleration: vehicles and cyclists.
    Unicycle,
    /// Velocity: pedestrians.
    SingleIntegrator,
}

impl From<DynamicsArg> for Dynamics {
    fn from(d: DynamicsArg) -> Self {
        match d {
            DynamicsArg::Unicycle => Self::Unicycle,
            DynamicsArg::SingleIntegrator => Self::SingleIntegrator,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynotraj_core::model::arch::Dims;

    #[test]
    fn the_default_dims_flag_is_the_core_default() {
        assert_eq!(crate::model_cost::parse_dims(DEFAULT_DIMS).unwrap(), Dims::DEFAULT);
    }
}

//! Named, seeded parameters in a candle [`VarMap`].
//!
//! candle's CPU random generator cannot be seeded, so parameters are created as zeros and then
//! filled from our own seeded generator: the same seed gives the same initial network. The
//! initial values follow PyTorch's defaults (uniform in +-1/sqrt(fan_in) for linear layers,
//! +-1/sqrt(hidden) for recurrent cells), which Trajectron++ trains from.

use candle_core::{DType, Device, Result, Tensor};
use candle_nn::{Init, VarMap};
use rand::{Rng as _, SeedableRng as _};
use rand_xoshiro::Xoshiro256PlusPlus;

/// The parameter store of one network and the generator that initialises it.
pub struct ParamStore {
    vars: VarMap,
    rng: Xoshiro256PlusPlus,
}

impl ParamStore {
    /// An empty store whose initial values come from `seed`.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Self { vars: VarMap::new(), rng: Xoshiro256PlusPlus::seed_from_u64(seed) }
    }

    /// Creates parameter `name` of `shape`, uniform in +-`bound`, and returns its tensor (which
    /// tracks gradients).
    ///
    /// # Errors
    /// A name used twice with another shape.
    pub fn uniform(&mut self, name: &str, shape: &[usize], bound: f32) -> Result<Tensor> {
        let t = self.vars.get(shape, name, Init::Const(0.0), DType::F32, &Device::Cpu)?;
        let n: usize = shape.iter().product();
        let values: Vec<f32> = (0..n).map(|_| self.rng.random_range(-bound..=bound)).collect();
        self.vars.set_one(name, Tensor::from_vec(values, shape, &Device::Cpu)?)?;
        Ok(t)
    }

    /// The variables.
    #[must_use]
    pub fn into_vars(self) -> VarMap {
        self.vars
    }
}

/// PyTorch's default bound for a layer with `fan_in` inputs (or a recurrent cell of that width).
#[must_use]
pub fn default_bound(fan_in: usize) -> f32 {
    1.0 / (fan_in.max(1) as f32).sqrt()
}

//! The trajectory predictor: a Trajectron++-style CVAE with an LSTM history encoder, a
//! neighbour (edge) encoder, a discrete latent and a GRU decoder over unicycle controls.
//!
//! - [`arch`]: the one architecture definition (sizes, feature definition, weight layout).
//! - [`features`]: the input features, shared by training (host) and inference (ECU).
//! - [`dot`]: the int8 dot products, the one part a target may replace with its own instructions.
//! - [`blob`]: the versioned, checksummed model image in f32 or int8, read in place.
//! - [`signed`]: a blob with an Ed25519 signature trailer, checked against a provisioned key.

pub mod arch;
pub mod blob;
pub mod dot;
pub mod features;
pub mod infer;
pub mod kernel;
mod lut;
pub mod signed;
pub mod stand_in;

pub use arch::Dims;
pub use dot::{Int8Dot, PortableDot};
pub use infer::{LearnedPredictor, Scratch, forecast};

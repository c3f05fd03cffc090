//! The predictors that are scored: the baselines by name and trained model files
//! (`model:PATH`), as `dynotraj eval --predictor` names them, loaded into forecasters.

use std::path::PathBuf;

use dynotraj_core::predict::{Baseline, Dynamics, MotionPrior, PriorSettings};

use dynotraj_core::predict::Predictor;
use dynotraj_formats::model_file::ModelFile;

/// A predictor `eval` can run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PredictorSpec {
    /// A baseline by its name ([`Baseline::name`]): cv (constant velocity from the last two
    /// positions), cv-fit (along the fitted current velocity), ctra (constant turn rate and
    /// acceleration on the unicycle, within the paper's limits).
    Baseline(Baseline),
    /// The motion prior (`prior`, with `PriorSettings::DEFAULT`) or the prior a trained model
    /// holds (`prior:PATH`: the settings its training chose).
    Prior(Option<PathBuf>),
    /// A trained model blob (f32 or int8) from `dynotraj train`.
    Model(PathBuf),
}

impl std::str::FromStr for PredictorSpec {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if let Some(b) = Baseline::ALL.into_iter().find(|b| b.name() == s) {
            return Ok(Self::Baseline(b));
        }
        if s == "prior" {
            return Ok(Self::Prior(None));
        }
        if let Some(p) = s.strip_prefix("prior:").filter(|p| !p.is_empty()) {
            return Ok(Self::Prior(Some(PathBuf::from(p))));
        }
        s.strip_prefix("model:").filter(|p| !p.is_empty()).map(|p| Self::Model(PathBuf::from(p))).ok_or_else(|| {
            format!("unknown predictor `{s}`: expected cv, cv-fit, ctra, prior, prior:PATH or model:PATH")
        })
    }
}

impl PredictorSpec {
    /// The name in tables.
    #[must_use]
    pub fn label(&self) -> String {
        match self {
            Self::Baseline(b) => b.name().into(),
            Self::Prior(None) => "prior".into(),
            Self::Prior(Some(p)) => format!(
                "prior of {}",
                p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
            ),
            Self::Model(p) => format!(
                "model {}",
                p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
            ),
        }
    }
}

/// A predictor ready to forecast: a baseline, or a model file read and checked.
#[derive(Debug)]
pub enum LoadedPredictor {
    /// A baseline.
    Baseline(Baseline),
    /// The motion prior with these settings.
    Prior(MotionPrior),
    /// A model blob.
    Model(ModelFile),
}

impl LoadedPredictor {
    /// Loads `spec` for forecasts at frame period `dt` seconds.
    ///
    /// # Errors
    /// A model file that cannot be read or parsed, or that was trained at another frame
    /// period: it would forecast nothing at this one (every row `-`), so this says so instead.
    pub fn load(spec: &PredictorSpec, dt: f32) -> anyhow::Result<Self> {
        match spec {
            PredictorSpec::Baseline(b) => Ok(Self::Baseline(*b)),
            PredictorSpec::Prior(None) => Ok(Self::Prior(MotionPrior(PriorSettings::DEFAULT))),
            PredictorSpec::Prior(Some(path)) => Ok(Self::Prior(MotionPrior(*ModelFile::load(path)?.blob().prior()))),
            PredictorSpec::Model(path) => {
                let m = ModelFile::load(path)?;
                let trained = m.blob().frame_period_s();
                anyhow::ensure!(
                    (trained - dt).abs() <= 1e-6 * dt.max(trained),
                    "model {}: trained at {:.3} Hz, evaluated with --rate {:.3} Hz; give --rate {:.3}",
                    path.display(),
                    1.0 / trained,
                    1.0 / dt,
                    1.0 / trained
                );
                Ok(Self::Model(m))
            }
        }
    }

    /// Whether it forecasts agents of `dynamics`: a baseline or a prior forecasts any agent, a
    /// model only those of its blob's dynamics.
    #[must_use]
    pub fn forecasts(&self, dynamics: Dynamics) -> bool {
        match self {
            Self::Baseline(_) | Self::Prior(_) => true,
            Self::Model(m) => m.blob().dynamics() == dynamics,
        }
    }

    /// The forecaster.
    #[must_use]
    pub fn forecaster(&self) -> Box<dyn Predictor + '_> {
        match self {
            Self::Baseline(b) => Box::new(*b),
            Self::Prior(p) => Box::new(*p),
            Self::Model(m) => Box::new(m.predictor()),
        }
    }
}

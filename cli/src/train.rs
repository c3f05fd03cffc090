//! `dynotraj train`: trains the predictor on every sequence but the excluded ones (one fold of
//! the leave-one-sequence-out protocol) and writes the model blob and checkpoint.

use std::path::PathBuf;

use anyhow::Context as _;
use clap::{Args, ValueEnum};
use dynotraj_core::model::arch::Dims;
use dynotraj_core::model::blob::Precision;
use dynotraj_core::predict::PriorSettings;

use super::data_args::DataArgs;
use super::model_args::{DEFAULT_DIMS, DynamicsArg};
use super::model_cost::parse_dims;
use super::progress::progress;
use dynotraj_sources::trajectory::Source;
use dynotraj_train::loss::LossConfig;
use dynotraj_train::{
    DEFAULT_MIRROR, DEFAULT_SHRINK, DEFAULT_VALIDATE_ON_SEQUENCES, DEFAULT_VALIDATION_FRACTION, Event, Hyper,
    PriorChoice, PriorObjective, TrainConfig, train_fold_with,
};

/// Blob precisions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PrecisionArg {
    /// 32-bit floats.
    F32,
    /// int8 weights with per-channel scales.
    Int8,
}

impl From<PrecisionArg> for Precision {
    fn from(p: PrecisionArg) -> Self {
        match p {
            PrecisionArg::F32 => Self::F32,
            PrecisionArg::Int8 => Self::Int8,
        }
    }
}

/// What a fold's motion prior settings are chosen for (`--prior-objective`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PriorObjectiveArg {
    /// The least mean ADE on the training sequences.
    Ade,
    /// The least mean ADE among the settings whose consistency error (ACE) on the training
    /// sequences is no worse than constant velocity's (the default).
    AdeWithinCvAce,
    /// The least mean ADE plus mean ACE.
    AdePlusAce,
}

/// The model blob's name in `train --out`'s folder.
pub const MODEL_FILE: &str = "model.blob";

/// Options of `dynotraj train`.
#[derive(Debug, Args)]
#[command(
    after_help = "Each training runs on one thread (candle's kernels split over threads train this small network \
        about 3 times slower); --jobs spreads folds over the cores."
)]
pub struct TrainArgs {
    /// Data options.
    #[command(flatten)]
    pub data: DataArgs,
    /// Trajectory source for inputs and targets: gt (labels), gt-ekf (forward EKF: causal),
    /// gt-rts (fixed-lag RTS smoother: inputs have seen later frames), estimated (Ours: the core
    /// estimator's newest-frame estimates on the KITTI-driven simulator, no labels) or
    /// estimated-ekf (Ours through gt-ekf's forward EKF: causal) or estimated-smoothed (its
    /// states as they leave the smoothing window).
    #[arg(long, default_value = "gt", value_name = "SOURCE")]
    pub source: Source,
    /// Sequences held out of training (the fold's test sequences), comma-separated.
    #[arg(long, value_delimiter = ',', value_parser = crate::numbers::sequence_id, required = true, value_name = "SEQ[,SEQ..]")]
    pub exclude: Vec<String>,
    /// Sequences to load, comma-separated (default: every sequence in the folder); the
    /// excluded ones are then dropped.
    #[arg(long = "sequences", visible_alias = "sequence", value_delimiter = ',', value_parser = crate::numbers::sequence_id, value_name = "LIST")]
    pub sequences: Vec<String>,
    /// Folder for the model: `model.blob` (at --precision), `model.blob.int8` (the int8 blob)
    /// and `model.blob.safetensors` (the checkpoint: every parameter, training-only ones too,
    /// and the f32 blob).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Network widths: history encoder, edge encoder, latent modes, decoder.
    #[arg(long, default_value = DEFAULT_DIMS, value_parser = parse_dims, value_name = "ENC,EDGE,K,DEC")]
    pub dims: Dims,
    /// The agent type trained, among the classes of --classes: unicycle (vehicles and cyclists)
    /// or single-integrator (pedestrians). One blob per agent type; the edge takes both.
    #[arg(long, value_enum, default_value_t = DynamicsArg::Unicycle)]
    pub dynamics: DynamicsArg,
    /// Optimisation and loss settings.
    #[command(flatten)]
    pub hyper: HyperArgs,
    /// Precision of `model.blob` (`model.blob.int8` is always int8).
    #[arg(long, value_enum, default_value_t = PrecisionArg::F32)]
    pub precision: PrecisionArg,
}

/// Training settings shared by `dynotraj train` and `dynotraj experiment`; the defaults are
/// [`Hyper::default`] and [`TrainConfig::new`]'s (how they were chosen: docs/decisions.md).
#[derive(Debug, Clone, Args)]
pub struct HyperArgs {
    /// Most epochs (training stops earlier when the validation ADE has not improved for
    /// --patience epochs; the best epoch's weights are kept).
    #[arg(long, default_value_t = Hyper::default().epochs, value_name = "N")]
    pub epochs: usize,
    /// Epochs without a better validation ADE before stopping.
    #[arg(long, default_value_t = Hyper::default().patience, value_name = "N")]
    pub patience: usize,
    /// Samples per optimiser step.
    #[arg(long, default_value_t = Hyper::default().batch, value_name = "N")]
    pub batch: usize,
    /// Seed of the initial weights and the shuffling (the validation split has a fixed seed of
    /// its own, so every seed is judged on the same sequences).
    #[arg(long, default_value_t = Hyper::default().seed, value_name = "N")]
    pub seed: u64,
    /// Adam's initial learning rate (decays by 0.9999 per step).
    #[arg(
        long,
        value_parser = crate::numbers::positive,
        default_value_t = Hyper::default().learning_rate,
        value_name = "RATE",
    )]
    pub lr: f64,
    /// AdamW's decoupled weight decay.
    #[arg(
        long,
        value_parser = crate::numbers::non_negative,
        default_value_t = Hyper::default().weight_decay,
        value_name = "DECAY",
    )]
    pub weight_decay: f64,
    /// Standard deviation of the position noise floor of the likelihood, metres: error the
    /// controls need not explain (label or estimator noise).
    #[arg(
        long,
        value_parser = crate::numbers::positive_f32,
        default_value_t = LossConfig::default().position_floor_m,
        value_name = "METRES",
    )]
    pub position_floor: f32,
    /// Weight of the CVAE objective (0: train on the position error alone).
    #[arg(
        long,
        value_parser = crate::numbers::non_negative_f32,
        default_value_t = LossConfig::default().likelihood_weight,
        value_name = "W",
    )]
    pub likelihood_weight: f32,
    /// Weight of the p(z|x)-weighted ADE of the mean forecasts, per metre.
    #[arg(
        long,
        value_parser = crate::numbers::non_negative_f32,
        default_value_t = LossConfig::default().ade_weight,
        value_name = "W",
    )]
    pub ade_weight: f32,
    /// Keep the trained mean-control outputs as they are. By default they are scaled, after
    /// training, by the factor (0.25, 0.5, 0.75 or 1) with the best validation ADE.
    #[arg(long = "no-shrink", action = clap::ArgAction::SetFalse)]
    pub shrink: bool,
    /// Decay per step of the moving average of the weights that is validated and kept (0: the
    /// last step's weights).
    #[arg(
        long,
        value_parser = crate::numbers::fraction,
        default_value_t = Hyper::default().ema_decay,
        value_name = "DECAY",
    )]
    pub ema_decay: f64,
    /// Independent trainings from different seeds; the one with the best validation ADE is
    /// kept.
    #[arg(long, default_value_t = Hyper::default().restarts, value_name = "N")]
    pub restarts: usize,
    /// Share of the training runs held out for early stopping and model selection.
    #[arg(
        long,
        value_parser = crate::numbers::fraction_f32,
        default_value_t = DEFAULT_VALIDATION_FRACTION,
        value_name = "SHARE",
    )]
    pub val_fraction: f32,
    /// Validate on runs of every training sequence. By default whole training sequences (at
    /// least --val-fraction of the instances) are held out for validation.
    #[arg(long = "no-val-sequences", action = clap::ArgAction::SetFalse)]
    pub val_sequences: bool,
    /// Train on the instances as recorded only. By default every training instance is also
    /// trained reflected left-right.
    #[arg(long = "no-mirror", action = clap::ArgAction::SetFalse)]
    pub mirror: bool,
    /// The paper's setting: the network alone over the rollout start (seven states, no motion
    /// prior). By default the network learns a residual over a motion prior whose settings are
    /// chosen on the training sequences.
    #[arg(long = "no-prior", action = clap::ArgAction::SetFalse)]
    pub prior: bool,
    /// What the motion prior's settings are chosen for on the training sequences
    /// (docs/decisions.md, "A motion prior under the network").
    #[arg(long, value_enum, default_value = "ade-within-cv-ace", conflicts_with = "prior", value_name = "OBJECTIVE")]
    pub prior_objective: PriorObjectiveArg,
}

// The three switches above turn a default off; they would mean nothing if a default were off.
const _: () = assert!(DEFAULT_SHRINK && DEFAULT_VALIDATE_ON_SEQUENCES && DEFAULT_MIRROR);

impl HyperArgs {
    /// The settings, checked.
    ///
    /// # Errors
    /// A value out of range, naming its flag.
    pub fn hyper(&self) -> anyhow::Result<Hyper> {
        anyhow::ensure!(
            self.position_floor > 0.0,
            "--position-floor: expected metres > 0, found {}",
            self.position_floor
        );
        anyhow::ensure!(
            self.likelihood_weight >= 0.0 && self.ade_weight >= 0.0,
            "--likelihood-weight, --ade-weight: expected >= 0"
        );
        anyhow::ensure!(
            self.likelihood_weight > 0.0 || self.ade_weight > 0.0,
            "--likelihood-weight and --ade-weight are both 0: nothing to train on"
        );
        anyhow::ensure!(self.weight_decay >= 0.0, "--weight-decay: expected >= 0, found {}", self.weight_decay);
        anyhow::ensure!(
            (0.0..1.0).contains(&self.val_fraction),
            "--val-fraction: expected a share in [0, 1), found {}",
            self.val_fraction
        );
        anyhow::ensure!(
            (0.0..1.0).contains(&self.ema_decay),
            "--ema-decay: expected a decay in [0, 1), found {}",
            self.ema_decay
        );
        anyhow::ensure!(self.restarts >= 1, "--restarts: expected at least 1, found {}", self.restarts);
        anyhow::ensure!(self.batch > 0 && self.epochs > 0, "--batch and --epochs must be at least 1");
        let loss = LossConfig {
            position_floor_m: self.position_floor,
            likelihood_weight: self.likelihood_weight,
            ade_weight: self.ade_weight,
            ..LossConfig::default()
        };
        Ok(Hyper {
            epochs: self.epochs,
            batch: self.batch,
            seed: self.seed,
            patience: self.patience,
            learning_rate: self.lr,
            weight_decay: self.weight_decay,
            shrink: self.shrink,
            ema_decay: self.ema_decay,
            restarts: self.restarts,
            loss,
            ..Hyper::default()
        })
    }

    /// Applies these settings to a fold's configuration.
    ///
    /// # Errors
    /// See [`HyperArgs::hyper`].
    pub fn apply(&self, config: &mut TrainConfig<'_>) -> anyhow::Result<()> {
        config.hyper = self.hyper()?;
        config.validation_fraction = self.val_fraction;
        config.mirror = self.mirror;
        config.validate_on_sequences = self.val_sequences;
        config.prior = self.prior_choice();
        Ok(())
    }

    /// The fold's motion prior: chosen on the training sequences, or off (`--no-prior`).
    #[must_use]
    pub fn prior_choice(&self) -> PriorChoice {
        match (self.prior, self.prior_objective) {
            (false, _) => PriorChoice::Fixed(PriorSettings::OFF),
            (true, PriorObjectiveArg::Ade) => PriorChoice::TunedFor(PriorObjective::Ade),
            (true, PriorObjectiveArg::AdeWithinCvAce) => PriorChoice::Tuned,
            (true, PriorObjectiveArg::AdePlusAce) => PriorChoice::TunedFor(PriorObjective::AdePlusAce),
        }
    }
}

/// Trains, writes the files and prints a one-line summary.
///
/// # Errors
/// Loading errors, no training instances, I/O errors.
pub fn run(args: &TrainArgs) -> anyhow::Result<()> {
    dynotraj_formats::atomic::output_folder("--out", &args.out)?;
    let dt = args.data.dt()?;
    let rule = args.data.rule()?;
    let sequences = args.data.load_for(&args.sequences, &[args.source])?;
    for ex in &args.exclude {
        // Training on every sequence, the one meant to be held out among them, must not pass
        // for a fold.
        anyhow::ensure!(
            sequences.iter().any(|s| &s.id == ex),
            "--exclude {ex}: no such sequence was loaded (loaded: {})",
            sequences.iter().map(|s| s.id.as_str()).collect::<Vec<_>>().join(", ")
        );
    }
    let mut config = TrainConfig {
        dt,
        rule,
        dims: args.dims,
        dynamics: args.dynamics.into(),
        ..TrainConfig::new(&sequences, args.exclude.clone(), args.source)
    };
    args.hyper.apply(&mut config)?;
    let bar = progress(0, "training");
    let mut val = f32::NAN;
    let model = train_fold_with(&config, &mut |e| match e {
        Event::Step { step, total, loss } => {
            bar.set_length(total as u64);
            bar.set_position(step as u64);
            bar.set_message(format!("loss {loss:.2} val ADE {val:.3}"));
        }
        Event::Epoch(r) => {
            val = r.val_ade;
            log::info!(
                "epoch {}: loss {:.3} log-lik {:.3} KL {:.3} beta {:.1} val ADE {:.3} ({:.1} s)",
                r.epoch,
                r.loss,
                r.log_likelihood,
                r.kl,
                r.beta,
                r.val_ade,
                r.seconds
            );
        }
    })?;
    bar.finish_and_clear();
    std::fs::create_dir_all(&args.out).with_context(|| format!("--out: creating {}", args.out.display()))?;
    let files = model.save_as(&args.out.join(MODEL_FILE), args.precision.into())?;
    let r = &model.report;
    println!(
        "trained {} on {} ({} params): {} train / {} val instances, {} epochs (best {}), best val ADE {:.3} m \
            (constant velocity {:.3} m), {:.1} s; wrote {}, {}, {}",
        args.source,
        r.sequences.join(","),
        args.dims.parameters(),
        r.train_instances,
        r.val_instances,
        r.epochs,
        r.best_epoch,
        r.best_val_ade,
        r.val_cv_ade,
        r.seconds,
        files.f32_blob.display(),
        files.int8_blob.display(),
        files.checkpoint.display()
    );
    let [f32_crc, int8_crc] = files.crc64()?;
    println!(
        "model CRC-64: {f32_crc:016x} ({}), int8 {int8_crc:016x} ({})",
        files.f32_blob.display(),
        files.int8_blob.display()
    );
    Ok(())
}

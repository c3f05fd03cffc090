//! The optimisation loop: seeded shuffling, Adam with per-step learning-rate decay, gradient
//! clipping by value, the KL schedule, and early stopping on the validation ADE of the
//! unimodal forecast (the best epoch's weights are restored at the end).

use std::collections::{BTreeMap, HashMap};
use std::time::Instant;

use candle_core::{Device, Result, Tensor, Var};
use candle_nn::{AdamW, Optimizer as _, ParamsAdamW, VarMap};
use dynotraj_core::metrics::ForecastScores;
use rand::SeedableRng as _;
use rand::seq::SliceRandom as _;
use rand_xoshiro::Xoshiro256PlusPlus;

use super::batch::Batch;
use super::bootstrap::{Metric, RatioInterval, ratio_interval};
use super::dataset::Sample;
use super::loss::{LossConfig, beta, loss};
use super::model::{Network, ade};

/// Optimisation settings.
///
/// Defaults: Trajectron++'s Adam, decay, clipping and KL plateau, with a smaller batch and
/// learning rate and early stopping, because a fold holds only about 65 runs (4000 heavily
/// overlapping instances): on KITTI fold 0000 (source gt) the validation ADE peaks within 2-5
/// epochs and then degrades as the model overfits, and batch 64 at lr 1e-3 got there as well
/// as batch 256 at 3e-3 in a third of the epochs, more steadily.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hyper {
    /// Most passes over the training samples.
    pub epochs: usize,
    /// Samples per optimiser step.
    pub batch: usize,
    /// Adam's initial learning rate.
    pub learning_rate: f64,
    /// Learning rate factor per step (Trajectron++: 0.9999).
    pub lr_decay: f64,
    /// Gradients are clamped to +-this, element by element (Trajectron++: 1.0).
    pub clip: f32,
    /// Plateau of the KL weight (Trajectron++: 100).
    pub beta_max: f32,
    /// Stop after this many epochs without a better validation ADE.
    pub patience: usize,
    /// Loss settings.
    pub loss: LossConfig,
    /// AdamW's decoupled weight decay (per step, times the learning rate).
    pub weight_decay: f64,
    /// Seed of the shuffling (and, in [`super::TrainConfig`], of the initial weights).
    pub seed: u64,
    /// Keep the untrained model (zero controls: the cv-fit forecast) when no
    /// epoch beats it on the held-out runs. Off only to study trained weights as they are.
    pub keep_untrained_if_better: bool,
    /// Decay of the exponential moving average of the weights, per step (0: off). The
    /// average, not the last step's weights, is validated, kept and exported: it smooths the
    /// step-to-step noise of small batches, so which epoch wins and what it forecasts depend
    /// less on the seed.
    pub ema_decay: f64,
    /// Independent trainings of a fold from different seeds ([`super::restart_seed`]); the one
    /// with the best validation ADE is kept. Why: with a fold's few validation sequences,
    /// whether a seed's first epochs improve on them before the patience runs out is a coin
    /// toss; the best of several is not.
    pub restarts: usize,
    /// After training, scale the mean-control outputs by the factor of [`SHRINK_FACTORS`]
    /// with the best held-out ADE ([`shrink_towards_cv`]).
    pub shrink: bool,
    /// With [`Hyper::keep_untrained_if_better`], keep the trained weights only when their
    /// held-out gain over the motion prior holds under a bootstrap over whole runs (the 97.5th
    /// percentile of the ADE ratio below 1); otherwise ship the prior (epoch 0). Why: a fold's few validation runs pick the best of many epochs,
    /// and a gain of a percent on them is as often noise as not.
    pub require_sure_gain: bool,
}

/// [`Hyper::ema_decay`] by default: off (tried on a training fold's validation sequences, no
/// gain: docs/decisions.md).
pub const DEFAULT_EMA_DECAY: f64 = 0.0;

/// Whether training shrinks the mean-control outputs towards constant velocity by default.
pub const DEFAULT_SHRINK: bool = true;

/// [`Hyper::restarts`] by default.
pub const DEFAULT_RESTARTS: usize = 1;

/// Factors tried by [`shrink_towards_cv`] (1: the trained weights; 0 would be the
/// cv-fit forecast, which the untrained epoch 0 already is).
pub const SHRINK_FACTORS: [f32; 4] = [0.25, 0.5, 0.75, 1.0];

impl Default for Hyper {
    fn default() -> Self {
        Self {
            epochs: 30,
            batch: 64,
            learning_rate: 1e-3,
            lr_decay: 0.9999,
            clip: 1.0,
            beta_max: 100.0,
            patience: 4,
            loss: LossConfig::default(),
            weight_decay: 0.05,
            seed: 1,
            keep_untrained_if_better: true,
            ema_decay: DEFAULT_EMA_DECAY,
            restarts: DEFAULT_RESTARTS,
            shrink: DEFAULT_SHRINK,
            require_sure_gain: true,
        }
    }
}

/// What one epoch did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpochReport {
    /// Epoch number, from 1.
    pub epoch: usize,
    /// Optimiser steps so far.
    pub steps: usize,
    /// Mean loss over the epoch's batches.
    pub loss: f32,
    /// Mean E_q[log p(y|x,z)] over the epoch's batches.
    pub log_likelihood: f32,
    /// Mean KL(q || p) over the epoch's batches.
    pub kl: f32,
    /// KL weight at the epoch's last step.
    pub beta: f32,
    /// Validation ADE after the epoch, metres.
    pub val_ade: f32,
    /// Seconds since training started.
    pub seconds: f32,
}

/// Progress events.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// An optimiser step finished: (step, total steps planned, batch loss).
    Step {
        /// Steps so far.
        step: usize,
        /// Steps if no early stop.
        total: usize,
        /// This batch's loss.
        loss: f32,
    },
    /// An epoch finished.
    Epoch(EpochReport),
}

/// The outcome of [`fit`].
#[derive(Debug, Clone, PartialEq)]
pub struct FitOutcome {
    /// Every epoch run.
    pub history: Vec<EpochReport>,
    /// The epoch whose weights were kept (from 1; 0 when no epoch ran).
    pub best_epoch: usize,
    /// Its validation ADE, metres.
    pub best_val_ade: f32,
    /// Optimiser steps run.
    pub steps: usize,
    /// The factor [`shrink_towards_cv`] kept (1 when not asked for).
    pub shrink: f32,
    /// The best epoch's held-out ADE over the prior's with its run-bootstrap interval, when an
    /// epoch beat the prior and [`Hyper::require_sure_gain`] judged it (kept when its upper end is
    /// below 1).
    pub gain: Option<RatioInterval>,
}

/// Mean ADE (metres) of the unimodal forecast over `samples`, in chunks.
///
/// # Errors
/// Shape errors; an empty set.
pub fn mean_ade(net: &Network, samples: &[Sample], dt: f32) -> Result<f32> {
    let ades = sample_ades(net, samples, dt)?;
    Ok((ades.iter().map(|&v| f64::from(v)).sum::<f64>() / samples.len() as f64) as f32)
}

/// ADE (metres) of the unimodal forecast of every sample, in order.
///
/// # Errors
/// Shape errors; an empty set.
pub fn sample_ades(net: &Network, samples: &[Sample], dt: f32) -> Result<Vec<f32>> {
    if samples.is_empty() {
        candle_core::bail!("no samples to score");
    }
    let mut out = Vec::with_capacity(samples.len());
    for chunk in samples.chunks(1024) {
        let refs: Vec<&Sample> = chunk.iter().collect();
        let b = Batch::new(&refs, &Device::Cpu)?;
        out.extend(ade(&net.forecast(&b, dt)?, &b.future)?);
    }
    Ok(out)
}

/// Fewest held-out runs a gain is judged on. A bootstrap over k runs has C(2k-1, k) distinct
/// draws: 126 at five runs, 10 at three, one at one, where the interval is a point and any
/// gain "holds". Below this, no gain is sure and the fold ships the prior (KITTI's pedestrians:
/// a fold's validation sequences hold one to three of them).
pub const MIN_JUDGED_RUNS: usize = 5;

/// The ADE ratio of `trained` over `untrained` (per-sample ADEs of `samples`) with its
/// bootstrap interval over whole runs; a gain is sure when the interval's upper end is below 1.
/// `None` over fewer than [`MIN_JUDGED_RUNS`] runs.
#[must_use]
pub fn judged_gain(samples: &[Sample], trained: &[f32], untrained: &[f32]) -> Option<RatioInterval> {
    let (num, den) = (by_run(samples, trained), by_run(samples, untrained));
    if num.len() < MIN_JUDGED_RUNS {
        return None;
    }
    ratio_interval(&num, &den, Metric::Ade)
}

/// Per-sample ADEs gathered into one [`ForecastScores`] per run (`Sample::group`), in group order.
fn by_run(samples: &[Sample], ades: &[f32]) -> Vec<ForecastScores> {
    let mut runs: BTreeMap<usize, ForecastScores> = BTreeMap::new();
    for (s, &a) in samples.iter().zip(ades) {
        let run = runs.entry(s.group).or_default();
        run.ade.push(a);
        run.fde.push(a);
    }
    runs.into_values().collect()
}

fn snapshot(vars: &VarMap) -> Result<HashMap<String, Tensor>> {
    let data = vars.data().lock().map_err(|_| candle_core::Error::Msg("variable store poisoned".into()))?;
    data.iter().map(|(k, v)| Ok((k.clone(), v.as_tensor().copy()?))).collect()
}

fn restore(vars: &VarMap, saved: &HashMap<String, Tensor>) -> Result<()> {
    let data = vars.data().lock().map_err(|_| candle_core::Error::Msg("variable store poisoned".into()))?;
    for (k, v) in data.iter() {
        if let Some(t) = saved.get(k) {
            v.set(t)?;
        }
    }
    Ok(())
}

/// The exponential moving average of a set of variables.
struct Average {
    decay: f64,
    values: Vec<Tensor>,
}

impl Average {
    fn new(decay: f64, params: &[Var]) -> Result<Self> {
        Ok(Self { decay, values: params.iter().map(|p| p.as_tensor().copy()).collect::<Result<_>>()? })
    }

    fn update(&mut self, params: &[Var]) -> Result<()> {
        for (avg, p) in self.values.iter_mut().zip(params) {
            *avg = ((&*avg * self.decay)? + (p.as_tensor() * (1.0 - self.decay))?)?;
        }
        Ok(())
    }

    /// Puts the average into `params` and returns the weights it replaced.
    fn swap_in(&self, params: &[Var]) -> Result<Vec<Tensor>> {
        let mut old = Vec::with_capacity(params.len());
        for (avg, p) in self.values.iter().zip(params) {
            old.push(p.as_tensor().copy()?);
            p.set(avg)?;
        }
        Ok(old)
    }
}

fn put_back(params: &[Var], old: &[Tensor]) -> Result<()> {
    for (p, t) in params.iter().zip(old) {
        p.set(t)?;
    }
    Ok(())
}

/// Trains `net` (whose variables are `vars`) on `train`, early-stopping on the ADE over
/// `validation` (over `train` when `validation` is empty), reporting to `observer`.
///
/// # Errors
/// An empty training set; numerical failure (a non-finite loss).
pub fn fit(
    net: &Network,
    vars: &VarMap,
    train: &[Sample],
    validation: &[Sample],
    dt: f32,
    hyper: &Hyper,
    observer: &mut dyn FnMut(Event),
) -> Result<FitOutcome> {
    if train.is_empty() {
        candle_core::bail!("no training samples");
    }
    let held_out = if validation.is_empty() { train } else { validation };
    let start = Instant::now();
    // Sorted names give the optimiser (and so the run) a fixed variable order.
    let mut named: Vec<(String, Var)> = vars
        .data()
        .lock()
        .map_err(|_| candle_core::Error::Msg("poisoned".into()))?
        .iter()
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    named.sort_by(|a, b| a.0.cmp(&b.0));
    let params: Vec<Var> = named.into_iter().map(|(_, v)| v).collect();
    let mut opt = AdamW::new(
        params.clone(),
        ParamsAdamW { lr: hyper.learning_rate, weight_decay: hyper.weight_decay, ..ParamsAdamW::default() },
    )?;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(hyper.seed);
    let batch = hyper.batch.max(1);
    let per_epoch = train.len().div_ceil(batch);
    let total = per_epoch * hyper.epochs;
    let mut order: Vec<usize> = (0..train.len()).collect();
    // Epoch 0 is the untrained model (the cv-fit forecast, constant velocity along the fitted
    // velocity, when the output layer starts at zero): a trained epoch is kept only if it beats it
    // on the held-out runs.
    let untrained_ades = sample_ades(net, held_out, dt)?;
    let untrained_mean = (untrained_ades.iter().map(|&v| f64::from(v)).sum::<f64>() / held_out.len() as f64) as f32;
    let untrained = if hyper.keep_untrained_if_better { untrained_mean } else { f32::INFINITY };
    let mut out =
        FitOutcome { history: Vec::new(), best_epoch: 0, best_val_ade: untrained, steps: 0, shrink: 1.0, gain: None };
    let untrained_weights = snapshot(vars)?;
    let mut best = untrained_weights.clone();
    let mut average = if hyper.ema_decay > 0.0 { Some(Average::new(hyper.ema_decay, &params)?) } else { None };
    for epoch in 1..=hyper.epochs {
        order.shuffle(&mut rng);
        let (mut sum_loss, mut sum_ll, mut sum_kl, mut b_now) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
        for idx in order.chunks(batch) {
            let refs: Vec<&Sample> = idx.iter().filter_map(|&i| train.get(i)).collect();
            let b = Batch::new(&refs, &Device::Cpu)?;
            b_now = beta(out.steps, total, hyper.beta_max);
            let l = loss(net, &b, dt, b_now, &hyper.loss)?;
            let value = l.total.to_scalar::<f32>()?;
            if !value.is_finite() {
                candle_core::bail!("non-finite loss at step {} (epoch {epoch})", out.steps + 1);
            }
            let mut grads = l.total.backward()?;
            for p in &params {
                if let Some(g) = grads.get(p) {
                    let clipped = g.clamp(-hyper.clip, hyper.clip)?;
                    grads.insert(p, clipped);
                }
            }
            opt.step(&grads)?;
            opt.set_learning_rate(opt.learning_rate() * hyper.lr_decay);
            if let Some(a) = average.as_mut() {
                a.update(&params)?;
            }
            out.steps += 1;
            sum_loss += value;
            sum_ll += l.log_likelihood;
            sum_kl += l.kl;
            observer(Event::Step { step: out.steps, total, loss: value });
        }
        // With the average on, the averaged weights are what is validated and kept.
        let trained = average.as_ref().map(|a| a.swap_in(&params)).transpose()?;
        let val_ade = mean_ade(net, held_out, dt)?;
        let candidate = if val_ade < out.best_val_ade { Some(snapshot(vars)?) } else { None };
        if let Some(old) = &trained {
            put_back(&params, old)?;
        }
        let n = per_epoch as f32;
        let report = EpochReport {
            epoch,
            steps: out.steps,
            loss: sum_loss / n,
            log_likelihood: sum_ll / n,
            kl: sum_kl / n,
            beta: b_now,
            val_ade,
            seconds: start.elapsed().as_secs_f32(),
        };
        out.history.push(report);
        observer(Event::Epoch(report));
        if let Some(weights) = candidate {
            out.best_val_ade = val_ade;
            out.best_epoch = epoch;
            best = weights;
        } else if epoch - out.best_epoch >= hyper.patience {
            break;
        }
    }
    restore(vars, &best)?;
    if hyper.shrink && out.best_epoch > 0 {
        (out.shrink, out.best_val_ade) = shrink_towards_cv(net, vars, held_out, dt)?;
    }
    if hyper.keep_untrained_if_better && hyper.require_sure_gain && out.best_epoch > 0 {
        let gain = judged_gain(held_out, &sample_ades(net, held_out, dt)?, &untrained_ades);
        out.gain = gain;
        if !gain.is_some_and(|g| g.high < 1.0) {
            restore(vars, &untrained_weights)?;
            (out.best_epoch, out.best_val_ade, out.shrink) = (0, untrained_mean, 1.0);
        }
    }
    Ok(out)
}

/// Scales the decoder's mean-control outputs (rows 0 and 1 of `out`: turn rate and
/// acceleration) by each of [`SHRINK_FACTORS`], keeps the factor with the lowest ADE on
/// `held_out` and returns it with that ADE. Why: a fold's eight sequences are few, and a
/// correction learned on them can be right in direction but too strong on another sequence;
/// shrinking towards zero controls (constant velocity along the fitted velocity) is the one-number regulariser that
/// held-out runs can choose. The factor is folded into the weights, so the blob and core
/// inference need nothing new.
///
/// # Errors
/// Shape errors; a missing output layer.
pub fn shrink_towards_cv(net: &Network, vars: &VarMap, held_out: &[Sample], dt: f32) -> Result<(f32, f32)> {
    let data = vars.data().lock().map_err(|_| candle_core::Error::Msg("variable store poisoned".into()))?;
    let (Some(w), Some(b)) = (data.get("out.weight"), data.get("out.bias")) else {
        candle_core::bail!("no output layer `out` in the variables")
    };
    let (w0, b0) = (w.as_tensor().copy()?, b.as_tensor().copy()?);
    let rows = w0.dim(0)?;
    let scale_of = |f: f32| {
        Tensor::from_vec((0..rows).map(|r| if r < 2 { f } else { 1.0 }).collect::<Vec<f32>>(), rows, &Device::Cpu)
    };
    let mut best = (1.0f32, f32::INFINITY);
    for &f in &SHRINK_FACTORS {
        let scale = scale_of(f)?;
        w.set(&w0.broadcast_mul(&scale.unsqueeze(1)?)?)?;
        b.set(&(&b0 * &scale)?)?;
        let ade = mean_ade(net, held_out, dt)?;
        if ade < best.1 {
            best = (f, ade);
        }
    }
    let scale = scale_of(best.0)?;
    w.set(&w0.broadcast_mul(&scale.unsqueeze(1)?)?)?;
    b.set(&(&b0 * &scale)?)?;
    Ok(best)
}

#[cfg(test)]
mod tests {
    use dynotraj_core::model::arch::Dims;

    use super::*;
    use crate::dataset::split_by_run;
    use crate::synthetic::{constant_control_runs, samples};

    #[test]
    fn a_few_dozen_steps_on_constant_controls_lower_the_validation_ade() {
        let dt = 0.05;
        let runs = constant_control_runs(24, 45, dt, 9);
        let split = split_by_run(samples(&runs, dt), runs.len(), 0.25, 3);
        assert!(split.train.len() > 200 && split.validation.len() > 50);
        let (net, vars) = Network::new(Dims { enc: 16, edge: 8, k: 3, dec: 32 }, 5).unwrap();
        let before = mean_ade(&net, &split.validation, dt).unwrap();
        let hyper = Hyper { epochs: 6, batch: 32, patience: 6, ..Hyper::default() };
        let mut steps = 0;
        let out = fit(&net, &vars, &split.train, &split.validation, dt, &hyper, &mut |e| {
            if let Event::Step { step, .. } = e {
                steps = step;
            }
        })
        .unwrap();
        assert!(steps >= 36, "{steps} steps");
        let after = mean_ade(&net, &split.validation, dt).unwrap();
        assert_eq!(after, out.best_val_ade, "the best epoch's weights are restored");
        assert!(after < 0.7 * before, "validation ADE {before} -> {after}");
        let refs: Vec<&Sample> = split.validation.iter().collect();
        let forecast = net.forecast(&Batch::new(&refs, &Device::Cpu).unwrap(), dt).unwrap();
        assert!(forecast.flatten_all().unwrap().to_vec1::<f32>().unwrap().iter().all(|v| v.is_finite()));
    }

    #[test]
    fn a_gain_is_sure_only_when_it_holds_over_the_runs() {
        let dt = 0.05;
        let runs = constant_control_runs(12, 45, dt, 4);
        let all = samples(&runs, dt);
        let untrained: Vec<f32> = all.iter().map(|_| 1.0).collect();
        // Every run 10 % better: sure.
        let steady: Vec<f32> = all.iter().map(|_| 0.9).collect();
        let g = judged_gain(&all, &steady, &untrained).unwrap();
        assert!((g.ratio - 0.9).abs() < 1e-6 && g.high < 1.0, "{g:?}");
        // Half the runs 40 % better, half 30 % worse: better on average, not surely.
        let mixed: Vec<f32> = all.iter().map(|s| if s.group % 2 == 0 { 0.6 } else { 1.3 }).collect();
        let m = judged_gain(&all, &mixed, &untrained).unwrap();
        assert!(m.ratio < 1.0 && m.high >= 1.0, "{m:?}");
        // Every run better, but too few runs to tell: not judged, so not sure.
        let few: Vec<Sample> = all.iter().filter(|s| s.group < MIN_JUDGED_RUNS - 1).cloned().collect();
        let ones = vec![1.0; few.len()];
        assert!(judged_gain(&few, &vec![0.5; few.len()], &ones).is_none());
        let enough: Vec<Sample> = all.iter().filter(|s| s.group < MIN_JUDGED_RUNS).cloned().collect();
        assert!(judged_gain(&enough, &vec![0.5; enough.len()], &vec![1.0; enough.len()]).is_some_and(|g| g.high < 1.0));
    }

    #[test]
    fn shrinking_an_overshooting_model_picks_a_smaller_factor_and_keeps_it() {
        let dt = 0.05;
        let runs = constant_control_runs(16, 45, dt, 4);
        let split = split_by_run(samples(&runs, dt), runs.len(), 0.25, 2);
        let (net, vars) = Network::new(Dims { enc: 16, edge: 8, k: 2, dec: 16 }, 3).unwrap();
        let hyper =
            Hyper { epochs: 4, batch: 32, patience: 4, shrink: false, require_sure_gain: false, ..Hyper::default() };
        fit(&net, &vars, &split.train, &split.validation, dt, &hyper, &mut |_| {}).unwrap();
        // Make the trained corrections four times too strong: a quarter is then the right one.
        let weight = vars.data().lock().unwrap().get("out.weight").unwrap().clone();
        let bias = vars.data().lock().unwrap().get("out.bias").unwrap().clone();
        weight.set(&(weight.as_tensor() * 4.0).unwrap()).unwrap();
        bias.set(&(bias.as_tensor() * 4.0).unwrap()).unwrap();
        let overshooting = mean_ade(&net, &split.validation, dt).unwrap();
        let (factor, ade) = shrink_towards_cv(&net, &vars, &split.validation, dt).unwrap();
        assert!(factor < 1.0 && ade < overshooting, "factor {factor}: {overshooting} -> {ade}");
        assert_eq!(mean_ade(&net, &split.validation, dt).unwrap(), ade, "the chosen factor stays in the weights");
    }
}

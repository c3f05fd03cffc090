//! The `eval` command's scores: every (source, predictor) arm on every test sequence, per agent
//! type, in the Table IV layout.

use dynotraj_core::predict::consistency::MAX_CARRY;
use dynotraj_core::predict::{Carried, Carry};
use dynotraj_sources::drives::first_repeated;
use dynotraj_sources::scene::Scene;
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{EligibilityRule, EligibleRun, Source, eligible_runs};

use crate::forecast_eval::score_sequence;
use crate::predictors::{LoadedPredictor, PredictorSpec};
use crate::report::{ArmScores, Table, forecast_table};

/// What [`scores_table`] scores.
#[derive(Debug, Clone, Copy)]
pub struct ScoresRequest<'a> {
    /// The eligibility rule; each of its agent types is scored apart.
    pub rule: &'a EligibilityRule,
    /// The frame period, seconds.
    pub dt: f32,
    /// The trajectory sources.
    pub sources: &'a [Source],
    /// The predictors.
    pub predictors: &'a [PredictorSpec],
    /// Share of an object's previous forecast its next one carries.
    pub carry: f32,
}

impl ScoresRequest<'_> {
    /// Checks the request before any data is loaded.
    ///
    /// # Errors
    /// A predictor given twice, or a carry out of range.
    pub fn check(&self) -> anyhow::Result<()> {
        if let Some(twice) = first_repeated(self.predictors) {
            anyhow::bail!("--predictor: {} is given twice (its rows would repeat)", twice.label());
        }
        anyhow::ensure!(self.carry <= MAX_CARRY, "--carry {}: at most {MAX_CARRY}", self.carry);
        Ok(())
    }
}

/// Scores every (source, predictor) arm on every sequence of `seqs`, each agent type apart (a
/// model forecasts only the agents of its dynamics): the Table IV layout. `on_arm` is told the
/// arms done after each.
///
/// # Errors
/// A predictor given twice, a carry out of range, or a model that cannot be loaded, named.
pub fn scores_table(
    seqs: &[SequenceTracks],
    request: &ScoresRequest<'_>,
    on_arm: &dyn Fn(u64),
) -> anyhow::Result<Table> {
    request.check()?;
    let ScoresRequest { rule, dt, sources, predictors, carry } = *request;
    let ids: Vec<String> = seqs.iter().map(|s| s.id.clone()).collect();

    let loaded: Vec<LoadedPredictor> =
        predictors.iter().map(|spec| LoadedPredictor::load(spec, dt)).collect::<anyhow::Result<_>>()?;
    let agent_types = rule.agent_types();
    let mut arms = Vec::new();
    // Each agent type apart: a model forecasts only the agents of its dynamics, and a row
    // mixing agent types would hide which one a change helps.
    for (k, &agents) in agent_types.iter().enumerate() {
        let agent_rule = rule.for_agents(agents);
        for &source in sources {
            let runs: Vec<_> = seqs.iter().map(|s| eligible_runs(s.tracks_for(source), &agent_rule)).collect();
            if k > 0 && runs.iter().all(Vec::is_empty) {
                on_arm(predictors.len() as u64);
                continue;
            }
            let scenes: Vec<Scene> = seqs.iter().map(|s| s.scene(source, dt)).collect();
            for (spec, loaded) in predictors.iter().zip(&loaded) {
                on_arm(1);
                if !loaded.forecasts(agents) {
                    continue;
                }
                let label = arm_label(spec, source, carry);
                let label = if k == 0 { label } else { format!("{label}, {}", agents.agents()) };
                arms.push(score_arm(loaded, label, &runs, &scenes, (dt, carry)));
            }
        }
    }
    Ok(forecast_table(&ids, &arms, &[]))
}

/// The scores of `loaded` (carrying `carry` of its last forecast) on every sequence's `runs`.
fn score_arm(
    loaded: &LoadedPredictor,
    label: String,
    runs: &[Vec<EligibleRun>],
    scenes: &[Scene],
    (dt, carry): (f32, f32),
) -> ArmScores {
    let mut forecaster = loaded.forecaster();
    let mut forecaster = Carried(forecaster.as_mut(), Carry::new(carry));
    let mut arm = ArmScores::new(label);
    let mut failed = 0;
    for (seq_runs, scene) in runs.iter().zip(scenes) {
        let r = score_sequence(seq_runs, scene, &mut forecaster, dt);
        arm.push_sequence(&r);
        failed += r.failed;
    }
    if failed > 0 {
        log::warn!("{}: {failed} instances could not be forecast", arm.label);
    }
    arm
}

fn arm_label(p: &PredictorSpec, s: Source, carry: f32) -> String {
    let carried = if carry > 0.0 { format!(" carrying {carry}") } else { String::new() };
    let name = format!("{}{carried} on {}", p.label(), s.name());
    if s.is_causal() { name } else { format!("{name} (inputs saw later frames)") }
}

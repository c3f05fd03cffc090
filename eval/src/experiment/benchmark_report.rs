//! The benchmark's report: its sections (weighted scores per seed, the goal, the deployment
//! comparison, Table I, per-sequence tables; every other agent type's by its own models), notes
//! and figure.

use std::path::Path;

use anyhow::Context as _;
use dynotraj_core::predict::Dynamics;
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::EligibilityRule;

use super::ExperimentConfig;
use super::benchmark::{BenchmarkResult, GOAL_VS_CV, GOAL_VS_CV_HIGH, GOAL_VS_PRIOR, goal_table, seeds_table};
use super::figures::Figure;
use super::report::{Report, Section};
use super::sections::{agents_caption, deployment_section, table_i_sources};
use crate::report::chart::{Chart, Series, write_chart};
use crate::report::instances_table;

/// The benchmark's report: its `sections` ([`benchmark_sections`]), notes on the stages'
/// times (`loaded_s` loading and estimating, `seconds` in all) and the folds, and its figures,
/// written to `dir`/figures.
///
/// # Errors
/// A figure that cannot be written, named.
pub fn benchmark_report(
    dir: &Path,
    sections: Vec<Section>,
    result: &BenchmarkResult,
    config: &ExperimentConfig,
    sequences: &[SequenceTracks],
    (command, loaded_s, seconds): (String, f64, f64),
) -> anyhow::Result<Report> {
    let mut notes = vec![
        format!(
            "Stages: loading and estimating the sequences {loaded_s:.0} s (rendering and tracking, or the \
            estimate cache), training and scoring {:.0} s on {} job(s).",
            result.seconds, config.jobs
        ),
        format!(
            "Folds (held out together): {}.",
            config.folds.iter().map(|f| f.join(", ")).collect::<Vec<_>>().join(" | ")
        ),
        super::figures::time_axis::time_span_note(config.dt, config.prior.history_frames()),
        "Settings are the defaults of `dynotraj train` (chosen on training folds: docs/decisions.md), never on \
            these held-out sequences."
            .to_string(),
    ];
    let untrue: Vec<&str> =
        sequences.iter().filter(|s| s.estimated.is_some() && s.truth().is_none()).map(|s| s.id.as_str()).collect();
    if !untrue.is_empty() {
        notes.push(format!(
            "No deployment or truth-scored tables: {} drive(s) were estimated from their own images and have no \
             simulator's truth to score against ({}); every arm is scored against its own source's future.",
            untrue.len(),
            untrue.join(", ")
        ));
    }
    let figures = write_benchmark_figures(&dir.join("figures"), result, config)?;
    Ok(Report {
        title: "dynotraj generalisation benchmark".into(),
        command,
        sections,
        folds: result.folds.clone(),
        seconds,
        notes,
        figures,
    })
}

/// The report's tables: the weighted scores per seed, the goal, the deployment comparison, the
/// truth-scored rows, Table I and the per-sequence tables of every seed; then the weighted
/// scores, goal and deployment of every other agent type (pedestrians), by their own models.
/// Table I counts the eligible objects under `rule`; the captions name the `seeds`.
///
/// # Errors
/// No agent type to report (no class forecast).
pub fn benchmark_sections(
    result: &BenchmarkResult,
    config: &ExperimentConfig,
    sequences: &[SequenceTracks],
    (rule, seeds): (&EligibilityRule, &[u64]),
) -> anyhow::Result<Vec<Section>> {
    let agent_types = result.agent_types();
    let Some(first) = agent_types.first() else { anyhow::bail!("--classes: no class to forecast") };
    let primary = result.of_agents(*first).context("the first agent type's rows")?;
    let mut out = agent_sections(&primary, config, seeds, (*first, false));
    let sources = table_i_sources(&config.arms);
    out.push(Section {
        stem: "table_i".into(),
        title: "Eligible objects and test instances".into(),
        caption: "Per source: the labels (GT and GT+EKF share them) and, for the estimated arm, the estimator's own \
            tracks; every forecast class, each agent type scored below by its own models."
            .into(),
        table: instances_table(sequences, &sources, rule),
    });
    for (seed, r) in result.seeds.iter().zip(&result.per_seed) {
        out.push(Section {
            stem: format!("per_sequence_seed{seed}"),
            title: format!("Per held-out sequence, seed {seed}"),
            caption: "ADE, FDE (m), ACE per held-out sequence and weighted; each arm against its own source's future."
                .into(),
            table: r.table.clone(),
        });
        if let Some((t, _)) = &r.deployment {
            let mut d = deployment_section(t.clone());
            d.stem = format!("deployment_seed{seed}");
            d.title = format!("Deployment per held-out sequence, seed {seed}");
            out.push(d);
        }
    }
    for &agents in agent_types.iter().skip(1) {
        let other = result.of_agents(agents).context("an agent type's rows")?;
        out.extend(agent_sections(&other, config, seeds, (agents, true)));
    }
    Ok(out)
}

/// The weighted scores per seed, the goal, and (with the simulator's truth) the deployment
/// comparison and the truth-scored rows of one agent type's `result`; stems and titles name
/// the `agents` when `named` (every agent type after the first), captions always.
fn agent_sections(
    result: &BenchmarkResult,
    config: &ExperimentConfig,
    seeds: &[u64],
    (agents, named): (Dynamics, bool),
) -> Vec<Section> {
    let seeds = seeds.iter().map(ToString::to_string).collect::<Vec<_>>().join(", ");
    let mut out = vec![
        Section {
            stem: "weighted".into(),
            title: "Weighted over every held-out instance, per seed".into(),
            caption: format!(
                "ADE, FDE (m) and ACE per forecast over all held-out sequences; each arm scored against its own \
                    source's future (the paper's protocol); seeds {seeds}; spread = largest minus smallest over \
                    the seeds. cv, cv-fit and ctra do not depend on the seed."
            ),
            table: seeds_table(result, |r| Some(&r.arms)),
        },
        Section {
            stem: "goal".into(),
            title: "The goal per arm and seed".into(),
            caption: format!(
                "The learned int8 model's weighted ADE and FDE as ratios to cv's and to the motion prior's (the \
                    prior alone, with the settings each fold chose on its training sequences), and the prior's to \
                    cv's; in brackets the 95 % interval of a bootstrap over whole object runs (2,000 draws). The \
                    goal: at most {GOAL_VS_CV} of cv with the interval's upper end below {GOAL_VS_CV_HIGH}, at \
                    most {GOAL_VS_PRIOR} of the prior with the upper end below 1, ACE no worse than cv's."
            ),
            table: goal_table(result, &config.arms),
        },
    ];
    if result.per_seed.iter().all(|r| r.deployment.is_some()) {
        let mut d = deployment_section(seeds_table(result, |r| r.deployment.as_ref().map(|(_, rows)| &rows[..])));
        d.stem = "deployment_weighted".into();
        d.caption.push_str(" Weighted over every held-out instance, per seed.");
        out.push(d);
        out.push(Section {
            stem: "truth_weighted".into(),
            title: "Each arm on its own inputs against the simulator's truth, per seed".into(),
            caption: "The same models, each on its own source's inputs, every arm scored against the simulator's \
                true future on the instances every arm has."
                .into(),
            table: seeds_table(result, |r| r.common.as_ref().map(|(_, rows)| &rows[..])),
        });
    }
    let caption = agents_caption(agents, &config.rule);
    for s in &mut out {
        if named {
            s.stem = format!("{}_{}", s.stem, agents.agents());
            s.title = format!("{}: {}", capitalised(agents.agents()), s.title);
        }
        s.caption.push_str(&caption);
    }
    out
}

/// `word` with its first letter in capitals.
fn capitalised(word: &str) -> String {
    let mut chars = word.chars();
    chars.next().map(|c| c.to_uppercase().chain(chars).collect()).unwrap_or_default()
}

/// Weighted ADE per held-out sequence of the learned int8 model and cv, per arm, averaged over
/// the seeds; x is the sequence number.
fn write_benchmark_figures(
    dir: &Path,
    result: &BenchmarkResult,
    config: &ExperimentConfig,
) -> anyhow::Result<Vec<Figure>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let ids = config.test_sequences();
    let mut series = Vec::new();
    for arm in &config.arms {
        for label in [format!("learned int8 on {arm}"), format!("cv on {arm}")] {
            let mut points = Vec::new();
            for (i, id) in ids.iter().enumerate() {
                let values: Vec<f64> = result
                    .per_seed
                    .iter()
                    .filter_map(|r| {
                        r.arms
                            .iter()
                            .find(|a| a.label == label)
                            .and_then(|a| a.per_sequence.get(i))
                            .and_then(|s| s.ade.value())
                    })
                    .collect();
                if let (Ok(x), false) = (id.parse::<f64>(), values.is_empty()) {
                    points.push((x, values.iter().sum::<f64>() / values.len() as f64));
                }
            }
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            series.push(Series::new(label, points));
        }
    }
    let chart = Chart {
        title: "ADE per held-out sequence (mean over seeds)".into(),
        x_label: "KITTI sequence".into(),
        y_label: "ADE (m)".into(),
        series,
    };
    let [png, _] = write_chart(&chart, &dir.join("ade_per_sequence"))?;
    Ok(vec![Figure {
        png,
        caption: "ADE of the learned int8 model and of constant velocity per held-out sequence \
        and arm, each point the mean over the seeds."
            .into(),
    }])
}

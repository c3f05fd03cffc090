//! The sections of the experiment's report: Table I for every arm's source, Table III of the
//! estimator behind the estimated arms, Table IV (own future and common truth), deployment, and
//! the notes on what the inputs mean. The commands only gather their settings.

use std::path::Path;

use super::ExperimentResult;
use super::figures::{FoldModels, ObjectChoice, write_figures};
use super::findings::{Scoring, findings};
use super::report::{Report, Section, write_report};
use crate::recording::experiment::write_recordings;
use crate::report::estimator_tables::table_iii_of;
use crate::report::{Table, instances_table};
use dynotraj_core::predict::Dynamics;
use dynotraj_sources::estimation::EstimateInput;
use dynotraj_sources::estimation::{Kind, RunScores};
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{EligibilityRule, Source};

/// What of a run's settings its report tells.
#[derive(Debug, Clone, Copy)]
pub struct RunSettings<'a> {
    /// The arms trained and tested.
    pub arms: &'a [Source],
    /// The render scale of rendered Estimated inputs.
    pub render_scale: f64,
    /// Jobs the run had.
    pub jobs: usize,
    /// Frame period, seconds.
    pub dt: f32,
    /// Past frames a forecast reads at most ([`dynotraj_train::PriorChoice::history_frames`]).
    pub history_frames: usize,
}

/// The report of a finished run: Table I for every arm's source, Table III of the estimator
/// behind the estimated arms, Table IV, the folds and the findings.
#[must_use]
pub fn experiment_report(
    run: &RunSettings<'_>,
    command: String,
    result: &ExperimentResult,
    sequences: &[SequenceTracks],
    rule: &EligibilityRule,
) -> Report {
    let mut sections = vec![Section {
        stem: "table_i".into(),
        title: "Table I: eligible objects and test instances".into(),
        caption: "Per source: the labels (GT and GT+EKF share them) and, for the estimated arms, the estimator's \
            own tracks. Every loaded sequence is a training candidate; the paper's test sequences are held out in \
            turn."
            .into(),
        table: instances_table(sequences, &table_i_sources(run.arms), rule),
    }];
    let inputs: Vec<EstimateInput> = sequences.iter().filter_map(|s| s.estimated.as_ref().map(|e| e.input)).collect();
    let estimated: Vec<(&str, usize, &RunScores)> = sequences
        .iter()
        .filter_map(|s| s.estimated.as_ref().and_then(|e| e.rpe.as_ref().map(|rpe| (s.id.as_str(), e.frames, rpe))))
        .collect();
    if !estimated.is_empty() {
        for (k, kind, stem) in [(1, Kind::Causal, "table_iii_causal"), (2, Kind::Smoothed, "table_iii_smoothed")] {
            sections.push(Section {
                stem: stem.into(),
                title: format!("Table III: the estimator behind the Estimated arm, {} estimate", kind.name()),
                caption: table_iii_caption(&inputs, run.render_scale),
                table: table_iii_of(estimated.iter().copied(), k, kind),
            });
        }
        let instances = super::budget::budget_instances(sequences, rule, run.dt);
        if !instances.is_empty() {
            sections.push(Section {
                stem: "error_budget".into(),
                title: "Error budget of the Estimated arm's causal states".into(),
                caption: format!(
                    "At every test instance of the estimator's causal tracks (every sequence) whose object the \
                        simulator holds over the horizon: mean absolute errors against the simulator's truth of the \
                        position relative to the camera, the speed (also signed: a bias survives the mean, noise \
                        does not) and direction constant velocity reads (direction \
                        where the truth moves at {} m/s or more) and the motion prior's turn rate; then the ADE of \
                        constant velocity from the true velocity (what no state estimate can beat) and from Ours', \
                        the ADE added by Ours' speed alone and by its direction alone, and the errors and ADE of the \
                        state's own speed and heading (the bird's-eye track's velocity), which constant velocity does \
                        not read. Distance: the truth's \
                        from the camera. Run start: fewer than {} frames after the run's first state.",
                    super::budget::MOVING_MPS,
                    super::budget::START_FRAMES
                ),
                table: super::budget::budget_table(&instances),
            });
        }
    }
    let first_table_iv = sections.len();
    sections.push(Section {
        stem: "table_iv".into(),
        title: "Table IV: forecasts, leave one sequence out".into(),
        caption: "ADE, FDE (m) and ACE per test sequence and weighted per forecast; each arm is scored against its \
            own source's future (the paper's protocol); learned = the Trajectron++-style model trained on the \
            other sequences of that source; int8 = its quantised twin as the ECU runs it. Inputs are causal except \
            in rows labelled otherwise. The paper's rows are on its 522 DynoSAM-tracked instances, not on ours."
            .into(),
        table: result.table.clone(),
    });
    if let Some((table, _)) = &result.common {
        sections.push(Section {
            stem: "table_iv_truth".into(),
            title: "Table IV against one common reference: the simulator's truth".into(),
            caption: "The same models and forecasts, every arm scored against the simulator's true future (the box \
                centre, as a displacement from the current frame: see eval/src/forecast_eval.rs) on the instances that \
                every arm has, so the rows share their instances and their reference. The paper cannot make this \
                comparison on real data; a simulator can."
                .into(),
            table: table.clone(),
        });
    }
    if let Some((table, _)) = &result.deployment {
        sections.push(deployment_section(table.clone()));
    }
    for s in &mut sections[first_table_iv..] {
        s.caption.push_str(&agents_caption(result.agents, rule));
    }
    for other in &result.other_agents {
        sections.extend(other_agent_sections(other, rule));
    }
    let mut notes = vec![format!(
        "Stages: loading and estimating the sequences {:.0} s (rendering and tracking them, or reading the \
            estimate cache), training and scoring {:.0} s, on {} job(s).",
        result.loading_seconds,
        result.seconds - result.loading_seconds,
        run.jobs
    )];
    notes.push(super::figures::time_axis::time_span_note(run.dt, run.history_frames));
    let scored: Vec<Dynamics> =
        std::iter::once(result.agents).chain(result.other_agents.iter().map(|o| o.agents)).collect();
    for missing in rule.agent_types().into_iter().filter(|d| !scored.contains(d)) {
        let trained = result.folds.iter().any(|f| f.agents == missing);
        notes.push(format!(
            "No eligible {} in the test sequences, so no table scores them; {}.",
            missing.agents(),
            if trained {
                "their models were trained all the same (Folds), and Table I counts them where the sequences hold any"
            } else {
                "no loaded sequence holds one, so none was trained"
            }
        ));
    }
    notes.extend(findings(&result.arms, run.arms, Scoring::OwnFuture));
    if let Some((_, arms)) = &result.common {
        notes.extend(findings(arms, run.arms, Scoring::CommonTruth));
    }
    if run.arms.iter().any(Source::is_estimated) {
        notes.extend(input_notes(&inputs));
    }
    Report {
        title: "dynotraj experiment report".into(),
        command,
        sections,
        folds: result.folds.clone(),
        seconds: result.seconds,
        notes,
        figures: Vec::new(),
    }
}

/// Which classes a table of `agents` scores, under `rule`, for its caption.
#[must_use]
pub fn agents_caption(agents: Dynamics, rule: &EligibilityRule) -> String {
    let classes: Vec<&str> = rule.for_agents(agents).classes.iter().map(|c| c.kitti_name()).collect();
    format!(
        " Only {} ({} dynamics), each fold by a model trained on them alone; a fold whose training sequences hold \
            none ships the prior at its settings for no data (cv-fit).",
        classes.join(", "),
        agents.name()
    )
}

/// Table IV of another agent type (pedestrians), against its own future, the common truth and
/// in deployment, with stems and titles that name it.
fn other_agent_sections(result: &ExperimentResult, rule: &EligibilityRule) -> Vec<Section> {
    let name = result.agents.agents();
    let mut out = vec![Section {
        stem: format!("table_iv_{name}"),
        title: format!("Table IV, {name}: forecasts, leave one sequence out"),
        caption: "As Table IV above.".into(),
        table: result.table.clone(),
    }];
    if let Some((table, _)) = &result.common {
        out.push(Section {
            stem: format!("table_iv_truth_{name}"),
            title: format!("Table IV, {name}, against the simulator's truth"),
            caption: "As above, against the simulator's truth.".into(),
            table: table.clone(),
        });
    }
    if let Some((table, _)) = &result.deployment {
        let mut d = deployment_section(table.clone());
        d.stem = format!("deployment_{name}");
        d.title = format!("Deployment, {name}");
        out.push(d);
    }
    for s in &mut out {
        s.caption.push_str(&agents_caption(result.agents, rule));
    }
    out
}

/// The deployment comparison as a report section.
#[must_use]
pub fn deployment_section(table: Table) -> Section {
    Section {
        stem: "deployment".into(),
        title: "Deployment: every training source's model on what the vehicle sees".into(),
        caption: "A vehicle has only its own estimates at run time. Each arm's models (trained on that source, \
            test sequences held out) run on the estimated arm's inputs (the estimator's causal tracks from the \
            rendered images) and are scored against the simulator's true future on the instances every arm has; \
            the baselines run on the same inputs. Lower is better; the rows share their instances and their \
            reference."
            .into(),
        table,
    }
}

/// Table III's caption for estimates made from `inputs` (one per sequence).
fn table_iii_caption(inputs: &[EstimateInput], render_scale: f64) -> String {
    let truth = if inputs.iter().all(|i| *i == EstimateInput::Rendered) {
        format!(
            "the truth of the image simulator, which renders each sequence from its real labels, ego poses and \
                calibration (scale {render_scale}); the OpenCV front-end tracks the rendered stereo images and the \
                core estimator runs on its tracks. DynoSAM's figures on real images are printed below for \
                reference (rendered images lack real images' blur, glare and texture)"
        )
    } else if inputs.iter().all(|i| *i == EstimateInput::Tracks) {
        "the truth of the track-level simulator driven by each sequence's real labels, ego poses and calibration \
            (no images: simulated feature tracks). Not comparable to DynoSAM on real images, printed below for \
            reference"
            .into()
    } else {
        "the simulator's truth of each sequence made by a simulator (the track-level one or the image renderer, \
            per sequence; real-image sequences have no truth and no row)"
            .into()
    };
    format!("Camera and object RPE (delta = 1 frame) against {truth}.")
}

/// What the Estimated arm's inputs mean for its results, one note per kind of input present.
fn input_notes(inputs: &[EstimateInput]) -> Vec<String> {
    let mut out = Vec::new();
    if inputs.contains(&EstimateInput::Rendered) {
        out.push(
            "The Estimated arm runs images -> front-end -> estimator on the image simulator's rendering of \
            each sequence: boxes moving along trajectories fitted smoothly to the labels, so the truth behind it \
            is smoother than the labels, and the images are cleaner than real ones: part of any advantage is the \
            simulator's (docs/decisions.md)."
                .into(),
        );
    }
    if inputs.contains(&EstimateInput::Tracks) {
        out.push(
            "The Estimated arm's tracks come from simulated feature tracks (`--ours-input tracks`) of boxes \
            that move along trajectories fitted smoothly to the labels, so the truth behind it is smoother than \
            the labels: part of any advantage is the simulator's, not the estimator's (docs/decisions.md)."
                .into(),
        );
    }
    if inputs.contains(&EstimateInput::Images) {
        out.push(
            "Where a sequence has its own stereo images, the Estimated arm ran on them (no simulator, no \
            truth: only the paper's protocol scores it)."
                .into(),
        );
    }
    out
}

/// The sources Table I counts for `arms`: the labels once (GT, GT+EKF and GT+RTS share them),
/// then each estimated arm.
#[must_use]
pub fn table_i_sources(arms: &[Source]) -> Vec<Source> {
    let mut out = Vec::new();
    if arms.iter().any(|a| !a.is_estimated()) {
        out.push(Source::Gt);
    }
    out.extend(arms.iter().copied().filter(Source::is_estimated));
    out
}

/// Where and how an experiment's report folder is written.
#[derive(Debug, Clone)]
pub struct ReportFolder<'a> {
    /// The report folder (REPORT.md, tables, figures/, models/).
    pub dir: &'a Path,
    /// Where the test sequences' recordings go, if anywhere.
    pub record: Option<&'a Path>,
    /// The encoding of recordings.
    pub record_encoding: dynotraj_bag::record::RecordingEncoding,
    /// The command line the report names.
    pub command: String,
    /// The objects the per-object figures draw.
    pub objects: &'a [ObjectChoice],
    /// The test sequences (recorded).
    pub tests: &'a [String],
}

/// Writes the report folder of a finished experiment: REPORT.md with its tables, the figures
/// of the first agent type (vehicles) from the fold models in `models/`, and with `record` the
/// test sequences' recordings. Returns what is said of the files written.
///
/// # Errors
/// A file that cannot be written or a fold model that cannot be read, named.
pub fn write_report_folder(
    folder: &ReportFolder<'_>,
    run: &RunSettings<'_>,
    result: &ExperimentResult,
    sequences: &[SequenceTracks],
    rule: &EligibilityRule,
) -> anyhow::Result<Vec<String>> {
    // The figures and recordings show the first agent type's forecasts (vehicles).
    let shown = rule.for_agents(result.agents);
    let mut r = experiment_report(run, folder.command.clone(), result, sequences, rule);
    let (figures, models) = (folder.dir.join("figures"), folder.dir.join("models"));
    r.figures = write_figures(&figures, sequences, run.arms, &shown, run.dt, &models, folder.objects)?;
    let mut said = vec![format!("wrote {}", write_report(folder.dir, &r)?.display())];
    if let Some(record) = folder.record {
        let tests: Vec<&SequenceTracks> = sequences.iter().filter(|s| folder.tests.contains(&s.id)).collect();
        let fold_models = FoldModels::load(&models, run.arms, sequences)?;
        for w in write_recordings(record, folder.record_encoding, &tests, run.arms, &fold_models, &shown, run.dt)? {
            said.push(crate::recording::recorded(&w));
        }
    }
    Ok(said)
}

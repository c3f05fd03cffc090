//! `dynotraj experiment`: the paper's leave-one-sequence-out experiment for the chosen arms.

use clap::Args;

use super::common::{DataArgs, PAPER_TEST_SEQUENCES};
use super::fold_run::FoldRunArgs;
use super::train_progress::TrainBars;
use crate::estimate::{Kind, RunScores};
use crate::experiment::figures::write_figures;
use crate::experiment::findings::{Scoring, findings};
use crate::experiment::report::{Report, Section, write_report};
use crate::experiment::{ExperimentConfig, ExperimentResult, run_experiment};
use crate::report::estimator_tables::table_iii_of;
use crate::report::{Table, instances_table};
use crate::sequence::SequenceTracks;
use crate::trajectory::{EligibilityRule, EstimateInput, Source};

/// Options of `dynotraj experiment`.
#[derive(Debug, Args)]
pub struct ExperimentArgs {
    /// Data options.
    #[command(flatten)]
    pub data: DataArgs,
    /// Arms: the sources trained and tested (gt, gt-ekf, estimated; gt-rts and
    /// estimated-smoothed are the labelled non-causal variants), comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "gt,gt-ekf", value_name = "LIST")]
    pub arms: Vec<Source>,
    /// Sequences to load (default: every sequence in --kitti); every loaded sequence that is
    /// not the fold's test sequence is trained on. The paper's setting is
    /// `--sequences 0000,0001,0002,0003,0004,0005,0006,0018,0020`.
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub sequences: Vec<String>,
    /// Test sequences, each held out in turn (default: the paper's 0000, 0003, 0005, 0018, 0020).
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub tests: Vec<String>,
    /// Widths, training settings, report folder and format.
    #[command(flatten)]
    pub run: FoldRunArgs,
}

/// Runs the experiment and returns its table and a summary of the folds.
///
/// # Errors
/// Loading, training or writing errors, named.
pub fn table(args: &ExperimentArgs) -> anyhow::Result<(Table, String)> {
    let (result, summary, _) = experiment(args)?;
    Ok((result.table, summary))
}

/// Runs the experiment; returns its result, the fold summary and the loaded sequences.
///
/// # Errors
/// Loading, training or writing errors, named.
pub fn experiment(args: &ExperimentArgs) -> anyhow::Result<(ExperimentResult, String, Vec<SequenceTracks>)> {
    let start = std::time::Instant::now();
    let sequences = args.data.load_cached(&args.sequences, &args.arms, args.run.estimate_cache(&args.data))?;
    let test_sequences: Vec<String> = if args.tests.is_empty() {
        PAPER_TEST_SEQUENCES.iter().map(ToString::to_string).collect()
    } else {
        args.tests.clone()
    };
    let config = args.run.config(&args.data, &args.arms, ExperimentConfig::one_sequence_folds(&test_sequences))?;
    let loading_seconds = start.elapsed().as_secs_f64();
    let bars = TrainBars::new(config.arms.len() * config.folds.len());
    let result = run_experiment(&sequences, &config, &bars);
    bars.finish();
    let mut result = result?;
    // The whole command: loading and estimating the sequences too.
    result.seconds = start.elapsed().as_secs_f64();
    result.loading_seconds = loading_seconds;
    let mut summary = String::from(
        "folds (arm / held-out sequence: training instances, epoch kept, output shrink, validation ADE vs cv, \
            seconds):\n",
    );
    for f in &result.folds {
        summary.push_str(&format!(
            "  {} / {}: {} instances, epoch {}, shrink {}, val ADE {:.3} m (cv {:.3} m), {:.1} s{}\n",
            f.arm,
            f.sequence,
            f.train_instances,
            f.best_epoch,
            f.shrink,
            f.val_ade,
            f.val_cv_ade,
            f.seconds,
            if f.cached { " (cached)" } else { "" }
        ));
    }
    summary.push_str(&format!("total: {:.1} s\n", result.seconds));
    Ok((result, summary, sequences))
}

/// The report of a finished run: Table I for every arm's source, Table III of the estimator
/// behind the estimated arms, Table IV, the folds and the findings.
#[must_use]
pub fn report(
    args: &ExperimentArgs,
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
        table: instances_table(sequences, &table_i_sources(&args.arms), rule),
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
                caption: table_iii_caption(&inputs, args.data.ours.render_scale),
                table: table_iii_of(estimated.iter().copied(), k, kind),
            });
        }
    }
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
                centre, as a displacement from the current frame: see host/src/evaluate.rs) on the instances that \
                every arm has, so the rows share their instances and their reference. The paper cannot make this \
                comparison on real data; a simulator can."
                .into(),
            table: table.clone(),
        });
    }
    if let Some((table, _)) = &result.deployment {
        sections.push(deployment_section(table.clone()));
    }
    let mut command = String::from("dynotraj experiment");
    for a in std::env::args().skip(2) {
        command.push(' ');
        command.push_str(&a);
    }
    let mut notes = vec![format!(
        "Stages: loading and estimating the sequences {:.0} s (rendering and tracking them, or reading the \
            estimate cache), training and scoring {:.0} s, on {} job(s).",
        result.loading_seconds,
        result.seconds - result.loading_seconds,
        args.data.ours.jobs
    )];
    notes.extend(findings(&result.arms, &args.arms, Scoring::OwnFuture));
    if let Some((_, arms)) = &result.common {
        notes.extend(findings(arms, &args.arms, Scoring::CommonTruth));
    }
    if args.arms.iter().any(Source::is_estimated) {
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

/// Prints the table and the fold summary.
///
/// # Errors
/// See [`table`].
pub fn run(args: &ExperimentArgs) -> anyhow::Result<()> {
    let (result, summary, sequences) = experiment(args)?;
    print!("{}", result.table.render(args.run.format));
    if let Some((table, _)) = &result.common {
        println!("\nAgainst the simulator's truth, on the instances every arm has:\n");
        print!("{}", table.render(args.run.format));
    }
    eprint!("{summary}");
    if let Some(dir) = &args.run.out {
        let rule = args.data.rule()?;
        let mut r = report(args, &result, &sequences, &rule);
        r.figures =
            write_figures(&dir.join("figures"), &sequences, &args.arms, &rule, args.data.dt()?, &dir.join("models"))?;
        let path = write_report(dir, &r)?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

//! The experiment's figures, PNG and SVG, each with the caption the report prints under it.
//!
//! Per chosen object ([`choice`]: `--object SEQ:ID`, by default the longest eligible moving
//! object of sequence 0000, and of 0018 for its heading):
//! - [`paper`]: the paper's figures 2-6: distance between consecutive positions, speed and
//!   heading per source over time, the ACE of each arm's int8 forecasts over time;
//! - [`birdseye`]: its bird's-eye trajectory per source, with the simulator's truth;
//! - [`forecasts`]: each arm's int8 forecast and constant velocity over the true future at a
//!   few of its test instances.
//!
//! Per run: [`horizon`], the ADE and FDE of each arm's int8 model and of constant velocity
//! against the horizon, pooled over the sequences with a fold model; and [`rpe`], the
//! estimator's RPE over time for the chosen objects' sequences.
//!
//! Time axes are in seconds at the run's frame rate ([`time_axis`]); objects are numbered as
//! everywhere a user sees them ([`dynotraj_sources::trajectory::object_number`]).

pub mod birdseye;
pub mod choice;
pub mod forecasts;
pub mod horizon;
pub mod paper;
pub mod rpe;
pub mod time_axis;

use std::path::{Path, PathBuf};

use anyhow::Context as _;

pub use choice::{ObjectChoice, longest_moving_object, parse_object_choice, subjects};

use dynotraj_formats::model_file::ModelFile;
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{EligibilityRule, Source};

/// A figure written: its file stem's paths and its caption.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// The PNG (an SVG of the same name sits beside it).
    pub png: PathBuf,
    /// What it shows.
    pub caption: String,
}

/// What the figures are drawn from.
#[derive(Debug, Clone, Copy)]
pub struct FigureInputs<'a> {
    /// The loaded sequences.
    pub sequences: &'a [SequenceTracks],
    /// The experiment's arms.
    pub arms: &'a [Source],
    /// Eligibility of runs and test instances.
    pub rule: &'a EligibilityRule,
    /// Frame period, seconds.
    pub dt: f32,
    /// The int8 fold models there are, read once for every figure.
    pub models: &'a FoldModels,
}

/// The int8 fold models of a run: per arm and loaded sequence, the model trained without that
/// sequence, where the models folder holds one (`<arm>-<seq>.blob.int8`).
#[derive(Debug, Default)]
pub struct FoldModels(Vec<(Source, String, ModelFile)>);

impl FoldModels {
    /// Reads every fold model of `arms` for the `sequences` that have the arm's source.
    ///
    /// # Errors
    /// A model file that is there but does not load, named.
    pub fn load(dir: &Path, arms: &[Source], sequences: &[SequenceTracks]) -> anyhow::Result<Self> {
        let mut out = Vec::new();
        for &arm in arms {
            for seq in sequences.iter().filter(|s| s.has(arm)) {
                let path = dir.join(format!("{arm}-{}.blob.int8", seq.id));
                if path.is_file() {
                    let model = ModelFile::load(&path)
                        .with_context(|| format!("figures: the fold model {}", path.display()))?;
                    out.push((arm, seq.id.clone(), model));
                }
            }
        }
        Ok(Self(out))
    }

    /// The model of `arm` trained without sequence `seq`, if there is one.
    #[must_use]
    pub fn get(&self, arm: Source, seq: &str) -> Option<&ModelFile> {
        self.0.iter().find(|(a, s, _)| *a == arm && s == seq).map(|(_, _, m)| m)
    }
}

/// Writes the figures into `dir` for what `sequences` hold: per object of `objects` (or the
/// defaults, [`subjects`]) and per run. Sources are the labels' (GT, GT+EKF) and `arms`' that
/// are loaded; fold models are read from `models` (`<arm>-<seq>.blob.int8`). A figure whose
/// inputs are not there (its sequence not loaded, no estimated arm, no fold model) is left out.
///
/// # Errors
/// A choice of `objects` that names no loaded object; a figure that cannot be drawn or
/// written, named.
pub fn write_figures(
    dir: &Path,
    sequences: &[SequenceTracks],
    arms: &[Source],
    rule: &EligibilityRule,
    dt: f32,
    models: &Path,
    objects: &[ObjectChoice],
) -> anyhow::Result<Vec<Figure>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let models = FoldModels::load(models, arms, sequences)?;
    let inputs = FigureInputs { sequences, arms, rule, dt, models: &models };
    let chosen = subjects(objects, sequences, rule)?;
    let mut out = Vec::new();
    for subject in &chosen {
        out.extend(paper::write(dir, subject, &inputs)?);
        if subject.extent == choice::Extent::All {
            out.extend(birdseye::write(dir, subject, &inputs)?);
            out.extend(forecasts::write(dir, subject, &inputs)?);
        }
    }
    out.extend(horizon::write(dir, &inputs)?);
    let mut rpe_sequences: Vec<&SequenceTracks> = Vec::new();
    for s in chosen.iter().filter(|s| s.extent == choice::Extent::All) {
        if !rpe_sequences.iter().any(|q| q.id == s.seq.id) {
            rpe_sequences.push(s.seq);
        }
    }
    for seq in rpe_sequences {
        out.extend(rpe::write(dir, seq, dt)?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynotraj_core::model::Dims;
    use dynotraj_core::model::blob::Precision;
    use dynotraj_formats::kitti::TrackingDir;
    use dynotraj_sim::cost_inputs::random_blob;
    use dynotraj_sim::drive::{DriveSpec, generate};
    use dynotraj_sim::kitti_layout::write_sequence;
    use dynotraj_sources::estimation::settings::EstimateSettings;
    use dynotraj_sources::estimation::simulated::EvalOptions;
    use dynotraj_sources::sequence::load_sequence;

    /// Sequence 0000 of the simulators' synthetic drive with the estimator's tracks, at 10 Hz.
    fn drive_0000(root: &Path) -> SequenceTracks {
        write_sequence(root, "0000", &generate(&DriveSpec::default())).unwrap();
        let dir = TrackingDir::open(root).unwrap();
        let settings = EstimateSettings::tracks(EvalOptions::kitti(0.1));
        load_sequence(&dir, "0000", 0.1, Some(&settings)).unwrap()
    }

    #[test]
    fn every_figure_is_written_as_png_and_svg_with_seconds_on_time_axes() {
        let dir = tempfile::tempdir().unwrap();
        let seqs = [drive_0000(&dir.path().join("kitti"))];
        let models = dir.path().join("models");
        std::fs::create_dir_all(&models).unwrap();
        let arms = [Source::Gt, Source::Estimated];
        for arm in arms {
            let blob = random_blob(&Dims::DEFAULT, Precision::Int8, 0.1);
            std::fs::write(models.join(format!("{arm}-0000.blob.int8")), blob).unwrap();
        }
        let rule = EligibilityRule::default();
        let out = dir.path().join("figures");
        let figures = write_figures(&out, &seqs, &arms, &rule, 0.1, &models, &[]).unwrap();
        let stems: Vec<String> =
            figures.iter().map(|f| f.png.file_stem().unwrap().to_string_lossy().into_owned()).collect();
        // The drive's longest mover is KITTI track 1 (the car seen in every frame): object 2.
        assert_eq!(
            stems,
            [
                "fig2_distance_0000_object2",
                "fig3_speed_0000_object2",
                "fig4_heading_0000_object2",
                "fig5_ace_0000_object2",
                "birdseye_0000_object2",
                "forecasts_0000_object2",
                "ade_horizon",
                "fde_horizon",
                "rpe_camera_0000",
                "rpe_objects_0000",
            ]
        );
        for f in &figures {
            let png = std::fs::read(&f.png).unwrap();
            assert!(png.len() > 1000 && &png[1..4] == b"PNG", "{}", f.png.display());
            let svg = std::fs::read_to_string(f.png.with_extension("svg")).unwrap();
            assert!(svg.contains("<svg") && svg.contains("<polyline"), "{}", f.png.display());
            assert!(f.caption.len() > 40, "{}: {}", f.png.display(), f.caption);
            assert!(!f.caption.contains("object 1 ") && !f.caption.contains("object 1,"), "{}", f.caption);
        }
        let svg = |stem: &str| std::fs::read_to_string(out.join(format!("{stem}.svg"))).unwrap();
        for stem in ["fig3_speed_0000_object2", "fig5_ace_0000_object2", "rpe_camera_0000"] {
            assert!(svg(stem).contains("time (s; frames at 10 Hz)"), "{stem}: the x axis says seconds");
        }
        assert!(svg("ade_horizon").contains("horizon (s; 30 steps at 10 Hz)"));
        assert!(svg("fig3_speed_0000_object2").contains("sequence 0000, object 2"), "the title's number");
        let forecasts = svg("forecasts_0000_object2");
        for label in ["true future (labels)", "learned int8 on gt", "learned int8 on estimated", "constant velocity"] {
            assert!(forecasts.contains(label), "{label} in the forecasts figure");
        }
        let birdseye = svg("birdseye_0000_object2");
        for label in ["\ngt\n", "\ngt-ekf\n", "\nestimated\n", "\nestimated-smoothed\n", "simulator&apos;s truth"] {
            // SVG escapes the apostrophe
            assert!(birdseye.contains(label), "{label:?} in the bird's-eye figure");
        }

        // A chosen object: object 3 (the cyclist, KITTI track 2) gets every per-object figure.
        let chosen = [parse_object_choice("0000:3").unwrap()];
        let out = dir.path().join("chosen");
        let figures = write_figures(&out, &seqs, &arms, &rule, 0.1, &models, &chosen).unwrap();
        assert!(figures.iter().any(|f| f.png.ends_with("birdseye_0000_object3.png")));
        assert!(figures.iter().all(|f| !f.png.to_string_lossy().contains("object2")));
        let bad = [parse_object_choice("0000:9").unwrap()];
        let e = write_figures(&out, &seqs, &arms, &rule, 0.1, &models, &bad).unwrap_err();
        assert!(e.to_string().starts_with("--object 0000:9: sequence 0000 has no object 9"), "{e}");
    }

    #[test]
    fn figures_without_their_inputs_are_left_out() {
        let dir = tempfile::tempdir().unwrap();
        let mut seq = drive_0000(&dir.path().join("kitti"));
        seq.estimated = None;
        let figures = write_figures(
            &dir.path().join("figures"),
            &[seq],
            &[Source::Gt],
            &EligibilityRule::default(),
            0.1,
            &dir.path().join("no models"),
            &[],
        )
        .unwrap();
        let stems: Vec<String> =
            figures.iter().map(|f| f.png.file_stem().unwrap().to_string_lossy().into_owned()).collect();
        assert_eq!(
            stems,
            [
                "fig2_distance_0000_object2",
                "fig3_speed_0000_object2",
                "fig4_heading_0000_object2",
                "birdseye_0000_object2"
            ],
            "no fold model: no ACE, forecasts or horizon; no estimator: no RPE"
        );
    }
}

//! `dynotraj simulate`: renders an image sequence with the image simulator, driven by a KITTI
//! sequence's labels and ego poses (or by the built-in synthetic drive), and writes it in the
//! KITTI tracking layout with its truth (see `dynotraj_bag::sim_layout`).

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::Context as _;
use clap::Args;
use dynotraj_sim::image_sim::{Camera, ImageSim};

use super::data_args::ClassesArg;
use super::progress::progress;
use dynotraj_bag::sim_layout::write_sequence_with;
use dynotraj_eval::report::estimator_tables::end_to_end_text;
use dynotraj_formats::kitti::TrackingDir;
use dynotraj_frontend::StereoParams;
use dynotraj_sources::estimation::end_to_end;
use dynotraj_sources::estimation::input::image_sim;

/// Options of `dynotraj simulate`.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// A KITTI tracking split folder whose labels and ego poses drive the scene (only their
    /// geometry is used: no KITTI pixels). Without it, the built-in synthetic drive is rendered.
    #[arg(long, env = "DYNOTRAJ_KITTI", hide_env_values = true, value_name = "DIR")]
    pub kitti: Option<PathBuf>,
    /// Use the built-in synthetic drive even when --kitti / DYNOTRAJ_KITTI is set.
    #[arg(long)]
    pub drive: bool,
    /// Sequences to render, comma-separated (default: every sequence in the folder). The
    /// synthetic drive is one sequence, written as 0000 unless one id is given.
    #[arg(long = "sequences", visible_alias = "sequence", value_delimiter = ',', value_parser = crate::numbers::sequence_id, value_name = "LIST")]
    pub sequences: Vec<String>,
    /// Output folder (KITTI tracking layout).
    #[arg(long, value_name = "DIR", required_unless_present = "e2e")]
    pub out: Option<PathBuf>,
    /// Instead of writing, run the rendered frames through the front-end (stereo depth, the
    /// rendered instance masks) and the core estimator, and print camera and object RPE against
    /// the simulator's truth.
    #[arg(long)]
    pub e2e: bool,
    /// Stereo matching on images shrunk by this factor (1 or 2), for --e2e.
    #[arg(long, default_value_t = 1)]
    pub stereo_downscale: i32,
    /// Image scale: 1 renders at KITTI's 1242 x 375, 0.5 at 621 x 188.
    #[arg(long, value_parser = crate::numbers::positive, default_value_t = 1.0)]
    pub scale: f64,
    /// Frames to render (default: the whole sequence).
    #[arg(long, value_name = "N")]
    pub frames: Option<usize>,
    /// Sensor noise, grey levels (uniform, +-). 0 makes PNGs several times smaller.
    #[arg(long, default_value_t = 2)]
    pub noise: i32,
    /// Seed of the scene and texture.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The classes.
    #[command(flatten)]
    pub classes: ClassesArg,
}

/// The sequences `args` asks for: those of the KITTI folder, or the synthetic drive's one.
///
/// # Errors
/// A folder that cannot be listed, a sequence given twice, several ids for the drive.
pub fn sequence_ids(args: &SimulateArgs) -> anyhow::Result<Vec<String>> {
    match (&args.kitti, args.drive) {
        (Some(dir), false) => dynotraj_sources::drives::sequence_ids(&TrackingDir::open(dir)?, &args.sequences),
        _ => match args.sequences.as_slice() {
            [] => Ok(vec!["0000".to_string()]),
            [one] => Ok(vec![one.clone()]),
            more => anyhow::bail!(
                "--sequences: the synthetic drive is one sequence; expected at most one id, found {}",
                more.join(",")
            ),
        },
    }
}

/// The simulator for sequence `id` of `args`: a KITTI sequence's geometry or the synthetic
/// drive ([`dynotraj_sources::estimation::input::image_sim`]).
///
/// # Errors
/// Loading errors, named; a bad scale or noise.
pub fn build(args: &SimulateArgs, id: &str) -> anyhow::Result<ImageSim> {
    anyhow::ensure!(
        args.scale.is_finite() && (0.05..=2.0).contains(&args.scale),
        "--scale: expected 0.05..=2, found {}",
        args.scale
    );
    anyhow::ensure!((0..=50).contains(&args.noise), "--noise: expected 0..=50 grey levels, found {}", args.noise);
    let camera = Camera { noise: args.noise, ..Camera::kitti(args.scale) };
    let kitti = args.kitti.as_deref().filter(|_| !args.drive).map(|dir| (dir, id, args.classes.list.as_slice()));
    image_sim(kitti, camera, args.frames, args.seed)
}

/// Renders and writes.
///
/// # Errors
/// Loading or writing errors, named.
pub fn run(args: &SimulateArgs) -> anyhow::Result<()> {
    args.out.as_deref().map(|d| dynotraj_formats::atomic::output_folder("--out", d)).transpose()?;
    for id in sequence_ids(args)? {
        let sim = build(args, &id)?;
        let n = args.frames.unwrap_or(sim.len()).min(sim.len());
        if args.e2e {
            end_to_end(args, &id, &sim, n)?;
            continue;
        }
        let out = args.out.as_ref().context("--out: the output folder is needed")?;
        let bar = Arc::new(progress(n as u64, &format!("sequence {id}: frames rendered")));
        write_sequence_with(out, &id, &sim, n, Some(bar.hook().as_fn()))?;
        bar.finish_and_clear();
        eprintln!(
            "wrote {n} frames of {}x{} of sequence {id} to {}",
            sim.camera.width,
            sim.camera.height,
            out.display()
        );
    }
    Ok(())
}

/// `--e2e`: front-end and estimator on the rendered frames, scored against the truth.
fn end_to_end(args: &SimulateArgs, id: &str, sim: &ImageSim, n: usize) -> anyhow::Result<()> {
    let stereo = StereoParams { downscale: args.stereo_downscale, ..StereoParams::kitti_at_scale(args.scale) };
    // The paper's 20 Hz for timestamps; RPE does not depend on it.
    let bar = Arc::new(progress(n as u64, &format!("sequence {id}: frames rendered and tracked")));
    let r = end_to_end::run_with(sim, n, (0.05, stereo), 0.1, Some(&bar.hook()))?;
    bar.finish_and_clear();
    print!("{}", end_to_end_text(id, n, (sim.camera.width, sim.camera.height), &r));
    Ok(())
}

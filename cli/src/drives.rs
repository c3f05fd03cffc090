//! `dynotraj drives`: the drives a manifest (or a folder of drives) names, as a run with
//! `--drives` would read them.

use std::path::PathBuf;

use super::data_args::{KITTI_ENV, kitti_or_env};
use clap::Args;
use dynotraj_sources::drives::kitti_drives;
use dynotraj_sources::drives::manifest_drives;

/// Options of `dynotraj drives`.
#[derive(Debug, Args)]
#[command(after_help = "One line per drive, tab-separated: its name (what --sequences chooses), its kind \
    (labelled: a layout sequence with ego poses and labels; images: a layout sequence without ego poses, \
    estimated sources only; bag: a ROS 2 bag, imported into --estimate-cache), the folder or file it is \
    read from, and where it was listed.")]
pub struct DrivesArgs {
    /// A drive manifest, or a layout folder, a bag, or a folder of them.
    #[arg(value_name = "PATH", conflicts_with = "kitti")]
    pub path: Option<PathBuf>,
    /// Instead, a KITTI tracking folder's drives as `--kitti` reads them (every one labelled;
    /// default: $DYNOTRAJ_KITTI when no PATH is given).
    #[arg(long, value_name = "DIR")]
    pub kitti: Option<PathBuf>,
}

/// Lists the drives.
///
/// # Errors
/// As [`manifest_drives`] or [`kitti_drives`].
pub fn run(args: &DrivesArgs) -> anyhow::Result<()> {
    let drives = match (&args.path, kitti_or_env(args.kitti.as_deref())) {
        (Some(path), _) => manifest_drives(path)?,
        (None, Some(kitti)) => kitti_drives(&kitti, &[])?,
        (None, None) => anyhow::bail!("expected a drive manifest PATH, or --kitti DIR (or ${KITTI_ENV})"),
    };
    let mut text = String::new();
    for d in &drives {
        text.push_str(&format!("{}\t{}\t{}\t{}\n", d.name, d.kind(), d.path().display(), d.listed));
    }
    print!("{text}");
    Ok(())
}

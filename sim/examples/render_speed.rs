//! Renders frames of KITTI tracking sequences the way the reports do (KITTI's camera at scale 1,
//! 2 grey levels of noise, seed 1, the forecast classes) and prints the seconds per frame and one
//! 64-bit FNV-1a hash over every frame's left and right RGB, depth bits and ids, so that a change
//! to the renderer can be timed and checked for identical output.
//!
//! `cargo run --release -p dynotraj-sim --example render_speed -- DIR [SEQS] [FRAMES] [OPTICS] [THREADS] [SCALE]`
//! DIR: a KITTI tracking split (label_02/, calib/, poses; default `$DYNOTRAJ_KITTI`); SEQS: comma-separated ids (default
//! 0000); FRAMES: frames per sequence, `all` for every frame (default 50); OPTICS: `ideal` (the
//! reports' renderings, default) or `camera`; THREADS: render threads (default 1);
//! SCALE: image scale (default 1). The sequence id `drive` is the built-in synthetic drive.

use std::time::{Duration, Instant};

use dynotraj_core::wire::ObjectClass;
use dynotraj_formats::kitti::TrackingDir;
use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_sim::image_sim::{Camera, ImageSim, Optics};
use dynotraj_sim::track_sim::LabelBox;

/// FNV-1a, 64 bits: stable across platforms and releases, unlike std's hasher.
struct Fnv(u64);

impl Fnv {
    fn bytes(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 = (self.0 ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3);
        }
    }
}

/// The simulator of sequence `id`'s first `frames` frames, as the reports build it.
fn image_sim(dir: &TrackingDir, id: &str, frames: Option<usize>, camera: Camera) -> anyhow::Result<ImageSim> {
    if id == "drive" {
        let d = generate(&DriveSpec { frames: frames.unwrap_or(60), seed: 1, ..DriveSpec::default() });
        return Ok(ImageSim::new(camera, &d.camera_poses, &LabelBox::of_drive(&d), 1));
    }
    let data = dir.load_sequence(id)?;
    let classes = ObjectClass::FORECAST;
    let n = frames.map_or(data.poses.len(), |m| m.min(data.poses.len()));
    let boxes: Vec<LabelBox> =
        LabelBox::of_labels(&data.labels, &classes).into_iter().filter(|b| (b.frame as usize) < n).collect();
    Ok(ImageSim::new(camera, &data.poses[..n], &boxes, 1))
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = args.first().cloned().or_else(|| std::env::var("DYNOTRAJ_KITTI").ok());
    let dir = dir.ok_or_else(|| anyhow::anyhow!("give DIR, a KITTI tracking split (or set DYNOTRAJ_KITTI)"))?;
    let dir = TrackingDir::open(&dir)?;
    let seqs: Vec<&str> = args.get(1).map_or("0000", String::as_str).split(',').collect();
    let frames = match args.get(2).map(String::as_str) {
        Some("all") => None,
        Some(n) => Some(n.parse()?),
        None => Some(50),
    };
    let optics = match args.get(3).map(String::as_str) {
        None | Some("ideal") => Optics::IDEAL,
        Some("camera") => Optics::CAMERA,
        Some(o) => anyhow::bail!("optics: expected ideal or camera, found {o}"),
    };
    let threads: Option<usize> = args.get(4).map(|t| t.parse()).transpose()?;
    let scale: f64 = args.get(5).map_or(Ok(1.0), |s| s.parse())?;
    let camera = Camera { noise: 2, optics, ..Camera::kitti(scale) };
    let mut all = Fnv(0xcbf2_9ce4_8422_2325);
    let (mut total, mut count) = (Duration::ZERO, 0usize);
    for id in seqs {
        let sim = image_sim(&dir, id, frames, camera)?;
        let sim = match threads {
            Some(t) => sim.with_threads(t),
            None => sim,
        };
        let mut seq = Fnv(0xcbf2_9ce4_8422_2325);
        let mut elapsed = Duration::ZERO;
        for k in 0..sim.len() {
            let start = Instant::now();
            let f = sim.frame(k).expect("a frame in range");
            elapsed += start.elapsed();
            for h in [&mut seq, &mut all] {
                h.bytes(&f.left);
                h.bytes(&f.right);
                for z in &f.depth {
                    h.bytes(&z.to_bits().to_le_bytes());
                }
                for i in &f.ids {
                    h.bytes(&i.to_le_bytes());
                }
            }
        }
        println!(
            "sequence {id}: {} frames, {:.4} s/frame, hash {:016x}",
            sim.len(),
            elapsed.as_secs_f64() / sim.len().max(1) as f64,
            seq.0
        );
        total += elapsed;
        count += sim.len();
    }
    println!("all: {count} frames, {:.4} s/frame, hash {:016x}", total.as_secs_f64() / count.max(1) as f64, all.0);
    Ok(())
}

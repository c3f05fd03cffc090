//! Writes the image simulator's output ([`dynotraj_sim::image_sim`]) in the KITTI tracking
//! layout that the image front-end reads, plus the truth:
//!
//! ```text
//! <dir>/image_02/<seq>/NNNNNN.png     left RGB
//! <dir>/image_03/<seq>/NNNNNN.png     right RGB
//! <dir>/depth_02/<seq>/NNNNNN.png     left depth, uint16, value / 256 = metres (0: sky)
//! <dir>/instance_02/<seq>/NNNNNN.png  left instance ids, uint16 (0: static, else track id + 1)
//! <dir>/calib/<seq>.txt               P0 = P2 = left, P1 = P3 = right (rendered cameras)
//! <dir>/label_02/<seq>.txt            KITTI label rows of the truth; the 2D box is the visible
//!                                     mask's extent (rows only for objects with visible pixels)
//! <dir>/poses/<seq>.txt               true left-camera poses (KITTI 3x4)
//! <dir>/truth/<seq>.csv               frame,object_id,class,tx,ty,tz,qx,qy,qz,qw,h,w,l per true
//!                                     object pose (object_id 0 is the camera)
//! ```
//!
//! The rendered left camera plays KITTI's camera 0 and camera 2 at once (no offset between
//! them), so labels, poses and images share one frame.

use std::fmt::Write as _;
use std::path::Path;

use crate::png::{write_rgb, write_u16};
use anyhow::Context as _;
use dynotraj_formats::kitti::{LabelRow, write_labels, write_poses};
use dynotraj_sim::image_sim::{ImageSim, RenderedFrame};
use nalgebra::{Isometry3, Point3, Vector3};

/// Writes frame `f`'s four images.
///
/// # Errors
/// A file that cannot be written, named.
pub fn write_frame_images(dir: &Path, seq: &str, sim: &ImageSim, f: &RenderedFrame) -> anyhow::Result<()> {
    let (w, h) = (sim.camera.width, sim.camera.height);
    let name = format!("{:06}.png", f.frame);
    for (folder, rgb) in [("image_02", &f.left), ("image_03", &f.right)] {
        write_rgb(&dir.join(folder).join(seq).join(&name), rgb.clone(), (w, h))?;
    }
    let depth: Vec<u16> = f.depth.iter().map(|&z| (f64::from(z) * 256.0).round().clamp(0.0, 65535.0) as u16).collect();
    write_u16(&dir.join("depth_02").join(seq).join(&name), depth, (w, h))?;
    write_u16(&dir.join("instance_02").join(seq).join(&name), f.ids.clone(), (w, h))?;
    Ok(())
}

/// KITTI `rotation_y` of an object whose world pose is `o`, seen from camera `cam`.
fn rotation_y(cam: &Isometry3<f64>, o: &Isometry3<f64>) -> f64 {
    let x = cam.rotation.inverse() * (o.rotation * Vector3::x());
    (-x.z).atan2(x.x)
}

/// The label rows of frame `f`: one per object with visible pixels.
fn label_rows(f: &RenderedFrame, width: usize) -> Vec<LabelRow> {
    let to_cam = f.camera.inverse();
    let mut rows = Vec::new();
    for o in &f.objects {
        let mut bbox = [f64::MAX, f64::MAX, f64::MIN, f64::MIN];
        for (i, _) in f.ids.iter().enumerate().filter(|(_, id)| **id == o.object_id) {
            let (u, v) = ((i % width) as f64, (i / width) as f64);
            bbox = [bbox[0].min(u), bbox[1].min(v), bbox[2].max(u), bbox[3].max(v)];
        }
        if bbox[0] > bbox[2] {
            continue;
        }
        let [hgt, wid, len] = o.size;
        let bottom = to_cam * (o.pose * Point3::new(0.0, 0.5 * hgt, 0.0));
        let ry = rotation_y(&f.camera, &o.pose);
        rows.push(LabelRow {
            frame: f.frame as usize,
            track_id: i64::from(o.object_id) - 1,
            object_type: o.class.kitti_name().to_string(),
            truncated: 0.0,
            occluded: 0,
            alpha: ry - bottom.x.atan2(bottom.z),
            bbox_left: bbox[0],
            bbox_top: bbox[1],
            bbox_right: bbox[2],
            bbox_bottom: bbox[3],
            height: hgt,
            width: wid,
            length: len,
            x: bottom.x,
            y: bottom.y,
            z: bottom.z,
            rotation_y: ry,
            score: None,
        });
    }
    rows
}

/// The calibration file of the rendered stereo camera.
fn calib_text(sim: &ImageSim) -> String {
    let c = sim.camera;
    let p = |tx: f64| [c.fx, 0.0, c.cx, tx, 0.0, c.fy, c.cy, 0.0, 0.0, 0.0, 1.0, 0.0];
    dynotraj_formats::kitti::stereo_calib_text(&p(0.0), &p(-c.fb()))
}

/// Renders and writes frames `0..frames` of `sim` as sequence `seq` under `dir`.
///
/// # Errors
/// A file or folder that cannot be written, named.
pub fn write_sequence(dir: &Path, seq: &str, sim: &ImageSim, frames: usize) -> anyhow::Result<()> {
    write_sequence_with(dir, seq, sim, frames, None)
}

/// [`write_sequence`], telling `on_frame` the frames written after each.
///
/// # Errors
/// As [`write_sequence`].
pub fn write_sequence_with(
    dir: &Path,
    seq: &str,
    sim: &ImageSim,
    frames: usize,
    on_frame: Option<&dyn Fn(u64)>,
) -> anyhow::Result<()> {
    let seq = dynotraj_formats::kitti::checked_sequence_id(seq)?;
    for folder in ["image_02", "image_03", "depth_02", "instance_02"] {
        let d = dir.join(folder).join(seq);
        std::fs::create_dir_all(&d).with_context(|| format!("creating {}", d.display()))?;
    }
    for folder in ["calib", "label_02", "poses", "truth"] {
        let d = dir.join(folder);
        std::fs::create_dir_all(&d).with_context(|| format!("creating {}", d.display()))?;
    }
    let n = frames.min(sim.len());
    let mut labels = Vec::new();
    let mut truth = String::from("frame,object_id,class,tx,ty,tz,qx,qy,qz,qw,h,w,l\n");
    let row = |s: &mut String, k: usize, id: u16, class: &str, p: &Isometry3<f64>, size: [f64; 3]| {
        let (t, q) = (p.translation.vector, p.rotation.coords);
        let _ = writeln!(
            s,
            "{k},{id},{class},{:.6},{:.6},{:.6},{:.9},{:.9},{:.9},{:.9},{:.3},{:.3},{:.3}",
            t.x, t.y, t.z, q.x, q.y, q.z, q.w, size[0], size[1], size[2]
        );
    };
    for k in 0..n {
        let f = sim.frame(k).with_context(|| format!("frame {k} is past the sequence"))?;
        write_frame_images(dir, seq, sim, &f)?;
        if let Some(hook) = on_frame {
            hook(k as u64 + 1);
        }
        labels.extend(label_rows(&f, sim.camera.width));
        row(&mut truth, k, 0, "Camera", &f.camera, [0.0; 3]);
        for o in &f.objects {
            row(&mut truth, k, o.object_id, o.class.kitti_name(), &o.pose, o.size);
        }
    }
    let calib = dir.join("calib").join(format!("{seq}.txt"));
    dynotraj_formats::atomic::write_file(&calib, calib_text(sim))
        .with_context(|| format!("writing {}", calib.display()))?;
    write_labels(dir.join("label_02").join(format!("{seq}.txt")), &labels)?;
    write_poses(dir.join("poses").join(format!("{seq}.txt")), &sim.poses[..n])?;
    let truth_path = dir.join("truth").join(format!("{seq}.csv"));
    dynotraj_formats::atomic::write_file(&truth_path, truth)
        .with_context(|| format!("writing {}", truth_path.display()))?;
    Ok(())
}

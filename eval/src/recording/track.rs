//! The recording of the image front-end's tracks: each left image, the tracks drawn over it,
//! and the tracks with a depth as points of the camera frame.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use dynotraj_bag::record::{CAMERA_FRAME, ImagePoints, Recorder, RecordingEncoding, RecordingSummary, Rgba};
use dynotraj_core::estimate::Intrinsics;
use dynotraj_core::wire::{CameraInfo, Track};

/// Colour of the static tracks drawn over the image.
const STATIC_COLOR: Rgba = Rgba::opaque(0.2, 0.9, 0.3);
/// Colours of the objects' tracks drawn over the image, by object id in turn: distinct hues,
/// none of them the static tracks' green.
const OBJECT_COLORS: [Rgba; 6] = [
    Rgba::opaque(1.0, 0.3, 0.2),
    Rgba::opaque(0.2, 0.6, 1.0),
    Rgba::opaque(1.0, 0.8, 0.1),
    Rgba::opaque(0.9, 0.3, 0.9),
    Rgba::opaque(0.1, 0.9, 0.9),
    Rgba::opaque(1.0, 0.55, 0.1),
];
/// Diameter of a track drawn over the image, pixels.
const DOT_PX: f64 = 4.0;

/// A recording of the front-end's tracks over a sequence's images, being written frame by
/// frame.
#[derive(Debug)]
pub struct TrackRecorder {
    rec: Recorder,
    /// The sequence's left images, `NNNNNN.png`: the front-end reads them by the same names.
    left_dir: PathBuf,
    /// The camera the tracks were measured with.
    camera: Intrinsics,
}

impl TrackRecorder {
    /// Starts the recording `path` of the sequence whose left images are in `left_dir`, tracked
    /// with `camera`.
    ///
    /// # Errors
    /// The recording cannot be created, named.
    pub fn create(
        path: &Path,
        encoding: RecordingEncoding,
        left_dir: PathBuf,
        camera: &CameraInfo,
    ) -> anyhow::Result<Self> {
        Ok(Self { rec: Recorder::create_with(path, encoding)?, left_dir, camera: Intrinsics::from(camera) })
    }

    /// Ends the recording.
    ///
    /// # Errors
    /// Writing errors, named.
    pub fn finish(self) -> anyhow::Result<RecordingSummary> {
        self.rec.finish()
    }

    /// Writes frame `frame` (captured at `t_us`, the log time) and its `tracks`: the left
    /// image's file as it is (a PNG is already what `foxglove.CompressedImage` carries, so it
    /// is not decoded and encoded again), the tracks with a depth as points of the camera
    /// frame, static and object tracks apart, and every track over the image.
    ///
    /// # Errors
    /// The image cannot be read, or writing fails, named.
    pub fn frame(&mut self, frame: u32, t_us: u64, tracks: &[Track]) -> anyhow::Result<()> {
        let t = t_us.checked_mul(1000).with_context(|| format!("frame {frame}: capture time {t_us} us overflows"))?;
        let image = self.left_dir.join(format!("{frame:06}.png"));
        let bytes = std::fs::read(&image).with_context(|| format!("reading {}", image.display()))?;
        self.rec.image("/camera/left/compressed", t, CAMERA_FRAME, "png", &bytes)?;
        let (statics, objects): (Vec<&Track>, Vec<&Track>) = tracks.iter().partition(|k| k.is_static());
        self.rec.points("/tracks/static", t, CAMERA_FRAME, &super::back_project(&statics, &self.camera))?;
        let object_points: Vec<([f32; 3], u32)> = objects
            .iter()
            .filter_map(|k| Some((super::track_point(k, &self.camera)?, u32::from(k.object_id))))
            .collect();
        self.rec.labelled_points("/tracks/objects", t, CAMERA_FRAME, "object_id", &object_points)?;
        self.rec.image_points("/camera/left/annotations", t, &image_groups(&statics, &objects))?;
        Ok(())
    }
}

/// The tracks drawn over the image: the static ones in one group, each object's in a group of
/// its own colour (every track, with or without a depth: this is what the front-end followed).
fn image_groups(statics: &[&Track], objects: &[&Track]) -> Vec<ImagePoints> {
    let pixel = |k: &&Track| [f64::from(k.u), f64::from(k.v)];
    let mut groups =
        vec![ImagePoints { points: statics.iter().map(pixel).collect(), color: STATIC_COLOR, size: DOT_PX }];
    let mut by_object: std::collections::BTreeMap<u16, Vec<[f64; 2]>> = std::collections::BTreeMap::new();
    for k in objects {
        by_object.entry(k.object_id).or_default().push(pixel(k));
    }
    for (id, points) in by_object {
        let color = OBJECT_COLORS[usize::from(id) % OBJECT_COLORS.len()];
        groups.push(ImagePoints { points, color, size: DOT_PX });
    }
    groups
}

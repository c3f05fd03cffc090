//! Loading a KITTI tracking sequence into world-frame tracks: the labels' (ground truth), and,
//! when asked for, the estimator's (the paper's Estimated source).

use anyhow::Context as _;

use crate::estimation::cache;
use crate::estimation::from_images::{estimate_from_images, estimate_rendered, has_images, image_files};
use crate::estimation::settings::{EstimateSettings, SimulatedInput};
use crate::estimation::{EstimatedTracks, estimated_tracks, image_estimated_tracks, rendered_estimated_tracks};
use crate::scene::Scene;
use crate::trajectory::{ObjectTrack, Source, label_tracks};
use dynotraj_core::Point2;
use dynotraj_core::geometry::bev_point;
use dynotraj_formats::kitti::{SequenceData, TrackingDir};
use std::collections::BTreeMap;

/// The objects of one sequence as world-frame bird's-eye tracks.
#[derive(Debug, Clone)]
pub struct SequenceTracks {
    /// Sequence id, e.g. "0000".
    pub id: String,
    /// Frames in the sequence.
    pub frame_count: usize,
    /// One track per labelled object (DontCare regions and unknown types excluded).
    pub tracks: Vec<ObjectTrack>,
    /// The estimator's tracks of the same sequence, when they were asked for
    /// ([`load_sequence`] with `estimate`).
    pub estimated: Option<EstimatedTracks>,
    /// The camera's position on the bird's-eye plane per frame (index = frame) in the labels'
    /// world, from the ego poses; empty where there are none.
    pub camera_path: Vec<Point2>,
}

impl SequenceTracks {
    /// The base tracks of `source`: the labels for the GT sources, the estimator's causal or
    /// smoothed tracks for the estimated ones (empty when they were not loaded: callers check
    /// [`SequenceTracks::has`] first).
    #[must_use]
    pub fn tracks_for(&self, source: Source) -> &[ObjectTrack] {
        match (source, &self.estimated) {
            (Source::Estimated | Source::EstimatedEkf, Some(e)) => &e.causal,
            (Source::EstimatedSmoothed, Some(e)) => &e.smoothed,
            (Source::Estimated | Source::EstimatedEkf | Source::EstimatedSmoothed, None) => &[],
            _ => &self.tracks,
        }
    }

    /// Where the observing camera is at each frame in `source`'s world: the ego poses for the
    /// label sources, the estimator's causal camera for the estimated ones; empty when unknown.
    #[must_use]
    pub fn observer_for(&self, source: Source) -> BTreeMap<u32, Point2> {
        match (source, &self.estimated) {
            (Source::Estimated | Source::EstimatedEkf | Source::EstimatedSmoothed, e) => {
                e.as_ref().map(|e| e.observer.clone()).unwrap_or_default()
            }
            _ => (0u32..).zip(self.camera_path.iter().copied()).collect(),
        }
    }

    /// The tracks of `source` at frame period `dt` as a scene, seen from [`Self::observer_for`].
    #[must_use]
    pub fn scene(&self, source: Source, dt: f32) -> Scene {
        Scene::new(self.tracks_for(source), source, dt).seen_from(self.observer_for(source))
    }

    /// The simulator's true paths behind the estimated tracks, when there are any: `None`
    /// without estimated tracks or where they came from real images (no simulator).
    #[must_use]
    pub fn truth(&self) -> Option<&[ObjectTrack]> {
        self.estimated.as_ref().map(|e| &e.truth[..]).filter(|t| !t.is_empty())
    }

    /// The true track id behind track `id` of `source` (see
    /// [`EstimatedTracks::true_track_id`]); the labels' ids are the truth's.
    #[must_use]
    pub fn true_track_id(&self, source: Source, id: i32) -> Option<i32> {
        match &self.estimated {
            Some(e) if source.is_estimated() => e.true_track_id(id),
            _ => Some(id),
        }
    }

    /// Whether the tracks of `source` are loaded.
    #[must_use]
    pub fn has(&self, source: Source) -> bool {
        !source.is_estimated() || self.estimated.is_some()
    }
}

/// Loads sequence `id` of `dir` and builds its ground-truth tracks at frame period `dt`.
///
/// # Errors
/// Any loading error of the sequence's files, with the file named.
pub fn load_ground_truth(dir: &TrackingDir, id: &str, dt: f32) -> anyhow::Result<SequenceTracks> {
    load_sequence(dir, id, dt, None)
}

/// Loads sequence `id` of `dir` at frame period `dt`: its ground-truth tracks and, with
/// `estimate`, the estimator's tracks with those settings: from the sequence's own stereo
/// images through the image front-end where the folder holds every frame of them (a full KITTI
/// download), else from the track-level simulator driven by its labels and ego poses, or from
/// a rendering of it ([`SimulatedInput`]).
///
/// # Errors
/// Any loading error of the sequence's files, with the file named.
pub fn load_sequence(
    dir: &TrackingDir,
    id: &str,
    dt: f32,
    estimate: Option<&EstimateSettings>,
) -> anyhow::Result<SequenceTracks> {
    let data = dir.load_sequence(id).with_context(|| format!("loading KITTI tracking sequence {id}"))?;
    let mut seq = ground_truth_of(id, &data, dt);
    seq.estimated = match estimate {
        Some(e) => Some(estimated_cached(dir, id, &data, e)?),
        None => None,
    };
    Ok(seq)
}

/// The estimator's tracks of sequence `id` with settings `e`: from the sequence's images where
/// it has them all, else from the simulator or its rendering. Estimates from images or the
/// simulator are read from the cache when a file there has the key of these inputs, else
/// computed and stored; a rendering keeps its front-end tracks in the cache instead
/// ([`crate::estimation::rendered_cache`]) and is estimated afresh.
fn estimated_cached(
    dir: &TrackingDir,
    id: &str,
    data: &SequenceData,
    e: &EstimateSettings,
) -> anyhow::Result<EstimatedTracks> {
    let images = has_images(dir.root(), id, data.frame_count);
    if !images && e.input == SimulatedInput::Rendered {
        // The rendering and its front-end tracks are what take minutes; they are cached apart
        // from the estimator's settings and code, and the estimator runs on them in seconds.
        let r = estimate_rendered(id, data, &e.options, e.render_scale, e.cache.as_deref())
            .with_context(|| format!("sequence {id}: rendered front-end"))?;
        return Ok(rendered_estimated_tracks(&r, e.options.min_step_m));
    }
    let key = match &e.cache {
        Some(_) if images => {
            Some(cache::image_estimate_key(id, data, e, &image_files(dir.root(), id, data.frame_count))?)
        }
        Some(_) => Some(cache::estimate_key(id, data, e)?),
        None => None,
    };
    if let Some(t) = e.cache.as_deref().zip(key).and_then(|(dir, key)| cache::load(dir, id, key)) {
        log::info!("sequence {id}: estimated tracks read from the cache");
        return Ok(t);
    }
    let tracks = if images {
        log::info!("sequence {id}: estimating from its stereo images");
        image_estimated_tracks(&estimate_from_images(dir.root(), id, &e.options)?)
    } else {
        estimated_tracks(id, data, &e.options)
    };
    if let (Some(dir), Some(key)) = (&e.cache, key) {
        cache::store(dir, id, key, &tracks)?;
    }
    Ok(tracks)
}

/// Builds ground-truth tracks from loaded sequence data.
#[must_use]
pub fn ground_truth_of(id: &str, data: &SequenceData, dt: f32) -> SequenceTracks {
    SequenceTracks {
        id: id.to_string(),
        frame_count: data.frame_count,
        tracks: label_tracks(data, dt),
        estimated: None,
        camera_path: data.poses.iter().map(|p| bev_point(&p.translation.vector.cast::<f32>().into())).collect(),
    }
}

//! Every bad-input rule of the estimator (see `dynotraj_core::estimate`): each is counted, has
//! its documented effect, and nothing panics or turns non-finite.

use dynotraj_core::estimate::{
    Estimator, EstimatorParams, EstimatorStats, Intrinsics, MAX_HELD_FRAMES, PoseEstimate, Pushed,
};
use dynotraj_core::limits::MAX_OBJECTS;
use dynotraj_core::wire::{FrameTracks, ObjectClass, Track, frame_parts};
use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_sim::track_sim::{LabelBox, SimFrame, SimSpec, simulate};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

const W: usize = 8;

fn params() -> EstimatorParams {
    EstimatorParams::kitti(Intrinsics::KITTI_0926, 0.1)
}

fn sim(frames: usize) -> Vec<SimFrame> {
    let drive = generate(&DriveSpec { frames, ..DriveSpec::default() });
    let spec = SimSpec::kitti(Intrinsics::KITTI_0926, (1242.0, 375.0), 0.1, 5).noise_free();
    simulate(&drive.camera_poses, &LabelBox::of_drive(&drive), &spec)
}

/// Feeds frames of tracks; returns the causal estimate per frame and the smoothed ones.
struct Run {
    causal: Vec<PoseEstimate>,
    smoothed: Vec<PoseEstimate>,
    stats: EstimatorStats,
}

fn feed(frames: impl IntoIterator<Item = (u32, u64, Vec<Track>)>) -> Run {
    let mut est: Box<Estimator<W>> = Box::new(Estimator::new(params(), 1));
    let mut run = Run { causal: Vec::new(), smoothed: Vec::new(), stats: EstimatorStats::default() };
    for (frame, t, tracks) in frames {
        for part in frame_parts(frame, t, &tracks).expect("within budget") {
            if let Pushed::Frame { smoothed } = est.push(&part) {
                let mut e = PoseEstimate::new();
                est.causal(&mut e);
                run.causal.push(e);
                if smoothed {
                    run.smoothed.push(est.smoothed().clone());
                }
            }
        }
    }
    est.flush(|s| run.smoothed.push(s.clone()));
    run.stats = *est.stats();
    for e in run.causal.iter().chain(&run.smoothed) {
        assert!(e.camera.translation.vector.iter().all(|v| v.is_finite()), "non-finite camera at {}", e.frame);
        for o in &e.objects {
            assert!(o.bev.is_finite() && o.heading_rate.is_finite(), "non-finite object {o:?}");
        }
    }
    run
}

fn sim_frames(frames: &[SimFrame]) -> impl Iterator<Item = (u32, u64, Vec<Track>)> + '_ {
    frames.iter().map(|f| (f.frame, f.timestamp_us, f.tracks.clone()))
}

#[test]
fn fewer_points_than_a_minimal_set_hold_or_skip() {
    let frames = sim(12);
    // Frames 4..7 keep only two static tracks and two points of each object.
    let run = feed(sim_frames(&frames).map(|(k, t, tracks)| {
        if (4..7).contains(&k) {
            let mut kept = Vec::new();
            for id in [0u16, 1, 2, 3] {
                kept.extend(tracks.iter().filter(|tr| tr.object_id == id).take(2).copied());
            }
            (k, t, kept)
        } else {
            (k, t, tracks)
        }
    }));
    // Frames 4, 5, 6 and 7 (whose previous frame had two static tracks) hold.
    assert_eq!(run.stats.camera_motion_held, 4, "{:?}", run.stats);
    assert!(run.stats.object_motion_held >= 2, "{:?}", run.stats);
    // The held camera keeps moving at the previous speed (0.8 m per frame forward).
    let z = |k: usize| run.causal[k].camera.translation.vector.z;
    assert!((z(6) - z(5) - 0.8).abs() < 0.01, "{} {}", z(5), z(6));
    // A brand-new object with two points is not initialised.
    let lone = feed((0..3).map(|k| {
        (
            k,
            u64::from(k) * 100_000,
            frames[k as usize].tracks.iter().filter(|t| t.is_static()).copied().chain(two_point_object()).collect(),
        )
    }));
    assert_eq!(lone.stats.objects_not_initialised, 3);
    assert!(lone.causal.iter().all(|e| e.objects.is_empty()));
}

fn two_point_object() -> [Track; 2] {
    let t = Track { track_id: 9_000_000, object_id: 40, class: ObjectClass::Car, u: 600.0, v: 200.0, depth: 12.0 };
    [t, Track { track_id: 9_000_001, u: 610.0, ..t }]
}

#[test]
fn bad_depths_and_pixels_are_skipped_and_counted() {
    let frames = sim(10);
    let run = feed(sim_frames(&frames).map(|(k, t, mut tracks)| {
        for (i, tr) in tracks.iter_mut().enumerate().filter(|(i, _)| i % 10 == 0) {
            match i % 50 {
                0 => tr.depth = 0.0,
                10 => tr.depth = -4.0,
                20 => tr.depth = f32::NAN,
                30 => tr.u = f32::INFINITY,
                _ => tr.v = -3.0,
            }
        }
        (k, t, tracks)
    }));
    assert!(run.stats.tracks_bad_depth > 0 && run.stats.tracks_bad_pixel > 0, "{:?}", run.stats);
    assert_eq!(run.stats.camera_motion_held, 0);
    assert_eq!(run.causal.len(), 10);
}

#[test]
fn duplicate_track_ids_are_counted_and_one_copy_kept() {
    let frames = sim(10);
    let run = feed(sim_frames(&frames).map(|(k, t, tracks)| {
        // 64 static tracks sent twice, the copy 40 px off and first: the copy must be ignored
        // (the smaller pixel is kept, whatever the order). The list keeps room for the copies:
        // repeats count against its capacity until the frame completes.
        let statics: Vec<Track> = tracks.iter().filter(|t| t.is_static()).take(192).copied().collect();
        let mut out: Vec<Track> = statics.iter().take(64).map(|t| Track { u: t.u + 40.0, ..*t }).collect();
        out.extend(statics);
        out.extend(tracks.iter().filter(|t| !t.is_static()).copied());
        (k, t, out)
    }));
    assert_eq!(run.stats.tracks_duplicate, 10 * 64);
    assert_eq!(run.stats.static_tracks_dropped, 0);
    assert_eq!(run.stats.camera_motion_held, 0);
    let z = run.causal[9].camera.translation.vector.z;
    assert!((z - 7.2).abs() < 0.02, "camera at {z} m, expected 7.2 m");
}

/// Frames `gap` of the drive without object 1's tracks.
fn without_object_1(frames: usize, gap: std::ops::Range<u32>) -> Run {
    let sim = sim(frames);
    feed(sim_frames(&sim).map(|(k, t, tracks)| {
        let tracks =
            if gap.contains(&k) { tracks.into_iter().filter(|tr| tr.object_id != 1).collect() } else { tracks };
        (k, t, tracks)
    }))
}

fn has_object_1(e: &PoseEstimate) -> bool {
    e.objects.iter().any(|o| o.object_id == 1)
}

#[test]
fn an_object_missing_for_a_few_frames_coasts_and_resumes_its_run() {
    // The drive's other objects leave the view (and coast out): counted against the same drive
    // without the gap.
    let b = without_object_1(40, 0..0).stats;
    let run = without_object_1(40, 15..18);
    let s = run.stats;
    assert_eq!(
        (s.objects_resumed, s.object_frames_coasted),
        (b.objects_resumed + 1, b.object_frames_coasted + 3),
        "{s:?}"
    );
    assert_eq!((s.objects_returned, s.runs_ended_lost), (b.objects_returned, b.runs_ended_lost), "{s:?}");
    // One run: every frame from the second on, the gap included, causal and smoothed, in one
    // output segment.
    assert!(run.causal.iter().filter(|e| e.frame >= 1).all(has_object_1));
    assert!(run.smoothed.iter().filter(|e| e.frame >= 1).all(has_object_1));
    let segments: std::collections::BTreeSet<u16> = run
        .smoothed
        .iter()
        .flat_map(|e| e.objects.iter().filter(|o| o.object_id == 1 && o.heading_known).map(|o| o.segment))
        .collect();
    assert_eq!(segments.len(), 1, "{segments:?}");
    // The coasted frames lie on the object's path: the step into and out of the gap is no
    // larger than the steps around it.
    let x = |k: u32| {
        let e = run.smoothed.iter().find(|e| e.frame == k).unwrap();
        e.objects.iter().find(|o| o.object_id == 1).unwrap().bev
    };
    let step = |a: u32| x(a).position().distance(&x(a + 1).position());
    let before = step(12);
    for k in 14..19 {
        assert!((step(k) - before).abs() < 0.25 * before + 0.05, "step {k}: {} m vs {before} m", step(k));
    }
}

#[test]
fn an_object_missing_too_long_ends_its_run_and_is_reinitialised() {
    let gap = 15..(15 + u32::from(MAX_HELD_FRAMES) + 2);
    let b = without_object_1(50, 0..0).stats;
    let run = without_object_1(50, gap.clone());
    let s = run.stats;
    let expected = (b.runs_ended_lost + 1, b.objects_returned + 1, b.objects_resumed);
    assert_eq!((s.runs_ended_lost, s.objects_returned, s.objects_resumed), expected, "{s:?}");
    assert_eq!(s.object_frames_coasted, b.object_frames_coasted + u32::from(MAX_HELD_FRAMES), "{s:?}");
    // The first run's measured frames still come out smoothed (its window drained); its coasted
    // frames were extrapolations and do not.
    assert!(run.smoothed.iter().filter(|e| e.frame < 15).all(has_object_1));
    assert!(run.smoothed.iter().filter(|e| gap.contains(&e.frame)).all(|e| !has_object_1(e)));
    // Causal: coasting for MAX_HELD_FRAMES frames, then gone until tracked again from the
    // second frame of the new run.
    let coasting = 15..15 + u32::from(MAX_HELD_FRAMES);
    assert!(run.causal.iter().filter(|e| coasting.contains(&e.frame)).all(has_object_1));
    assert!(run.causal.iter().filter(|e| e.frame >= coasting.end && e.frame <= gap.end).all(|e| !has_object_1(e)));
    assert!(run.causal.iter().filter(|e| e.frame > gap.end).all(has_object_1));
    assert_eq!(run.smoothed.len(), 50);
}

/// Object 1's tracks renumbered (every id new) from frame `from` on, and missing in `gap`.
fn renumbered_object_1(frames: usize, from: u32, gap: std::ops::Range<u32>) -> Run {
    let sim = sim(frames);
    feed(sim_frames(&sim).map(|(k, t, tracks)| {
        let tracks =
            tracks
                .into_iter()
                .filter(|tr| tr.object_id != 1 || !gap.contains(&k))
                .map(|tr| {
                    if tr.object_id == 1 && k >= from { Track { track_id: tr.track_id + 1_000_000, ..tr } } else { tr }
                })
                .collect();
        (k, t, tracks)
    }))
}

#[test]
fn an_object_whose_points_all_get_new_ids_is_found_again_not_restarted() {
    let b = without_object_1(40, 0..0).stats;
    let run = renumbered_object_1(40, 20, 0..0);
    let s = run.stats;
    assert_eq!(s.objects_initialised, b.objects_initialised, "{s:?}");
    assert_eq!((s.objects_returned, s.runs_ended_fit_failed), (b.objects_returned, b.runs_ended_fit_failed), "{s:?}");
    assert!(run.causal.iter().filter(|e| e.frame >= 1).all(has_object_1));
    // Through a gap as well: coasted, then found by position.
    let run = renumbered_object_1(40, 18, 15..18);
    let s = run.stats;
    let expected = (b.objects_resumed + 1, b.objects_returned, b.runs_ended_lost);
    assert_eq!((s.objects_resumed, s.objects_returned, s.runs_ended_lost), expected, "{s:?}");
    assert!(run.smoothed.iter().filter(|e| e.frame >= 1).all(has_object_1));
}

#[test]
fn an_object_out_of_range_too_long_ends_its_run_as_out_of_range() {
    let sim = sim(30);
    let run = feed(sim_frames(&sim).map(|(k, t, tracks)| {
        let far = |tr: Track| if tr.object_id == 1 && k >= 15 { Track { depth: 500.0, ..tr } } else { tr };
        (k, t, tracks.into_iter().map(far).collect())
    }));
    let s = run.stats;
    let b = without_object_1(30, 0..0).stats;
    let expected = (1, b.runs_ended_lost, b.runs_ended_fit_failed);
    assert_eq!((s.runs_ended_out_of_range, s.runs_ended_lost, s.runs_ended_fit_failed), expected, "{s:?}");
    assert!(s.tracks_too_far > 0, "{s:?}");
    // Held (not coasted) while out of range, then gone; never re-initialised from no points.
    assert_eq!(s.object_frames_coasted, b.object_frames_coasted, "{s:?}");
    let ended = 15 + u32::from(MAX_HELD_FRAMES);
    assert!(run.causal.iter().filter(|e| e.frame > ended).all(|e| !has_object_1(e)));
}

#[test]
fn more_objects_than_capacity_are_dropped_and_counted() {
    let frames = sim(6);
    let run = feed(sim_frames(&frames).map(|(k, t, mut tracks)| {
        // Twenty extra fake objects, each a copy of the static tracks under a new id.
        let statics: Vec<Track> = tracks.iter().filter(|t| t.is_static()).take(20).copied().collect();
        for extra in 0..20u16 {
            tracks.extend(statics.iter().map(|t| Track {
                track_id: t.track_id,
                object_id: 100 + extra,
                class: ObjectClass::Car,
                ..*t
            }));
        }
        (k, t, tracks)
    }));
    assert_eq!(run.stats.frames_with_objects_dropped, 6);
    assert!(run.stats.object_tracks_dropped > 0);
    assert!(run.causal.iter().chain(&run.smoothed).all(|e| e.objects.len() <= MAX_OBJECTS));
}

#[test]
fn lost_parts_and_bad_timestamps_are_counted() {
    let frames = sim(8);
    let mut est: Box<Estimator<W>> = Box::new(Estimator::new(params(), 1));
    let mut done = 0;
    for f in &frames {
        // Frame 3 loses its last part; frame 5 goes back in time.
        let t = if f.frame == 5 { 1 } else { f.timestamp_us };
        let parts: Vec<FrameTracks> = frame_parts(f.frame, t, &f.tracks).expect("budget").collect();
        let n = if f.frame == 3 { parts.len() - 1 } else { parts.len() };
        for p in &parts[..n] {
            if matches!(est.push(p), Pushed::Frame { .. }) {
                done += 1;
            }
        }
        // A repeated part and a malformed one are ignored.
        assert_eq!(est.push(&parts[0]), Pushed::Rejected);
        let mut bad = parts[0].clone();
        bad.part = bad.parts;
        assert_eq!(est.push(&bad), Pushed::Rejected);
    }
    let s = est.stats();
    assert_eq!(done, 7);
    assert_eq!(s.frames_incomplete, 1);
    assert_eq!(s.timestamps_replaced, 1, "frame 5 goes back in time");
    assert!(s.parts_stale + s.parts_duplicate >= 7 && s.parts_malformed == 8, "{s:?}");
}

#[test]
fn garbage_tracks_never_panic() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(99);
    let wild = |rng: &mut Xoshiro256PlusPlus| match rng.random_range(0..6) {
        0 => f32::NAN,
        1 => f32::INFINITY,
        2 => -rng.random_range(0.0..1e6),
        3 => rng.random_range(0.0..1e9),
        _ => rng.random_range(0.0..1300.0),
    };
    let frames: Vec<(u32, u64, Vec<Track>)> = (0..30)
        .map(|k| {
            let n = rng.random_range(0..600);
            let tracks = (0..n)
                .map(|_| Track {
                    track_id: rng.random_range(0..300),
                    object_id: rng.random_range(0..24),
                    class: ObjectClass::Car,
                    u: wild(&mut rng),
                    v: wild(&mut rng),
                    depth: wild(&mut rng),
                })
                .collect();
            (k, rng.random_range(0..10_000_000), tracks)
        })
        .collect();
    let run = feed(frames);
    assert_eq!(run.stats.frames_processed, 30);
    let s = run.stats;
    assert!(s.tracks_bad_depth > 0 && s.tracks_too_far > 0 && s.tracks_bad_pixel > 0, "{s:?}");
}

#[test]
fn motion_held_too_long_reinitialises_the_object() {
    let frames = sim(30);
    // Object 1's points jump randomly from frame 10 on for 6 frames: no fit agrees.
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    let run = feed(sim_frames(&frames).map(|(k, t, mut tracks)| {
        if (10..16).contains(&k) {
            for tr in tracks.iter_mut().filter(|t| t.object_id == 1) {
                tr.u = rng.random_range(0.0..1200.0);
                tr.v = rng.random_range(0.0..370.0);
            }
        }
        (k, t, tracks)
    }));
    assert!(run.stats.object_motion_held > u32::from(MAX_HELD_FRAMES), "{:?}", run.stats);
    assert!(run.stats.objects_initialised >= 4, "{:?}", run.stats);
}

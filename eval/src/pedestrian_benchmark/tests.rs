use super::*;

/// Two walkers crossing at constant speed and one turning, in the file layout.
fn write_recording(dir: &Path, split: &str, name: &str, offset: f32) {
    let mut text = String::new();
    for k in 0..40u32 {
        let t = k as f32 * PERIOD_S;
        let _ = std::fmt::Write::write_fmt(&mut text, format_args!("{}\t1\t{}\t{}\n", k * 10, offset + 1.2 * t, 0.0));
        let _ = std::fmt::Write::write_fmt(&mut text, format_args!("{}\t2\t{}\t{}\n", k * 10, 5.0, offset - 1.0 * t));
        let a = 0.15 * t;
        let _ = std::fmt::Write::write_fmt(
            &mut text,
            format_args!("{}\t3\t{}\t{}\n", k * 10, 8.0 * a.sin(), 8.0 * (1.0 - a.cos())),
        );
    }
    let path = recording_path(dir, split, name);
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, text).unwrap();
}

#[test]
fn a_scene_is_scored_on_its_own_recordings_with_every_row() {
    let dir = tempfile::tempdir().unwrap();
    for (i, name) in RECORDINGS.iter().enumerate() {
        for split in ["all_data", "train", "val"] {
            write_recording(dir.path(), split, name, i as f32);
        }
    }
    let options = BenchmarkOptions {
        data: dir.path().to_path_buf(),
        scenes: vec!["univ".into()],
        dims: Dims::DEFAULT,
        hyper: Hyper { epochs: 2, ..Hyper::default() },
        dynamics: Dynamics::SingleIntegrator,
        train: true,
    };
    let scenes = chosen_scenes(&options.scenes).unwrap();
    let r = run_scene(scenes[0], &options, &mut |_| {}).unwrap();
    // Two test recordings, three walks of 40 steps each: 21 windows per walk.
    assert_eq!(r.windows, 2 * 3 * 21);
    assert_eq!(r.rows.iter().map(|(l, _)| *l).collect::<Vec<_>>(), ROWS.to_vec());
    let cv = r.total("cv").unwrap();
    assert_eq!(cv.ade.count() as usize, r.windows);
    // Straight walkers are forecast exactly by cv; the turning one is not.
    assert!(cv.ade.value().unwrap() > 0.01, "{cv:?}");
    assert!(r.rows.iter().all(|(_, walks)| walks.len() == 6));
    let int8 = r.ratio("learned int8", "cv", Metric::Ade).unwrap();
    assert!(int8.low <= int8.ratio && int8.ratio <= int8.high);
    assert_eq!(r.train_windows, (6 * 3 * 21, 6 * 3 * 21), "six recordings train and select");
    assert!(chosen_scenes(&["nowhere".into()]).unwrap_err().to_string().contains("expected eth, hotel"));
    let missing = BenchmarkOptions { data: dir.path().join("absent"), ..options };
    let err = run_scene(scenes[0], &missing, &mut |_| {}).unwrap_err().to_string();
    assert!(err.contains("absent") && err.contains("biwi_eth_train.txt"), "{err}");
}

#[test]
fn consecutive_windows_of_a_walk_are_blended_and_others_are_not() {
    let window = |walk, step| Window {
        pedestrian: 1,
        walk,
        step,
        history: Vec::new(),
        future: vec![Point2::default(); FUTURE_STEPS],
        neighbours: Vec::new(),
    };
    // Walk 0 steps 0, 1, 3 (a gap before 3), walk 1 step 4: each fresh forecast is 1 m off.
    let windows = [window(0, 0), window(0, 1), window(0, 3), window(1, 4)];
    let fresh = |w: &Window, out: &mut Forecast| {
        // The second window's fresh forecast is 3 m off, the others 1 m.
        let off = if w.step == 1 { 3.0 } else { 1.0 };
        *out = [Point2::new(off, 0.0); HORIZON];
        true
    };
    let walks = score(&windows, Carry::new(0.5), fresh);
    assert_eq!(walks.iter().map(|w| w.ade.count()).sum::<u32>(), 4);
    let ade = |walk: usize| walks[walk].ade.value().unwrap();
    // Walk 0: 1 m, then (3 + 1) / 2 = 2 m blended, then 1 m after the gap.
    assert!((ade(0) - (1.0 + 2.0 + 1.0) / 3.0).abs() < 1e-4, "{}", ade(0));
    assert!((ade(1) - 1.0).abs() < 1e-6, "a new walk starts afresh: {}", ade(1));
    let unblended = score(&windows, Carry::NONE, fresh);
    assert!((unblended[0].ade.value().unwrap() - 5.0 / 3.0).abs() < 1e-4);
}

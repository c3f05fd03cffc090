//! Property tests of two more input boundaries: the command line's number parsers (any text
//! gives a value in the flag's documented range, or an error saying what was expected) and the
//! KITTI layout loader as a whole (a tracking folder with any of its files damaged, removed or
//! replaced by random bytes loads, or fails with an error naming a file, never panics), and
//! drive manifests (any text gives entries from its lines, or names a line of it).

use std::path::{Path, PathBuf};
use std::time::Duration;

use dynotraj_cli::numbers::{self, FRAME_RATE_RANGE, MAX_SECONDS};
use dynotraj_formats::kitti::TrackingDir;
use dynotraj_formats::manifest::parse_manifest;
use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_tests::synthetic_kitti::write_sequence;
use proptest::prelude::*;

/// Text that looks like a number more often than random text does.
fn number_text() -> impl Strategy<Value = String> {
    prop_oneof![
        "[-+]?[0-9]{0,4}(\\.[0-9]{0,4})?([eE][-+]?[0-9]{1,3})?",
        Just("inf".to_string()),
        Just("-inf".to_string()),
        Just("NaN".to_string()),
        Just(" 1 ".to_string()),
        any::<f64>().prop_map(|v| v.to_string()),
        ".{0,12}",
    ]
}

/// Checks one parser: an error says what was expected; a value is finite and passes `ok`.
fn holds<T: Copy + std::fmt::Debug>(
    text: &str,
    got: Result<T, String>,
    finite: impl Fn(T) -> bool,
    ok: impl Fn(T) -> bool,
) -> Result<(), TestCaseError> {
    match got {
        Ok(v) => prop_assert!(finite(v) && ok(v), "`{text}` gave {v:?}"),
        Err(e) => prop_assert!(e.starts_with("expected ") && e.contains(text), "`{text}`: {e}"),
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4096))]

    #[test]
    fn every_number_parser_returns_a_usable_value_or_says_what_it_expected(text in number_text()) {
        let (lo, hi) = FRAME_RATE_RANGE;
        let f = |v: f64| v.is_finite();
        let f32_ok = |v: f32| v.is_finite();
        holds(&text, numbers::positive(&text), f, |v| v > 0.0)?;
        holds(&text, numbers::positive_f32(&text), f32_ok, |v| v > 0.0)?;
        holds(&text, numbers::non_negative(&text), f, |v| v >= 0.0)?;
        holds(&text, numbers::non_negative_f32(&text), f32_ok, |v| v >= 0.0)?;
        holds(&text, numbers::fraction(&text), f, |v| (0.0..=1.0).contains(&v))?;
        holds(&text, numbers::fraction_f32(&text), f32_ok, |v| (0.0..=1.0).contains(&v))?;
        holds(&text, numbers::seconds(&text), f, |v| v > 0.0 && v <= MAX_SECONDS)?;
        holds(&text, numbers::frame_rate(&text), f, |v| (lo..=hi).contains(&v))?;
        holds(&text, numbers::frame_rate_f32(&text), f32_ok, |v| v > 0.0)?;
        holds(&text, numbers::send_rate(&text), f, |v| v == 0.0 || (lo..=hi).contains(&v))?;
        // What the commands do with them must not panic either.
        if let Ok(s) = numbers::seconds(&text) {
            let _ = Duration::from_secs_f64(s);
        }
        if let Ok(r) = numbers::send_rate(&text).or_else(|_| numbers::frame_rate(&text)) && r > 0.0 {
            let _ = Duration::from_secs_f64(1000.0 / r);
        }
    }
}

/// Every file under `dir`, sorted.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() { todo.push(p) } else { out.push(p) }
        }
    }
    out.sort();
    out
}

/// One damage to a file of the layout.
#[derive(Debug, Clone)]
enum Damage {
    Remove,
    CutAt(usize),
    Overwrite(usize, Vec<u8>),
    Replace(Vec<u8>),
    Append(Vec<u8>),
    StrayFile(String, Vec<u8>),
}

fn damage() -> impl Strategy<Value = Damage> {
    let bytes = proptest::collection::vec(any::<u8>(), 0..64);
    prop_oneof![
        Just(Damage::Remove),
        any::<usize>().prop_map(Damage::CutAt),
        (any::<usize>(), bytes.clone()).prop_map(|(at, b)| Damage::Overwrite(at, b)),
        bytes.clone().prop_map(Damage::Replace),
        bytes.clone().prop_map(Damage::Append),
        ("[a-z0-9]{1,8}(\\.txt)?", bytes).prop_map(|(n, b)| Damage::StrayFile(n, b)),
    ]
}

fn apply(file: &Path, damage: &Damage) {
    let mut bytes = std::fs::read(file).unwrap();
    match damage {
        Damage::Remove => return std::fs::remove_file(file).unwrap(),
        Damage::CutAt(at) => bytes.truncate(at % (bytes.len() + 1)),
        Damage::Overwrite(at, with) => {
            let at = at % (bytes.len() + 1);
            let end = (at + with.len()).min(bytes.len());
            bytes.splice(at..end, with.iter().copied());
        }
        Damage::Replace(with) => bytes.clone_from(with),
        Damage::Append(more) => bytes.extend_from_slice(more),
        Damage::StrayFile(name, content) => {
            return std::fs::write(file.parent().unwrap().join(name), content).unwrap();
        }
    }
    std::fs::write(file, bytes).unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn a_tracking_folder_with_damaged_files_loads_or_names_a_file(
        picks in proptest::collection::vec((any::<prop::sample::Index>(), damage()), 1..4),
    ) {
        let dir = tempfile::tempdir().unwrap();
        write_sequence(dir.path(), "0000", &generate(&DriveSpec { frames: 12, ..DriveSpec::default() }));
        for (pick, d) in &picks {
            let all = files(dir.path());
            if all.is_empty() {
                break;
            }
            apply(pick.get::<PathBuf>(&all), d);
        }
        let loaded = TrackingDir::open(dir.path()).and_then(|t| {
            let ids = t.sequences()?;
            ids.iter().map(|id| t.load_sequence(id).map(|_| ())).collect::<Result<Vec<_>, _>>()
        });
        if let Err(e) = loaded {
            let message = e.to_string();
            let root = dir.path().display().to_string();
            prop_assert!(message.contains(&root), "the error names a file of the folder: {message}");
        }
    }
}

/// Text shaped like a manifest: paths, sequence lists, comments, stray fields and bytes.
fn manifest_text() -> impl Strategy<Value = String> {
    let line = prop_oneof![
        "[a-z/._]{1,12}",
        "[a-z/]{1,8} [0-9,]{0,12}",
        "[a-z]{1,4} [0-9a-z_,-]{1,8} [a-z]{1,3}",
        "#.{0,10}",
        "[ \t]{0,3}",
        ".{0,16}",
    ];
    prop::collection::vec(line, 0..8).prop_map(|lines| lines.join("\n"))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn any_manifest_text_gives_entries_from_its_lines_or_names_one(text in manifest_text()) {
        let lines = text.lines().count();
        match parse_manifest(&text, Path::new("/base")) {
            Ok(Some(entries)) => {
                for e in entries {
                    prop_assert!((1..=lines).contains(&e.line), "line {} of {lines}", e.line);
                    prop_assert!(e.path.starts_with("/"), "{}", e.path.display());
                }
            }
            Ok(None) => {
                // A leading byte-order mark is not content (the parser drops it, as editors write it).
                let body = text.strip_prefix('\u{feff}').unwrap_or(&text);
                prop_assert!(body.lines().all(|l| l.split('#').next().unwrap_or("").trim().is_empty()));
            }
            Err((line, what)) => {
                prop_assert!((1..=lines).contains(&line), "line {line} of {lines}: {what}");
                prop_assert!(what.starts_with("expected") || what.starts_with("sequence"), "{what}");
            }
        }
    }
}

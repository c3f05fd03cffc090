//! The tables `dynotraj stream` writes into `--out` (`forecasts`; `frames`: per-frame latency,
//! compute and losses), read back as a data-frame library would, from a short lockstep stream
//! into the host build of the edge: CSV with the `csv` crate (the documented header, every row
//! of the header's width, every cell of its column's type: whole numbers for counts, numbers for
//! measures, known words for text), and their JSON twins beside them with serde_json (flat objects under the same keys, numbers as numbers, the same figures).
//!
//! cli/tests/tables_machine_readable.rs reads the other commands' tables; these need an edge,
//! which only this crate can start.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use dynotraj_core::limits::HORIZON;
use dynotraj_tests::edge_fixture::{dynotraj_command, scene_tracks, spawn_listening_edge, write_tracks_file};
use serde_json::Value;

/// What a column may hold (besides nothing).
#[derive(Debug, Clone, Copy)]
enum Kind {
    /// Whole numbers, never negative (counts, indices).
    Count,
    /// Finite numbers.
    Num,
    /// One of these words.
    Word(&'static [&'static str]),
}

/// `forecasts.csv`, as `--out`'s help and docs/cli.md document it.
const FORECASTS: [(&str, Kind); 5] =
    [("frame", Kind::Count), ("object_id", Kind::Count), ("step", Kind::Count), ("x", Kind::Num), ("y", Kind::Num)];

/// `frames.csv`, as docs/cli.md documents it.
const FRAMES: [(&str, Kind); 12] = [
    ("frame", Kind::Count),
    ("sent_ms", Kind::Num),
    ("latency_ms", Kind::Num),
    ("forecaster", Kind::Word(&["model", "constant_velocity"])),
    ("compute", Kind::Count),
    ("unit", Kind::Word(&["ns", "instructions"])),
    ("objects", Kind::Count),
    ("predictions", Kind::Count),
    ("frames_lost", Kind::Count),
    ("objects_dropped", Kind::Count),
    ("tracks_dropped", Kind::Count),
    ("bytes_dropped", Kind::Count),
];

/// A cell as read: empty is `None`.
type Row = Vec<Option<String>>;

fn check_cell(what: &str, column: &str, kind: Kind, cell: &str) {
    let ok = match kind {
        Kind::Count => cell.parse::<u64>().is_ok(),
        Kind::Num => cell.parse::<f64>().is_ok_and(f64::is_finite),
        Kind::Word(words) => words.contains(&cell),
    };
    assert!(ok, "{what}: column {column}: `{cell}` is no {kind:?}");
}

/// Reads `text` as CSV with a header: exactly `columns`' names, every row as wide, every
/// non-empty cell of its column's kind.
fn read_csv(what: &str, text: &str, columns: &[(&str, Kind)]) -> Vec<Row> {
    let mut r = csv::ReaderBuilder::new().has_headers(true).flexible(false).from_reader(text.as_bytes());
    let header: Vec<String> =
        r.headers().unwrap_or_else(|e| panic!("{what}: header: {e}")).iter().map(String::from).collect();
    let names: Vec<&str> = columns.iter().map(|(n, _)| *n).collect();
    assert_eq!(header, names, "{what}: the documented columns");
    let mut rows = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let rec = rec.unwrap_or_else(|e| panic!("{what}: row {}: {e}", i + 1));
        assert_eq!(rec.len(), columns.len(), "{what}: row {} has {} fields", i + 1, rec.len());
        let row: Row = rec.iter().map(|c| (!c.is_empty()).then(|| c.to_string())).collect();
        for ((name, kind), cell) in columns.iter().zip(&row) {
            if let Some(c) = cell {
                check_cell(&format!("{what}: row {}", i + 1), name, *kind, c);
            }
        }
        rows.push(row);
    }
    rows
}

/// Reads `text` as a JSON table: an array of flat objects keyed by exactly `columns`' names, in
/// order; counts as whole numbers, measures as numbers, words as strings, nothing as null. Rows
/// as the CSV reader gives them (numbers in their shortest form), to compare with the CSV.
fn read_json(what: &str, text: &str, columns: &[(&str, Kind)]) -> Vec<Row> {
    let v: Value = serde_json::from_str(text).unwrap_or_else(|e| panic!("{what}: not JSON: {e}"));
    let names: Vec<&str> = columns.iter().map(|(n, _)| *n).collect();
    let rows = v.as_array().unwrap_or_else(|| panic!("{what}: not an array"));
    rows.iter()
        .enumerate()
        .map(|(i, obj)| {
            let obj = obj.as_object().unwrap_or_else(|| panic!("{what}: row {} is no object", i + 1));
            assert_eq!(obj.keys().map(String::as_str).collect::<Vec<_>>(), names, "{what}: row {} keys", i + 1);
            columns
                .iter()
                .map(|(name, kind)| {
                    let cell = match (&obj[*name], kind) {
                        (Value::Null, _) => None,
                        (Value::Number(n), Kind::Count) if n.is_u64() => Some(n.to_string()),
                        (Value::Number(n), Kind::Num) => n.as_f64().map(|f| f.to_string()),
                        (Value::String(s), Kind::Word(_)) => Some(s.clone()),
                        (other, _) => panic!("{what}: row {}: column {name}: {other} is no {kind:?}", i + 1),
                    };
                    if let Some(c) = &cell {
                        check_cell(&format!("{what}: row {}", i + 1), name, *kind, c);
                    }
                    cell
                })
                .collect()
        })
        .collect()
}

/// The CSV's numbers in the JSON's form (shortest `f64`), so that the two compare as text.
fn normalised(rows: &[Row], columns: &[(&str, Kind)]) -> Vec<Row> {
    rows.iter()
        .map(|r| {
            r.iter()
                .zip(columns)
                .map(|(c, (_, kind))| match kind {
                    Kind::Num => c.as_ref().map(|c| c.parse::<f64>().unwrap().to_string()),
                    _ => c.clone(),
                })
                .collect()
        })
        .collect()
}

/// `row[column]` as a whole number.
fn count(row: &Row, columns: &[(&str, Kind)], column: &str) -> u64 {
    let i = columns.iter().position(|(n, _)| *n == column).unwrap();
    row[i].as_deref().unwrap_or_else(|| panic!("{column} is empty in {row:?}")).parse().unwrap()
}

/// Streams `frames` frames of `dtt` to the edge at `to` in lockstep, writing what came back into
/// the folder `out`.
fn stream(dtt: &Path, to: &str, frames: usize, out: &Path) {
    let run = dynotraj_command()
        .args(["stream", "--tracks"])
        .arg(dtt)
        .args(["--frames", &frames.to_string(), "--rate", "0", "--lockstep", "--to", to, "--out"])
        .arg(out)
        .output()
        .unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&run.stdout), String::from_utf8_lossy(&run.stderr));
    assert!(run.status.success(), "dynotraj stream exited {}:\n{stdout}{stderr}", run.status);
}

#[test]
fn the_stream_tables_read_as_typed_csv_and_the_same_figures_as_json() {
    const FRAMES_SENT: usize = 8;
    let dir = tempfile::tempdir().unwrap();
    let tracks = scene_tracks(FRAMES_SENT);
    let dtt = dir.path().join("scene.dtt");
    write_tracks_file(&tracks, &dtt);
    let (mut edge, _lines, addr) = spawn_listening_edge(&["--listen", "tcp://127.0.0.1:0", "--sessions", "1"]);
    let to = format!("tcp://{addr}");
    let out = dir.path().join("out");
    let file = |name: &str| out.join(name);
    stream(&dtt, &to, FRAMES_SENT, &out);
    assert!(edge.wait().unwrap().success(), "the edge served its session");
    assert!(file("replies.bin").metadata().is_ok_and(|m| m.len() > 0), "the raw replies are kept");
    let text = |name: &str| std::fs::read_to_string(file(name)).unwrap();

    let frames = read_csv("frames.csv", &text("frames.csv"), &FRAMES);
    let sent: Vec<u64> = tracks.frames.iter().map(|f| u64::from(f.frame)).collect();
    assert_eq!(frames.iter().map(|r| count(r, &FRAMES, "frame")).collect::<Vec<_>>(), sent, "one row per frame sent");
    assert!(frames.iter().all(|r| r.iter().all(Option::is_some)), "in lockstep every frame is answered: {frames:?}");

    let forecasts = read_csv("forecasts.csv", &text("forecasts.csv"), &FORECASTS);
    assert!(!forecasts.is_empty(), "the edge forecast some objects");
    let predicted: u64 = frames.iter().map(|r| count(r, &FRAMES, "predictions")).sum();
    let objects: std::collections::BTreeSet<(u64, u64)> =
        forecasts.iter().map(|r| (count(r, &FORECASTS, "frame"), count(r, &FORECASTS, "object_id"))).collect();
    assert_eq!(objects.len() as u64, predicted, "one forecast per prediction the report counts");
    for r in &forecasts {
        assert!(sent.contains(&count(r, &FORECASTS, "frame")), "a forecast of a frame sent: {r:?}");
        assert!((1..=HORIZON as u64).contains(&count(r, &FORECASTS, "step")), "step 1..={HORIZON}: {r:?}");
        assert!(r.iter().all(Option::is_some), "a forecast point has every value: {r:?}");
    }

    // The JSON twins: the same figures.
    let json = read_json("forecasts.json", &text("forecasts.json"), &FORECASTS);
    assert_eq!(json, normalised(&forecasts, &FORECASTS), "forecasts.json against forecasts.csv");
    let json = read_json("frames.json", &text("frames.json"), &FRAMES);
    assert_eq!(json, normalised(&frames, &FRAMES), "frames.json against frames.csv");
}

#[test]
fn the_readers_refuse_a_ragged_row_a_word_for_a_number_and_another_header() {
    let refuses = |text: &str, json: bool| {
        let r = catch_unwind(AssertUnwindSafe(|| {
            if json {
                read_json("bad", text, &FORECASTS);
            } else {
                read_csv("bad", text, &FORECASTS);
            }
        }));
        assert!(r.is_err(), "accepted: {text}");
    };
    let good = "frame,object_id,step,x,y\n3,1,1,0.5,-2\n";
    assert_eq!(read_csv("good", good, &FORECASTS).len(), 1, "the good table reads");
    refuses("frame,object_id,step,x,y\n3,1,1,0.5\n", false);
    refuses("frame,object_id,step,x,y\n3,1,1,0.5,-2\naverage,,,0.5,-2\n", false);
    refuses("frame,object_id,step,x,y\n3,1,1.5,0.5,-2\n", false);
    refuses("frame,object_id,step,x,y\n3,1,1,NaN,-2\n", false);
    refuses("frame,object,step,x,y\n3,1,1,0.5,-2\n", false);
    refuses(r#"[{"frame":3,"object_id":1,"step":1,"x":"0.5","y":-2}]"#, true);
    refuses(r#"[{"frame":3,"object_id":1,"step":1,"y":-2,"x":0.5}]"#, true);
    refuses(r#"[{"frame":3.5,"object_id":1,"step":1,"x":0.5,"y":-2}]"#, true);
    let mut frames = read_csv("frames", "frame,sent_ms\n0,1.5\n", &FRAMES[..2]);
    assert_eq!(frames.pop(), Some(vec![Some("0".into()), Some("1.5".into())]));
    let word = catch_unwind(|| read_csv("frames", "frame,forecaster\n0,cv\n", &[FRAMES[0], FRAMES[3]]));
    assert!(word.is_err(), "an unknown forecaster is refused");
}

/// `soak.csv`, as `soak --out`'s help and docs/cli.md document it.
const SOAK: [(&str, Kind); 18] = [
    ("seconds", Kind::Num),
    ("frames_sent", Kind::Count),
    ("wire_frames_sent", Kind::Count),
    ("bytes_flipped", Kind::Count),
    ("tails_dropped", Kind::Count),
    ("frames_duplicated", Kind::Count),
    ("damaged_frames", Kind::Count),
    ("answered", Kind::Count),
    ("clean_unanswered", Kind::Count),
    ("edge_frames_lost", Kind::Count),
    ("edge_wire_frames_ok", Kind::Count),
    ("edge_wire_frames_rejected", Kind::Count),
    ("edge_bytes_discarded", Kind::Count),
    ("host_wire_frames_rejected", Kind::Count),
    ("host_bytes_discarded", Kind::Count),
    ("edge_rss_start_kib", Kind::Count),
    ("edge_rss_end_kib", Kind::Count),
    ("edge_rss_peak_kib", Kind::Count),
];

#[test]
fn the_soak_table_reads_as_one_typed_row_in_csv_and_json() {
    const FRAMES_SENT: u64 = 40;
    let dir = tempfile::tempdir().unwrap();
    let dtt = dir.path().join("scene.dtt");
    write_tracks_file(&scene_tracks(8), &dtt);
    let out = dir.path().join("soak");
    let run = dynotraj_command()
        .args(["soak", "--tracks"])
        .arg(&dtt)
        .args(["--frames", &FRAMES_SENT.to_string(), "--fault-probability", "0.2", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&run.stdout), String::from_utf8_lossy(&run.stderr));
    assert!(run.status.success(), "dynotraj soak exited {}:\n{stdout}{stderr}", run.status);
    let text = |name: &str| std::fs::read_to_string(out.join(name)).unwrap();
    let rows = read_csv("soak.csv", &text("soak.csv"), &SOAK);
    let [row] = rows.as_slice() else { panic!("soak.csv has one row, not {}", rows.len()) };
    assert_eq!(count(row, &SOAK, "frames_sent"), FRAMES_SENT);
    assert_eq!(count(row, &SOAK, "clean_unanswered"), 0, "{row:?}");
    assert!(count(row, &SOAK, "damaged_frames") > 0, "a fifth of the wire frames are damaged: {row:?}");
    let json = read_json("soak.json", &text("soak.json"), &SOAK);
    assert_eq!(json, normalised(&rows, &SOAK), "soak.json against soak.csv");
}

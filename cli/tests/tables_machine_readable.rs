//! Every table a command prints or writes as CSV or JSON, read back with real readers (the `csv`
//! crate, serde_json) as a data-frame library would: every CSV row has the header's field count,
//! no header is empty or repeated, and every column that holds numbers (declared so by its JSON
//! twin, or known to) parses as a number in every row; JSON is an array of flat objects with
//! the same keys, a column never mixing numbers and text. Runs on a small synthetic KITTI layout.
//! The tables of `dynotraj stream`, which needs an edge, are read in
//! tests/tests/stream_csv_machine_readable.rs.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::{Command, Output};

use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_sim::kitti_layout::write_sequence;
use serde_json::Value;

/// Columns that hold numbers wherever they appear.
const NUMERIC: [&str; 22] = [
    "ade",
    "fde",
    "ace",
    "instances",
    "ace_pairs",
    "eligible_objects",
    "test_instances",
    "frames",
    "camera_rpe_t_m",
    "camera_rpe_r_deg",
    "objects_scored",
    "objects_moving",
    "object_rpe_t_m",
    "object_rpe_r_deg",
    "seed",
    "parameters",
    "us_per_object",
    "heading_change_deg",
    "speed_change_mps",
    "restarts",
    "training_instances",
    "val_ade_m",
];

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dynotraj"))
        .args(args)
        .env_remove("DYNOTRAJ_KITTI")
        .output()
        .expect("runs the binary")
}

/// Runs the binary; asserts exit 0 and returns stdout.
fn stdout(args: &[&str]) -> String {
    let out = run(args);
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "dynotraj {} exited {}:\n{text}{}",
        args.join(" "),
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// A table read back: its columns and, per column, the cells of every row (None: empty).
#[derive(Debug)]
struct Read {
    columns: Vec<String>,
    cells: BTreeMap<String, Vec<Option<String>>>,
}

impl Read {
    fn numbers(&self, column: &str) -> Vec<f64> {
        self.cells[column].iter().flatten().map(|c| c.parse().expect("checked numeric")).collect()
    }
}

/// Reads `text` as CSV and checks its shape; `numeric` columns (plus the known ones present)
/// must parse as numbers in every non-empty cell and hold at least one.
fn read_csv(what: &str, text: &str, numeric: &BTreeSet<String>) -> Read {
    let mut r = csv::ReaderBuilder::new().has_headers(true).flexible(false).from_reader(text.as_bytes());
    let headers: Vec<String> =
        r.headers().unwrap_or_else(|e| panic!("{what}: header: {e}")).iter().map(String::from).collect();
    assert!(!headers.is_empty(), "{what}: no columns");
    let unique: BTreeSet<&String> = headers.iter().collect();
    assert_eq!(unique.len(), headers.len(), "{what}: repeated header in {headers:?}");
    assert!(headers.iter().all(|h| !h.trim().is_empty()), "{what}: empty header in {headers:?}");
    let mut cells: BTreeMap<String, Vec<Option<String>>> = headers.iter().map(|h| (h.clone(), Vec::new())).collect();
    for (i, rec) in r.records().enumerate() {
        let rec = rec.unwrap_or_else(|e| panic!("{what}: row {}: {e}", i + 1));
        assert_eq!(rec.len(), headers.len(), "{what}: row {} has {} fields", i + 1, rec.len());
        for (h, c) in headers.iter().zip(rec.iter()) {
            cells.get_mut(h).unwrap().push((!c.is_empty()).then(|| c.to_string()));
        }
    }
    let rows = cells.values().next().map_or(0, Vec::len);
    assert!(rows > 0, "{what}: no rows");
    for h in &headers {
        if numeric.contains(h) || NUMERIC.contains(&h.as_str()) {
            let col = &cells[h];
            for (i, c) in col.iter().enumerate() {
                if let Some(c) = c {
                    assert!(c.parse::<f64>().is_ok(), "{what}: column {h}, row {}: `{c}` is no number", i + 1);
                }
            }
            assert!(col.iter().any(Option::is_some), "{what}: numeric column {h} is empty");
        }
    }
    Read { columns: headers, cells }
}

/// Checks one JSON table (an array of flat objects with the same keys, no column mixing numbers
/// and text); returns its columns and the ones holding numbers.
fn check_json_table(what: &str, v: &Value) -> (Vec<String>, BTreeSet<String>, usize) {
    let rows = v.as_array().unwrap_or_else(|| panic!("{what}: not an array: {v}"));
    let mut columns: Option<Vec<String>> = None;
    let (mut numbers, mut texts) = (BTreeSet::new(), BTreeSet::new());
    for (i, row) in rows.iter().enumerate() {
        let obj = row.as_object().unwrap_or_else(|| panic!("{what}: row {i} is no object"));
        let keys: Vec<String> = obj.keys().cloned().collect();
        assert!(keys.iter().all(|k| !k.is_empty()), "{what}: empty key");
        match &columns {
            None => columns = Some(keys),
            Some(c) => assert_eq!(c, &keys, "{what}: row {i} has other keys"),
        }
        for (k, val) in obj {
            match val {
                Value::Number(_) => {
                    numbers.insert(k.clone());
                }
                Value::String(_) => {
                    texts.insert(k.clone());
                }
                Value::Null => {}
                other => panic!("{what}: {k} holds {other}, not a number, text or null"),
            }
        }
    }
    let mixed: Vec<_> = numbers.intersection(&texts).collect();
    assert!(mixed.is_empty(), "{what}: columns holding numbers and text: {mixed:?}");
    for k in NUMERIC {
        assert!(!texts.contains(k), "{what}: {k} holds text");
    }
    (columns.unwrap_or_default(), numbers, rows.len())
}

/// Checks JSON text: one table (array) or several (object of arrays); returns them by name
/// (`""` for a lone array).
fn check_json(what: &str, text: &str) -> BTreeMap<String, (Vec<String>, BTreeSet<String>, usize)> {
    let v: Value = serde_json::from_str(text).unwrap_or_else(|e| panic!("{what}: not JSON: {e}\n{text}"));
    match &v {
        Value::Object(tables) => {
            tables.iter().map(|(n, t)| (n.clone(), check_json_table(&format!("{what} [{n}]"), t))).collect()
        }
        _ => BTreeMap::from([(String::new(), check_json_table(what, &v))]),
    }
}

/// Every CSV and JSON file under `dir`, checked; each CSV against its JSON twin (same columns,
/// same rows, the JSON's number columns numeric in the CSV). Returns the CSVs by file name.
fn check_folder(dir: &Path) -> BTreeMap<String, Read> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
                continue;
            }
            let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
            let name = p.display().to_string();
            if ext == "json" {
                check_json(&name, &std::fs::read_to_string(&p).unwrap());
            } else if ext == "csv" {
                let twin = p.with_extension("json");
                let json = twin.is_file().then(|| check_json(&name, &std::fs::read_to_string(&twin).unwrap()));
                let (cols, numeric, rows) = json.and_then(|j| j.get("").cloned()).unwrap_or_default();
                let read = read_csv(&name, &std::fs::read_to_string(&p).unwrap(), &numeric);
                if twin.is_file() {
                    assert_eq!(read.columns, cols, "{name}: columns against {}", twin.display());
                    assert_eq!(read.cells[&cols[0]].len(), rows, "{name}: rows against {}", twin.display());
                }
                out.insert(p.file_name().unwrap().to_string_lossy().into_owned(), read);
            }
        }
    }
    out
}

/// Both formats of one printed table: the CSV against the JSON.
fn check_both(what: &str, csv_text: &str, json_text: &str) -> Read {
    let json = check_json(what, json_text);
    let (cols, numeric, rows) = &json[""];
    let read = read_csv(what, csv_text, numeric);
    assert_eq!(&read.columns, cols, "{what}: CSV and JSON columns");
    assert_eq!(read.cells[&cols[0]].len(), *rows, "{what}: CSV and JSON rows");
    read
}

fn synthetic_kitti(root: &Path) {
    for (id, seed) in [("0000", 1), ("0001", 2), ("0002", 3)] {
        write_sequence(root, id, &generate(&DriveSpec { frames: 60, seed, ..DriveSpec::default() })).expect("writes");
    }
}

const TRACKS: [&str; 4] = ["--ours-input", "tracks", "--rate", "10"];

#[test]
fn the_dataset_eval_bench_and_estimate_tables_read_as_typed_data() {
    let dir = tempfile::tempdir().expect("temp dir");
    synthetic_kitti(dir.path());
    let kitti = dir.path().to_str().expect("utf-8");
    let with = |cmd: &[&str], format: &str| stdout(&[cmd, &TRACKS, &["--format", format]].concat());

    let dataset = ["dataset", "--kitti", kitti, "--sequences", "0000,0001", "--source", "gt,estimated"];
    let t = check_both("dataset", &with(&dataset, "csv"), &with(&dataset, "json"));
    let kinds: BTreeSet<_> = t.cells["row_kind"].iter().flatten().cloned().collect();
    assert_eq!(kinds, BTreeSet::from(["data".to_string(), "sum".to_string()]), "Table I's rows are data or sums");
    assert_eq!(t.cells["row_kind"].len(), 12, "(all agents, pedestrians) x two sources x (two sequences + sum)");
    let agents: BTreeSet<_> = t.cells["agents"].iter().flatten().cloned().collect();
    assert_eq!(agents, BTreeSet::from(["all".to_string(), "pedestrians".to_string()]));

    let eval = ["eval", "--kitti", kitti, "--tests", "0000,0001", "--source", "gt,estimated"];
    let eval = [&eval[..], &["--predictor", "cv,ctra"]].concat();
    let t = check_both("eval", &with(&eval, "csv"), &with(&eval, "json"));
    // Four arms, each two sequences and its weighted average; counts are whole numbers.
    assert_eq!(t.cells["arm"].len(), 12);
    assert!(t.numbers("instances").iter().all(|n| n.fract() == 0.0 && *n >= 0.0));
    assert!(t.numbers("ade").iter().all(|v| v.is_finite() && *v >= 0.0));

    let bench = ["model-cost", "--dims", "8,8,2,16", "--iterations", "20"];
    let csv_text = stdout(&[&bench[..], &["--format", "csv"]].concat());
    let t = check_both("model-cost", &csv_text, &stdout(&[&bench[..], &["--format", "json"]].concat()));
    assert_eq!(t.numbers("enc"), vec![8.0, 8.0], "the widths are split into numeric columns");

    // Several tables: JSON is one object of them; CSV is one table per run, chosen by --table.
    let estimate = ["estimate", "--kitti", kitti, "--sequence", "0000", "--profile", "host,edge"];
    let estimate = [&estimate[..], &["--counters", "--per-object"]].concat();
    let json = with(&estimate, "json");
    let tables = check_json("estimate", &json);
    let names: Vec<&str> = tables.keys().map(String::as_str).collect();
    assert_eq!(names, ["counters", "per_object", "restarts", "smoothness", "table_iii"]);
    let v: Value = serde_json::from_str(&json).unwrap();
    for name in names {
        let csv_text = with(&[&estimate[..], &["--table", name]].concat(), "csv");
        let table = Value::Array(v[name].as_array().unwrap().clone());
        let t = check_both(&format!("estimate {name}"), &csv_text, &serde_json::to_string(&table).unwrap());
        if name == "table_iii" {
            // 2 profiles x 3 estimates x (1 sequence + average + DynoSAM's figures).
            assert_eq!(t.cells["row_kind"].len(), 18);
            let paper = t.cells["row_kind"].iter().filter(|k| k.as_deref() == Some("paper_average")).count();
            assert_eq!(paper, 6, "DynoSAM's row is marked, once per table");
            assert!(t.numbers("objects_moving").iter().all(|n| n.fract() == 0.0));
        }
    }
    let out = run(&[&estimate[..], &TRACKS, &["--format", "csv"]].concat());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("--table"), "CSV of several tables needs --table: {err}");
    let out = run(&[&estimate[..], &TRACKS, &["--format", "csv", "--table", "nope"]].concat());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("--table: `nope`"), "{err}");

    // The per-frame log the estimator writes beside its pose files.
    let poses = dir.path().join("poses");
    stdout(&[&estimate[..3], &["--sequence", "0000", "--out", poses.to_str().unwrap()], &TRACKS].concat());
    assert!(check_folder(&poses).contains_key("log.csv"), "estimate --out writes log.csv");
    let numeric = ["frame", "time_s", "tx", "ty", "tz", "qw"];
    let log = std::fs::read_to_string(poses.join("0000").join("log.csv")).unwrap();
    let read = read_csv("log.csv", &log, &numeric.iter().map(ToString::to_string).collect());
    assert!(read.cells["frame"].iter().all(Option::is_some), "every log row names its frame");

    let b = ["estimate", "--cost", "--frames", "3"];
    let csv_text = stdout(&[&b[..], &["--format", "csv"]].concat());
    let t = check_both("estimate --cost", &csv_text, &stdout(&[&b[..], &["--format", "json"]].concat()));
    assert_eq!(t.numbers("frames_timed"), vec![3.0]);
}

#[test]
fn the_report_folders_and_printed_tables_of_experiment_and_benchmark_read_as_typed_data() {
    let dir = tempfile::tempdir().expect("temp dir");
    synthetic_kitti(dir.path());
    let kitti = dir.path().to_str().expect("utf-8");
    let small = [&TRACKS[..], &["--jobs", "2", "--dims", "8,8,2,16", "--epochs", "1", "--batch", "16"]].concat();

    let report = dir.path().join("exp");
    let report_s = report.to_str().expect("utf-8");
    let exp = ["experiment", "--kitti", kitti, "--arms", "estimated,gt", "--tests", "0000", "--out", report_s];
    let exp = [&exp[..], &small].concat();
    let json = stdout(&[&exp[..], &["--format", "json"]].concat());
    let printed = check_json("experiment", &json);
    assert!(printed.contains_key("table_iv") && printed.contains_key("table_iv_truth"), "{json}");
    let csv_text = stdout(&[&exp[..], &["--format", "csv", "--table", "table_iv"]].concat());
    let v: Value = serde_json::from_str(&json).unwrap();
    check_both("experiment table_iv", &csv_text, &serde_json::to_string(&v["table_iv"]).unwrap());

    let files = check_folder(&report);
    for name in ["table_i.csv", "table_iii_causal.csv", "table_iii_smoothed.csv", "table_iv.csv", "folds.csv"] {
        assert!(files.contains_key(name), "{name} in {:?}", files.keys());
    }
    let iv = &files["table_iv.csv"];
    let kinds: BTreeSet<_> = iv.cells["row_kind"].iter().flatten().map(String::as_str).collect();
    assert!(kinds.contains("paper") && kinds.contains("data"), "the paper's rows are marked: {kinds:?}");
    for (kind, seq) in iv.cells["row_kind"].iter().zip(&iv.cells["sequence"]) {
        let aggregate = matches!(kind.as_deref(), Some("weighted_average" | "paper_average"));
        assert_eq!(seq.is_none(), aggregate, "only averages have no sequence");
    }

    let bench = dir.path().join("bench");
    let bench_s = bench.to_str().expect("utf-8");
    let args = ["benchmark", "--kitti", kitti, "--arms", "gt", "--folds", "3", "--seeds", "1,2", "--out", bench_s];
    let args = [&args[..], &small].concat();
    // A run can take hours: a --table that cannot be honoured is refused before it starts.
    for (extra, says) in [
        (&["--format", "csv"][..], "choose it with --table"),
        (&["--format", "md", "--table", "goal"][..], "--table: chooses among"),
        (&["--format", "json", "--table", "table_iv"][..], "--table: `table_iv` is not printed here"),
    ] {
        let out = run(&[&args[..], extra].concat());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(says) && !bench.exists(), "{extra:?}: {err}");
    }
    let printed = check_json("benchmark", &stdout(&[&args[..], &["--format", "json"]].concat()));
    assert_eq!(printed.keys().map(String::as_str).collect::<Vec<_>>(), ["goal", "weighted"]);
    let files = check_folder(&bench);
    let w = &files["weighted.csv"];
    let kinds: BTreeSet<_> = w.cells["row_kind"].iter().flatten().map(String::as_str).collect();
    assert_eq!(kinds, BTreeSet::from(["data", "mean", "spread"]));
    assert!(files.contains_key("table_i.csv") && files.contains_key("per_sequence_seed2.csv"), "{:?}", files.keys());
}

#[test]
fn the_committed_report_folders_read_as_typed_data_each_csv_beside_its_json() {
    let reports = Path::new(env!("CARGO_MANIFEST_DIR")).join("../reports");
    let mut folders: Vec<_> =
        std::fs::read_dir(&reports).unwrap().map(|e| e.unwrap().path()).filter(|p| p.is_dir()).collect();
    folders.sort();
    assert!(folders.len() >= 5, "{folders:?}");
    for dir in folders {
        let read = check_folder(&dir);
        assert!(!read.is_empty(), "{}: no CSV", dir.display());
        for name in read.keys() {
            let twin = dir.join(Path::new(name).with_extension("json"));
            assert!(twin.is_file(), "{}: {name} has no JSON twin (old layout?)", dir.display());
        }
    }
}

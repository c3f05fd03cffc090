//! The KITTI tracking label format (`label_02/NNNN.txt`), also used for tracking results.
//!
//! One object observation per line, 17 whitespace-separated columns, plus an optional 18th
//! `score` column in tracking results:
//!
//! | column | field | meaning |
//! |---|---|---|
//! | 1 | `frame` | frame index, 0-based, non-negative |
//! | 2 | `track_id` | object id, constant over the track; `-1` for `DontCare` regions |
//! | 3 | `type` | `Car`, `Van`, `Truck`, `Pedestrian`, `Person_sitting`, `Cyclist`, `Tram`, `Misc` or `DontCare` |
//! | 4 | `truncated` | truncation level (0, 1, 2 in tracking; a fraction in object detection; `-1` for `DontCare`) |
//! | 5 | `occluded` | 0 visible, 1 partly occluded, 2 largely occluded, 3 unknown; `-1` for `DontCare` |
//! | 6 | `alpha` | observation angle, radians |
//! | 7-10 | `bbox_left` `bbox_top` `bbox_right` `bbox_bottom` | 2D box in image 2, pixels |
//! | 11-13 | `height` `width` `length` | 3D box dimensions, metres |
//! | 14-16 | `x` `y` `z` | bottom centre of the 3D box in rectified camera-0 coordinates (x right, y down, z forward), metres |
//! | 17 | `rotation_y` | yaw around the camera y axis, radians, in `[-pi, pi]` |
//! | 18 | `score` | detection confidence (results only) |
//!
//! `DontCare` rows (`track_id == -1`) mark image regions without labels; they carry no 3D box
//! (sentinel values such as `-1000` and `-10`). They are kept by the parser, so that a file can be
//! read and written back unchanged, and are recognised with [`LabelRow::is_dont_care`]; callers
//! that build trajectories filter them out.
//!
//! Blank lines are skipped; the frame index is explicit in every row, so rows need not be sorted.

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::Vector3;

use super::error::KittiError;
use super::text::{LineCtx, quote, read_text, write_text};

/// Column names, 1-based column `i` is `COLUMNS[i - 1]`.
pub const COLUMNS: [&str; 18] = [
    "frame",
    "track_id",
    "type",
    "truncated",
    "occluded",
    "alpha",
    "bbox_left",
    "bbox_top",
    "bbox_right",
    "bbox_bottom",
    "height",
    "width",
    "length",
    "x",
    "y",
    "z",
    "rotation_y",
    "score",
];

/// Number of columns of a ground-truth label row.
pub const LABEL_COLUMNS: usize = 17;

/// The object type string of `DontCare` regions.
pub const DONT_CARE: &str = "DontCare";

/// One row of a KITTI tracking label (or tracking result) file. See the module docs for units
/// and frames.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelRow {
    /// Frame index (column `frame`).
    pub frame: usize,
    /// Track id, `-1` for `DontCare` (column `track_id`).
    pub track_id: i64,
    /// Object type as written, e.g. `Car` (column `type`).
    pub object_type: String,
    /// Truncation (column `truncated`).
    pub truncated: f64,
    /// Occlusion state (column `occluded`).
    pub occluded: i32,
    /// Observation angle, radians (column `alpha`).
    pub alpha: f64,
    /// 2D box left edge, pixels.
    pub bbox_left: f64,
    /// 2D box top edge, pixels.
    pub bbox_top: f64,
    /// 2D box right edge, pixels.
    pub bbox_right: f64,
    /// 2D box bottom edge, pixels.
    pub bbox_bottom: f64,
    /// 3D box height, metres.
    pub height: f64,
    /// 3D box width, metres.
    pub width: f64,
    /// 3D box length, metres.
    pub length: f64,
    /// Bottom centre x, rectified camera-0 frame, metres.
    pub x: f64,
    /// Bottom centre y (down), rectified camera-0 frame, metres.
    pub y: f64,
    /// Bottom centre z (forward), rectified camera-0 frame, metres.
    pub z: f64,
    /// Yaw around the camera y axis, radians.
    pub rotation_y: f64,
    /// Confidence, present in tracking results only.
    pub score: Option<f64>,
}

impl LabelRow {
    /// Whether this row marks an unlabelled `DontCare` region (`track_id == -1` or type
    /// `DontCare`) rather than an object.
    #[must_use]
    pub fn is_dont_care(&self) -> bool {
        self.track_id < 0 || self.object_type == DONT_CARE
    }

    /// Whether this row is a 2D detection without a 3D box: the devkit's placeholders
    /// (size `-1 -1 -1`, location `-1000 -1000 -1000`), as a 2D detector's output or an
    /// imported bag's detections are written. Such rows serve as image boxes only.
    #[must_use]
    pub fn is_box_only(&self) -> bool {
        [self.height, self.width, self.length] == [-1.0; 3] && [self.x, self.y, self.z] == [-1000.0; 3]
    }

    /// Bottom centre of the 3D box in rectified camera-0 coordinates.
    #[must_use]
    pub fn location(&self) -> Vector3<f64> {
        Vector3::new(self.x, self.y, self.z)
    }

    /// `(height, width, length)` of the 3D box.
    #[must_use]
    pub fn dimensions(&self) -> Vector3<f64> {
        Vector3::new(self.height, self.width, self.length)
    }
}

/// Parses the text of a label file; `path` is only used in error messages.
///
/// # Errors
/// [`KittiError::Parse`] (naming `path`, the 1-based line and the field) for a column count other
/// than 17 or 18, a non-numeric or non-finite number, a negative or non-integer `frame`, a non-integer,
/// `< -1` or `>` [`MAX_TRACK_ID`] `track_id`, a non-integer `occluded`.
pub fn parse_labels(text: &str, path: &Path) -> Result<Vec<LabelRow>, KittiError> {
    let mut rows = Vec::new();
    // (frame, track id) -> line: an object labelled twice in a frame is an error, not a row
    // silently kept or dropped.
    let mut seen = std::collections::HashMap::new();
    for (i, line) in text.lines().enumerate() {
        let ctx = LineCtx { path, line: i + 1 };
        let toks: Vec<&str> = line.split_whitespace().collect();
        if toks.is_empty() {
            continue;
        }
        let row = parse_row(&toks, ctx)?;
        if row.track_id >= 0
            && let Some(first) = seen.insert((row.frame, row.track_id), i + 1)
        {
            return Err(ctx.error(
                COLUMNS[1],
                Some(2),
                "one row per object and frame",
                format!("track {} in frame {} again (first on line {first})", row.track_id, row.frame),
            ));
        }
        rows.push(row);
    }
    Ok(rows)
}

/// The largest track id a label may carry: the wire names an object by its track id + 1 in a
/// `u16`, and a larger id would drop the object from every estimated source without a word.
pub const MAX_TRACK_ID: i64 = u16::MAX as i64 - 1;

/// KITTI's object types (label column `type`): the tracking benchmark's (`Person` is its
/// spelling of the object benchmark's `Person_sitting`, which is accepted too).
pub const OBJECT_TYPES: [&str; 10] =
    ["Car", "Van", "Truck", "Pedestrian", "Person", "Person_sitting", "Cyclist", "Tram", "Misc", "DontCare"];

fn parse_row(toks: &[&str], ctx: LineCtx<'_>) -> Result<LabelRow, KittiError> {
    let n = toks.len();
    if !(LABEL_COLUMNS..=LABEL_COLUMNS + 1).contains(&n) {
        // Name the first missing column, or the first surplus one.
        let (field, column) =
            if n < LABEL_COLUMNS { (COLUMNS[n], n + 1) } else { ("(extra column)", LABEL_COLUMNS + 2) };
        return Err(ctx.error(
            field,
            Some(column),
            "17 whitespace-separated columns (18 with `score`)",
            format!("{n} columns"),
        ));
    }
    let num = |c: usize| ctx.finite(toks[c], COLUMNS[c], Some(c + 1));

    let frame = ctx.integer(toks[0], COLUMNS[0], Some(1))?;
    if frame < 0 {
        return Err(ctx.error(COLUMNS[0], Some(1), "a non-negative frame index", quote(toks[0])));
    }
    let track_id = ctx.integer(toks[1], COLUMNS[1], Some(2))?;
    if !(-1..=MAX_TRACK_ID).contains(&track_id) {
        return Err(ctx.error(
            COLUMNS[1],
            Some(2),
            "a track id from 0 to 65534 (the link carries an object's id, track id + 1, in 16 bits), \
             or -1 for DontCare",
            quote(toks[1]),
        ));
    }
    if !OBJECT_TYPES.contains(&toks[2]) {
        return Err(ctx.error(COLUMNS[2], Some(3), &format!("one of {}", OBJECT_TYPES.join(", ")), quote(toks[2])));
    }
    let occluded = ctx.integer(toks[4], COLUMNS[4], Some(5))?;
    let occluded = i32::try_from(occluded)
        .map_err(|_| ctx.error(COLUMNS[4], Some(5), "a small integer (-1..=3)", quote(toks[4])))?;

    let row = LabelRow {
        frame: usize::try_from(frame).map_err(|_| ctx.error(COLUMNS[0], Some(1), "a frame index", quote(toks[0])))?,
        track_id,
        object_type: toks[2].to_string(),
        truncated: num(3)?,
        occluded,
        alpha: num(5)?,
        bbox_left: num(6)?,
        bbox_top: num(7)?,
        bbox_right: num(8)?,
        bbox_bottom: num(9)?,
        height: num(10)?,
        width: num(11)?,
        length: num(12)?,
        x: num(13)?,
        y: num(14)?,
        z: num(15)?,
        rotation_y: num(16)?,
        score: if toks.len() > LABEL_COLUMNS { Some(num(17)?) } else { None },
    };
    if !row.is_dont_care() && !row.is_box_only() {
        // DontCare and box-only rows carry -1 / -1000 / -10 placeholders; a 3D object has a size and lies
        // within reach of the camera.
        for (c, v) in [(10, row.height), (11, row.width), (12, row.length)] {
            if v <= 0.0 {
                return Err(ctx.error(COLUMNS[c], Some(c + 1), "a positive size in metres", quote(toks[c])));
            }
        }
        for (c, v) in [(13, row.x), (14, row.y), (15, row.z)] {
            if v.abs() > MAX_LOCATION_M {
                return Err(ctx.error(
                    COLUMNS[c],
                    Some(c + 1),
                    &format!("a location within {MAX_LOCATION_M} m of the camera"),
                    quote(toks[c]),
                ));
            }
        }
    }
    Ok(row)
}

/// The farthest a labelled object may lie from the camera on any axis, metres: KITTI labels
/// reach about 100 m; a coordinate beyond this is a broken file, not a far object.
pub const MAX_LOCATION_M: f64 = 10_000.0;

/// Reads and parses a label file.
///
/// # Errors
/// As [`parse_labels`]; a file that does not exist is [`KittiError::Missing`], other read
/// failures [`KittiError::Io`].
pub fn read_labels(path: impl AsRef<Path>) -> Result<Vec<LabelRow>, KittiError> {
    let path = path.as_ref();
    parse_labels(&read_text(path, "label file")?, path)
}

/// Number of frames the labels span: highest `frame` + 1, or `None` for no rows.
/// `DontCare` rows count: they are frames of the sequence too.
#[must_use]
pub fn label_frame_count(rows: &[LabelRow]) -> Option<usize> {
    rows.iter().map(|r| r.frame + 1).max()
}

/// One row in the KITTI tracking format (`%d %d %s %d %d %f ...`, numbers with 6 decimals,
/// `truncated` in its shortest exact form), with the `score` column when present. No newline.
#[must_use]
pub fn format_label_row(row: &LabelRow) -> String {
    let mut s = format!(
        "{} {} {} {} {} {:.6} {:.6} {:.6} {:.6} {:.6} {:.6} {:.6} {:.6} {:.6} {:.6} {:.6} {:.6}",
        row.frame,
        row.track_id,
        row.object_type,
        row.truncated,
        row.occluded,
        row.alpha,
        row.bbox_left,
        row.bbox_top,
        row.bbox_right,
        row.bbox_bottom,
        row.height,
        row.width,
        row.length,
        row.x,
        row.y,
        row.z,
        row.rotation_y
    );
    if let Some(score) = row.score {
        let _ = write!(s, " {score:.6}");
    }
    s
}

/// Writes rows in the KITTI tracking format, one per line.
///
/// # Errors
/// [`KittiError::Io`] when the file cannot be written.
pub fn write_labels(path: impl AsRef<Path>, rows: &[LabelRow]) -> Result<(), KittiError> {
    let mut text = String::with_capacity(rows.len() * 120);
    for row in rows {
        text.push_str(&format_label_row(row));
        text.push('\n');
    }
    write_text(path.as_ref(), &text)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    const GOOD: &str = "\
0 -1 DontCare -1 -1 -10.000000 210.500000 180.250000 240.750000 215.125000 -1000.000000 -1000.000000 -1000.000000 -10.000000 -1.000000 -1.000000 -1.000000
0 0 Van 0 0 -1.750000 300.125000 160.500000 450.250000 290.750000 2.100000 1.850000 4.500000 -4.250000 1.750000 13.500000 -2.062500

1 0 Van 0 1 -1.8 301.5 160.5 452.0 291.0 2.1 1.85 4.5 -4.25 1.75 14.5 -2.0625
";

    #[test]
    fn rows_that_would_be_dropped_or_overwritten_are_errors_naming_the_line() {
        let van = "0 0 Van 0 0 -1.75 300 160 450 290 2.1 1.85 4.5 -4.25 1.75 13.5 -2.0";
        let text = format!("{van}\n{van}\n");
        let e = parse_labels(&text, &p()).unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("first on line 1"), "{e}");
        let e = parse_labels(&van.replace("Van", "cyclist"), &p()).unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("`cyclist`") && e.contains("Cyclist"), "{e}");
        let e = parse_labels(&van.replacen("0 0 Van", "0 2147483648 Van", 1), &p()).unwrap_err().to_string();
        assert!(e.contains("`2147483648`") && e.contains("65534"), "{e}");
        let e = parse_labels(&van.replace("13.5 -2.0", "1e300 -2.0"), &p()).unwrap_err().to_string();
        assert!(e.contains("field `z`") && e.contains("within 10000 m"), "{e}");
        let e = parse_labels(&van.replace(" 2.1 1.85 4.5", " 2.1 0 4.5"), &p()).unwrap_err().to_string();
        assert!(e.contains("field `width`") && e.contains("a positive size"), "{e}");
        // DontCare rows share track id -1 in a frame: not duplicates.
        let dc = "0 -1 DontCare -1 -1 -10 210 180 240 215 -1000 -1000 -1000 -10 -1 -1 -1";
        assert_eq!(parse_labels(&format!("{dc}\n{dc}\n"), &p()).unwrap().len(), 2);
    }

    fn p() -> PathBuf {
        PathBuf::from("label_02/0003.txt")
    }

    fn err(text: &str) -> String {
        parse_labels(text, &p()).unwrap_err().to_string()
    }

    #[test]
    fn parses_good_rows_and_keeps_dont_care() {
        let rows = parse_labels(GOOD, &p()).unwrap();
        assert_eq!(rows.len(), 3);
        assert!(rows[0].is_dont_care());
        assert_eq!(rows[0].track_id, -1);
        let van = &rows[1];
        assert!(!van.is_dont_care());
        assert_eq!((van.frame, van.track_id, van.object_type.as_str(), van.occluded), (0, 0, "Van", 0));
        assert_eq!(van.location(), Vector3::new(-4.25, 1.75, 13.5));
        assert_eq!(van.dimensions(), Vector3::new(2.1, 1.85, 4.5));
        assert_eq!(van.rotation_y, -2.0625);
        assert_eq!(van.score, None);
        assert_eq!(rows[2].frame, 1);
        assert_eq!(label_frame_count(&rows), Some(2));
        assert_eq!(label_frame_count(&[]), None);
    }

    #[test]
    fn a_box_only_detection_parses_and_says_so() {
        let rows = parse_labels("3 7 Car 0 0 -10 10 20 50 60 -1 -1 -1 -1000 -1000 -1000 -10 0.8\n", &p()).unwrap();
        assert!(rows[0].is_box_only() && !rows[0].is_dont_care());
        assert_eq!((rows[0].bbox_left, rows[0].bbox_bottom, rows[0].score), (10.0, 60.0, Some(0.8)));
        // Only the devkit's placeholders make a row box-only: any other size is checked.
        let m = err("3 7 Car 0 0 -10 10 20 50 60 -1 -1 -1 0 1 10 -10\n");
        assert!(m.contains("field `height` (column 11)"), "{m}");
        assert!(!parse_labels(GOOD, &p()).unwrap().iter().any(LabelRow::is_box_only));
    }

    #[test]
    fn crlf_and_score_column() {
        let rows = parse_labels("5 3 Car 0 0 0 1 2 3 4 1.5 1.6 4 1 2 20 0.1 0.93\r\n", &p()).unwrap();
        assert_eq!(rows[0].score, Some(0.93));
        assert_eq!(rows[0].frame, 5);
    }

    #[test]
    fn wrong_column_count_names_line_and_field() {
        let m = err("0 0 Car 0 0 0 1 2 3 4 1.5 1.6 4 1 2 20 0.1\n0 1 Car 0 0 0 1 2 3 4 1.5 1.6 4 1 2\n");
        assert!(m.contains("label_02/0003.txt line 2, field `z` (column 16)"), "{m}");
        assert!(m.contains("15 columns"), "{m}");
        let m = err("0 0 Car 0 0 0 1 2 3 4 1.5 1.6 4 1 2 20 0.1 0.9 7\n");
        assert!(m.contains("line 1") && m.contains("column 19") && m.contains("19 columns"), "{m}");
    }

    #[test]
    fn non_numeric_field_is_named() {
        let m = err("\n\n0 0 Car 0 0 0 1 2 3 4 1.5 1.6 4 1 2 20 abc\n");
        assert_eq!(m, "label_02/0003.txt line 3, field `rotation_y` (column 17): expected a number, found `abc`");
        let m = err("0 0 Car 0 0 0 1 2 3 4 1.5 1.6 4 1 y 20 0.1\n");
        assert!(m.contains("line 1, field `y` (column 15)"), "{m}");
        let m = err("0 x Car 0 0 0 1 2 3 4 1.5 1.6 4 1 2 20 0.1\n");
        assert!(m.contains("field `track_id` (column 2): expected an integer"), "{m}");
        let m = err("0 0 Car 0 0.5 0 1 2 3 4 1.5 1.6 4 1 2 20 0.1\n");
        assert!(m.contains("field `occluded` (column 5)"), "{m}");
    }

    #[test]
    fn non_finite_and_negative_frame_rejected() {
        let m = err("0 0 Car 0 0 0 1 2 3 4 1.5 NaN 4 1 2 20 0.1\n");
        assert!(m.contains("line 1, field `width` (column 12): expected a finite number, found `NaN`"), "{m}");
        let m = err("0 0 Car 0 0 0 1 2 3 4 1.5 1.6 4 1 2 inf 0.1\n");
        assert!(m.contains("field `z`") && m.contains("finite"), "{m}");
        let m = err("-2 0 Car 0 0 0 1 2 3 4 1.5 1.6 4 1 2 20 0.1\n");
        assert!(m.contains("line 1, field `frame` (column 1): expected a non-negative frame index, found `-2`"), "{m}");
        let m = err("1.5 0 Car 0 0 0 1 2 3 4 1.5 1.6 4 1 2 20 0.1\n");
        assert!(m.contains("field `frame`"), "{m}");
        let m = err("1 -3 Car 0 0 0 1 2 3 4 1.5 1.6 4 1 2 20 0.1\n");
        assert!(m.contains("field `track_id`"), "{m}");
        // The largest id the link can name, and one past it.
        assert!(parse_labels("1 65534 Car 0 0 0 1 2 3 4 1.5 1.6 4 1 2 20 0.1\n", Path::new("t")).is_ok());
        let m = err("1 65535 Car 0 0 0 1 2 3 4 1.5 1.6 4 1 2 20 0.1\n");
        assert!(
            m.contains("line 1, field `track_id` (column 2)") && m.contains("16 bits") && m.contains("`65535`"),
            "{m}"
        );
    }

    #[test]
    fn write_read_round_trip_and_missing_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("0000.txt");
        let mut rows = parse_labels(GOOD, &p()).unwrap();
        rows[2].score = Some(0.5);
        write_labels(&path, &rows).unwrap();
        assert_eq!(read_labels(&path).unwrap(), rows);

        let missing = dir.path().join("nope.txt");
        let m = read_labels(&missing).unwrap_err().to_string();
        assert!(m.contains("nope.txt") && m.contains("label file not found"), "{m}");
    }
}

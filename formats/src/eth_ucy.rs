//! ETH/UCY pedestrian recordings as the field's benchmark ships them (Trajectron++'s copy): one
//! observation per line, `frame<TAB>pedestrian_id<TAB>x<TAB>y`, positions in metres on the
//! scene's ground plane, consecutive observations [`FRAME_STEP`] frame numbers apart
//! ([`PERIOD_S`] seconds). Frame numbers and ids are written as integers in some files and as
//! floats (`10.0`) in others; both are read, a fraction is refused.
//!
//! A pedestrian's observations are split into walks at every missing step, so each
//! [`Walk`] is a run of consecutive steps.

use std::collections::BTreeMap;
use std::path::Path;

use dynotraj_core::Point2;

use crate::line_file::LineFileError;

/// Frame numbers between consecutive observations of a recording.
pub const FRAME_STEP: u32 = 10;

/// Seconds between consecutive observations (2.5 Hz).
pub const PERIOD_S: f32 = 0.4;

/// The largest frame number read: larger values are not frame numbers of these recordings.
const MAX_FRAME: f64 = 1.0e8;

/// One pedestrian's consecutive observations.
#[derive(Debug, Clone, PartialEq)]
pub struct Walk {
    /// The pedestrian's id in the file.
    pub id: u32,
    /// The step (frame number / [`FRAME_STEP`]) of the first position.
    pub first_step: u32,
    /// Positions at steps `first_step`, `first_step + 1`, ..., metres.
    pub positions: Vec<Point2>,
}

impl Walk {
    /// The step after the last position.
    #[must_use]
    pub fn end_step(&self) -> u32 {
        self.first_step.saturating_add(u32::try_from(self.positions.len()).unwrap_or(u32::MAX))
    }

    /// The position at `step`, if the walk has one.
    #[must_use]
    pub fn at(&self, step: u32) -> Option<Point2> {
        let k = step.checked_sub(self.first_step)?;
        self.positions.get(usize::try_from(k).ok()?).copied()
    }
}

/// A recording: every pedestrian's walks, ordered by id and start.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// The file's name without its extension (e.g. `biwi_eth_train`).
    pub name: String,
    /// Every walk.
    pub walks: Vec<Walk>,
}

impl Recording {
    /// Observations in the recording.
    #[must_use]
    pub fn observations(&self) -> usize {
        self.walks.iter().map(|w| w.positions.len()).sum()
    }

    /// Distinct pedestrians.
    #[must_use]
    pub fn pedestrians(&self) -> usize {
        let mut ids: Vec<u32> = self.walks.iter().map(|w| w.id).collect();
        ids.dedup();
        ids.len()
    }
}

/// A recording that cannot be used, naming the file and line.
pub type EthUcyError = LineFileError;

/// What an empty recording is told it lacks.
const NO_OBSERVATION: &str = "no observation (expected lines `frame<TAB>pedestrian_id<TAB>x<TAB>y`)";

/// Reads the recording at `path`.
///
/// # Errors
/// The file cannot be read, or [`parse`] refuses it.
pub fn read(path: &Path) -> Result<Recording, EthUcyError> {
    let text = std::fs::read_to_string(path).map_err(|source| LineFileError::Io {
        path: path.to_path_buf(),
        kind: "trajectory file",
        source,
    })?;
    parse(&text, path)
}

/// A whole number in `text` (written `12` or `12.0`) at most `max`.
fn whole(text: &str, max: f64) -> Option<u32> {
    let v: f64 = text.parse().ok()?;
    (v.is_finite() && v >= 0.0 && v <= max && v.fract() == 0.0).then_some(v as u32)
}

/// Parses a recording's text; `path` names it in errors and gives its name.
///
/// # Errors
/// A line without four whitespace-separated fields, a frame number or id that is not a whole
/// number, a frame number not a multiple of [`FRAME_STEP`], a coordinate that is not a finite
/// number, one pedestrian twice at one frame; a file without observations.
pub fn parse(text: &str, path: &Path) -> Result<Recording, EthUcyError> {
    let bad = |line: usize, what: String| LineFileError::Line { path: path.to_path_buf(), line, what };
    let mut by_id: BTreeMap<u32, BTreeMap<u32, (usize, Point2)>> = BTreeMap::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let trimmed = raw.trim();
        if trimmed.is_empty() {
            continue;
        }
        let fields: Vec<&str> = trimmed.split_whitespace().collect();
        let [frame, id, x, y] = fields[..] else {
            return Err(bad(line, format!("expected 4 fields (frame, pedestrian id, x, y), found {}", fields.len())));
        };
        let frame = whole(frame, MAX_FRAME).ok_or_else(|| {
            bad(line, format!("frame: expected a whole number from 0 to {MAX_FRAME}, found {frame:?}"))
        })?;
        if frame % FRAME_STEP != 0 {
            return Err(bad(line, format!("frame: expected a multiple of {FRAME_STEP}, found {frame}")));
        }
        let id = whole(id, f64::from(u32::MAX))
            .ok_or_else(|| bad(line, format!("pedestrian id: expected a whole number, found {id:?}")))?;
        let coord = |name: &str, v: &str| {
            v.parse::<f32>()
                .ok()
                .filter(|c| c.is_finite())
                .ok_or_else(|| bad(line, format!("{name}: expected a finite number of metres, found {v:?}")))
        };
        let position = Point2::new(coord("x", x)?, coord("y", y)?);
        let step = frame / FRAME_STEP;
        if let Some((first, _)) = by_id.entry(id).or_default().insert(step, (line, position)) {
            return Err(bad(line, format!("pedestrian {id} at frame {frame} again (first on line {first})")));
        }
    }
    if by_id.is_empty() {
        return Err(LineFileError::Empty { path: path.to_path_buf(), expected: NO_OBSERVATION });
    }
    let mut walks = Vec::new();
    for (id, steps) in by_id {
        let mut current: Option<Walk> = None;
        for (step, (_, position)) in steps {
            match current.as_mut() {
                Some(w) if w.end_step() == step => w.positions.push(position),
                _ => {
                    walks.extend(current.take());
                    current = Some(Walk { id, first_step: step, positions: vec![position] });
                }
            }
        }
        walks.extend(current);
    }
    let name = path.file_stem().map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    Ok(Recording { name, walks })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parsed(text: &str) -> Result<Recording, EthUcyError> {
        parse(text, Path::new("scene_train.txt"))
    }

    #[test]
    fn observations_become_walks_split_at_missing_steps() {
        let text = "780\t1.0\t8.46\t3.59\n790\t1.0\t9.57\t3.79\n\n800.0\t2\t1\t2\n800\t1\t10.0\t4.0\n820\t1\t11\t4\n";
        let r = parsed(text).unwrap();
        assert_eq!(r.name, "scene_train");
        assert_eq!((r.observations(), r.pedestrians()), (5, 2));
        let ids: Vec<(u32, u32, usize)> = r.walks.iter().map(|w| (w.id, w.first_step, w.positions.len())).collect();
        assert_eq!(ids, vec![(1, 78, 3), (1, 82, 1), (2, 80, 1)], "pedestrian 1 is missing at frame 810");
        assert_eq!(r.walks[0].at(79), Some(Point2::new(9.57, 3.79)));
        assert_eq!(r.walks[0].at(81), None);
    }

    #[test]
    fn bad_lines_are_refused_with_their_number_and_field() {
        let cases = [
            ("0\t1\t2\n", "line 1: expected 4 fields"),
            ("0\t1\t2\t3\n5\t1\t2\t3\n", "line 2: frame: expected a multiple of 10, found 5"),
            ("0.5\t1\t2\t3\n", "line 1: frame: expected a whole number"),
            ("-10\t1\t2\t3\n", "line 1: frame: expected a whole number"),
            ("0\t1.5\t2\t3\n", "line 1: pedestrian id: expected a whole number"),
            ("0\t1\tnan\t3\n", "line 1: x: expected a finite number"),
            ("0\t1\t2\tinf\n", "line 1: y: expected a finite number"),
            ("0\t1\t2\t3\n0\t1\t2\t3\n", "line 2: pedestrian 1 at frame 0 again (first on line 1)"),
        ];
        for (text, want) in cases {
            let err = parsed(text).unwrap_err().to_string();
            assert!(err.starts_with("scene_train.txt ") && err.contains(want), "{text:?}: {err}");
        }
        assert!(parsed("\n\n").unwrap_err().to_string().contains("no observation"));
    }
}

//! Which objects the per-object figures draw: `--object SEQ:ID` (ID the object number, KITTI
//! track id + 1, as the pose files and `--per-object` number them), or by default the longest
//! eligible moving object of sequence 0000 (every per-object figure) and of 0018 (its heading:
//! the paper's figure 6).

use std::fmt;
use std::str::FromStr;

use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{EligibilityRule, eligible_runs, object_number, track_id_of};

/// One object chosen on the command line: a sequence and an object number.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ObjectChoice {
    /// Sequence id, e.g. "0000".
    pub sequence: String,
    /// Object number (KITTI track id + 1).
    pub object: i64,
}

/// What `--object` expects, said in every parse error.
const EXPECTED: &str = "expected SEQ:ID, a sequence id and an object number (KITTI track id + 1, as in the pose \
    files), e.g. 0000:2";

impl FromStr for ObjectChoice {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let (sequence, object) =
            text.split_once(':').ok_or_else(|| format!("{EXPECTED}; found `{text}` (no colon)"))?;
        if sequence.is_empty() || !sequence.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') {
            return Err(format!("{EXPECTED}; found the sequence `{sequence}`"));
        }
        let object: i64 = object
            .parse()
            .ok()
            .filter(|&n| track_id_of(n).is_some())
            .ok_or_else(|| format!("{EXPECTED}; found the object `{object}` (object numbers start at 1)"))?;
        Ok(Self { sequence: sequence.to_string(), object })
    }
}

impl fmt::Display for ObjectChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.sequence, self.object)
    }
}

/// `--object`'s value parser.
///
/// # Errors
/// A value that is not `SEQ:ID` with ID a positive object number, saying what was expected.
pub fn parse_object_choice(text: &str) -> Result<ObjectChoice, String> {
    text.parse()
}

/// Which per-object figures an object gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Extent {
    /// Every one.
    All,
    /// Its heading only (the paper's figure 6, by default for sequence 0018).
    Heading,
}

/// An object the figures draw.
#[derive(Debug, Clone, Copy)]
pub struct Subject<'a> {
    /// Its sequence.
    pub seq: &'a SequenceTracks,
    /// Its KITTI track id.
    pub track: i32,
    /// Which figures.
    pub extent: Extent,
}

impl Subject<'_> {
    /// "sequence 0000, object 2", with the object number users see.
    #[must_use]
    pub fn name(&self) -> String {
        format!("sequence {}, object {}", self.seq.id, object_number(self.track))
    }

    /// The file stem's part naming this object: "0000_object2".
    #[must_use]
    pub fn stem(&self) -> String {
        format!("{}_object{}", self.seq.id, object_number(self.track))
    }

    /// The length of its longest eligible run in the labels, frames (0: none).
    #[must_use]
    pub fn longest_run(&self, rule: &EligibilityRule) -> usize {
        eligible_runs(&self.seq.tracks, rule)
            .iter()
            .filter(|r| r.track_id == self.track)
            .map(|r| r.states.len())
            .max()
            .unwrap_or(0)
    }
}

/// The track id and length of the longest eligible run of the labels of `seq`.
#[must_use]
pub fn longest_moving_object(seq: &SequenceTracks, rule: &EligibilityRule) -> Option<(i32, usize)> {
    eligible_runs(&seq.tracks, rule).iter().max_by_key(|r| r.states.len()).map(|r| (r.track_id, r.states.len()))
}

/// The objects the figures draw: each of `choices`, or without any the defaults (the longest
/// eligible moving object of 0000, all figures, and of 0018, its heading; a sequence that is
/// not loaded or has no such object is left out).
///
/// # Errors
/// A choice whose sequence is not loaded or has no object of that number, naming `--object`
/// and what is there.
pub fn subjects<'a>(
    choices: &[ObjectChoice],
    sequences: &'a [SequenceTracks],
    rule: &EligibilityRule,
) -> anyhow::Result<Vec<Subject<'a>>> {
    let find = |id: &str| sequences.iter().find(|s| s.id == id);
    if choices.is_empty() {
        let defaults = [("0000", Extent::All), ("0018", Extent::Heading)];
        return Ok(defaults
            .into_iter()
            .filter_map(|(id, extent)| {
                let seq = find(id)?;
                longest_moving_object(seq, rule).map(|(track, _)| Subject { seq, track, extent })
            })
            .collect());
    }
    let mut out: Vec<Subject<'a>> = Vec::new();
    for c in choices {
        let Some(seq) = find(&c.sequence) else {
            let loaded: Vec<&str> = sequences.iter().map(|s| s.id.as_str()).collect();
            anyhow::bail!("--object {c}: sequence {} is not loaded (loaded: {})", c.sequence, loaded.join(", "));
        };
        let track = track_id_of(c.object).filter(|&t| seq.tracks.iter().any(|o| o.track_id == t));
        let Some(track) = track else {
            let numbers: Vec<String> = seq.tracks.iter().map(|t| object_number(t.track_id).to_string()).collect();
            anyhow::bail!(
                "--object {c}: sequence {} has no object {} (object numbers are KITTI track id + 1; its objects: {})",
                c.sequence,
                c.object,
                numbers.join(", ")
            );
        };
        if !out.iter().any(|s| s.seq.id == seq.id && s.track == track) {
            out.push(Subject { seq, track, extent: Extent::All });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynotraj_core::BevState;
    use dynotraj_core::wire::ObjectClass;
    use dynotraj_sources::trajectory::ObjectTrack;

    #[test]
    fn good_values_parse_into_a_sequence_and_an_object_number() {
        assert_eq!(parse_object_choice("0000:2"), Ok(ObjectChoice { sequence: "0000".into(), object: 2 }));
        assert_eq!(parse_object_choice("0018:12").map(|c| c.to_string()), Ok("0018:12".into()));
    }

    #[test]
    fn bad_values_say_what_was_expected() {
        for (text, says) in [
            ("0000", "no colon"),
            ("0000-2", "no colon"),
            (":2", "found the sequence ``"),
            ("00 00:2", "found the sequence `00 00`"),
            ("0000:two", "found the object `two`"),
            ("0000:", "found the object ``"),
            ("0000:0", "object numbers start at 1"),
            ("0000:-1", "found the object `-1`"),
            ("0000:2:3", "found the object `2:3`"),
        ] {
            let e = parse_object_choice(text).unwrap_err();
            assert!(e.starts_with("expected SEQ:ID") && e.contains(says), "{text}: {e}");
        }
    }

    fn sequence(id: &str, tracks: &[(i32, u32)]) -> SequenceTracks {
        let tracks = tracks
            .iter()
            .map(|&(track_id, frames)| ObjectTrack {
                track_id,
                class: ObjectClass::Car,
                frames: (0..frames).collect(),
                states: (0..frames).map(|k| BevState { x: k as f32, ..BevState::default() }).collect(),
            })
            .collect();
        SequenceTracks { id: id.into(), frame_count: 100, tracks, estimated: None, camera_path: Vec::new() }
    }

    #[test]
    fn choices_name_loaded_objects_and_the_defaults_are_the_longest_movers() {
        let seqs = [sequence("0000", &[(0, 40), (1, 60)]), sequence("0018", &[(3, 50)])];
        let rule = EligibilityRule::default();
        let default = subjects(&[], &seqs, &rule).unwrap();
        let names: Vec<(String, Extent)> = default.iter().map(|s| (s.name(), s.extent)).collect();
        assert_eq!(
            names,
            vec![("sequence 0000, object 2".into(), Extent::All), ("sequence 0018, object 4".into(), Extent::Heading)]
        );
        assert_eq!(default[0].stem(), "0000_object2");
        assert_eq!(default[0].longest_run(&rule), 60);
        let chosen = subjects(&[parse_object_choice("0018:4").unwrap()], &seqs, &rule).unwrap();
        assert_eq!((chosen.len(), chosen[0].track, chosen[0].extent), (1, 3, Extent::All));
        let e = subjects(&[parse_object_choice("0007:1").unwrap()], &seqs, &rule).unwrap_err().to_string();
        assert_eq!(e, "--object 0007:1: sequence 0007 is not loaded (loaded: 0000, 0018)");
        let e = subjects(&[parse_object_choice("0000:4").unwrap()], &seqs, &rule).unwrap_err().to_string();
        assert!(e.starts_with("--object 0000:4: sequence 0000 has no object 4") && e.ends_with("its objects: 1, 2)"));
    }
}

//! The one numbering of objects that users see: "object N" with N = KITTI track id + 1.
//!
//! KITTI's labels number objects from 0; the wire, the estimator, the pose files
//! (`objects/<N>_*.tum`), `estimate --per-object` and the image simulator's instance ids use
//! the track id + 1 (0 is "no object" there). Tracks inside the host keep the KITTI track id
//! (so the estimator's tracks pair with the labels); everything printed for a user, figures
//! and the `--object` flag included, goes through these two functions.

/// The number a user sees for the object with KITTI track id `track_id`.
#[must_use]
pub const fn object_number(track_id: i32) -> i64 {
    track_id as i64 + 1
}

/// The KITTI track id of the object a user calls `number`, or `None` when no track id has
/// that number (0 or below, or beyond the ids KITTI's `i32` holds).
#[must_use]
pub fn track_id_of(number: i64) -> Option<i32> {
    if number < 1 { None } else { i32::try_from(number - 1).ok() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_track_ids_plus_one_and_invert() {
        assert_eq!(object_number(0), 1);
        assert_eq!(object_number(1), 2, "the cyclist of 0000, KITTI track 1, is object 2 in the pose files");
        for id in [0, 1, 17, 1000, i32::MAX] {
            assert_eq!(track_id_of(object_number(id)), Some(id));
        }
        assert_eq!(track_id_of(0), None, "object numbers start at 1");
        assert_eq!(track_id_of(-3), None);
        assert_eq!(track_id_of(i64::from(i32::MAX) + 2), None);
    }
}

//! The command line's number parsers: every float flag is checked when it is parsed, so that a
//! value the command cannot use (not a number, NaN, infinite, out of its range) is an error
//! naming the flag and what was expected, never a panic or a silent fallback later.

/// The largest time a flag may give, seconds (about 11.6 days): any longer wait is a mistake,
/// and `Duration` holds it exactly.
pub const MAX_SECONDS: f64 = 1e6;
/// The slowest and fastest frame rates a flag may give, Hz.
pub const FRAME_RATE_RANGE: (f64, f64) = (1e-3, 1e6);

fn number(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let v: f64 = t.parse().map_err(|_| format!("expected a number, found `{text}`"))?;
    if v.is_finite() { Ok(v) } else { Err(format!("expected a finite number, found `{text}`")) }
}

fn checked(text: &str, what: &str, ok: impl Fn(f64) -> bool) -> Result<f64, String> {
    let v = number(text)?;
    if ok(v) { Ok(v) } else { Err(format!("expected {what}, found `{text}`")) }
}

fn single(v: f64, text: &str) -> Result<f32, String> {
    // In range for f32 by the callers' bounds, or rejected here when it overflows.
    #[allow(clippy::cast_possible_truncation)]
    let x = v as f32;
    // A tiny non-zero value would round to 0 and pass as "positive" while meaning nothing.
    if x.is_finite() && (x != 0.0 || v == 0.0) {
        Ok(x)
    } else {
        Err(format!(
            "expected a number within single precision (at most 3.4e38, and not so small it rounds to 0), found \
                `{text}`"
        ))
    }
}

/// A positive finite number.
///
/// # Errors
/// Anything else, with what was expected.
pub fn positive(text: &str) -> Result<f64, String> {
    checked(text, "a positive number", |v| v > 0.0)
}

/// [`positive`] as `f32`.
///
/// # Errors
/// As [`positive`], or a value beyond single precision.
pub fn positive_f32(text: &str) -> Result<f32, String> {
    positive(text).and_then(|v| single(v, text))
}

/// A finite number at least 0.
///
/// # Errors
/// Anything else, with what was expected.
pub fn non_negative(text: &str) -> Result<f64, String> {
    checked(text, "a number >= 0", |v| v >= 0.0)
}

/// [`non_negative`] within single precision, kept in double: the same value whichever
/// precision a command holds it in.
///
/// # Errors
/// As [`non_negative_f32`].
pub fn non_negative_single(text: &str) -> Result<f64, String> {
    non_negative(text).and_then(|v| single(v, text).map(|_| v))
}

/// [`non_negative`] as `f32`.
///
/// # Errors
/// As [`non_negative`], or a value beyond single precision.
pub fn non_negative_f32(text: &str) -> Result<f32, String> {
    non_negative(text).and_then(|v| single(v, text))
}

/// A fraction: a number in [0, 1].
///
/// # Errors
/// Anything else, with what was expected.
pub fn fraction(text: &str) -> Result<f64, String> {
    checked(text, "a fraction in [0, 1]", |v| (0.0..=1.0).contains(&v))
}

/// [`fraction`] as `f32`.
///
/// # Errors
/// As [`fraction`].
pub fn fraction_f32(text: &str) -> Result<f32, String> {
    fraction(text).and_then(|v| single(v, text))
}

/// A time in seconds: positive, at most [`MAX_SECONDS`].
///
/// # Errors
/// Anything else, with what was expected.
pub fn seconds(text: &str) -> Result<f64, String> {
    checked(text, &format!("a time in seconds, > 0 and <= {MAX_SECONDS:e}"), |v| v > 0.0 && v <= MAX_SECONDS)
}

/// A camera frame rate in Hz, within [`FRAME_RATE_RANGE`].
///
/// # Errors
/// Anything else, with what was expected.
pub fn frame_rate(text: &str) -> Result<f64, String> {
    let (lo, hi) = FRAME_RATE_RANGE;
    checked(text, &format!("a frame rate in Hz, {lo:e} to {hi:e}"), |v| (lo..=hi).contains(&v))
}

/// [`frame_rate`] as `f32`.
///
/// # Errors
/// As [`frame_rate`].
pub fn frame_rate_f32(text: &str) -> Result<f32, String> {
    frame_rate(text).and_then(|v| single(v, text))
}

/// A sending rate in Hz: 0 (as fast as possible) or a [`frame_rate`].
///
/// # Errors
/// Anything else, with what was expected.
pub fn send_rate(text: &str) -> Result<f64, String> {
    let (lo, hi) = FRAME_RATE_RANGE;
    checked(text, &format!("0 (as fast as possible) or a rate in Hz, {lo:e} to {hi:e}"), |v| {
        v == 0.0 || (lo..=hi).contains(&v)
    })
}

/// A KITTI object type name (`--classes`).
///
/// # Errors
/// Anything else, with the names that are.
pub fn object_class(text: &str) -> Result<dynotraj_core::wire::ObjectClass, String> {
    dynotraj_core::wire::ObjectClass::from_kitti_name(text.trim()).ok_or_else(|| {
        let names: Vec<&str> = dynotraj_core::wire::ObjectClass::KITTI.iter().map(|c| c.kitti_name()).collect();
        format!("expected a KITTI type ({}), found `{text}`", names.join(", "))
    })
}

/// A sequence id (`--sequences`, `--tests`, `--exclude`): it names files and folders, so it
/// is a plain name ([`dynotraj_formats::kitti::checked_sequence_id`]).
///
/// # Errors
/// Anything else, with what was expected.
pub fn sequence_id(text: &str) -> Result<String, String> {
    dynotraj_formats::kitti::checked_sequence_id(text.trim()).map(str::to_string).map_err(|e| e.to_string())
}

/// A value parser over a library's enum `T` from its table of (value, name, help): the
/// libraries name their choices without depending on clap, and `--help` lists them with their
/// helps as clap's own enums do.
pub fn choices<T: Copy + Send + Sync + 'static>(
    table: &'static [(T, &'static str, &'static str)],
) -> impl clap::builder::TypedValueParser<Value = T> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser as _};
    PossibleValuesParser::new(table.iter().map(|(_, name, help)| PossibleValue::new(*name).help(*help)))
        // The possible values admit only the table's names.
        .map(move |name: String| table.iter().find(|(_, n, _)| *n == name).map_or(table[0].0, |(v, _, _)| *v))
}

/// Parses a count that must be at least 1 (`--frames` of a command for which none is nothing
/// to do).
///
/// # Errors
/// Not a whole number, or 0, with what was expected.
pub fn at_least_one(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(0) => Err("expected a count of at least 1, found 0".into()),
        Ok(n) => Ok(n),
        Err(_) => Err(format!("expected a count of at least 1, found `{text}`")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_that_single_precision_rounds_to_zero_is_refused() {
        assert!(positive_f32("1e-50").unwrap_err().contains("rounds to 0"));
        assert_eq!(non_negative_f32("0"), Ok(0.0));
    }

    #[test]
    fn every_unusable_value_is_refused_with_what_was_expected() {
        for bad in ["inf", "-inf", "NaN", "nan", "1e400", "abc", "", "0x10"] {
            assert!(positive(bad).is_err(), "{bad}");
            assert!(non_negative(bad).is_err(), "{bad}");
            assert!(seconds(bad).is_err(), "{bad}");
        }
        assert_eq!(positive("0").unwrap_err(), "expected a positive number, found `0`");
        assert!(positive("-1").is_err() && non_negative("-1").is_err());
        assert_eq!(non_negative("0"), Ok(0.0));
        assert!(fraction("1.5").is_err() && fraction("-0.1").is_err());
        assert_eq!(fraction("1"), Ok(1.0));
        assert!(seconds("1e20").is_err() && seconds("0").is_err() && seconds("-1").is_err());
        assert_eq!(seconds(" 3 "), Ok(3.0));
        assert!(frame_rate("1e-20").is_err() && frame_rate("0").is_err());
        assert_eq!(send_rate("0"), Ok(0.0));
        assert!(send_rate("1e-20").is_err() && send_rate("-1").is_err());
        assert!(positive_f32("1e39").is_err(), "beyond f32");
        assert_eq!(frame_rate_f32("20"), Ok(20.0));
    }
}

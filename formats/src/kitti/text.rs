//! Crate-private helpers shared by the line-oriented KITTI parsers: reading a whole file with
//! errors that name it, and parsing single whitespace-separated tokens with errors that name the
//! file, line, field and column.

use std::io::ErrorKind;
use std::path::Path;

use super::error::KittiError;

/// Longest token quoted verbatim in an error message; longer ones are cut.
const MAX_QUOTED: usize = 40;

/// Reads `path` as UTF-8 text. A file that does not exist is [`KittiError::Missing`] with `what`
/// (e.g. "label file"); any other failure is [`KittiError::Io`].
pub(crate) fn read_text(path: &Path, what: &str) -> Result<String, KittiError> {
    let bytes = std::fs::read(path).map_err(|source| io_error(path, what, source))?;
    match String::from_utf8(bytes) {
        // A byte-order mark (some editors write one) is not part of the first line.
        Ok(text) => Ok(text.strip_prefix('\u{feff}').map(str::to_string).unwrap_or(text)),
        Err(e) => {
            let at = e.utf8_error().valid_up_to();
            let bytes = e.as_bytes();
            let line = bytes.get(..at).map_or(0, |b| b.iter().filter(|&&c| c == b'\n').count()) + 1;
            let byte = bytes.get(at).copied().unwrap_or(0);
            Err(KittiError::Parse {
                path: path.to_path_buf(),
                line,
                field: "text".into(),
                column: None,
                expected: "UTF-8 text".into(),
                found: format!("byte 0x{byte:02x} at byte {at} of the file"),
            })
        }
    }
}

/// Writes `text` to `path`, creating or truncating it.
pub(crate) fn write_text(path: &Path, text: &str) -> Result<(), KittiError> {
    crate::atomic::write_file(path, text).map_err(|source| KittiError::Io { path: path.to_path_buf(), cause: source })
}

/// Maps an I/O error on `path` to `Missing` (not found) or `Io`.
pub(crate) fn io_error(path: &Path, what: &str, source: std::io::Error) -> KittiError {
    if source.kind() == ErrorKind::NotFound {
        KittiError::Missing { path: path.to_path_buf(), what: what.to_string() }
    } else {
        KittiError::Io { path: path.to_path_buf(), cause: source }
    }
}

/// Quotes a token from a file for an error message: `` `tok` ``, cut if very long.
pub(crate) fn quote(tok: &str) -> String {
    if tok.chars().count() > MAX_QUOTED {
        let cut: String = tok.chars().take(MAX_QUOTED).collect();
        format!("`{cut}...`")
    } else {
        format!("`{tok}`")
    }
}

/// Position of a line in a file, for building parse errors.
#[derive(Clone, Copy)]
pub(crate) struct LineCtx<'a> {
    pub path: &'a Path,
    /// 1-based.
    pub line: usize,
}

impl LineCtx<'_> {
    /// A [`KittiError::Parse`] at this line.
    pub fn error(&self, field: &str, column: Option<usize>, expected: &str, found: String) -> KittiError {
        KittiError::Parse {
            path: self.path.to_path_buf(),
            line: self.line,
            field: field.to_string(),
            column,
            expected: expected.to_string(),
            found,
        }
    }

    /// Parses a finite `f64`. `nan`, `inf` and friends are rejected.
    pub fn finite(&self, tok: &str, field: &str, column: Option<usize>) -> Result<f64, KittiError> {
        match tok.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(self.error(field, column, "a finite number", quote(tok))),
            Err(_) => Err(self.error(field, column, "a number", quote(tok))),
        }
    }

    /// Parses a decimal integer (no fraction, no exponent).
    pub fn integer(&self, tok: &str, field: &str, column: Option<usize>) -> Result<i64, KittiError> {
        tok.parse::<i64>().map_err(|_| self.error(field, column, "an integer", quote(tok)))
    }

    /// Parses an integer that may be written as a float with zero fraction (`4` or `4.0`), as some
    /// converters write the integer status fields of oxts files.
    pub fn integral(&self, tok: &str, field: &str, column: Option<usize>) -> Result<i64, KittiError> {
        if let Ok(v) = tok.parse::<i64>() {
            return Ok(v);
        }
        match tok.parse::<f64>() {
            #[allow(clippy::cast_possible_truncation)] // integral and well inside i64's range
            Ok(v) if v.is_finite() && v.fract() == 0.0 && v.abs() < 9.0e15 => Ok(v as i64),
            _ => Err(self.error(field, column, "an integer", quote(tok))),
        }
    }
}

/// Formats `x` like C's `%.{prec}e` (`-1.386023500e-02`), the style of the KITTI devkit files.
pub(crate) fn c_exp(x: f64, prec: usize) -> String {
    let x = if x == 0.0 { 0.0 } else { x }; // no "-0"
    let s = format!("{x:.prec$e}");
    match s.split_once('e') {
        Some((mantissa, exp)) => {
            let (sign, digits) = match exp.strip_prefix('-') {
                Some(d) => ('-', d),
                None => ('+', exp),
            };
            let digits = if digits.len() < 2 { format!("0{digits}") } else { digits.to_string() };
            format!("{mantissa}e{sign}{digits}")
        }
        None => s, // inf / NaN: no exponent
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_byte_order_mark_is_skipped_and_invalid_utf8_names_its_line_once() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("labels.txt");
        std::fs::write(&path, b"\xef\xbb\xbf0 1\n").unwrap();
        assert_eq!(read_text(&path, "label file").unwrap(), "0 1\n");
        std::fs::write(&path, b"ok\nP0: 1 \xff\n").unwrap();
        let e = read_text(&path, "label file").unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("expected UTF-8 text") && e.contains("0xff"), "{e}");
        // An I/O failure is said once: in the message, not again as a source.
        let e = read_text(dir.path(), "label file").unwrap_err();
        assert!(std::error::Error::source(&e).is_none(), "{e}");
    }

    #[test]
    fn c_exp_matches_c_printf() {
        assert_eq!(c_exp(1.0, 6), "1.000000e+00");
        assert_eq!(c_exp(-0.013860235, 9), "-1.386023500e-02");
        assert_eq!(c_exp(-0.0, 3), "0.000e+00");
        assert_eq!(c_exp(1.5e123, 2), "1.50e+123");
        assert_eq!(c_exp(2.5e-7, 1), "2.5e-07");
    }

    #[test]
    fn numbers_are_checked() {
        let ctx = LineCtx { path: Path::new("x.txt"), line: 3 };
        assert_eq!(ctx.finite("1e-05", "f", None).unwrap(), 1e-5);
        assert!(ctx.finite("nan", "f", None).unwrap_err().to_string().contains("finite"));
        assert!(ctx.finite("inf", "f", None).is_err());
        assert_eq!(ctx.integral("4.0", "f", None).unwrap(), 4);
        assert!(ctx.integral("4.5", "f", None).is_err());
        assert!(ctx.integer("4.0", "f", None).is_err());
        let long = "x".repeat(100);
        let m = ctx.finite(&long, "f", Some(2)).unwrap_err().to_string();
        assert!(m.len() < 120 && m.contains("x.txt line 3, field `f` (column 2)"), "{m}");
    }
}

//! A plain table that prints as Markdown or CSV.

use std::fmt::Write as _;
use std::str::FromStr;

/// Output format of a table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Format {
    /// GitHub-flavoured Markdown.
    #[default]
    Md,
    /// Comma-separated values with a header row.
    Csv,
}

impl FromStr for Format {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "md" => Ok(Self::Md),
            "csv" => Ok(Self::Csv),
            _ => Err(format!("unknown format `{s}`: expected md or csv")),
        }
    }
}

/// A table of strings with a header row.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    /// Column headers.
    pub headers: Vec<String>,
    /// Rows; each as long as `headers`.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// A table with these headers and no rows.
    pub fn new<S: Into<String>>(headers: impl IntoIterator<Item = S>) -> Self {
        Self { headers: headers.into_iter().map(Into::into).collect(), rows: Vec::new() }
    }

    /// Appends a row (padded or cut to the header width).
    pub fn push<S: Into<String>>(&mut self, row: impl IntoIterator<Item = S>) {
        let mut r: Vec<String> = row.into_iter().map(Into::into).collect();
        r.resize(self.headers.len(), String::new());
        self.rows.push(r);
    }

    /// The table with `note` added to its first header, in brackets (which of several tables of
    /// one layout it is).
    #[must_use]
    pub fn noted(mut self, note: impl AsRef<str>) -> Self {
        if let Some(h) = self.headers.first_mut() {
            *h = format!("{h} [{}]", note.as_ref());
        }
        self
    }

    /// The table in `format`.
    #[must_use]
    pub fn render(&self, format: Format) -> String {
        match format {
            Format::Md => self.markdown(),
            Format::Csv => self.csv(),
        }
    }

    fn markdown(&self) -> String {
        let widths: Vec<usize> = (0..self.headers.len())
            .map(|c| self.rows.iter().map(|r| r[c].len()).chain([self.headers[c].len(), 3]).max().unwrap_or(3))
            .collect();
        let line = |cells: &[String]| {
            let mut s = String::from("|");
            for (cell, w) in cells.iter().zip(&widths) {
                let _ = write!(s, " {cell:<w$} |");
            }
            s.push('\n');
            s
        };
        let mut out = line(&self.headers);
        out.push('|');
        for w in &widths {
            let _ = write!(out, "{}|", "-".repeat(w + 2));
        }
        out.push('\n');
        for r in &self.rows {
            out.push_str(&line(r));
        }
        out
    }

    fn csv(&self) -> String {
        let quote = |s: &String| {
            if s.contains([',', '"', '\n']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.clone() }
        };
        let mut out = String::new();
        for r in std::iter::once(&self.headers).chain(&self.rows) {
            out.push_str(&r.iter().map(quote).collect::<Vec<_>>().join(","));
            out.push('\n');
        }
        out
    }
}

/// A number with `digits` decimals, or `-` when absent.
#[must_use]
pub fn fmt_opt(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "-".to_string(), |v| format!("{v:.digits$}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_markdown_and_quoted_csv() {
        let mut t = Table::new(["a", "bb"]);
        t.push(["1", "x,y"]);
        assert_eq!(t.render(Format::Csv), "a,bb\n1,\"x,y\"\n");
        let md = t.render(Format::Md);
        assert!(md.starts_with("| a   | bb  |\n|-----|-----|\n| 1   | x,y |"), "{md}");
    }
}

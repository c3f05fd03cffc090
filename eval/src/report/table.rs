//! A table that prints as Markdown for people and as CSV or JSON for programs.

use std::fmt::Write as _;
use std::str::FromStr;

use super::data::{Cell, ColumnKind, Data, snake};

/// Output format of a table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Format {
    /// GitHub-flavoured Markdown.
    #[default]
    Md,
    /// Comma-separated values with a header row: one observation per row, typed columns.
    Csv,
    /// An array of objects (numbers as numbers, missing values as null).
    Json,
}

impl Format {
    /// Every format with its name on the command line and what it is.
    pub const CHOICES: [(Self, &'static str, &'static str); 3] = [
        (Self::Md, "md", "GitHub-flavoured Markdown"),
        (Self::Csv, "csv", "Comma-separated values with a header row: one observation per row, typed columns"),
        (Self::Json, "json", "An array of objects (numbers as numbers, missing values as null)"),
    ];
}

impl FromStr for Format {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "md" => Ok(Self::Md),
            "csv" => Ok(Self::Csv),
            "json" => Ok(Self::Json),
            _ => Err(format!("unknown format `{s}`: expected md, csv or json")),
        }
    }
}

/// A table: the Markdown layout (strings, composite cells allowed) and the machine-readable
/// data behind it (typed columns, one observation per row) that CSV and JSON are written from.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    /// Column headers (Markdown).
    pub headers: Vec<String>,
    /// Rows (Markdown); each as long as `headers`.
    pub rows: Vec<Vec<String>>,
    /// The typed data; without it the Markdown cells are written as text columns.
    data: Option<Data>,
}

impl Table {
    /// A table with these headers and no rows.
    pub fn new<S: Into<String>>(headers: impl IntoIterator<Item = S>) -> Self {
        Self { headers: headers.into_iter().map(Into::into).collect(), rows: Vec::new(), data: None }
    }

    /// A table whose Markdown shows `data` row for row under `headers` (one per column).
    #[must_use]
    pub fn of_data<S: Into<String>>(headers: impl IntoIterator<Item = S>, data: Data) -> Self {
        let mut t = Self::new(headers);
        debug_assert_eq!(t.headers.len(), data.columns.len(), "one header per column");
        t.rows = data.rows.iter().map(|r| r.iter().map(Cell::md).collect()).collect();
        t.data = Some(data);
        t
    }

    /// The table with `data` as its machine-readable form (for a Markdown layout that is not
    /// one observation per row).
    #[must_use]
    pub fn with_data(mut self, data: Data) -> Self {
        self.data = Some(data);
        self
    }

    /// The machine-readable data: the typed data when set, else every Markdown column as text
    /// under its header in snake_case.
    #[must_use]
    pub fn data(&self) -> Data {
        if let Some(d) = &self.data {
            return d.clone();
        }
        let mut d = Data::new(self.headers.iter().map(|_| ("", ColumnKind::Text)));
        for (col, h) in d.columns.iter_mut().zip(&self.headers) {
            col.name = snake(h);
        }
        for r in &self.rows {
            d.push(r.iter().map(|c| Cell::text(c.as_str())).collect());
        }
        d
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
            Format::Csv => self.data().csv(),
            Format::Json => json_text(&self.data().json()),
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
}

/// Writes `data` into the folder `dir` (made if missing) as `STEM.csv` and `STEM.json`.
///
/// # Errors
/// A folder or file that cannot be written, named.
pub fn write_table_files(dir: &std::path::Path, stem: &str, data: &super::Data) -> anyhow::Result<()> {
    use anyhow::Context as _;
    std::fs::create_dir_all(dir).with_context(|| format!("--out: creating {}", dir.display()))?;
    for (ext, text) in [("csv", data.csv()), ("json", json_text(&data.json()))] {
        let path = dir.join(format!("{stem}.{ext}"));
        dynotraj_formats::atomic::write_file(&path, text)
            .with_context(|| format!("--out: writing {}", path.display()))?;
    }
    Ok(())
}

/// `value` as pretty JSON ending in a newline: the text of a JSON file or of `--format json`.
#[must_use]
pub fn json_text(value: &serde_json::Value) -> String {
    let mut s = serde_json::to_string_pretty(value).unwrap_or_default();
    s.push('\n');
    s
}

/// Checks a `--table` choice before a command runs: `names` are the tables it may print in
/// `format`.
///
/// # Errors
/// A choice with Markdown (which prints every table) or naming no table of `names`; CSV without
/// a choice when `names` has several.
pub fn check_table(format: Format, choice: Option<&str>, names: &[&str]) -> anyhow::Result<()> {
    let list = names.join(", ");
    match (format, choice) {
        (Format::Md, Some(_)) => {
            anyhow::bail!("--table: chooses among the tables of --format csv or json (Markdown prints them all)")
        }
        (_, Some(c)) if !names.contains(&c) => {
            anyhow::bail!("--table: `{c}` is not printed here (expected one of {list})")
        }
        (Format::Csv, None) if names.len() > 1 => anyhow::bail!(
            "--format csv: this command prints {} tables ({list}) and CSV holds one; choose it with --table, or use \
             --format json",
            names.len()
        ),
        _ => Ok(()),
    }
}

/// The tables a command prints, `tables` (name, table), in `format`: Markdown prints them all
/// one after another; JSON one array, or one object of arrays keyed by name when there are
/// several; CSV one table, so with several `choice` (the `--table` flag) must name it.
///
/// # Errors
/// `choice` names no table, or CSV of several tables without a choice.
pub fn render_tables(format: Format, choice: Option<&str>, tables: &[(&str, &Table)]) -> anyhow::Result<String> {
    let names = || tables.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ");
    let chosen: Vec<(&str, &Table)> =
        match choice {
            Some(c) => {
                let found = tables.iter().find(|(n, _)| *n == c).copied();
                vec![found.ok_or_else(|| {
                    anyhow::anyhow!("--table: `{c}` is not printed here (expected one of {})", names())
                })?]
            }
            None => tables.to_vec(),
        };
    Ok(match (format, chosen.as_slice()) {
        (Format::Md, _) => chosen.iter().map(|(_, t)| t.render(Format::Md)).collect::<Vec<_>>().join("\n"),
        (_, [(_, t)]) => t.render(format),
        (Format::Json, _) => {
            let obj: serde_json::Map<String, serde_json::Value> =
                chosen.iter().map(|(n, t)| ((*n).to_string(), t.data().json())).collect();
            json_text(&serde_json::Value::Object(obj))
        }
        (Format::Csv, _) => {
            let names: Vec<&str> = chosen.iter().map(|(n, _)| *n).collect();
            check_table(format, None, &names)?;
            String::new()
        }
    })
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
        assert_eq!(t.render(Format::Json), "[\n  {\n    \"a\": \"1\",\n    \"bb\": \"x,y\"\n  }\n]\n");
    }

    #[test]
    fn several_tables_are_one_json_object_and_csv_needs_a_choice() {
        let mut d = Data::new([("n", ColumnKind::Int)]);
        d.push(vec![Cell::int(3)]);
        let a = Table::of_data(["count"], d);
        assert_eq!(a.render(Format::Md), "| count |\n|-------|\n| 3     |\n");
        let b = Table::new(["x"]);
        let both = [("a", &a), ("b", &b)];
        let json = render_tables(Format::Json, None, &both).unwrap();
        let v: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert_eq!(v["a"][0]["n"], 3);
        assert!(v["b"].as_array().unwrap().is_empty());
        let err = render_tables(Format::Csv, None, &both).unwrap_err().to_string();
        assert!(err.contains("--table") && err.contains("a, b"), "{err}");
        assert_eq!(render_tables(Format::Csv, Some("a"), &both).unwrap(), "n\n3\n");
        let err = render_tables(Format::Csv, Some("c"), &both).unwrap_err().to_string();
        assert!(err.contains("--table: `c`"), "{err}");
    }
}

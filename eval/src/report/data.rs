//! The machine-readable form of a table: named, typed columns and one observation per row,
//! rendered as CSV or JSON. Numbers carry the decimals their Markdown cell shows, so the three
//! formats print the same figures.

use serde_json::{Map, Number, Value};

/// What a column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColumnKind {
    /// Whole numbers (or missing).
    Int,
    /// Real numbers (or missing).
    Num,
    /// Text (or missing).
    Text,
}

/// One cell.
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    /// A whole number.
    Int(i64),
    /// A real number and the decimals it is printed with.
    Num(f64, usize),
    /// A real number printed in its shortest exact form.
    Real(f64),
    /// Text.
    Text(String),
    /// No value (Markdown `-`; empty in CSV, null in JSON).
    Missing,
    /// Not applicable to this row (Markdown blank; empty in CSV, null in JSON).
    Blank,
}

impl Cell {
    /// A count.
    #[must_use]
    pub fn int(v: impl TryInto<i64>) -> Self {
        v.try_into().map_or(Self::Missing, Self::Int)
    }

    /// A real number with `digits` decimals; missing when not finite.
    #[must_use]
    pub fn num(v: f64, digits: usize) -> Self {
        if v.is_finite() { Self::Num(v, digits) } else { Self::Missing }
    }

    /// A real number with `digits` decimals, or missing.
    #[must_use]
    pub fn opt(v: Option<f64>, digits: usize) -> Self {
        v.map_or(Self::Missing, |v| Self::num(v, digits))
    }

    /// A single-precision number in its shortest exact form (the digits `f32` prints, not
    /// those of its `f64` widening); missing when not finite.
    #[must_use]
    pub fn real32(v: f32) -> Self {
        // The shortest decimal of the f32 read as an f64 prints as the same decimal.
        if v.is_finite() { v.to_string().parse().map_or(Self::Missing, Self::Real) } else { Self::Missing }
    }

    /// Text.
    #[must_use]
    pub fn text(s: impl Into<String>) -> Self {
        Self::Text(s.into())
    }

    /// The cell as Markdown shows it.
    #[must_use]
    pub fn md(&self) -> String {
        match self {
            Self::Int(v) => v.to_string(),
            Self::Num(v, d) => format!("{v:.d$}"),
            Self::Real(v) => v.to_string(),
            Self::Text(s) => s.clone(),
            Self::Missing => "-".into(),
            Self::Blank => String::new(),
        }
    }

    /// The cell as a CSV field (unquoted).
    fn field(&self) -> String {
        match self {
            Self::Missing | Self::Blank => String::new(),
            other => other.md(),
        }
    }

    /// The cell as JSON: numbers as printed (the same decimals as the other formats).
    fn json(&self) -> Value {
        match self {
            Self::Int(v) => Value::from(*v),
            Self::Num(..) | Self::Real(_) => {
                self.md().parse::<f64>().ok().and_then(Number::from_f64).map_or(Value::Null, Value::Number)
            }
            Self::Text(s) => Value::from(s.as_str()),
            Self::Missing | Self::Blank => Value::Null,
        }
    }

    /// Whether the cell may stand in a column of `kind`.
    fn fits(&self, kind: ColumnKind) -> bool {
        matches!(
            (self, kind),
            (Self::Missing | Self::Blank, _)
                | (Self::Int(_), ColumnKind::Int)
                | (Self::Num(..) | Self::Real(_), ColumnKind::Num)
                | (Self::Text(_), ColumnKind::Text)
        )
    }
}

/// A named, typed column.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Column {
    /// Name (snake_case, unique in its table).
    pub name: String,
    /// What it holds.
    pub kind: ColumnKind,
}

/// Rows of typed cells under named columns: the form CSV and JSON are written from.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Data {
    /// The columns.
    pub columns: Vec<Column>,
    /// The rows; each as long as `columns`, each cell of its column's kind or missing.
    pub rows: Vec<Vec<Cell>>,
}

impl Data {
    /// No rows under these columns.
    #[must_use]
    pub fn new<'a>(columns: impl IntoIterator<Item = (&'a str, ColumnKind)>) -> Self {
        let columns = columns.into_iter().map(|(name, kind)| Column { name: name.to_string(), kind }).collect();
        Self { columns, rows: Vec::new() }
    }

    /// Appends a row.
    ///
    /// # Panics
    /// A row of another width, or a cell of another kind than its column's: a table builder's
    /// mistake, caught by the report tests.
    pub fn push(&mut self, row: Vec<Cell>) {
        assert_eq!(row.len(), self.columns.len(), "row width against columns {:?}", self.names());
        for (cell, col) in row.iter().zip(&self.columns) {
            assert!(cell.fits(col.kind), "column {}: {cell:?} is no {:?}", col.name, col.kind);
        }
        self.rows.push(row);
    }

    /// The column names.
    #[must_use]
    pub fn names(&self) -> Vec<&str> {
        self.columns.iter().map(|c| c.name.as_str()).collect()
    }

    /// The same rows with a leading column `name` holding `value` in every row.
    #[must_use]
    pub fn with_leading(mut self, name: &str, kind: ColumnKind, value: &Cell) -> Self {
        self.columns.insert(0, Column { name: name.to_string(), kind });
        for r in &mut self.rows {
            r.insert(0, value.clone());
        }
        self
    }

    /// The rows of `parts` one after another (the columns of the first; parts with other columns
    /// are a builder's mistake).
    ///
    /// # Panics
    /// Parts with different columns.
    #[must_use]
    pub fn concat(parts: impl IntoIterator<Item = Self>) -> Self {
        let mut out: Option<Self> = None;
        for p in parts {
            match &mut out {
                None => out = Some(p),
                Some(o) => {
                    assert_eq!(o.columns, p.columns, "concatenated tables differ in their columns");
                    o.rows.extend(p.rows);
                }
            }
        }
        out.unwrap_or_default()
    }

    /// CSV with a header row.
    #[must_use]
    pub fn csv(&self) -> String {
        let quote = |s: &str| {
            if s.contains([',', '"', '\n', '\r']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
        };
        let mut out = String::new();
        out.push_str(&self.columns.iter().map(|c| quote(&c.name)).collect::<Vec<_>>().join(","));
        out.push('\n');
        for r in &self.rows {
            out.push_str(&r.iter().map(|c| quote(&c.field())).collect::<Vec<_>>().join(","));
            out.push('\n');
        }
        out
    }

    /// An array of objects, one per row, keyed by column name.
    #[must_use]
    pub fn json(&self) -> Value {
        let rows = self
            .rows
            .iter()
            .map(|r| {
                let obj: Map<String, Value> =
                    self.columns.iter().zip(r).map(|(col, cell)| (col.name.clone(), cell.json())).collect();
                Value::Object(obj)
            })
            .collect();
        Value::Array(rows)
    }
}

/// `label` as a column name: lower case, runs of anything but letters and digits as one `_`.
#[must_use]
pub fn snake(label: &str) -> String {
    let mut out = String::new();
    for ch in label.chars() {
        if ch.is_ascii_alphanumeric() {
            out.push(ch.to_ascii_lowercase());
        } else if !out.is_empty() && !out.ends_with('_') {
            out.push('_');
        }
    }
    let out = out.trim_end_matches('_').to_string();
    if out.is_empty() { "column".into() } else { out }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_and_json_print_the_markdown_figures() {
        let mut d = Data::new([("arm", ColumnKind::Text), ("ade", ColumnKind::Num), ("n", ColumnKind::Int)]);
        d.push(vec![Cell::text("cv, gt"), Cell::num(1.2345, 2), Cell::int(7u32)]);
        d.push(vec![Cell::text("ctra"), Cell::Missing, Cell::Blank]);
        assert_eq!(d.csv(), "arm,ade,n\n\"cv, gt\",1.23,7\nctra,,\n");
        assert_eq!(
            serde_json::to_string(&d.json()).unwrap(),
            r#"[{"arm":"cv, gt","ade":1.23,"n":7},{"arm":"ctra","ade":null,"n":null}]"#
        );
        assert_eq!(Cell::num(f64::NAN, 2), Cell::Missing);
        assert_eq!(Cell::num(0.5, 3).md(), "0.500");
        assert_eq!(Cell::real32(1.1).md(), "1.1");
        assert_eq!(Cell::real32(f32::NAN), Cell::Missing);
    }

    #[test]
    #[should_panic(expected = "column n")]
    fn a_cell_of_the_wrong_kind_is_refused() {
        let mut d = Data::new([("n", ColumnKind::Int)]);
        d.push(vec![Cell::text("x")]);
    }

    #[test]
    fn labels_become_column_names() {
        assert_eq!(snake("camera RPE_t (m)"), "camera_rpe_t_m");
        assert_eq!(snake("ended: fit failed"), "ended_fit_failed");
        assert_eq!(snake(""), "column");
    }
}

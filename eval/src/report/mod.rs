//! Reports: tables in Markdown, CSV or JSON (Table I, III and IV layouts among them).

/// Run-resampled ratio intervals (defined in `dynotraj_train`, which selects epochs with them).
pub mod bootstrap {
    pub use dynotraj_train::bootstrap::*;
}
pub mod chart;
pub mod data;
pub mod estimator_tables;
mod forecast_table;
mod instances_table;
pub mod stream_report;
mod table;

pub use data::{Cell, ColumnKind, Data};
pub use forecast_table::{ArmScores, ReferenceRow, forecast_table};
pub use instances_table::instances_table;
pub use table::{Format, Table, check_table, fmt_opt, json_text, render_tables, write_table_files};

//! Reports: tables in Markdown or CSV (Table I, III and IV layouts among them).

pub mod chart;
pub mod estimator_tables;
mod forecast_table;
mod instances_table;
pub mod stream_report;
mod table;

pub use forecast_table::{ArmScores, ReferenceRow, forecast_table};
pub use instances_table::instances_table;
pub use table::{Format, Table, fmt_opt};

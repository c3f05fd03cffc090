//! Reports: tables in Markdown or CSV (Table I and Table IV layouts among them).

pub mod chart;
mod forecast_table;
mod instances_table;
mod table;

pub use forecast_table::{forecast_table, ArmScores, ReferenceRow};
pub use instances_table::instances_table;
pub use table::{fmt_opt, Format, Table};

//! Reports: tables in Markdown or CSV.

mod forecast_table;
mod table;

pub use forecast_table::{forecast_table, ArmScores, ReferenceRow};
pub use table::{fmt_opt, Format, Table};

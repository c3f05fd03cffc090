//! Reports: tables in Markdown or CSV.

mod table;

pub use table::{fmt_opt, Format, Table};

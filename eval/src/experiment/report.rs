//! The experiment's report folder: every table as Markdown, CSV and JSON, and a REPORT.md that
//! embeds them with the fold summary and the run's time.
//!
//! Layout of `DIR`: `REPORT.md`; `table_i.{md,csv,json}` (eligible objects and test instances
//! per source), `table_iii_<kind>.{md,csv,json}` (RPE of the estimator behind the Estimated arm,
//! when it ran), `table_iv.{md,csv,json}` (ADE, FDE, ACE per arm), `table_iv_truth.{md,csv,json}`
//! (against the simulator's truth), `folds.{csv,json}`; the CSV and JSON files hold one
//! observation per row (see [`crate::report`]); `figures/` (PNG and SVG, [`super::figures`]); `models/`
//! (each fold's blobs) and `cache/` (trained folds, see [`super::cache`]).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context as _;

use super::FoldReport;
use crate::report::{Cell, ColumnKind, Data, Format, Table};

/// One table of the report.
#[derive(Debug, Clone)]
pub struct Section {
    /// File stem (`table_iv`).
    pub stem: String,
    /// Heading in REPORT.md.
    pub title: String,
    /// What the reader must know to read it (one paragraph, may be empty).
    pub caption: String,
    /// The table.
    pub table: Table,
}

/// Everything REPORT.md shows.
#[derive(Debug, Clone)]
pub struct Report {
    /// The heading of REPORT.md.
    pub title: String,
    /// The command line that made it.
    pub command: String,
    /// The tables, in order.
    pub sections: Vec<Section>,
    /// Per fold: how it was trained.
    pub folds: Vec<FoldReport>,
    /// Wall-clock seconds of the whole run.
    pub seconds: f64,
    /// Findings and caveats, one paragraph each.
    pub notes: Vec<String>,
    /// Figures to embed (PNG paths; an SVG of each sits beside it).
    pub figures: Vec<super::figures::Figure>,
}

/// The fold summary as a table.
#[must_use]
pub fn folds_table(folds: &[FoldReport]) -> Table {
    use ColumnKind::{Int, Num, Text};
    let columns = [
        ("arm", "arm", Text),
        ("agents", "agents", Text),
        ("held-out sequences", "held_out_sequences", Text),
        ("seed", "seed", Int),
        ("training instances", "training_instances", Int),
        ("epoch kept", "epoch_kept", Int),
        ("shrink", "shrink", Num),
        ("val ADE (m)", "val_ade_m", Num),
        ("val cv ADE (m)", "val_cv_ade_m", Num),
        ("val prior ADE (m)", "val_prior_ade_m", Num),
        ("prior windows v/t", "prior_windows", Text),
        ("prior gains a/w", "prior_gains", Text),
        ("prior decays a/w", "prior_decays", Text),
        ("prior carry %", "prior_carry_percent", Int),
        ("training s", "training_s", Num),
        ("cached", "cached", Text),
    ];
    let mut d = Data::new(columns.map(|(_, n, k)| (n, k)));
    for f in folds {
        d.push(vec![
            Cell::text(f.arm.to_string()),
            Cell::text(f.agents.agents()),
            Cell::text(f.sequence.as_str()),
            Cell::int(f.seed),
            Cell::int(f.train_instances),
            Cell::int(f.best_epoch),
            // The shrink as the f32 prints it, not as its f64 widening would.
            f.shrink.to_string().parse().map_or(Cell::Missing, Cell::Real),
            Cell::num(f64::from(f.val_ade), 3),
            Cell::num(f64::from(f.val_cv_ade), 3),
            Cell::num(f64::from(f.val_prior_ade), 3),
            Cell::text(format!("{}/{}", f.prior.velocity_window, f.prior.trend_window)),
            Cell::text(format!("{}/{}", f.prior.accel_gain, f.prior.turn_gain)),
            Cell::text(format!("{}/{}", f.prior.accel_decay, f.prior.turn_decay)),
            Cell::int(f.prior.carry_percent),
            Cell::num(f64::from(f.seconds), 1),
            Cell::text(if f.cached { "yes" } else { "no" }),
        ]);
    }
    Table::of_data(columns.map(|(h, _, _)| h), d)
}

/// Writes the report into `dir`; returns the path of REPORT.md.
///
/// # Errors
/// A file cannot be written, named.
pub fn write_report(dir: &Path, report: &Report) -> anyhow::Result<PathBuf> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let write = |name: String, text: &str| -> anyhow::Result<()> {
        let path = dir.join(name);
        dynotraj_formats::atomic::write_file(&path, text).with_context(|| format!("writing {}", path.display()))
    };
    let mut md = format!("# {}\n\n", report.title);
    let _ = write!(md, "Made by `{}` in {:.0} s ({:.1} min).", report.command, report.seconds, report.seconds / 60.0);
    let cached: Vec<&FoldReport> = report.folds.iter().filter(|f| f.cached).collect();
    if !cached.is_empty() {
        let trained: f32 = cached.iter().map(|f| f.seconds).sum();
        let _ = write!(
            md,
            " {} of {} folds were read from the fold cache; training them took {trained:.0} s when they were trained.",
            cached.len(),
            report.folds.len()
        );
    }
    md.push_str("\n\n");
    for s in &report.sections {
        write(format!("{}.md", s.stem), &s.table.render(Format::Md))?;
        write(format!("{}.csv", s.stem), &s.table.render(Format::Csv))?;
        write(format!("{}.json", s.stem), &s.table.render(Format::Json))?;
        let _ = writeln!(md, "## {}\n", s.title);
        if !s.caption.is_empty() {
            let _ = writeln!(md, "{}\n", s.caption);
        }
        let _ = writeln!(md, "{}\n\n([{1}.csv]({1}.csv))\n", s.table.render(Format::Md).trim_end(), s.stem);
    }
    let folds = folds_table(&report.folds);
    write("folds.csv".into(), &folds.render(Format::Csv))?;
    write("folds.json".into(), &folds.render(Format::Json))?;
    let _ = writeln!(
        md,
        "## Folds\n\nEpoch 0 is the untrained model (cv-fit: constant velocity along the velocity of a parabola \
            fitted through the history), kept when no epoch beats it on the held-out training sequences.\n\n{}\n",
        folds.render(Format::Md).trim_end()
    );
    if !report.figures.is_empty() {
        md.push_str("## Figures\n\n");
        for f in &report.figures {
            let rel = f.png.strip_prefix(dir).unwrap_or(&f.png).display().to_string();
            let _ = writeln!(md, "![{}]({rel})\n\n{} ([SVG]({}))\n", f.caption, f.caption, rel.replace(".png", ".svg"));
        }
    }
    if !report.notes.is_empty() {
        md.push_str("## Findings\n\n");
        for n in &report.notes {
            let _ = writeln!(md, "- {n}");
        }
    }
    let path = dir.join("REPORT.md");
    dynotraj_formats::atomic::write_file(&path, md).with_context(|| format!("writing {}", path.display()))?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynotraj_sources::trajectory::Source;

    #[test]
    fn every_table_is_written_twice_and_embedded() {
        let dir = tempfile::tempdir().unwrap();
        let mut table = Table::new(["metric", "avg"]);
        table.push(["ADE", "1.25"]);
        let fold = FoldReport {
            arm: Source::Estimated,
            agents: dynotraj_core::predict::Dynamics::Unicycle,
            sequence: "0003".into(),
            seed: 1,
            train_instances: 9,
            val_ade: 1.0,
            val_cv_ade: 1.1,
            val_prior_ade: 1.05,
            prior: dynotraj_core::predict::PriorSettings::DEFAULT,
            best_epoch: 2,
            shrink: 1.0,
            seconds: 3.0,
            cached: true,
        };
        let report = Report {
            title: "dynotraj experiment report".into(),
            command: "dynotraj experiment".into(),
            sections: vec![Section {
                stem: "table_iv".into(),
                title: "Table IV".into(),
                caption: "scored against own future".into(),
                table,
            }],
            folds: vec![fold],
            seconds: 90.0,
            notes: vec!["a finding".into()],
            figures: vec![super::super::figures::Figure {
                png: dir.path().join("figures/fig5.png"),
                caption: "ACE".into(),
            }],
        };
        let md = std::fs::read_to_string(write_report(dir.path(), &report).unwrap()).unwrap();
        assert!(
            md.contains("| ADE    | 1.25 |") && md.contains("scored against own future") && md.contains("a finding"),
            "{md}"
        );
        assert!(md.contains("| estimated | vehicles | 0003"), "{md}");
        assert!(md.contains("![ACE](figures/fig5.png)") && md.contains("(figures/fig5.svg)"), "{md}");
        assert!(md.contains("1 of 1 folds were read from the fold cache; training them took 3 s"), "{md}");
        assert_eq!(std::fs::read_to_string(dir.path().join("table_iv.csv")).unwrap(), "metric,avg\nADE,1.25\n");
        assert!(dir.path().join("table_iv.md").is_file() && dir.path().join("folds.csv").is_file());
    }
}

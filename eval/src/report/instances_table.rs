//! The paper's Table I layout: eligible objects and test instances per sequence, per source.
//!
//! Its data (CSV, JSON) has one row per source and sequence: `row_kind` (`data`, or `sum` over
//! the sequences), `source`, `agents` (`all`, or one agent type's share of them: `pedestrians`
//! when the rule holds more than one agent type), `sequence` (empty on sums),
//! `eligible_objects`, `test_instances`.

use super::{Cell, ColumnKind, Data, Table};
use dynotraj_sources::sequence::SequenceTracks;
use dynotraj_sources::trajectory::{EligibilityRule, Source, eligible_runs};

/// Eligible objects and test instances of `seqs` under `rule`, two rows per source (the source
/// named in the row label unless `sources` is the labels alone), with totals; then, for every
/// agent type of the rule after the first (pedestrians), two rows of its share.
#[must_use]
pub fn instances_table(seqs: &[SequenceTracks], sources: &[Source], rule: &EligibilityRule) -> Table {
    use ColumnKind::{Int, Text};
    let mut headers = vec![String::new()];
    headers.extend(seqs.iter().map(|s| s.id.clone()));
    headers.push("sum".into());
    let mut t = Table::new(headers);
    let mut d = Data::new([
        ("row_kind", Text),
        ("source", Text),
        ("agents", Text),
        ("sequence", Text),
        ("eligible_objects", Int),
        ("test_instances", Int),
    ]);
    let only_labels = sources == [Source::Gt];
    let agent_types = rule.agent_types();
    let shares = agent_types.iter().skip(1).map(|&a| (a.agents(), rule.for_agents(a)));
    for (agents, rule) in std::iter::once(("all", rule.clone())).chain(shares) {
        for &source in sources {
            let mut suffix = if only_labels { String::new() } else { format!(" ({source})") };
            if agents != "all" {
                suffix.push_str(&format!(": {agents}"));
            }
            push_rows(seqs, source, (agents, &rule), &suffix, (&mut t, &mut d));
        }
    }
    t.with_data(d)
}

/// The two rows of `source`'s eligible runs under `rule` (of `agents`), labelled with `suffix`.
fn push_rows(
    seqs: &[SequenceTracks],
    source: Source,
    (agents, rule): (&str, &EligibilityRule),
    suffix: &str,
    (t, d): (&mut Table, &mut Data),
) {
    let mut objects = vec![format!("eligible objects{suffix}")];
    let mut instances = vec![format!("test instances{suffix}")];
    let (mut total_objects, mut total_instances) = (0, 0);
    for s in seqs {
        let runs = eligible_runs(s.tracks_for(source), rule);
        let mut ids: Vec<i32> = runs.iter().map(|r| r.track_id).collect();
        ids.dedup();
        let n: usize = runs.iter().map(|r| r.instances().len()).sum();
        let cell = |v: usize| if v == 0 { "-".to_string() } else { v.to_string() };
        objects.push(cell(ids.len()));
        instances.push(cell(n));
        d.push(vec![
            Cell::text("data"),
            Cell::text(source.to_string()),
            Cell::text(agents),
            Cell::text(s.id.as_str()),
            Cell::int(ids.len()),
            Cell::int(n),
        ]);
        total_objects += ids.len();
        total_instances += n;
    }
    objects.push(total_objects.to_string());
    instances.push(total_instances.to_string());
    d.push(vec![
        Cell::text("sum"),
        Cell::text(source.to_string()),
        Cell::text(agents),
        Cell::Blank,
        Cell::int(total_objects),
        Cell::int(total_instances),
    ]);
    t.push(objects);
    t.push(instances);
}

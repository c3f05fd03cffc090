//! docs/cli.md ends with every command's `--help`, as clap renders it at 100 columns: this test
//! renders it and fails when the page differs (a flag added, renamed or re-documented without
//! the page). `DYNOTRAJ_BLESS=1` rewrites that section after a deliberate change.

use clap::CommandFactory as _;

/// The heading the generated section starts at; everything above it is written by hand.
const MARKER: &str = "## Every command's options (`--help`)";

/// Columns the help is rendered at.
const WIDTH: usize = 100;

/// The generated section: each subcommand's long help, in the order `dynotraj --help` lists them.
fn generated() -> String {
    let mut cli = dynotraj_cli::Cli::command().term_width(WIDTH).max_term_width(WIDTH);
    cli.build();
    let mut out = format!(
        "{MARKER}\n\nGenerated from `dynotraj <command> --help` at {WIDTH} columns (tests/tests/cli_help_doc.rs \
         keeps it equal to the help; `DYNOTRAJ_BLESS=1` rewrites it).\n"
    );
    for sub in cli.get_subcommands_mut() {
        let name = sub.get_name().to_string();
        if name == "help" {
            continue;
        }
        let help = sub.clone().term_width(WIDTH).max_term_width(WIDTH).render_long_help().to_string();
        let help: Vec<&str> = help.lines().map(str::trim_end).collect();
        out.push_str(&format!("\n### `dynotraj {name}`\n\n```text\n{}\n```\n", help.join("\n").trim_end()));
    }
    out
}

#[test]
fn the_command_reference_is_the_help() {
    let path = dynotraj_tests::manifest_dir().join("../docs/cli.md");
    let page = std::fs::read_to_string(&path).unwrap();
    let (by_hand, section) = page.split_once(MARKER).map_or((page.as_str(), ""), |(a, b)| (a, b));
    let want = generated();
    if std::env::var_os("DYNOTRAJ_BLESS").is_some() {
        std::fs::write(&path, format!("{}{want}", by_hand.trim_end().to_string() + "\n\n")).unwrap();
        return;
    }
    assert_eq!(
        format!("{MARKER}{section}"),
        want,
        "docs/cli.md's generated section differs from the help: rerun with DYNOTRAJ_BLESS=1 and commit it"
    );
    for sub in ["experiment", "benchmark", "train", "eval", "pedestrians", "import", "forecast"] {
        assert!(want.contains(&format!("### `dynotraj {sub}`")), "{sub} is documented");
    }
}

#[test]
fn the_readme_reads_in_two_minutes() {
    let readme = std::fs::read_to_string(dynotraj_tests::manifest_dir().join("../README.md")).unwrap();
    assert!(readme.len() <= 8_000, "README.md is {} characters: at most 8,000", readme.len());
    for link in ["docs/cli.md", "docs/overview.md", "docs/architecture.md", "docs/results.md"] {
        assert!(readme.contains(&format!("]({link})")), "the README links {link}");
    }
}

//! One grammar across the commands, as docs/cli.md's table states it: read from clap's own
//! description of every subcommand, so a new flag that breaks a rule fails here.

use std::process::Command;

use clap::CommandFactory as _;
use dynotraj_cli::Cli;

/// Every (subcommand, argument) pair of the command line.
fn every_arg() -> Vec<(String, clap::Arg)> {
    let cli = Cli::command();
    cli.get_subcommands().flat_map(|c| c.get_arguments().map(move |a| (c.get_name().to_string(), a.clone()))).collect()
}

/// Whether `arg` takes `true` or `false` as a value.
fn takes_bool(arg: &clap::Arg) -> bool {
    let values: Vec<String> = arg.get_possible_values().iter().map(|v| v.get_name().to_string()).collect();
    arg.get_action().takes_values() && values == ["true", "false"]
}

#[test]
fn no_flag_takes_true_or_false() {
    let old_style =
        clap::Arg::new("mirror").long("mirror").action(clap::ArgAction::Set).value_parser(clap::value_parser!(bool));
    assert!(takes_bool(&old_style), "the check sees a `--mirror <BOOL>`");
    assert!(!takes_bool(&clap::Arg::new("lockstep").long("lockstep").action(clap::ArgAction::SetTrue)));
    for (cmd, arg) in every_arg() {
        assert!(!takes_bool(&arg), "{cmd} --{}: a boolean is a switch, not a value", arg.get_id());
    }
}

#[test]
fn sequences_are_one_flag_that_takes_a_list() {
    let mut seen = Vec::new();
    for (cmd, arg) in every_arg() {
        let Some(long) = arg.get_long() else { continue };
        if !long.contains("sequence") || long == "no-val-sequences" {
            continue;
        }
        assert_eq!(long, "sequences", "{cmd}: the sequence flag is --sequences");
        let aliases = arg.get_visible_aliases().unwrap_or_default();
        assert_eq!(aliases, ["sequence"], "{cmd} --sequences: --sequence is its one alias");
        assert_eq!(arg.get_value_delimiter(), Some(','), "{cmd} --sequences takes a comma-separated list");
        seen.push(cmd);
    }
    for cmd in ["dataset", "estimate", "train", "experiment", "benchmark", "simulate", "track", "stream", "soak"] {
        assert!(seen.iter().any(|c| c == cmd), "{cmd} has --sequences");
    }
}

#[test]
fn out_is_always_a_folder() {
    let mut seen = 0;
    for (cmd, arg) in every_arg() {
        if arg.get_long() == Some("out") {
            let names: Vec<_> = arg.get_value_names().unwrap_or_default().iter().map(ToString::to_string).collect();
            assert_eq!(names, ["DIR"], "{cmd} --out names a folder");
            seen += 1;
        }
    }
    assert!(seen >= 10, "--out on {seen} commands");
}

#[test]
fn every_kitti_flag_defaults_to_the_environment_variable() {
    for (cmd, arg) in every_arg() {
        if arg.get_long() != Some("kitti") {
            continue;
        }
        let by_clap = arg.get_env().is_some_and(|e| e == "DYNOTRAJ_KITTI");
        // stream and soak read it themselves, so that --tracks does not conflict with it.
        let by_command = arg.get_help().is_some_and(|h| h.to_string().contains("default: $DYNOTRAJ_KITTI"));
        assert!(by_clap || by_command, "{cmd} --kitti: DYNOTRAJ_KITTI is its default");
    }
}

fn dynotraj(args: &[&str], kitti: &str) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_dynotraj")).args(args).env("DYNOTRAJ_KITTI", kitti).output().unwrap();
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn a_tracks_file_is_read_even_when_the_kitti_variable_is_set() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.dtt");
    let missing = missing.to_str().unwrap();
    let kitti = dir.path().to_str().unwrap();
    let stream = ["stream", "--tracks", missing, "--to", "tcp://127.0.0.1:9"];
    let soak = ["soak", "--tracks", missing];
    for args in [&stream[..], &soak[..]] {
        let (code, err) = dynotraj(args, kitti);
        assert_eq!(code, Some(1), "{args:?}: {err}");
        assert!(err.contains("missing.dtt"), "{args:?} reads the tracks file, not the folder: {err}");
    }
    // Without --tracks, the variable's folder is used and the sequence must be named.
    let (code, err) = dynotraj(&["stream", "--to", "tcp://127.0.0.1:9"], kitti);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("--sequences: expected the id of the sequence to send"), "{err}");
    let (code, err) = dynotraj(&["stream", "--sequences", "0000,0001", "--to", "tcp://127.0.0.1:9"], kitti);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("expected one id, found 0000,0001"), "{err}");
}

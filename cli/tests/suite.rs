//! The command's integration tests as one test binary, each file beside this one a module of it
//! (why: tests/tests/suite.rs).

mod cli_errors;
mod cli_grammar;
mod doc_commands;
mod tables_machine_readable;

//! Every flag of every subcommand says what it takes: the clap tree, read from the binary's sources, has a help
//! line for each argument a user sees.

use clap::CommandFactory;

// The command line's clap tree (the binary crate has no library to import).
#[allow(dead_code)]
#[path = "../src/cli/mod.rs"]
mod cli;

fn walk(c: &clap::Command, path: &str, missing: &mut Vec<String>) {
    for a in c.get_arguments() {
        let id = a.get_id().as_str();
        // A hidden flag (a process's internal role) is shown to no one.
        let shown = !a.is_hide_set() && id != "help" && id != "version";
        if shown && a.get_help().is_none() && a.get_long_help().is_none() {
            missing.push(format!("{path} --{}", a.get_long().unwrap_or(id)));
        }
    }
    for s in c.get_subcommands() {
        walk(s, &format!("{path} {}", s.get_name()), missing);
    }
}

#[test]
fn every_flag_has_a_help_line() {
    let mut missing = Vec::new();
    walk(&cli::Cli::command(), "topa", &mut missing);
    assert!(missing.is_empty(), "{} flags without a help line:\n{}", missing.len(), missing.join("\n"));
}

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

/// Every shown flag: (command path, long name, value type, takes a value).
fn flags(c: &clap::Command, path: &str, out: &mut Vec<(String, String, String, bool)>) {
    for a in c.get_arguments().filter(|a| !a.is_hide_set()) {
        if let Some(long) = a.get_long() {
            let takes = a.get_action().takes_values();
            out.push((path.to_string(), long.to_string(), format!("{:?}", a.get_value_parser().type_id()), takes));
        }
    }
    for s in c.get_subcommands() {
        flags(s, &format!("{path} {}", s.get_name()), out);
    }
}

fn names(c: &clap::Command, out: &mut std::collections::BTreeSet<String>) {
    for s in c.get_subcommands() {
        out.insert(s.get_name().to_string());
        names(s, out);
    }
}

#[test]
fn one_concept_one_flag_name_across_subcommands() {
    let root = cli::Cli::command();
    let mut all = Vec::new();
    flags(&root, "topa", &mut all);
    let mut problems = Vec::new();
    // The same name takes the same kind of value everywhere (a count is a count, a duration a number).
    let mut by_name: std::collections::BTreeMap<&str, Vec<&(String, String, String, bool)>> = Default::default();
    for f in &all {
        by_name.entry(f.1.as_str()).or_default().push(f);
    }
    for (name, uses) in &by_name {
        let first = uses[0];
        for u in &uses[1..] {
            if (&u.2, u.3) != (&first.2, first.3) {
                problems.push(format!("--{name}: one kind of value in `{}`, another in `{}`", first.0, u.0));
            }
        }
    }
    // A flag is not another command's flag renamed with that command's name in front (`--push-range` where
    // `topa eval push` says `--range`): a command that runs several experiments takes their own names.
    let mut commands = Default::default();
    names(&root, &mut commands);
    for f in &all {
        if let Some((prefix, rest)) = f.1.split_once('-') {
            if commands.contains(prefix) && by_name.get(rest).is_some_and(|u| u.iter().any(|g| g.2 == f.2)) {
                problems.push(format!("`{}` --{}: `--{rest}` elsewhere names the same thing", f.0, f.1));
            }
        }
    }
    assert!(problems.is_empty(), "{} inconsistent flags:\n{}", problems.len(), problems.join("\n"));
}

#[test]
fn the_version_printed_is_the_changelogs_latest_release() {
    let log = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/CHANGELOG.md")).unwrap();
    let latest = log
        .lines()
        .filter_map(|l| l.strip_prefix("## [")?.split_once(']').map(|(v, _)| v))
        .find(|v| *v != "Unreleased")
        .expect("a released version in CHANGELOG.md");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_topa")).arg("--version").output().unwrap();
    let printed = String::from_utf8_lossy(&out.stdout);
    assert_eq!(printed.trim(), format!("topa {latest}"), "the binary's version is the changelog's latest release");
}

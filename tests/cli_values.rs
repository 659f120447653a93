//! Durations, forces and counts are checked when the command line is read: a negative or zero value is one error
//! naming the flag of the command that was run, before anything loads or runs.

use std::process::Command;

fn refused(args: &[&str], flag: &str) {
    let out =
        Command::new(env!("CARGO_BIN_EXE_topa")).current_dir(env!("CARGO_MANIFEST_DIR")).args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{args:?} ran");
    assert!(err.contains(&format!("'{flag} <")), "{args:?}: the error names {flag}: {err}");
    assert_eq!(err.lines().filter(|l| l.starts_with("error")).count(), 1, "{err}");
}

#[test]
fn negative_durations_and_zero_counts_are_refused_naming_the_flag() {
    let p = "assets/policies/C/seed1.json";
    refused(&["eval", "tracking", "--policy", p, "--seconds=-3"], "--seconds");
    refused(&["eval", "tracking", "--policy", p, "--starts", "0"], "--starts");
    refused(&["eval", "push", "--policy", p, "--range", "0"], "--range");
    refused(&["eval", "noise", "--policy", p, "--runs", "0"], "--runs");
    refused(&["eval", "endurance", "--policy", p, "--minutes=-1"], "--minutes");
    refused(&["eval", "physics", "--policy", p, "--push-force", "nan"], "--push-force");
    refused(&["ablate", "--c", "assets/policies/C", "--starts", "0"], "--starts");
}

#[test]
fn a_toml_syntax_error_keeps_its_excerpt_and_caret() {
    let dir = std::env::temp_dir().join(format!("topa-toml-caret-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "[run]\nseed = 1\nnum_envs = \"x\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_topa"))
        .args(["train", "--config"])
        .arg(&bad)
        .arg("--out")
        .arg(dir.join("run"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = err.lines().collect();
    assert!(lines[0].starts_with("error: config ") && lines[0].contains("line 3, column 14"), "{err}");
    let excerpt =
        lines.iter().position(|l| l.starts_with("3 | num_envs")).expect("the offending line, as TOML shows it");
    let caret = lines[excerpt + 1];
    assert_eq!(caret.find('^'), Some("3 | num_envs = \"x".len()), "the caret under column 14: {err}");
    let _ = std::fs::remove_dir_all(&dir);
}

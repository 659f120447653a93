//! `topa info` as a user runs it: a summary for good models, one clear line and a non-zero exit for bad ones.

use std::path::{Path, PathBuf};
use std::process::Command;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("mujoco-sys/tests/fixtures").join(name)
}

fn topa(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_topa")).args(args).output().expect("run topa")
}

#[test]
fn info_json_describes_the_four_bar() {
    let out = topa(&["info", "--json", fixture("fourbar.xml").to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("valid JSON");
    assert_eq!(v["model"], "fourbar");
    assert_eq!(v["nq"], 3);
    assert_eq!(v["nv"], 3);
    assert_eq!(v["nu"], 1);
    assert_eq!(v["neq"], 1);
    assert_eq!(v["bodies"], 4);
    assert_eq!(v["equality"][0]["type"], "connect");
    assert_eq!(v["equality"][0]["obj1"], "coupler");
    assert_eq!(v["equality"][0]["obj2"], "rocker");
    assert_eq!(v["timestep_s"], 0.001);
    assert_eq!(v["integrator"], "Euler");
    let mass = v["total_mass_kg"].as_f64().unwrap();
    assert!(mass > 0.1 && mass < 1.0, "{mass}");
}

#[test]
fn info_text_names_the_equality_constraint() {
    let out = topa(&["info", fixture("fourbar.xml").to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    assert!(text.contains("nq=3 nv=3 nu=1"), "{text}");
    assert!(text.lines().any(|l| l.contains("loop") && l.contains("connect") && l.contains("coupler")), "{text}");
}

fn assert_one_line_error(out: &std::process::Output, must_contain: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "stderr: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "exactly one error line, got: {err}");
    assert!(err.starts_with("error: "), "{err}");
    assert!(err.contains(must_contain), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(out.stdout.is_empty());
}

#[test]
fn info_on_a_broken_file_prints_one_clear_line_and_fails() {
    assert_one_line_error(&topa(&["info", fixture("malformed.xml").to_str().unwrap()]), "Line number=3");
    assert_one_line_error(&topa(&["info", "/no/such/file.xml"]), "/no/such/file.xml");
}

#[test]
fn version_is_printed() {
    let out = topa(&["--version"]);
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("topa "));
}

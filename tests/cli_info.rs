//! `topa info` as a user runs it: a summary for good models, one clear line and a non-zero exit for bad ones.

use std::path::{Path, PathBuf};
use std::process::Command;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("mujoco/tests/fixtures").join(name)
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

fn robot_info(name: &str) -> serde_json::Value {
    let spec = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/robots").join(name);
    let out = topa(&["info", "--json", spec.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("valid JSON")
}

#[test]
fn info_on_a_robot_spec_shows_what_the_linkage_computes() {
    // TopA: the paper's M (ankle joint = ankle motor − knee) and a J that does not move anywhere near the stand.
    let topa = robot_info("topa_closed.toml");
    assert_eq!(topa["map"]["kind"], "linear");
    assert_eq!(topa["motors"].as_array().unwrap().len(), 10);
    let j = &topa["map"]["jacobian_at_stand"];
    assert!((j[4][3].as_f64().unwrap() + 1.0).abs() < 1e-9 && (j[4][4].as_f64().unwrap() - 1.0).abs() < 1e-9);
    assert!(topa["map"]["jacobian_spread"].as_f64().unwrap() < 1e-9, "{}", topa["map"]);
    assert_eq!(topa["motors"][0]["mirror"], "r_hip_roll");
    // Kestrel: the two-rod ankle couples pitch and roll, and J changes with the pose.
    let kestrel = robot_info("kestrel.toml");
    assert_eq!(kestrel["map"]["kind"], "nonlinear");
    assert_eq!(kestrel["motors"].as_array().unwrap().len(), 12);
    let j = &kestrel["map"]["jacobian_at_stand"];
    assert!(j[5][4].as_f64().unwrap().abs() > 0.1 && j[5][5].as_f64().unwrap().abs() > 0.1, "roll from both rods");
    assert!(kestrel["map"]["jacobian_spread"].as_f64().unwrap() > 1e-3);
    // The serial model: identity, and it names the robot it stands in for.
    let open = robot_info("topa_open.toml");
    assert_eq!(open["map"]["kind"], "identity");
    assert!(open["approximates"].as_str().unwrap().ends_with("topa_closed.toml"));
}

#[test]
fn info_on_a_broken_robot_spec_names_the_line() {
    let dir = std::env::temp_dir().join(format!("topa-info-spec-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/robots/kestrel.toml");
    let text = std::fs::read_to_string(src).unwrap().replace("../mjcf/kestrel.xml", "kestrel_missing.xml");
    let bad = dir.join("kestrel.toml");
    std::fs::write(&bad, text).unwrap();
    assert_one_line_error(&topa(&["info", bad.to_str().unwrap()]), "kestrel_missing.xml");
    std::fs::remove_dir_all(dir).ok();
}

//! The second evaluator: MuJoCo's current release (official Python bindings, ONNX Runtime) runs the tracking
//! experiment from the exported policy, and agrees with `topa eval tracking` (MuJoCo 2.2) on the same starts.
//! Needs `.venv-mujoco-release` (`bash scripts/mujoco_release/install.sh`, which test.sh runs); without it the
//! test says it skipped.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn release_python() -> Option<PathBuf> {
    let p = root().join(".venv-mujoco-release/bin/python");
    p.exists().then_some(p)
}

#[test]
fn the_current_release_walks_the_shipped_policies_as_mujoco_2_2_does() {
    let Some(python) = release_python() else {
        eprintln!("skipped: no .venv-mujoco-release (run `bash scripts/mujoco_release/install.sh`)");
        return;
    };
    let out = std::env::temp_dir().join(format!("topa-mujoco-release-{}", std::process::id()));
    // C seed 1 and the C+A seed whose turn was reported fragile across releases.
    let run = Command::new(python)
        .current_dir(root())
        .args(["scripts/mujoco_release/agreement.py", "--topa", env!("CARGO_BIN_EXE_topa")])
        .args(["--starts", "1", "--seconds", "5", "--out"])
        .arg(&out)
        .args(["assets/policies/C/seed1.json", "assets/policies/CA/seed4.json"])
        .output()
        .unwrap();
    assert!(run.status.success(), "agreement.py failed: {}", String::from_utf8_lossy(&run.stderr));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("agreement.json")).unwrap()).unwrap();
    let rows = report["policies"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    for r in rows {
        let release = r["release"].as_str().unwrap();
        assert!(!release.starts_with("2.2"), "the second evaluator must run another MuJoCo release, not {release}");
        assert_eq!(r["falls_22"], 0, "{r}");
        assert_eq!(r["falls_release"], 0, "{r}");
        let (ours, theirs) = (r["worst_22"].as_f64().unwrap(), r["worst_release"].as_f64().unwrap());
        // A walking policy has errors; a zero would mean an evaluator that measured nothing.
        assert!(ours > 0.02 && theirs > 0.02, "{r}");
        assert!((theirs - ours).abs() <= f64::max(0.2 * ours, 0.03), "{r}");
        // Every command's whole-window errors, not only the worst, within the bound.
        for c in r["per_command"].as_array().unwrap() {
            for (a, b) in c["mae_whole_22"].as_array().unwrap().iter().zip(c["mae_whole_release"].as_array().unwrap()) {
                let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
                assert!((a - b).abs() <= f64::max(0.2 * a, 0.03), "{}: {a} vs {b}", c["key"]);
            }
        }
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn the_release_evaluator_refuses_a_file_that_is_not_a_policy() {
    let Some(python) = release_python() else {
        eprintln!("skipped: no .venv-mujoco-release (run `bash scripts/mujoco_release/install.sh`)");
        return;
    };
    let run = Command::new(python)
        .current_dir(root())
        .args(["scripts/mujoco_release/agreement.py", "--topa", env!("CARGO_BIN_EXE_topa"), "configs/paper.toml"])
        .output()
        .unwrap();
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("configs/paper.toml") && err.contains("policy sidecar"), "{err}");
}

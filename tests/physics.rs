//! `topa eval physics`: a perturbation the policy cannot take fails its case while nominal passes, the fragility
//! search brackets where it starts to fail, and bad perturbation files get one error naming the case and the key.

use std::path::{Path, PathBuf};
use std::process::Command;

fn topa(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_topa")).current_dir(env!("CARGO_MANIFEST_DIR")).args(args).output().unwrap()
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("topa-physics-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(dir: &Path, text: &str) -> String {
    let f = dir.join("matrix.toml");
    std::fs::write(&f, text).unwrap();
    f.display().to_string()
}

#[test]
fn a_heavy_torso_fails_where_nominal_passes_and_the_search_brackets_the_mass_that_flips_it() {
    let dir = scratch("heavy");
    let matrix = write(&dir, "[[case]]\nname = \"heavy\"\ntorso_mass_scale = 3.0\n");
    let out = dir.join("out");
    let run = topa(&[
        "eval",
        "physics",
        "--policy",
        "assets/policies/C/seed1.json",
        "--matrix",
        &matrix,
        "--starts",
        "1",
        "--seconds",
        "4",
        "--fragility",
        "--threads",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("physics.json")).unwrap()).unwrap();
    let cases = r["entries"][0]["result"]["cases"].as_array().unwrap();
    let (nominal, heavy) = (&cases[0], &cases[1]);
    assert_eq!(nominal["case"], "nominal");
    assert_eq!((nominal["tracking_falls"].as_u64(), nominal["push_falls"].as_u64()), (Some(0), Some(0)), "{nominal}");
    assert!(nominal["worst_component_mae"].as_f64().unwrap() < 0.15, "{nominal}");
    // Three times the torso's mass: it falls.
    assert!(heavy["tracking_falls"].as_u64().unwrap() + heavy["push_falls"].as_u64().unwrap() > 0, "{heavy}");
    let flip = &r["fragility"][0];
    assert_eq!(flip["case"], "heavy");
    let t = &flip["finding"]["threshold"];
    let (lo, hi) = (t["survives_at"].as_f64().unwrap(), t["fails_at"].as_f64().unwrap());
    assert!(lo < hi && hi <= 1.0 && (hi - lo - 0.125).abs() < 1e-9, "bisection to an eighth: {t}");
    assert!(t["fails"].as_str().unwrap().starts_with("torso mass x"), "{t}");
    let md = std::fs::read_to_string(out.join("physics.md")).unwrap();
    assert!(md.contains("What flips each failed case") && md.contains("| C 1 | heavy | fails from torso mass x"));
    assert!(out.join("physics_heatmap.png").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_perturbation_files_get_one_error_naming_the_case_and_the_key() {
    let dir = scratch("bad");
    for (text, names) in [
        ("[[case]]\nname = \"typo\"\nfrction_scale = 0.5\n", ["typo", "frction_scale"]),
        ("[[case]]\nname = \"negative\"\nfriction_scale = -0.5\n", ["negative", "friction_scale"]),
        ("[[case]]\nname = \"late\"\nlatency_s = 0.05\n", ["late", "longer than 1 control period"]),
    ] {
        let matrix = write(&dir, text);
        let run = topa(&["eval", "physics", "--policy", "assets/policies/C/seed1.json", "--matrix", &matrix]);
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{text}");
        assert_eq!(err.lines().filter(|l| l.starts_with("error")).count(), 1, "{err}");
        for n in names {
            assert!(err.contains(n), "`{n}` not in: {err}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

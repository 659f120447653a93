//! Robot specs: TopA's two specs load, agree with the MJCF and with each other, and a broken spec gets one error
//! that names its line and the fix.

use std::path::{Path, PathBuf};

use topa_env::spec::{RobotSpec, SpecError};
use topa_env::ModelKind;

#[path = "reference/topa.rs"]
mod topa;

fn robots() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/robots")
}

#[test]
fn topa_specs_load_and_match_the_model() {
    for kind in [ModelKind::Closed, ModelKind::Open] {
        let (s, model) = RobotSpec::load(&robots().join(format!("{}.toml", kind.robot_name()))).unwrap();
        assert_eq!(s.name, kind.robot_name());
        assert_eq!(model.nu(), s.n_motors());
        assert_eq!(s.motors.iter().map(|m| m.actuator.clone()).collect::<Vec<_>>(), topa::actuator_names(kind));
        assert_eq!(s.motors.iter().map(|m| m.drives.clone()).collect::<Vec<_>>(), topa::actuated_joint_names(kind));
        assert_eq!(s.motors.iter().map(|m| m.joint.clone()).collect::<Vec<_>>(), topa::joint_names());
        assert_eq!(s.nominal_joints(), topa::nominal_joints().to_vec());
        let (perm, sign) = topa::mirror_legs_map();
        assert_eq!(s.mirror_map(), (perm.to_vec(), sign.to_vec()));
        assert_eq!(s.group("hip_roll"), &[topa::HIP_ROLL, topa::N_LEG + topa::HIP_ROLL]);
        assert_eq!(s.group("ankle_pitch"), &[topa::ANKLE, topa::N_LEG + topa::ANKLE]);
        assert_eq!(s.loops.len(), if kind == ModelKind::Closed { 2 } else { 0 });
        assert_eq!(s.feet[1].site, "r_foot_site");
    }
}

/// Writes a copy of the closed spec with one line replaced and loads it.
fn broken(tag: &str, from: &str, to: &str) -> String {
    let text = std::fs::read_to_string(robots().join("topa_closed.toml")).unwrap();
    assert!(text.contains(from), "fixture: {from}");
    let dir = std::env::temp_dir().join(format!("topa-spec-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("robot.toml");
    // The line the broken value is on (the first occurrence, the one replaced).
    let want = text[..text.find(from).unwrap()].matches('\n').count() + 1;
    let text = text.replacen(from, to, 1).replace("../mjcf/", &format!("{}/", robots().join("../mjcf").display()));
    std::fs::write(&path, &text).unwrap();
    let Err(err) = RobotSpec::load(&path) else { panic!("{tag}: the broken spec loaded") };
    std::fs::remove_dir_all(&dir).ok();
    match &err {
        SpecError::At { line, .. } => assert_eq!(*line, want, "{err}"),
        SpecError::Read { .. } => panic!("expected a located error, got {err}"),
    }
    err.to_string()
}

#[test]
fn broken_specs_name_the_line_and_the_fix() {
    let e = broken("act", "actuator = \"l_knee_motor\"", "actuator = \"l_knee_motr\"");
    assert!(e.contains("l_knee_motr") && e.contains("l_knee_motor"), "{e}");
    let e = broken("order", "actuator = \"l_hip_yaw\"", "actuator = \"l_hip_pitch\"");
    assert!(e.contains("actuator order"), "{e}");
    let e = broken("range", "motor_range = [-1.0, 3.0]", "motor_range = [-1.0, 2.0]");
    assert!(e.contains("ctrlrange"), "{e}");
    let e = broken("mirror", "mirror = \"r_hip_yaw\"", "mirror = \"r_hip_roll\"");
    assert!(e.contains("involution"), "{e}");
    let e = broken("sign", "mirror_sign = -1", "mirror_sign = 2");
    assert!(e.contains("1 or -1"), "{e}");
    let e = broken("key", "nominal = 0.7", "nominal = 0.6");
    assert!(e.contains("keyframe"), "{e}");
    let e = broken("typo", "torque_limit = 24.8", "torque_limt = 24.8");
    assert!(e.contains("torque_limt"), "{e}");
    let e = broken(
        "loop",
        "passive = [\"l_ankle_pitch\", \"l_ankle_rod\"]",
        "passive = [\"l_ankle_pitch\", \"l_knee_pitch\"]",
    );
    assert!(e.contains("driven by an actuator"), "{e}");
    // The ankle rod left out: the loop moves through it and nothing drives it.
    let e = broken("rodless", "passive = [\"l_ankle_pitch\", \"l_ankle_rod\"]", "passive = [\"l_ankle_pitch\"]");
    assert!(e.contains("loop 'l_knee_ankle'") && e.contains("l_ankle_rod") && e.contains("passive list"), "{e}");
    let e = broken("group", "hip_yaw = [\"l_hip_yaw\", \"r_hip_yaw\"]", "hip_yaw = [\"l_hip_yaw\", \"r_hip_yw\"]");
    assert!(e.contains("r_hip_yw"), "{e}");
}

#[test]
fn a_missing_spec_says_where_specs_live() {
    let Err(e) = RobotSpec::load(&robots().join("nope.toml")) else { panic!("loaded a missing spec") };
    let e = e.to_string();
    assert!(e.contains("nope.toml") && e.contains("assets/robots"), "{e}");
}

//! `topa robot stand` on a robot designed here (Kestrel, whose keyframe was solved by the linkage before): the
//! keyframe comes back closed where it was, the robot on the floor, and the feed-forward holds its pose.

use std::path::Path;

use topa_env::spec::RobotSpec;

#[test]
fn kestrels_stand_is_found_again_and_its_feedforward_holds_it() {
    let dir = std::env::temp_dir().join(format!("topa-robot-stand-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets");
    std::fs::copy(assets.join("mjcf/kestrel.xml"), dir.join("kestrel.xml")).unwrap();
    let spec = std::fs::read_to_string(assets.join("robots/kestrel.toml")).unwrap();
    std::fs::write(dir.join("kestrel.toml"), spec.replace("../mjcf/kestrel.xml", "kestrel.xml")).unwrap();
    let (_, before) = RobotSpec::load(&dir.join("kestrel.toml")).unwrap();
    let key_before = before.key_qpos(0).to_vec();

    let r = topa_robot::stand(&dir.join("kestrel.toml")).unwrap();
    assert!(r.closure_change < 1e-6, "the shipped keyframe already closes the loops: {r:?}");
    assert!(r.lowered.abs() < 2e-3, "and stands on the floor: {r:?}");
    assert!(r.sag_with < 0.2 * r.sag_without && r.sag_with < 0.01, "{r:?}");
    assert!(r.stands_alone, "flat feet stand on PD and feed-forward alone: {r:?}");

    let (spec, after) = RobotSpec::load(&dir.join("kestrel.toml")).unwrap();
    let moved = key_before.iter().zip(after.key_qpos(0)).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(moved < 2e-3, "keyframe moved by {moved}");
    let knee = spec.motors.iter().find(|m| m.actuator == "l_knee").unwrap();
    assert!(knee.feedforward.abs() > 1.0, "the knees carry the weight: {}", knee.feedforward);
    let _ = std::fs::remove_dir_all(&dir);
}

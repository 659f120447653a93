//! `topa robot import` on a published model nobody here wrote (Cassie, MuJoCo Menagerie, vendored unmodified
//! without its visual meshes), and the errors a model it cannot use gets. Each test imports into its own folder.

use std::path::{Path, PathBuf};

use mujoco::ObjType;
use topa_env::linkage::{JointMap, Linkage};
use topa_env::spec::RobotSpec;
use topa_robot::gains::GainRule;
use topa_robot::{import, ImportOptions};

fn cassie_xml() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/mjcf/cassie/cassie.xml")).unwrap()
}

/// A fresh folder holding `xml` as `model.xml`.
fn folder(test: &str, xml: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("topa-robot-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("model.xml"), xml).unwrap();
    dir
}

fn options(dir: &Path) -> ImportOptions {
    ImportOptions {
        model: dir.join("model.xml"),
        name: "robot".into(),
        robots_dir: dir.join("robots"),
        gains: GainRule::default(),
    }
}

fn error_of(xml: &str, test: &str) -> String {
    let dir = folder(test, xml);
    let e = import(&options(&dir)).expect_err("the import must refuse this model");
    let _ = std::fs::remove_dir_all(&dir);
    let mut s = e.to_string();
    let mut src = std::error::Error::source(&e);
    while let Some(c) = src {
        s += &format!(": {c}");
        src = c.source();
    }
    s
}

#[test]
fn cassie_imports_unmodified_and_loads_as_a_robot() {
    let dir = folder("cassie", &cassie_xml());
    let r = import(&options(&dir)).unwrap();
    assert!(r.to_choose.is_empty(), "nothing left to choose: {:?}", r.to_choose);
    assert!(r.dropped_assets.iter().any(|a| a == "pelvis.obj"), "the absent meshes are named: {:?}", r.dropped_assets);
    assert_eq!(
        std::fs::read_to_string(dir.join("model.xml")).unwrap(),
        cassie_xml(),
        "the published file is untouched"
    );

    let (spec, model) = RobotSpec::load(&r.spec).unwrap();
    assert_eq!(spec.n_motors(), 10);
    assert_eq!(spec.base_joint, "floating-base");
    assert_eq!((spec.feet[0].body.as_str(), spec.feet[1].body.as_str()), ("left-foot", "right-foot"));
    let m = |name: &str| spec.motors.iter().find(|m| m.actuator == name).unwrap();
    // The mirror from the names, its signs from the geometry: roll and yaw flip, pitch keeps its sign.
    assert_eq!(spec.motors[m("left-hip-roll").mirror].actuator, "right-hip-roll");
    assert_eq!((m("left-hip-roll").mirror_sign, m("left-hip-yaw").mirror_sign), (-1.0, -1.0));
    assert_eq!(
        (m("left-hip-pitch").mirror_sign, m("left-knee").mirror_sign, m("left-foot").mirror_sign),
        (1.0, 1.0, 1.0)
    );
    // The gear's torque at the joint: 25 × 4.5, 16 × 12.2, 50 × 0.9 N·m.
    assert!(
        (m("left-hip-roll").torque_limit - 112.5).abs() < 1e-9 && (m("left-foot").torque_limit - 45.0).abs() < 1e-9
    );
    assert_eq!(spec.group("hip_roll").len(), 2);
    assert_eq!(
        spec.group("ankle_pitch").iter().map(|&i| spec.motors[i].joint.as_str()).collect::<Vec<_>>(),
        ["left-foot", "right-foot"]
    );
    // Four loops; the achilles rods' ball joints passive, the shin and heel leaf springs springs.
    assert_eq!(spec.loops.len(), 4);
    let achilles = spec.loops.iter().find(|l| l.passive.contains(&"left-achilles-rod".to_string())).unwrap();
    assert_eq!(achilles.passive, ["left-achilles-rod", "left-tarsus"]);
    assert_eq!(achilles.springs, ["left-heel-spring", "left-shin"]);
    // The stand keyframe closes every loop (the strict constructor checks it) and stands on the floor.
    Linkage::new(&spec, &model).unwrap();
    assert!(matches!(JointMap::new(&spec, &model).unwrap(), JointMap::Linear { .. }), "motors drive their joints");
    let key = model.id(ObjType::Key, "stand").unwrap();
    assert!((model.key_qpos(key)[2] - spec.base_height_target).abs() < 1e-12);
    // The feed-forward holds the knees: on PD alone the stand sags by tenths of a radian, with it by millimetres.
    let stand = r.stand.expect("solved");
    assert!(stand.sag_without > 0.1 && stand.sag_with < 0.01, "{stand:?}");
    let knee = m("left-knee").feedforward;
    assert!(knee > 10.0 && knee == m("right-knee").feedforward, "{knee}");
    assert_eq!(m("left-hip-roll").feedforward, -m("right-hip-roll").feedforward);
    // The action's zero is the PD target that produces the feed-forward at the stand pose.
    let idx = topa_env::RobotIndices::resolve(&model, &std::sync::Arc::new(spec.clone())).unwrap();
    let k = spec.motors.iter().position(|m| m.actuator == "left-knee").unwrap();
    let kp = model.actuator_gainprm()[idx.actuators[k]][0];
    assert!((kp * (idx.action_zero[k] - idx.nominal_actuated[k]) - knee).abs() < 1e-9);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_model_without_a_floating_base_is_refused() {
    let xml = cassie_xml().replace("<freejoint/>", "");
    let xml = xml[..xml.find("<keyframe>").unwrap()].to_string() + "</mujoco>\n";
    let e = error_of(&xml, "fixed");
    assert!(e.contains("one floating base") && e.contains("<freejoint>"), "{e}");
}

#[test]
fn a_motor_on_a_tendon_is_refused_by_name() {
    let xml = cassie_xml().replace(
        "<motor name=\"left-hip-roll\"   joint=\"left-hip-roll\"",
        "<motor name=\"left-hip-roll\"   tendon=\"t\"",
    );
    let xml = xml.replace(
        "<actuator>",
        "<tendon><fixed name=\"t\"><joint joint=\"left-hip-roll\" coef=\"1\"/></fixed></tendon>\n  <actuator>",
    );
    let e = error_of(&xml, "tendon");
    assert!(e.contains("actuator 'left-hip-roll'") && e.contains("tendon"), "{e}");
}

#[test]
fn a_scene_that_includes_the_robot_is_refused() {
    let e = error_of("<mujoco><include file=\"cassie.xml\"/></mujoco>", "include");
    assert!(e.contains("<include file=\"cassie.xml\">") && e.contains("robot's own file"), "{e}");
}

/// The imported spec, edited: each edit is a load error naming the line's element and the fix.
#[test]
fn edits_that_break_the_mechanism_or_the_mirror_are_load_errors() {
    let dir = folder("edits", &cassie_xml());
    let r = import(&options(&dir)).unwrap();
    let text = std::fs::read_to_string(&r.spec).unwrap();
    let load_with = |edited: &str| {
        let p = dir.join("robots/edited.toml");
        std::fs::write(&p, edited).unwrap();
        match RobotSpec::load(&p) {
            Ok(_) => panic!("the edit must be refused: {edited}"),
            Err(e) => e.to_string(),
        }
    };
    // The achilles rod's ball joint left out of its loop: the loop cannot close, never a silent wrong J.
    let e =
        load_with(&text.replace("passive = [\"left-achilles-rod\", \"left-tarsus\"]", "passive = [\"left-tarsus\"]"));
    assert!(
        e.contains("left-achilles-rod-loop") && e.contains("left-achilles-rod") && e.contains("passive list"),
        "{e}"
    );
    // A spring left out is named too.
    let e = load_with(&text.replace("springs = [\"left-heel-spring\", \"left-shin\"]", "springs = [\"left-shin\"]"));
    assert!(e.contains("left-heel-spring") && e.contains("springs list"), "{e}");
    // A joint with no stiffness is no spring.
    let e = load_with(&text.replace(
        "springs = [\"left-heel-spring\", \"left-shin\"]",
        "springs = [\"left-heel-spring\", \"left-shin\", \"left-knee\"]",
    ));
    assert!(e.contains("spring 'left-knee' must be a joint with a stiffness"), "{e}");
    // A mirror sign against the geometry (hip yaw, at 0 in the stand pose, so only the geometry can tell): the
    // mirror reverses a yaw axis.
    let flipped = ["left", "right"].iter().fold(text.clone(), |t, side| {
        let from = format!("mirror = \"{side}-hip-yaw\"\nmirror_sign = -1");
        t.replacen(&from, &format!("mirror = \"{side}-hip-yaw\"\nmirror_sign = 1"), 1)
    });
    let e = load_with(&flipped);
    assert!(e.contains("disagrees with the geometry") && e.contains("hip-yaw") && e.contains("sign is -1"), "{e}");
    // A feed-forward that is not mirrored.
    let ff = text.lines().find(|l| l.starts_with("feedforward = ")).unwrap();
    let e = load_with(&text.replacen(ff, "feedforward = 99.0", 1));
    assert!(e.contains("is not the mirror of") && e.contains("topa robot stand"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

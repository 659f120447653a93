//! Loops found from a published model nobody here wrote: Agility Robotics' Cassie (MuJoCo Menagerie, vendored
//! unmodified in assets/mjcf/cassie/ without its visual meshes). Its four `<connect>` loops and their passive joints
//! — the achilles rod's ball joint and the shin and heel leaf springs among them — come out of the model alone.

use std::path::Path;

use mujoco::{JointType, Model, ObjType};
use topa_env::mechanism::loops;

/// Cassie's MJCF with its visual meshes and texture left out (their files are not vendored): collision geometry,
/// masses and inertias are the file's own.
fn cassie() -> Model {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/mjcf/cassie");
    let xml = std::fs::read_to_string(dir.join("cassie.xml")).unwrap();
    let kept: Vec<&str> = xml
        .lines()
        .filter(|l| !(l.contains("<mesh ") || l.contains("type=\"mesh\"") || l.contains("<texture ")))
        .collect();
    let xml =
        kept.join("\n").replace("<material name=\"cassie\"    texture=\"cassie\"/>", "<material name=\"cassie\"/>");
    Model::from_xml_string(&xml, &dir).unwrap()
}

fn names(m: &Model, joints: &[usize]) -> Vec<String> {
    let mut v: Vec<String> = joints.iter().map(|&j| m.name_of(ObjType::Joint, j).unwrap().to_string()).collect();
    v.sort();
    v
}

#[test]
fn cassies_loops_and_their_passive_joints_are_found_from_the_model() {
    let m = cassie();
    let found = loops(&m);
    assert_eq!(found.len(), 4, "four <connect> loops");
    for side in ["left", "right"] {
        let j = |n: &str| format!("{side}-{n}");
        let plantar =
            found.iter().find(|l| names(&m, &l.joints).contains(&j("plantar-rod"))).expect("the plantar rod's loop");
        // The foot motor drives the foot; the crank and the plantar rod follow it.
        assert_eq!(names(&m, &plantar.driven), vec![j("foot")]);
        assert_eq!(names(&m, &plantar.passive), vec![j("foot-crank"), j("plantar-rod")]);
        let achilles =
            found.iter().find(|l| names(&m, &l.joints).contains(&j("achilles-rod"))).expect("the achilles rod's loop");
        // The knee motor moves the shin and heel leaf springs, the tarsus and the achilles rod's ball.
        assert_eq!(names(&m, &achilles.driven), vec![j("knee")]);
        assert_eq!(names(&m, &achilles.passive), vec![j("achilles-rod"), j("tarsus")]);
        assert_eq!(names(&m, &achilles.springs), vec![j("heel-spring"), j("shin")]);
        assert!(plantar.springs.is_empty());
        let ball = m.id(ObjType::Joint, &j("achilles-rod")).unwrap();
        assert_eq!(m.jnt_type(ball), JointType::Ball);
        assert!(achilles.name.is_none() && plantar.name.is_none(), "Cassie's constraints are unnamed");
    }
}

#[test]
fn a_serial_model_has_no_loops_and_topas_are_its_specs() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/mjcf");
    let open = Model::from_xml_path(dir.join("topa_open.xml")).unwrap();
    assert!(loops(&open).is_empty());
    let closed = Model::from_xml_path(dir.join("topa_closed.xml")).unwrap();
    let found = loops(&closed);
    assert_eq!(found.len(), 2);
    for (l, side) in found.iter().zip(["l", "r"]) {
        assert_eq!(l.name.as_deref(), Some(format!("{side}_ankle_loop").as_str()));
        // As the spec's [[loops]] list them: the ankle pitch (the kinematic joint) and the rod.
        assert_eq!(names(&closed, &l.passive), vec![format!("{side}_ankle_pitch"), format!("{side}_ankle_rod")]);
    }
}

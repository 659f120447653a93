//! The whole-state mirror is derived from the model's geometry (anchors and axes at qpos0), not from names; the
//! names then serve as an independent check: on both robots every `l_*` joint pairs with its `r_*` twin, roll and
//! yaw joints (and the rods' roll joints) flip, pitch joints keep their sign, and the map is an involution.

use std::path::Path;
use std::sync::Arc;

use mujoco::{Model, ObjType};
use topa_env::symmetry::StateMirror;

fn model(rel: &str) -> Arc<Model> {
    Arc::new(Model::from_xml_path(Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)).unwrap())
}

fn check_pairs_by_name(rel: &str) -> usize {
    let m = model(rel);
    let mirror = StateMirror::new(&m).unwrap();
    let mut checked = 0;
    for j in 0..m.njnt() {
        let name = m.name_of(ObjType::Joint, j).unwrap_or("").to_string();
        let twin = match name.split_once('_') {
            Some(("l", rest)) => format!("r_{rest}"),
            Some(("r", rest)) => format!("l_{rest}"),
            _ => continue,
        };
        let k = m.id(ObjType::Joint, &twin).unwrap();
        // Probe: a state with only this joint's twin moved; the mirror moves only this joint.
        let mut qpos = m.qpos0().to_vec();
        let (qa, qk) = (m.jnt_qposadr_of(j), m.jnt_qposadr_of(k));
        qpos[qk] += 0.3;
        let qvel = vec![0.0; m.nv()];
        let (p, _) = mirror.apply(&qpos, &qvel);
        let flips = name.contains("roll") || name.contains("yaw");
        let want = if flips { -qpos[qk] } else { qpos[qk] };
        assert!((p[qa] - want).abs() < 1e-12, "{rel}: {name} ← {twin}: {} vs {want}", p[qa]);
        checked += 1;
    }
    // An involution on any state.
    let qpos: Vec<f64> = (0..m.nq()).map(|i| (i as f64 * 0.37).sin()).collect();
    let qvel: Vec<f64> = (0..m.nv()).map(|i| (i as f64 * 0.61).cos()).collect();
    let (p, v) = mirror.apply(&qpos, &qvel);
    let (p2, v2) = mirror.apply(&p, &v);
    assert_eq!((p2, v2), (qpos, qvel), "{rel}: mirroring twice is not the identity");
    checked
}

#[test]
fn geometry_derived_mirror_pairs_every_left_joint_with_its_right_twin() {
    // TopA closed: 5 motor-side joints + 2 passive linkage joints per leg; Kestrel: 6 + 6.
    assert_eq!(check_pairs_by_name("assets/mjcf/topa_closed.xml"), 14);
    assert_eq!(check_pairs_by_name("assets/mjcf/kestrel.xml"), 24);
    assert_eq!(check_pairs_by_name("assets/mjcf/topa_open.xml"), 10);
}

#[test]
fn an_asymmetric_model_is_refused_naming_the_joint() {
    // One arm on the left, none on the right.
    let xml = r#"<mujoco><worldbody><body name="torso"><freejoint/><geom size="0.1"/>
        <body name="arm" pos="0 0.2 0"><joint name="l_shoulder" axis="0 1 0"/><geom size="0.05"/></body>
        </body></worldbody></mujoco>"#;
    let m = Arc::new(Model::from_xml_string(xml, std::env::temp_dir()).unwrap());
    let err = StateMirror::new(&m).err().expect("a one-armed body is not left-right symmetric").to_string();
    assert!(err.contains("joint 'l_shoulder' has no mirror image"), "{err}");
}

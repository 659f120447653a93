//! The second robot, Kestrel (two-rod parallel ankle): its spec loads against its MJCF, the keyframe closes the
//! loops, the computed motor↔joint maps match finite differences of the constrained model to 1e-6, the map is
//! nonlinear (unlike TopA's M), and it is equivariant under the left↔right mirror the spec and MJCF define.

mod common;

use std::path::Path;

use mujoco::{Model, ObjType};
use rand::{RngExt, SeedableRng};
use topa_env::linkage::Linkage;
use topa_env::spec::RobotSpec;

fn kestrel() -> (RobotSpec, Model, Linkage) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/robots/kestrel.toml");
    let (spec, model) = match RobotSpec::load(&path) {
        Ok(x) => x,
        Err(e) => panic!("{e}"),
    };
    let l = Linkage::new(&spec, &model).unwrap();
    (spec, model, l)
}

/// Motor positions around the stand pose, inside the ankle's reach.
fn random_motors(l: &Linkage, rng: &mut rand_chacha::ChaCha8Rng, spread: f64) -> Vec<f64> {
    l.nominal_motors().iter().map(|q| q + rng.random_range(-spread..spread)).collect()
}

/// Under the XZ mirror a hinge about x or z flips its angle, one about y keeps it (the legs are mirror images).
fn joint_mirror_sign(model: &Model, name: &str) -> f64 {
    let j = model.id(ObjType::Joint, name).unwrap();
    if model.jnt_axis()[j][1].abs() > 0.5 {
        1.0
    } else {
        -1.0
    }
}

#[test]
fn spec_loads_and_the_keyframe_closes_the_loops() {
    let (spec, model, mut l) = kestrel();
    assert_eq!((spec.n_motors(), spec.loops.len(), model.nu()), (12, 2, 12));
    let solved = l.motors(&spec.nominal_joints()).unwrap();
    for (a, b) in solved.iter().zip(l.nominal_motors()) {
        assert!((a - b).abs() < 1e-9, "keyframe motor {b} vs solved {a}");
    }
    let key = model.id(ObjType::Key, "stand").unwrap();
    let qpos = l.closed_qpos(&solved).unwrap();
    for (a, b) in qpos.iter().zip(model.key_qpos(key)) {
        assert!((a - b).abs() < 1e-9, "keyframe qpos {b} vs the closed loops' {a}");
    }
}

#[test]
fn maps_match_finite_differences_and_are_nonlinear() {
    let (_, _, mut l) = kestrel();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let mut jacobians = Vec::new();
    for _ in 0..5 {
        let q = random_motors(&l, &mut rng, 0.3);
        let j = common::jacobian_checked_by_finite_differences(&mut l, &q);
        // The ankle's roll depends on both motors (a parallel linkage, not one motor per joint).
        assert!(j[(5, 4)].abs() > 0.1 && j[(5, 5)].abs() > 0.1, "{}", j.view((4, 4), (2, 2)));
        let joints = l.joints(&q).unwrap();
        let back = l.motors(&joints).unwrap();
        for (a, b) in back.iter().zip(&q) {
            assert!((a - b).abs() < 1e-9, "inverse map: {a} vs {b}");
        }
        jacobians.push(j);
    }
    let spread = (jacobians[0].clone() - &jacobians[1]).abs().max();
    assert!(spread > 1e-3, "the ankle map is nonlinear: its Jacobian moves with the configuration ({spread})");
}

#[test]
fn the_linkage_map_is_mirror_equivariant() {
    let (spec, model, mut l) = kestrel();
    let (perm, sign) = spec.mirror_map();
    let joint_sign: Vec<f64> = spec.motors.iter().map(|m| joint_mirror_sign(&model, &m.joint)).collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    for _ in 0..5 {
        let q = random_motors(&l, &mut rng, 0.3);
        let mirrored: Vec<f64> = (0..q.len()).map(|i| sign[i] as f64 * q[perm[i]]).collect();
        let (a, b) = (l.joints(&q).unwrap(), l.joints(&mirrored).unwrap());
        for i in 0..q.len() {
            let want = joint_sign[perm[i]] * a[perm[i]];
            assert!((b[i] - want).abs() < 1e-9, "joint {}: {} vs mirrored {want}", spec.motors[i].joint, b[i]);
        }
    }
}

#[test]
fn a_keyframe_that_does_not_close_the_loops_is_refused_with_the_fix() {
    let dir = std::env::temp_dir().join(format!("topa-kestrel-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("robots")).unwrap();
    std::fs::create_dir_all(dir.join("mjcf")).unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets");
    let xml = std::fs::read_to_string(root.join("mjcf/kestrel.xml")).unwrap();
    // Both legs' outboard rods tilted: a keyframe that leaves the loops open.
    let bad = xml.replace("-0.35 0.35 0 -0.35 0.35 0", "-0.35 0.30 0 -0.35 0.35 0");
    assert_ne!(bad, xml);
    std::fs::write(dir.join("mjcf/kestrel.xml"), bad).unwrap();
    std::fs::copy(root.join("robots/kestrel.toml"), dir.join("robots/kestrel.toml")).unwrap();
    let (spec, model) = match RobotSpec::load(&dir.join("robots/kestrel.toml")) {
        Ok(x) => x,
        Err(e) => panic!("{e}"),
    };
    let Err(e) = Linkage::new(&spec, &model) else { panic!("an open keyframe was accepted") };
    let e = e.to_string();
    assert!(e.contains("does not close the loops") && e.contains("topa robot stand"), "{e}");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn kestrel_simulates_with_its_loops_closed() {
    let (_, model, _) = kestrel();
    let eqs: Vec<usize> = (0..4).collect();
    let mut d = mujoco::Data::new(std::sync::Arc::new(model)).unwrap();
    d.reset_keyframe(0).unwrap();
    let mut worst = 0.0f64;
    // 2 s holding the stand pose under PD, then 1 s with the ankle motors swinging against each other (roll
    // within its range: ±0.15 rad of crank difference is ≈ ±0.2 rad of roll).
    for step in 0..600 {
        if step >= 400 {
            let t = step as f64 * 0.005;
            for a in [4, 10] {
                d.ctrl_mut()[a] = -0.35 + 0.075 * (8.0 * t).sin();
            }
            for a in [5, 11] {
                d.ctrl_mut()[a] = -0.35 - 0.075 * (8.0 * t).sin();
            }
        }
        d.step().unwrap();
        assert!(!d.is_unstable(), "step {step}");
        for &e in &eqs {
            worst = worst.max(d.equality_residual(e));
        }
        if step == 399 || step == 599 {
            eprintln!("step {step}: worst loop residual {worst:.2e} m, base height {:.3} m", d.qpos()[2]);
        }
    }
    assert!(worst < 1e-4, "loop residual {worst} m");
}

#[test]
fn kestrels_map_is_solved_not_linearised() {
    let (spec, model, _) = kestrel();
    let map = topa_env::linkage::JointMap::new(&spec, &model).unwrap();
    assert!(map.matrix(12).is_none(), "the two-rod ankle is nonlinear: no constant matrix");
}

//! Motor↔joint maps computed from the constraints: on TopA's closed chain they reproduce the paper's
//! M = [[1, 0], [−1, 1]] to 1e-6, the Jacobian matches finite differences of the closed loop, the inverse map
//! round-trips, torques follow virtual work; on the open model the maps are the identity.

mod common;

use std::path::Path;

use rand::{RngExt, SeedableRng};
use topa::N_MOTORS;
use topa_env::linkage::Linkage;
use topa_env::spec::RobotSpec;
use topa_env::ModelKind;

#[path = "reference/topa.rs"]
mod topa;

fn linkage(kind: ModelKind) -> (RobotSpec, Linkage) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../assets/robots/{}.toml", kind.robot_name()));
    let Ok((spec, model)) = RobotSpec::load(&path) else { panic!("{} does not load", path.display()) };
    let l = Linkage::new(&spec, &model).unwrap();
    (spec, l)
}

/// Random motor positions with the ankle joint (ankle motor − knee) inside its range.
fn random_motors(rng: &mut rand_chacha::ChaCha8Rng) -> Vec<f64> {
    let nominal = topa::nominal_motors();
    (0..N_MOTORS)
        .map(|i| {
            let spread = if i % topa::N_LEG == topa::ANKLE { 0.3 } else { 0.4 };
            nominal[i] + rng.random_range(-spread..spread)
        })
        .collect()
}

#[test]
fn closed_chain_maps_reproduce_the_papers_m() {
    let (_, mut l) = linkage(ModelKind::Closed);
    assert_eq!(l.nominal_motors(), topa::nominal_motors().as_slice());
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    for _ in 0..20 {
        let q: Vec<f64> = random_motors(&mut rng);
        let arr: [f64; N_MOTORS] = q.clone().try_into().unwrap();
        let want = topa::motor_to_joint(&arr);
        let got = l.joints(&q).unwrap();
        for i in 0..N_MOTORS {
            assert!((got[i] - want[i]).abs() < 1e-6, "joint {i}: {} vs M·q {}", got[i], want[i]);
        }
        let j = l.jacobian(&q).unwrap();
        for i in 0..N_MOTORS {
            let e: [f64; N_MOTORS] = std::array::from_fn(|k| if k == i { 1.0 } else { 0.0 });
            let col = topa::motor_to_joint(&e);
            for r in 0..N_MOTORS {
                assert!((j[(r, i)] - col[r]).abs() < 1e-6, "J[{r},{i}] = {} vs M {}", j[(r, i)], col[r]);
            }
        }
        // Torques: τ_m = Jᵀ τ_j, the paper's Mᵀ.
        let tau_j: Vec<f64> = (0..N_MOTORS).map(|_| rng.random_range(-20.0..20.0)).collect();
        let tau_m = l.motor_torques(&q, &tau_j).unwrap();
        let want = topa::joint_to_motor_torque(&<[f64; N_MOTORS]>::try_from(tau_j.clone()).unwrap());
        for i in 0..N_MOTORS {
            assert!((tau_m[i] - want[i]).abs() < 1e-5, "τ_m[{i}] {} vs Mᵀτ {}", tau_m[i], want[i]);
        }
        // The inverse map round-trips.
        let back = l.motors(&got).unwrap();
        for i in 0..N_MOTORS {
            assert!((back[i] - q[i]).abs() < 1e-9, "motor {i}: {} vs {}", back[i], q[i]);
        }
    }
}

#[test]
fn jacobian_matches_finite_differences_of_the_closed_loop() {
    let (_, mut l) = linkage(ModelKind::Closed);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
    for _ in 0..5 {
        let q = random_motors(&mut rng);
        common::jacobian_checked_by_finite_differences(&mut l, &q);
    }
}

#[test]
fn open_model_maps_are_the_identity() {
    let (spec, mut l) = linkage(ModelKind::Open);
    assert!(spec.loops.is_empty());
    let q: Vec<f64> = topa::nominal_joints().iter().map(|x| x + 0.1).collect();
    assert_eq!(l.joints(&q).unwrap(), q);
    assert_eq!(l.jacobian(&q).unwrap(), nalgebra::DMatrix::identity(N_MOTORS, N_MOTORS));
}

#[test]
fn topas_linear_map_is_detected_and_exactly_m() {
    use topa_env::linkage::JointMap;
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/robots/topa_closed.toml");
    let Ok((spec, model)) = RobotSpec::load(&path) else { panic!() };
    let mut map = JointMap::new(&spec, &model).unwrap();
    let j = map.matrix(N_MOTORS).expect("TopA's linkage is linear");
    for i in 0..N_MOTORS {
        let e: [f64; N_MOTORS] = std::array::from_fn(|k| if k == i { 1.0 } else { 0.0 });
        let col = topa::motor_to_joint(&e);
        for r in 0..N_MOTORS {
            assert_eq!(j[(r, i)], col[r], "J[{r},{i}]");
        }
    }
    // Bit for bit what M gives, positions and velocities.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    let mut out = vec![0.0; N_MOTORS];
    for _ in 0..50 {
        let q = random_motors(&mut rng);
        map.positions(&q, &mut out).unwrap();
        assert_eq!(out, topa::motor_to_joint(&<[f64; N_MOTORS]>::try_from(q.clone()).unwrap()).to_vec());
        map.velocities(&q, &q, &mut out).unwrap();
        assert_eq!(out, topa::motor_to_joint(&<[f64; N_MOTORS]>::try_from(q.clone()).unwrap()).to_vec());
    }
}

/// Far from the stand pose a Newton step can land on the linkage's other assembly branch (the parallelogram folded
/// over), which closes the loop just as well; over the whole knee range and ankle-joint range the solved joints
/// must stay the robot's, i.e. equal M·q.
#[test]
fn the_solver_stays_on_the_robots_branch_across_the_ranges() {
    let (spec, mut l) = linkage(ModelKind::Closed);
    let (knee, ankle) = (&spec.motors[topa::KNEE], &spec.motors[topa::ANKLE]);
    let mut q = topa::nominal_motors().to_vec();
    for a in 0..=10 {
        for b in 0..=10 {
            let lerp = |r: [f64; 2], t: f64| r[0] + (r[1] - r[0]) * (0.02 + 0.96 * t);
            let k = lerp(knee.motor_range, a as f64 / 10.0);
            let aj = lerp(ankle.joint_range, b as f64 / 10.0);
            q[topa::KNEE] = k;
            q[topa::ANKLE] = k + aj;
            let got = l.joints(&q).unwrap();
            assert!(
                (got[topa::ANKLE] - aj).abs() < 1e-6,
                "knee {k:.3}, ankle motor {:.3}: ankle joint {:.4} instead of {aj:.4}",
                q[topa::ANKLE],
                got[topa::ANKLE]
            );
        }
    }
}

/// TopA's closed MJCF as text, with each ankle rod's included file inlined through `rod` (its joint line in, the
/// line to use out), and the stand keyframe's rod angles replaced by `key_rod` (the angle in, its qpos values out).
fn closed_mjcf_with_rods(
    rod: impl Fn(&str) -> String,
    key_rod: impl Fn(f64) -> String,
) -> (String, std::path::PathBuf) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/mjcf");
    let mut xml = std::fs::read_to_string(dir.join("topa_closed.xml")).unwrap();
    for side in ["l", "r"] {
        let inc = format!("<include file=\"closed/{side}_ankle_rod.xml\"/>");
        let body = std::fs::read_to_string(dir.join(format!("closed/{side}_ankle_rod.xml"))).unwrap();
        let joint = format!("<joint name=\"{side}_ankle_rod\" class=\"ankle_rod\"/>");
        assert!(xml.contains(&inc) && body.contains(&joint), "the fixture no longer matches TopA's MJCF");
        let inner = body.replace("<mujoco>", "").replace("</mujoco>", "").replace(&joint, &rod(side));
        xml = xml.replace(&inc, &inner);
    }
    // The keyframe lists each leg as hip roll, yaw, pitch, knee, ankle pitch, ankle crank, ankle rod.
    let (start, end) = (xml.find("qpos=\"").unwrap() + 6, xml.find("\"\n         ctrl=").unwrap());
    let vals: Vec<f64> = xml[start..end].split_whitespace().map(|v| v.parse().unwrap()).collect();
    assert_eq!(vals.len(), 7 + 2 * 7);
    let mut out: Vec<String> = vals[..7].iter().map(|v| v.to_string()).collect();
    for leg in vals[7..].chunks(7) {
        out.extend(leg[..6].iter().map(|v| v.to_string()));
        out.push(key_rod(leg[6]));
    }
    xml.replace_range(start..end, &out.join(" "));
    (xml, dir)
}

/// Cassie's achilles rods are ball-jointed: TopA's ankle rods made ball joints (the keyframe's rod angles the same
/// rotations as quaternions) must give the same map, the paper's M, and a Jacobian that matches the closed loop.
#[test]
fn a_ball_joint_in_a_loop_gives_the_same_map() {
    let (spec, _) = linkage(ModelKind::Closed);
    let (xml, dir) = closed_mjcf_with_rods(
        |side| format!("<joint name=\"{side}_ankle_rod\" type=\"ball\" damping=\"0\" armature=\"0\"/>"),
        |a| format!("{} 0 {} 0", (a / 2.0).cos(), (a / 2.0).sin()),
    );
    let model = mujoco::Model::from_xml_string(&xml, &dir).unwrap();
    let rod = model.id(mujoco::ObjType::Joint, "l_ankle_rod").unwrap();
    assert_eq!(model.jnt_type(rod), mujoco::JointType::Ball);
    let mut l = Linkage::new(&spec, &model).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    for _ in 0..10 {
        let q = random_motors(&mut rng);
        let want = topa::motor_to_joint(&<[f64; N_MOTORS]>::try_from(q.clone()).unwrap());
        let got = l.joints(&q).unwrap();
        for i in 0..N_MOTORS {
            assert!((got[i] - want[i]).abs() < 1e-6, "joint {i}: {} vs M·q {}", got[i], want[i]);
        }
        common::jacobian_checked_by_finite_differences(&mut l, &q);
    }
    let map = topa_env::linkage::JointMap::from_linkage(l).unwrap();
    assert!(map.matrix(N_MOTORS).is_some(), "the ball-jointed parallelogram is still linear");
}

/// A passive set that leaves out a joint its loop moves through cannot close the loop as the motors move: the
/// least-squares J it would give has the wrong sign (Cassie with its achilles ball joint left out gave +0.99 where
/// the loop gives −0.99). It must be an error naming the loop and the missing joint.
#[test]
fn a_passive_set_missing_a_joint_is_an_error_naming_it() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/robots/topa_closed.toml");
    let (mut spec, model) = RobotSpec::load(&path).unwrap();
    for l in &mut spec.loops {
        l.passive.retain(|p| !p.ends_with("ankle_rod"));
    }
    let err = match Linkage::new(&spec, &model).and_then(topa_env::linkage::JointMap::from_linkage) {
        Ok(_) => panic!("a loop without its rod joint was accepted"),
        Err(e) => e.to_string(),
    };
    for want in ["loop 'l_knee_ankle'", "l_ankle_rod", "loop 'r_knee_ankle'", "r_ankle_rod", "passive list"] {
        assert!(err.contains(want), "{want} missing from: {err}");
    }
    assert!(!err.contains("l_ankle_pitch,") && !err.contains("knee,"), "names only the missing joints: {err}");
}

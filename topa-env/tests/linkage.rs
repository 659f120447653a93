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

//! TopA's reference numbers (tests/reference/topa.rs) checked against the paper: the knee–ankle map and its
//! inverse, the torque map's power balance, the mirror, the nominal pose, and the mirror maps of the observation.

#[path = "reference/topa.rs"]
mod topa;

use topa::*;
use topa_env::ModelKind;

#[test]
fn maps_are_inverse_and_match_the_paper() {
    let q: [f64; N_MOTORS] = std::array::from_fn(|i| 0.1 * i as f64 - 0.3);
    let back = joint_to_motor(&motor_to_joint(&q));
    for (a, b) in q.iter().zip(back) {
        assert!((a - b).abs() < 1e-15);
    }
    let j = motor_to_joint(&q);
    assert_eq!(j[KNEE], q[KNEE]);
    assert!((j[ANKLE] - (q[ANKLE] - q[KNEE])).abs() < 1e-15);
    assert!((j[N_LEG + ANKLE] - (q[N_LEG + ANKLE] - q[N_LEG + KNEE])).abs() < 1e-15);
    // Hips are untouched.
    assert_eq!(&j[..KNEE], &q[..KNEE]);
}

#[test]
fn torque_map_preserves_power() {
    let qd_m: [f64; N_MOTORS] = std::array::from_fn(|i| (i as f64 * 0.7).sin());
    let tau_j: [f64; N_MOTORS] = std::array::from_fn(|i| (i as f64 * 1.3).cos() * 5.0);
    let qd_j = motor_to_joint(&qd_m);
    let tau_m = joint_to_motor_torque(&tau_j);
    let p_joint: f64 = tau_j.iter().zip(&qd_j).map(|(a, b)| a * b).sum();
    let p_motor: f64 = tau_m.iter().zip(&qd_m).map(|(a, b)| a * b).sum();
    assert!((p_joint - p_motor).abs() < 1e-12);
    let round = motor_to_joint_torque(&tau_m);
    for (a, b) in round.iter().zip(&tau_j) {
        assert!((a - b).abs() < 1e-12);
    }
}

#[test]
fn mirror_is_an_involution_and_commutes_with_m() {
    let q: [f64; N_MOTORS] = std::array::from_fn(|i| i as f64 + 1.0);
    assert_eq!(mirror_legs(&mirror_legs(&q)), q);
    let m = mirror_legs(&q);
    assert_eq!(m[HIP_ROLL], -q[N_LEG + HIP_ROLL]);
    assert_eq!(m[N_LEG + HIP_YAW], -q[HIP_YAW]);
    assert_eq!(m[KNEE], q[N_LEG + KNEE]);
    assert_eq!(mirror_legs(&motor_to_joint(&q)), motor_to_joint(&mirror_legs(&q)));
    let (perm, sign) = mirror_legs_map();
    let via_map: [f64; N_MOTORS] = std::array::from_fn(|i| sign[i] as f64 * q[perm[i]]);
    assert_eq!(via_map, m);
}

#[test]
fn nominal_pose_is_symmetric_and_inside_the_limits() {
    for kind in [ModelKind::Closed, ModelKind::Open] {
        let nom = nominal_actuated(kind);
        assert_eq!(mirror_legs(&nom), nom);
        for (q, [lo, hi]) in nom.iter().zip(actuated_range(kind)) {
            assert!(*q >= lo && *q <= hi);
        }
    }
    assert_eq!(actuator_names(ModelKind::Closed)[3], "l_knee_motor");
    assert_eq!(actuated_joint_names(ModelKind::Closed)[9], "r_ankle_motor");
    assert_eq!(actuated_joint_names(ModelKind::Open)[9], "r_ankle_pitch");
}

#[test]
fn topa_maps_are_involutions_with_the_right_signs() {
    let s = symmetry();
    assert!(s.obs.is_involution() && s.act.is_involution());
    assert_eq!(s.obs.len(), 42);
    let x: Vec<f32> = (0..42).map(|i| i as f32 + 1.0).collect();
    let mut m = vec![0.0; 42];
    s.obs.apply(&x, &mut m);
    let mut mm = vec![0.0; 42];
    s.obs.apply(&m, &mut mm);
    assert_eq!(mm, x);
    assert_eq!(&m[0..3], &[1.0, -2.0, 3.0]); // v: y flips
    assert_eq!(&m[3..6], &[-4.0, 5.0, -6.0]); // ω: roll and yaw rates flip
    assert_eq!(&m[6..9], &[7.0, -8.0, 9.0]); // g: y flips
    assert_eq!(m[9], -x[14]); // left hip roll ← −right hip roll
    assert_eq!(m[12], x[17]); // left knee ← right knee
    assert_eq!(&m[39..42], &[40.0, -41.0, -42.0]); // command: v_y and w_z flip
}

//! TopA as the paper states it: motor and joint names per leg, nominal pose, limits, the knee–ankle map
//! `joint = M · motor` with M = [[1, 0], [-1, 1]] (paper, Hardware platform), and the left↔right mirror.
//! Nothing in the env reads these (it reads the robot's spec, assets/robots/*.toml, and computes the maps from
//! the MJCF): they are the independent reference the tests check the spec, the computed maps, the observation
//! layout and the mirror maps against. Test crates include this file (`#[path = …] mod topa;`); it is not part
//! of the library.
//!
//! Vectors of 10 follow the actuator order of the MJCF: left leg (hip roll, hip yaw, hip pitch, knee, ankle),
//! then right leg. "Motor space" is what the motors see (closed model); "joint space" is the kinematic joints
//! (the open model's actuated joints). The two differ only in the ankle entry: ankle_joint = ankle_motor − knee.

#![allow(dead_code)] // each test crate that includes this file uses its own part of it

use topa_env::observation::{Block, ObsLayout};
use topa_env::symmetry::Symmetry;
use topa_env::ModelKind;

pub const N_LEG: usize = 5;
pub const N_MOTORS: usize = 2 * N_LEG;
pub const SIDES: [&str; 2] = ["l", "r"];
/// Index of each degree of freedom within a leg.
pub const HIP_ROLL: usize = 0;
pub const HIP_YAW: usize = 1;
pub const HIP_PITCH: usize = 2;
pub const KNEE: usize = 3;
pub const ANKLE: usize = 4;
/// The paper's leg degrees of freedom, in actuator order.
pub const LEG_DOF_NAMES: [&str; N_LEG] = ["hip_roll", "hip_yaw", "hip_pitch", "knee_pitch", "ankle_pitch"];
/// Mirror in the XZ plane: roll and yaw angles change sign, pitch-type angles keep it.
pub const LEG_MIRROR_SIGN: [f64; N_LEG] = [-1.0, -1.0, 1.0, 1.0, 1.0];

/// One motor of a leg: its actuator, the joint it drives in each model, its limits.
#[derive(Debug, Clone, Copy)]
pub struct MotorSpec {
    /// Actuator name suffix in the closed model (prefixed by `l_`/`r_`).
    pub actuator_closed: &'static str,
    /// Actuator name suffix in the open model.
    pub actuator_open: &'static str,
    /// Joint the motor drives directly in the closed model.
    pub motor_joint: &'static str,
    /// The kinematic joint of this degree of freedom (both models).
    pub joint: &'static str,
    /// Position range of the motor (closed model control range), rad.
    pub motor_range: [f64; 2],
    /// Position range of the kinematic joint, rad.
    pub joint_range: [f64; 2],
    /// Peak torque of the motor class, N·m.
    pub torque_limit: f64,
}

/// The TopA leg, per degree of freedom (numbers from assets/mjcf/common/defaults.xml, where each is justified).
pub const LEG: [MotorSpec; N_LEG] = [
    MotorSpec {
        actuator_closed: "hip_roll",
        actuator_open: "hip_roll",
        motor_joint: "hip_roll",
        joint: "hip_roll",
        motor_range: [-0.5, 0.5],
        joint_range: [-0.5, 0.5],
        torque_limit: 24.8,
    },
    MotorSpec {
        actuator_closed: "hip_yaw",
        actuator_open: "hip_yaw",
        motor_joint: "hip_yaw",
        joint: "hip_yaw",
        motor_range: [-0.6, 0.6],
        joint_range: [-0.6, 0.6],
        torque_limit: 24.8,
    },
    MotorSpec {
        actuator_closed: "hip_pitch",
        actuator_open: "hip_pitch",
        motor_joint: "hip_pitch",
        joint: "hip_pitch",
        motor_range: [-1.6, 1.0],
        joint_range: [-1.6, 1.0],
        torque_limit: 75.0,
    },
    MotorSpec {
        actuator_closed: "knee_motor",
        actuator_open: "knee_pitch",
        motor_joint: "knee_pitch",
        joint: "knee_pitch",
        motor_range: [0.0, 2.2],
        joint_range: [0.0, 2.2],
        torque_limit: 75.0,
    },
    MotorSpec {
        actuator_closed: "ankle_motor",
        actuator_open: "ankle_pitch",
        motor_joint: "ankle_motor",
        joint: "ankle_pitch",
        motor_range: [-1.0, 3.0],
        joint_range: [-1.0, 0.8],
        torque_limit: 36.0,
    },
];

/// Nominal standing pose in joint space for one leg (hip pitch −θ, knee 2θ, ankle −θ with θ = 0.35 rad keeps the
/// feet flat under the hips).
pub const NOMINAL_LEG_JOINTS: [f64; N_LEG] = [0.0, 0.0, -0.35, 0.70, -0.35];

/// Name of the keyframe holding the nominal pose in both MJCF files.
pub const STAND_KEY: &str = "stand";

pub fn side_name(leg: usize, suffix: &str) -> String {
    format!("{}_{suffix}", SIDES[leg])
}

/// Names of the 10 actuators of a model, in order.
pub fn actuator_names(kind: ModelKind) -> Vec<String> {
    names(|m| match kind {
        ModelKind::Closed => m.actuator_closed,
        ModelKind::Open => m.actuator_open,
    })
}

/// Names of the 10 joints the actuators drive (motor joints on the closed model, kinematic joints on the open).
pub fn actuated_joint_names(kind: ModelKind) -> Vec<String> {
    names(|m| match kind {
        ModelKind::Closed => m.motor_joint,
        ModelKind::Open => m.joint,
    })
}

/// Names of the 10 kinematic joints (same in both models).
pub fn joint_names() -> Vec<String> {
    names(|m| m.joint)
}

fn names(f: impl Fn(&MotorSpec) -> &'static str) -> Vec<String> {
    (0..2).flat_map(|leg| LEG.iter().map(move |m| (leg, m))).map(|(leg, m)| side_name(leg, f(m))).collect()
}

/// Per-motor values of a leg table, for both legs.
pub fn per_motor<T: Copy>(f: impl Fn(&MotorSpec) -> T) -> [T; N_MOTORS] {
    std::array::from_fn(|i| f(&LEG[i % N_LEG]))
}

/// Nominal pose in joint space (10).
pub fn nominal_joints() -> [f64; N_MOTORS] {
    std::array::from_fn(|i| NOMINAL_LEG_JOINTS[i % N_LEG])
}

/// Nominal pose in motor space (10).
pub fn nominal_motors() -> [f64; N_MOTORS] {
    joint_to_motor(&nominal_joints())
}

/// Nominal pose in the actuated space of a model.
pub fn nominal_actuated(kind: ModelKind) -> [f64; N_MOTORS] {
    match kind {
        ModelKind::Closed => nominal_motors(),
        ModelKind::Open => nominal_joints(),
    }
}

/// Control range in the actuated space of a model.
pub fn actuated_range(kind: ModelKind) -> [[f64; 2]; N_MOTORS] {
    per_motor(|m| match kind {
        ModelKind::Closed => m.motor_range,
        ModelKind::Open => m.joint_range,
    })
}

/// The paper's M = [[1, 0], [-1, 1]] on (knee, ankle): joint = M · motor.
pub const M: [[f64; 2]; 2] = [[1.0, 0.0], [-1.0, 1.0]];
/// M⁻¹ = [[1, 0], [1, 1]]: motor = M⁻¹ · joint.
pub const M_INV: [[f64; 2]; 2] = [[1.0, 0.0], [1.0, 1.0]];

fn apply_knee_ankle<T>(v: &[T; N_MOTORS], a: [[f64; 2]; 2]) -> [T; N_MOTORS]
where
    T: Copy + Into<f64> + FromF64,
{
    let mut out = *v;
    for leg in 0..2 {
        let (k, an) = (leg * N_LEG + KNEE, leg * N_LEG + ANKLE);
        let (x, y) = (v[k].into(), v[an].into());
        out[k] = T::from_f64(a[0][0] * x + a[0][1] * y);
        out[an] = T::from_f64(a[1][0] * x + a[1][1] * y);
    }
    out
}

fn transpose(a: [[f64; 2]; 2]) -> [[f64; 2]; 2] {
    [[a[0][0], a[1][0]], [a[0][1], a[1][1]]]
}

/// Lossless conversion back from f64 for the numeric types we map (f32 rounds once, at the end).
pub trait FromF64 {
    fn from_f64(x: f64) -> Self;
}
impl FromF64 for f64 {
    fn from_f64(x: f64) -> Self {
        x
    }
}
impl FromF64 for f32 {
    fn from_f64(x: f64) -> Self {
        x as f32
    }
}

/// Motor positions (or velocities) → joint positions (velocities): q_j = M q_m.
pub fn motor_to_joint<T: Copy + Into<f64> + FromF64>(q_motor: &[T; N_MOTORS]) -> [T; N_MOTORS] {
    apply_knee_ankle(q_motor, M)
}

/// Joint positions (or velocities) → motor positions (velocities): q_m = M⁻¹ q_j.
pub fn joint_to_motor<T: Copy + Into<f64> + FromF64>(q_joint: &[T; N_MOTORS]) -> [T; N_MOTORS] {
    apply_knee_ankle(q_joint, M_INV)
}

/// Joint torques → motor torques: τ_m = Mᵀ τ_j (virtual work: τ_mᵀ q̇_m = τ_jᵀ q̇_j with q̇_j = M q̇_m).
pub fn joint_to_motor_torque<T: Copy + Into<f64> + FromF64>(tau_joint: &[T; N_MOTORS]) -> [T; N_MOTORS] {
    apply_knee_ankle(tau_joint, transpose(M))
}

/// Motor torques → joint torques: τ_j = M⁻ᵀ τ_m.
pub fn motor_to_joint_torque<T: Copy + Into<f64> + FromF64>(tau_motor: &[T; N_MOTORS]) -> [T; N_MOTORS] {
    apply_knee_ankle(tau_motor, transpose(M_INV))
}

/// Left↔right mirror of a motor- or joint-space vector (10): swap the legs, flip roll and yaw.
/// M is the same on both legs and maps pitch-type angles to pitch-type angles, so the mirror commutes with it.
pub fn mirror_legs<T: Copy + std::ops::Neg<Output = T>>(v: &[T; N_MOTORS]) -> [T; N_MOTORS] {
    std::array::from_fn(|i| {
        let src = (i + N_LEG) % N_MOTORS;
        if LEG_MIRROR_SIGN[i % N_LEG] < 0.0 {
            -v[src]
        } else {
            v[src]
        }
    })
}

/// The mirror as a signed permutation of the 10 entries: `out[i] = sign[i] * in[perm[i]]`.
pub fn mirror_legs_map() -> ([usize; N_MOTORS], [f32; N_MOTORS]) {
    (std::array::from_fn(|i| (i + N_LEG) % N_MOTORS), std::array::from_fn(|i| LEG_MIRROR_SIGN[i % N_LEG] as f32))
}

/// TopA's observation layout (10 motors): 42 values, and where each block starts.
pub const OBS: ObsLayout = ObsLayout::new(N_MOTORS);
pub const OBS_DIM: usize = OBS.dim();
pub const OBS_LIN_VEL: usize = OBS.offset(Block::LinVel);
pub const OBS_ANG_VEL: usize = OBS.offset(Block::AngVel);
pub const OBS_GRAVITY: usize = OBS.offset(Block::Gravity);
pub const OBS_Q: usize = OBS.offset(Block::MotorPos);
pub const OBS_QD: usize = OBS.offset(Block::MotorVel);
pub const OBS_LAST_ACTION: usize = OBS.offset(Block::LastAction);
pub const OBS_COMMAND: usize = OBS.offset(Block::Command);

/// S_o and S_a for TopA's observation `[v, ω, g, q, q̇, a_prev, c]` (3+3+3+10+10+10+3) and action (10), from the
/// paper's left↔right mirror (the env derives the same maps from the robot's spec and MJCF).
pub fn symmetry() -> Symmetry {
    let (leg_perm, leg_sign) = mirror_legs_map();
    topa_env::symmetry::for_layout(&OBS, &leg_perm, &leg_sign)
}

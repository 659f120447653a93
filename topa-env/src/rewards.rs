//! The paper's 14 reward terms (Table "Rewards") and one of ours (feet clearance, weight 0 in the paper's
//! table), computed from a plain snapshot of the state so that each term can be checked on hand-made states.

use crate::config::{AirTimeForm, ClearanceForm, RewardConfig};

pub const N_TERMS: usize = 15;

/// One reward term: its name (log and CSV column), its weight in the config, its equation (the unweighted value).
pub struct Term {
    pub name: &'static str,
    pub weight: fn(&RewardConfig) -> f64,
    pub value: fn(&RewardConfig, &RewardInputs) -> f64,
}

/// The terms in the paper's table order, then ours; one row each, so a name, a weight and an equation cannot
/// drift apart.
pub const TERMS: [Term; N_TERMS] = [
    Term {
        name: "lin_vel_xy_tracking",
        weight: |c| c.lin_vel_xy_tracking,
        value: |c, x| kernel(sq(x.command[0] - x.lin_vel[0]) + sq(x.command[1] - x.lin_vel[1]), c.sigma_v),
    },
    Term {
        name: "ang_vel_z_tracking",
        weight: |c| c.ang_vel_z_tracking,
        value: |c, x| kernel(sq(x.command[2] - x.ang_vel[2]), c.sigma_w),
    },
    Term { name: "lin_vel_z", weight: |c| c.lin_vel_z, value: |_, x| sq(x.lin_vel[2]) },
    Term { name: "ang_vel_xy", weight: |c| c.ang_vel_xy, value: |_, x| sq(x.ang_vel[0]) + sq(x.ang_vel[1]) },
    Term {
        name: "orientation",
        weight: |c| c.orientation,
        value: |c, x| kernel(sq(x.gravity[0]) + sq(x.gravity[1]), c.sigma_g),
    },
    Term {
        name: "body_height",
        weight: |c| c.body_height,
        value: |c, x| kernel(sq(x.base_height_target - x.base_height), c.sigma_h),
    },
    Term {
        name: "action_rate",
        weight: |c| c.action_rate,
        value: |_, x| x.motors.action.iter().zip(&x.motors.last_action).map(|(a, b)| sq(a - b)).sum(),
    },
    Term {
        name: "hip_roll_deviation",
        weight: |c| c.hip_roll_deviation,
        value: |c, x| kernel(group_sq(x, 0), c.sigma_roll),
    },
    Term {
        name: "hip_yaw_deviation",
        weight: |c| c.hip_yaw_deviation,
        value: |c, x| kernel(group_sq(x, 1), c.sigma_yaw),
    },
    Term {
        name: "ankle_pitch_deviation",
        weight: |c| c.ankle_pitch_deviation,
        value: |c, x| kernel(group_sq(x, 2), c.sigma_pitch),
    },
    Term { name: "joint_position_limits", weight: |c| c.joint_position_limits, value: |_, x| joint_limits(x) },
    Term { name: "motor_torque_limits", weight: |c| c.motor_torque_limits, value: |_, x| torque_limits(x) },
    Term {
        name: "feet_slip",
        weight: |c| c.feet_slip,
        value: |_, x| (0..2).filter(|&f| x.foot_contact[f]).map(|f| x.foot_speed[f]).sum(),
    },
    Term { name: "feet_air_time", weight: |c| c.feet_air_time, value: air_time },
    Term { name: "feet_clearance", weight: |c| c.feet_clearance, value: clearance },
];

/// Term names, in table order (also the order of logs and CSV columns).
pub const TERM_NAMES: [&str; N_TERMS] = {
    let mut names = [""; N_TERMS];
    let mut i = 0;
    while i < N_TERMS {
        names[i] = TERMS[i].name;
        i += 1;
    }
    names
};

/// What the rewards look at, all in SI units; velocities in the robot (torso) frame.
#[derive(Debug, Clone)]
pub struct RewardInputs<'a> {
    /// Commanded (v_x, v_y, w_z) — the command the policy observes.
    pub command: [f64; 3],
    pub lin_vel: [f64; 3],
    pub ang_vel: [f64; 3],
    /// Gravity direction in the robot frame (unit vector; (0, 0, −1) when upright).
    pub gravity: [f64; 3],
    /// Torso height above the ground, and the body-height term's target, m.
    pub base_height: f64,
    pub base_height_target: f64,
    /// The per-motor quantities.
    pub motors: &'a MotorInputs,
    /// Horizontal speed of each foot (left, right), m/s.
    pub foot_speed: [f64; 2],
    pub foot_contact: [bool; 2],
    /// A foot touched down this step.
    pub touchdown: [bool; 2],
    /// Time the foot spent in the air before this touchdown, s.
    pub air_time: [f64; 2],
    /// Time each foot has been in its current mode (in contact, or in the air), s.
    pub mode_time: [f64; 2],
    /// Height of each sole's centre above the ground, m (0 when standing on flat ground).
    pub foot_height: [f64; 2],
}

/// What the rewards read per motor (one entry per degree of freedom), kept by the env between steps.
#[derive(Debug, Clone, Default)]
pub struct MotorInputs {
    /// This step's and the previous step's position commands, as offsets from the nominal pose (rad).
    pub action: Vec<f64>,
    pub last_action: Vec<f64>,
    /// Kinematic joint angles, and their deviation from the nominal pose.
    pub joint_pos: Vec<f64>,
    pub joint_dev: Vec<f64>,
    /// Soft joint limits [low, high] per joint.
    pub joint_soft_limits: Vec<[f64; 2]>,
    /// Motor torques and their soft limits, N·m.
    pub motor_torque: Vec<f64>,
    pub torque_soft_limit: Vec<f64>,
    /// The joints of the deviation terms (hip roll, hip yaw, ankle pitch), as motor indices.
    pub deviation_groups: [Vec<usize>; 3],
}

impl MotorInputs {
    /// All zero for `n` motors, soft limits and groups empty-handed (set them before use).
    pub fn zeros(n: usize) -> Self {
        MotorInputs {
            action: vec![0.0; n],
            last_action: vec![0.0; n],
            joint_pos: vec![0.0; n],
            joint_dev: vec![0.0; n],
            joint_soft_limits: vec![[f64::NEG_INFINITY, f64::INFINITY]; n],
            motor_torque: vec![0.0; n],
            torque_soft_limit: vec![f64::INFINITY; n],
            deviation_groups: Default::default(),
        }
    }
}

fn sq(x: f64) -> f64 {
    x * x
}

fn kernel(err_sq: f64, sigma: f64) -> f64 {
    (-err_sq / sigma).exp()
}

/// Σ of the squared deviations of a group's joints (in the spec's order: left, then right).
fn group_sq(x: &RewardInputs, group: usize) -> f64 {
    x.motors.deviation_groups[group].iter().map(|&i| sq(x.motors.joint_dev[i])).fold(0.0, |a, b| a + b)
}

fn relu(v: f64) -> f64 {
    v.max(0.0)
}

fn joint_limits(x: &RewardInputs) -> f64 {
    let m = x.motors;
    (0..m.joint_pos.len())
        .map(|i| relu(m.joint_pos[i] - m.joint_soft_limits[i][1]) + relu(m.joint_soft_limits[i][0] - m.joint_pos[i]))
        .sum()
}

fn torque_limits(x: &RewardInputs) -> f64 {
    let m = x.motors;
    (0..m.motor_torque.len()).map(|i| relu(m.motor_torque[i].abs() - m.torque_soft_limit[i])).sum()
}

/// A motion is commanded (yaw included, so that turning in place steps too).
fn moving(x: &RewardInputs) -> bool {
    x.command.iter().map(|v| v * v).sum::<f64>().sqrt() > 0.1
}

fn air_time(c: &RewardConfig, x: &RewardInputs) -> f64 {
    let at_touchdown = |t: f64| match c.air_time_form {
        AirTimeForm::Abs => (t - c.air_time_target).abs(),
        AirTimeForm::Signed if moving(x) => t - c.air_time_target,
        AirTimeForm::Signed => 0.0,
        AirTimeForm::NegAbs => -(t - c.air_time_target).abs(),
        AirTimeForm::PositiveBiped => 0.0,
    };
    match c.air_time_form {
        // Every step of single stance pays the shorter of the two feet's time in their mode, capped at the target.
        AirTimeForm::PositiveBiped => {
            let single = x.foot_contact[0] != x.foot_contact[1];
            if single && moving(x) {
                x.mode_time[0].min(x.mode_time[1]).min(c.air_time_target)
            } else {
                0.0
            }
        }
        _ => (0..2).filter(|&f| x.touchdown[f]).map(|f| at_touchdown(x.air_time[f])).sum(),
    }
}

/// Kernel form: a foot that moves over the ground below the target height is a shuffle; weighting by tanh(2‖v‖)
/// leaves a foot at rest (stance) free, as IsaacLab's foot-clearance reward does. Swing-height form: each foot in
/// the air pays its height up to the target, while a motion is commanded.
fn clearance(c: &RewardConfig, x: &RewardInputs) -> f64 {
    match c.clearance_form {
        ClearanceForm::Kernel => {
            let low: f64 = (0..2)
                .map(|f| sq((c.clearance_target - x.foot_height[f]).max(0.0)) * (2.0 * x.foot_speed[f]).tanh())
                .sum();
            kernel(low, c.sigma_clearance)
        }
        ClearanceForm::SwingHeight if moving(x) => (0..2)
            .filter(|&f| !x.foot_contact[f])
            .map(|f| x.foot_height[f].clamp(0.0, c.clearance_target) / c.clearance_target)
            .sum(),
        ClearanceForm::SwingHeight => 0.0,
    }
}

/// The unweighted value of each term (the paper's "Equation" column).
pub fn raw_terms(c: &RewardConfig, x: &RewardInputs) -> [f64; N_TERMS] {
    std::array::from_fn(|i| (TERMS[i].value)(c, x))
}

/// The weights, in term order.
pub fn weights(c: &RewardConfig) -> [f64; N_TERMS] {
    std::array::from_fn(|i| (TERMS[i].weight)(c))
}

/// Weighted terms (weight × equation × `scale`) into `out`; returns their sum, the step reward.
pub fn weighted_terms(c: &RewardConfig, x: &RewardInputs, scale: f64, out: &mut [f64; N_TERMS]) -> f64 {
    let raw = raw_terms(c, x);
    let w = weights(c);
    let mut total = 0.0;
    for i in 0..N_TERMS {
        out[i] = w[i] * raw[i] * scale;
        total += out[i];
    }
    if c.only_positive_rewards {
        total.max(0.0)
    } else {
        total
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// TopA's ten motors: limits ±1 rad, torques ±10 N·m, groups hip roll (0, 5), hip yaw (1, 6), ankle (4, 9).
    fn motors() -> MotorInputs {
        let mut m = MotorInputs::zeros(10);
        m.joint_soft_limits = vec![[-1.0, 1.0]; 10];
        m.torque_soft_limit = vec![10.0; 10];
        m.deviation_groups = [vec![0, 5], vec![1, 6], vec![4, 9]];
        m
    }

    fn upright_perfect(m: &MotorInputs) -> RewardInputs<'_> {
        RewardInputs {
            command: [0.4, -0.1, 0.5],
            lin_vel: [0.4, -0.1, 0.0],
            ang_vel: [0.0, 0.0, 0.5],
            gravity: [0.0, 0.0, -1.0],
            base_height: 0.56,
            base_height_target: 0.56,
            motors: m,
            foot_speed: [0.0; 2],
            foot_contact: [false; 2],
            touchdown: [false; 2],
            air_time: [0.0; 2],
            mode_time: [0.0; 2],
            foot_height: [0.0; 2],
        }
    }

    #[test]
    fn perfect_state_earns_each_positive_weight_and_no_penalty() {
        let c = RewardConfig::default();
        let mut out = [0.0; N_TERMS];
        let m = motors();
        let total = weighted_terms(&c, &upright_perfect(&m), 1.0, &mut out);
        let w = weights(&c);
        for i in 0..N_TERMS {
            let expected = if ["feet_air_time"].contains(&TERM_NAMES[i]) || w[i] <= 0.0 { 0.0 } else { w[i] };
            assert!((out[i] - expected).abs() < 1e-12, "{}: {} vs {expected}", TERM_NAMES[i], out[i]);
        }
        assert!((total - (3.0 + 1.5 + 1.0 + 1.0 + 0.5 * 3.0)).abs() < 1e-12);
    }

    #[test]
    fn each_term_matches_its_equation_on_a_known_state() {
        let c = RewardConfig::default();
        let mut m = motors();
        m.action[0] = 0.5;
        m.last_action[0] = 0.1;
        m.joint_dev[0] = 0.1; // left hip roll
        m.joint_dev[5] = -0.2; // right hip roll
        m.joint_dev[6] = 0.3; // right hip yaw
        m.joint_dev[4] = 0.2; // left ankle
        m.joint_pos[2] = 1.3; // 0.3 past the soft upper limit
        m.joint_pos[7] = -1.1; // 0.1 below the soft lower limit
        m.motor_torque[3] = -14.0; // 4 N·m past its soft limit
        let mut x = upright_perfect(&m);
        x.lin_vel = [0.1, 0.2, 0.3];
        x.ang_vel = [0.2, -0.4, 0.0];
        x.gravity = [0.1, -0.2, -0.97];
        x.base_height -= 0.03;
        x.foot_speed = [0.3, 0.7];
        x.foot_contact = [true, false];
        x.touchdown = [false, true];
        x.air_time = [0.0, 0.2];
        x.foot_height = [0.0, 0.01];
        let c = RewardConfig { clearance_target: 0.05, ..c };
        let r = raw_terms(&c, &x);
        let e = |a: f64, b: f64| assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        e(r[0], (-(0.3f64.powi(2) + 0.3f64.powi(2)) / c.sigma_v).exp());
        e(r[1], (-(0.5f64.powi(2)) / c.sigma_w).exp());
        e(r[2], 0.09);
        e(r[3], 0.04 + 0.16);
        e(r[4], (-(0.01 + 0.04) / c.sigma_g).exp());
        e(r[5], (-(0.03f64.powi(2)) / c.sigma_h).exp());
        e(r[6], 0.16);
        e(r[7], (-(0.01 + 0.04) / c.sigma_roll).exp());
        e(r[8], (-0.09 / c.sigma_yaw).exp());
        e(r[9], (-0.04 / c.sigma_pitch).exp());
        e(r[10], 0.4);
        e(r[11], 4.0);
        e(r[12], 0.3);
        e(r[13], 0.3);
        // Left foot: on the ground, sliding at 0.3 m/s; right foot: 1 cm up, moving at 0.7 m/s.
        let low = 0.05f64.powi(2) * 0.6f64.tanh() + 0.04f64.powi(2) * 1.4f64.tanh();
        e(r[14], (-low / c.sigma_clearance).exp());
        let mut high = x.clone();
        high.foot_height = [0.0, 0.08];
        high.foot_speed = [0.0, 0.7];
        e(raw_terms(&c, &high)[14], 1.0);
        let form = |f| RewardConfig { air_time_form: f, ..c.clone() };
        e(raw_terms(&form(AirTimeForm::Signed), &x)[13], -0.3);
        e(raw_terms(&form(AirTimeForm::NegAbs), &x)[13], -0.3);
        x.air_time[1] = 0.7;
        e(raw_terms(&form(AirTimeForm::Signed), &x)[13], 0.2);
        e(raw_terms(&form(AirTimeForm::NegAbs), &x)[13], -0.2);
        // legged_gym's form pays nothing while the command is "stand still".
        let mut standing = x.clone();
        standing.command = [0.0; 3];
        e(raw_terms(&form(AirTimeForm::Signed), &standing)[13], 0.0);
        // IsaacLab's biped form: single stance pays min(mode times) up to the target, every step; double support
        // or flight pays nothing.
        let mut biped = x.clone();
        biped.foot_contact = [true, false];
        biped.mode_time = [0.3, 0.12];
        e(raw_terms(&form(AirTimeForm::PositiveBiped), &biped)[13], 0.12);
        biped.mode_time = [0.9, 0.7];
        e(raw_terms(&form(AirTimeForm::PositiveBiped), &biped)[13], 0.5);
        biped.foot_contact = [true, true];
        e(raw_terms(&form(AirTimeForm::PositiveBiped), &biped)[13], 0.0);
        // Swing-height clearance: the right foot (in the air, 1 cm of a 5 cm target) pays 0.2; higher than the
        // target pays 1; the stance foot nothing; a stand-still command nothing.
        let swing = RewardConfig { clearance_form: ClearanceForm::SwingHeight, ..c.clone() };
        e(raw_terms(&swing, &x)[14], 0.2);
        e(raw_terms(&swing, &high)[14], 1.0);
        e(raw_terms(&swing, &standing)[14], 0.0);
        x.air_time[1] = 0.2;
        let mut out = [0.0; N_TERMS];
        let total = weighted_terms(&c, &x, 0.02, &mut out);
        e(out[2], -0.09 * 0.02); // weight −1 × v_z² × dt
        e(total, out.iter().sum());
    }
}

//! `topa info ROBOT.toml`: what a robot spec resolves to on its MJCF — motors and the joints they move, the stand
//! pose in both spaces, ranges, the mirror, reward groups, loops, and the motor→joint map the linkage computes
//! (identity, a constant matrix, or nonlinear with how far J moves). The first thing to run on a new robot.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;
use topa_env::linkage::{JointMap, Linkage};
use topa_env::spec::RobotSpec;

use crate::error::Result;

#[derive(Debug, Serialize)]
pub struct RobotSummary {
    pub name: String,
    pub spec: String,
    pub mjcf: String,
    pub approximates: Option<String>,
    pub base_body: String,
    pub imu_site: String,
    pub feet: Vec<String>,
    pub base_height_target_m: f64,
    pub motors: Vec<MotorSummary>,
    pub groups: BTreeMap<String, Vec<String>>,
    pub loops: Vec<LoopSummary>,
    pub map: MapSummary,
}

#[derive(Debug, Serialize)]
pub struct MotorSummary {
    pub actuator: String,
    pub drives: String,
    pub joint: String,
    /// Stand pose: the driven joint (motor) and the kinematic joint, rad.
    pub nominal_motor: f64,
    pub nominal_joint: f64,
    pub motor_range: [f64; 2],
    pub joint_range: [f64; 2],
    pub torque_limit: f64,
    pub mirror: String,
    pub mirror_sign: f64,
    /// Torque held in the stand pose (gravity feed-forward), N·m.
    pub feedforward: f64,
}

#[derive(Debug, Serialize)]
pub struct LoopSummary {
    pub name: String,
    pub equality: Vec<String>,
    pub passive: Vec<String>,
    pub springs: Vec<String>,
}

#[derive(Debug, Serialize)]
pub struct MapSummary {
    /// "identity" (no loops), "linear" (constant J, e.g. TopA's M) or "nonlinear" (solved every step).
    pub kind: String,
    /// ∂q_joint/∂q_motor at the stand pose, row per kinematic joint.
    pub jacobian_at_stand: Vec<Vec<f64>>,
    /// The largest change of any entry of J over motor configurations within ±0.3 rad of the stand pose.
    pub jacobian_spread: f64,
}

pub fn summarize(path: &Path) -> Result<RobotSummary> {
    let (spec, model) = RobotSpec::load(path)?;
    let name_of = |i: usize| spec.motors[i].actuator.clone();
    let mut linkage = Linkage::new(&spec, &model)?;
    let q0 = linkage.nominal_motors().to_vec();
    let j0 = linkage.jacobian(&q0)?;
    let mut spread = 0.0f64;
    // Deterministic probes around the stand pose (not random: the output is compared between runs).
    for k in 0..8 {
        let q: Vec<f64> = q0.iter().enumerate().map(|(i, x)| x + 0.3 * ((i * 7 + k * 3) as f64 * 1.3).sin()).collect();
        if let Ok(j) = linkage.jacobian(&q) {
            spread = spread.max((j - &j0).abs().max());
        }
    }
    let kind = match JointMap::from_linkage(linkage)? {
        JointMap::Identity => "identity",
        JointMap::Linear { .. } => "linear",
        JointMap::Solve(_) => "nonlinear",
    };
    let motors = spec
        .motors
        .iter()
        .enumerate()
        .map(|(i, m)| MotorSummary {
            actuator: m.actuator.clone(),
            drives: m.drives.clone(),
            joint: m.joint.clone(),
            nominal_motor: q0[i],
            nominal_joint: m.nominal,
            motor_range: m.motor_range,
            joint_range: m.joint_range,
            torque_limit: m.torque_limit,
            mirror: name_of(m.mirror),
            mirror_sign: m.mirror_sign,
            feedforward: m.feedforward,
        })
        .collect();
    Ok(RobotSummary {
        name: spec.name.clone(),
        spec: path.display().to_string(),
        mjcf: spec.mjcf.display().to_string(),
        approximates: spec.approximates.as_ref().map(|p| p.display().to_string()),
        base_body: spec.base_body.clone(),
        imu_site: spec.imu_site.clone(),
        feet: spec.feet.iter().map(|f| f.body.clone()).collect(),
        base_height_target_m: spec.base_height_target,
        motors,
        groups: spec.groups.iter().map(|(g, ix)| (g.clone(), ix.iter().map(|&i| name_of(i)).collect())).collect(),
        loops: spec
            .loops
            .iter()
            .map(|l| LoopSummary {
                name: l.name.clone(),
                equality: l.equality.clone(),
                passive: l.passive.clone(),
                springs: l.springs.clone(),
            })
            .collect(),
        map: MapSummary {
            kind: kind.into(),
            jacobian_at_stand: j0.row_iter().map(|r| r.iter().copied().collect()).collect(),
            jacobian_spread: spread,
        },
    })
}

pub fn print_text(s: &RobotSummary) {
    println!("robot       {} ({}), model {}", s.name, s.spec, s.mjcf);
    if let Some(a) = &s.approximates {
        println!("approximates {a} (its policies are evaluated there)");
    }
    println!(
        "base        body {}, IMU site {}, feet {}, height target {:.3} m",
        s.base_body,
        s.imu_site,
        s.feet.join(" / "),
        s.base_height_target_m
    );
    println!(
        "{:<12}{:<18} {:<18} {:<18} {:>8} {:>8}  {:<16} {:>6}  mirror",
        "motor", "actuator", "drives", "joint", "q_motor", "q_joint", "motor range", "N·m"
    );
    for (i, m) in s.motors.iter().enumerate() {
        println!(
            "{:<12}{:<18} {:<18} {:<18} {:>8.4} {:>8.4}  [{:>6.3},{:>6.3}] {:>6.1}  {}{}",
            i,
            m.actuator,
            m.drives,
            m.joint,
            m.nominal_motor,
            m.nominal_joint,
            m.motor_range[0],
            m.motor_range[1],
            m.torque_limit,
            if m.mirror_sign < 0.0 { "−" } else { "+" },
            m.mirror
        );
    }
    if s.motors.iter().any(|m| m.feedforward != 0.0) {
        let ff: Vec<String> = s.motors.iter().map(|m| format!("{:.2}", m.feedforward)).collect();
        println!("feedforward {} N·m (stand pose, motor order)", ff.join(" "));
    }
    for (g, names) in &s.groups {
        println!("group       {g}: {}", names.join(", "));
    }
    for l in &s.loops {
        let springs = if l.springs.is_empty() { String::new() } else { format!("; springs {}", l.springs.join(", ")) };
        println!(
            "loop        {}: closed by {}; passive {}{springs}",
            l.name,
            l.equality.join(", "),
            l.passive.join(", ")
        );
    }
    println!(
        "map         motor → joint: {} (J varies by up to {:.2e} within ±0.3 rad of the stand pose)",
        s.map.kind, s.map.jacobian_spread
    );
    for (i, row) in s.map.jacobian_at_stand.iter().enumerate() {
        let cells: Vec<String> =
            row.iter().map(|v| if v.abs() < 5e-13 { "     0".into() } else { format!("{v:>6.3}") }).collect();
        println!("J[{i:>2}]       {}", cells.join(" "));
    }
}

pub fn run(path: &Path, json: bool) -> Result<()> {
    crate::info::show(&summarize(path)?, json, print_text)
}

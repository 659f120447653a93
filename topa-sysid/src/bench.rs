//! A motor bench in MuJoCo: an MJCF whose joints are driven by the logged motors (each with its known load), the
//! actuator parameters that identification changes, and the replay of a log's commands through the simulation.
//!
//! The drive is modelled outside MuJoCo's actuators (they are switched off): torque = K · u(t − delay), where u is
//! the logged torque or current, or the driver's PD law on the simulated state, so that the torque constant and the
//! command delay can be fitted. Armature, damping and dry friction are MuJoCo's own joint parameters — the values
//! the training model uses.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use mujoco::{Data, Model, ObjType};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use topa_env::sim2sim::actuators::ActuatorConfig;

use super::log::{Command, MotorLog};
use crate::error::{ensure_bench, Error, Result};

/// One motor's identified parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorParams {
    /// Reflected rotor inertia, kg·m².
    pub armature: f64,
    /// Viscous friction, N·m·s/rad.
    pub damping: f64,
    /// Dry (Coulomb) friction, N·m.
    pub frictionloss: f64,
    /// Torque per unit command: a ratio for torque and position commands, N·m/A for current.
    pub torque_constant: f64,
}

/// Every motor's parameters and the command-to-torque delay shared by the drives.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Params {
    pub motors: Vec<MotorParams>,
    /// s.
    pub delay_s: f64,
}

impl Params {
    /// The motors' values in the order `order` gives (indices into `motors`), as the sim2sim's `[actuators]` table
    /// holds them (not yet enabled).
    pub fn actuators(&self, order: &[usize]) -> ActuatorConfig {
        let pick = |f: fn(&MotorParams) -> f64| order.iter().map(|&i| f(&self.motors[i])).collect();
        ActuatorConfig {
            enabled: false,
            armature: pick(|m| m.armature),
            damping: pick(|m| m.damping),
            frictionloss: pick(|m| m.frictionloss),
            torque_constant: pick(|m| m.torque_constant),
        }
    }
}

/// A logged motor in the bench model.
#[derive(Debug, Clone)]
pub struct BenchMotor {
    pub name: String,
    pub actuator: usize,
    pub dof: usize,
    pub qpos: usize,
}

/// The whole qpos of a bench for its logged motor positions (log order): how a window of a bench with unlogged
/// joints (a robot's closed loops) starts.
pub type StartPose = Box<dyn Fn(&[f64]) -> Result<Vec<f64>> + Send + Sync>;

pub struct Bench {
    pub path: PathBuf,
    model: Arc<Model>,
    pub motors: Vec<BenchMotor>,
    /// Each motor's dynamically coupled group (a kinematic tree below a fixed body, joined with any tree an
    /// equality constraint ties it to). Motors of different trees do not feel each other's parameters, so one
    /// perturbed rollout gives a Jacobian column for one motor of every tree.
    pub tree: Vec<usize>,
    start_pose: Option<StartPose>,
    /// Physics steps per log sample.
    substeps: usize,
    /// Samples after each window's start left out of the comparison: under a PD loop the error of the logged
    /// initial state (noisy, quantised) dies out within them instead of biasing the fit.
    pub burn_in: usize,
}

/// Samples `[start, end)` of the log simulated from the logged state at `start`.
pub type Window = (usize, usize);

/// Half-width, in samples, of the line fitted to logged positions for a window's initial velocity when the log has
/// no velocity column (a central difference of quantised positions would be noisier than the signal).
const SLOPE_HALF_WIDTH: usize = 5;

impl Bench {
    /// Loads the bench MJCF and matches it to the log's motors (by actuator name).
    pub fn load(path: &Path, log: &MotorLog) -> Result<Bench> {
        let model = Model::from_xml_path(path).map_err(|e| {
            Error::bench(format!("bench MJCF {} (docs/sysid.md describes the format)", path.display()), e)
        })?;
        let motors = Self::motors_of(&model, path, log)?;
        Self::from_model(model, path, motors, log, None)
    }

    /// The log's motors on the model's actuators (by name), each driving a hinge.
    pub fn motors_of(model: &Model, path: &Path, log: &MotorLog) -> Result<Vec<BenchMotor>> {
        let actuators = model.names(ObjType::Actuator);
        let mut motors = Vec::new();
        for m in &log.motors {
            let a = model.id(ObjType::Actuator, &m.name).map_err(|_| {
                Error::bad_bench(format!(
                    "motor {} of the log is not an actuator of {} (it has: {})",
                    m.name,
                    path.display(),
                    actuators.join(", ")
                ))
            })?;
            let (kind, joint) = (model.actuator_trntype(a), model.actuator_trnid()[a][0]);
            ensure_bench!(
                kind == mujoco::Transmission::Joint,
                "actuator {} of {} must drive a joint",
                m.name,
                path.display()
            );
            let joint = joint as usize;
            ensure_bench!(
                model.jnt_type(joint) == mujoco::JointType::Hinge,
                "actuator {} of {} drives a joint that is not a hinge",
                m.name,
                path.display()
            );
            motors.push(BenchMotor {
                name: m.name.clone(),
                actuator: a,
                dof: model.jnt_dofadr_of(joint),
                qpos: model.jnt_qposadr_of(joint),
            });
        }
        for a in 0..model.nu() {
            let name = model.name_of(ObjType::Actuator, a).unwrap_or("");
            ensure_bench!(
                log.motors.iter().any(|m| m.name == name),
                "actuator {name} of {} has no columns in the log: log every motor of the bench",
                path.display()
            );
        }
        Ok(motors)
    }

    /// A bench on an already compiled model. Without `start_pose`, every joint must be a logged motor (a window
    /// starts from the logged state); with it, the unlogged joints start where it puts them, at rest.
    pub fn from_model(
        model: Model,
        path: &Path,
        motors: Vec<BenchMotor>,
        log: &MotorLog,
        start_pose: Option<StartPose>,
    ) -> Result<Bench> {
        if start_pose.is_none() {
            ensure_bench!(
                model.nv() == motors.len() && model.nq() == motors.len(),
                "{} has {} degrees of freedom and the log {} motors: every joint of a bench must be a logged motor \
                 (a window starts from the logged state)",
                path.display(),
                model.nv(),
                motors.len()
            );
        }
        let tree = trees(&model, &motors);
        let (step, dt) = (log.step(), model.timestep());
        let substeps = (step / dt).round().max(1.0) as usize;
        ensure_bench!(
            (substeps as f64 * dt - step).abs() < 1e-3 * step,
            "the log's sample step {step} s is not a whole number of the bench's timestep {dt} s: set \
             <option timestep> in {} to divide it",
            path.display()
        );
        Ok(Bench { path: path.to_path_buf(), model: Arc::new(model), motors, tree, start_pose, substeps, burn_in: 0 })
    }

    pub fn timestep(&self) -> f64 {
        self.model.timestep()
    }

    /// The PD gains (kp, kd) of motor `m`'s actuator in the MJCF (a `<general>` with gainprm = kp and
    /// biasprm = "0 −kp −kd", as the robot's drives are modelled).
    pub fn pd_gains(&self, m: usize) -> (f64, f64) {
        let a = self.motors[m].actuator;
        (self.model.actuator_gainprm()[a][0], -self.model.actuator_biasprm()[a][2])
    }

    /// The model's own values (torque constant 1, no delay): where the fit starts.
    pub fn nominal(&self) -> Params {
        let m = &self.model;
        Params {
            motors: self
                .motors
                .iter()
                .map(|b| MotorParams {
                    armature: m.dof_armature()[b.dof],
                    damping: m.dof_damping()[b.dof],
                    frictionloss: m.dof_frictionloss()[b.dof],
                    torque_constant: 1.0,
                })
                .collect(),
            delay_s: 0.0,
        }
    }

    /// A copy of the model with `p`'s joint parameters and its actuators off (the drive is ours).
    pub fn model_with(&self, p: &Params) -> Result<Model> {
        let mut m = self.model.try_clone()?;
        let motors: Vec<(usize, usize)> = self.motors.iter().map(|b| (b.dof, b.actuator)).collect();
        p.actuators(&(0..motors.len()).collect::<Vec<_>>()).put(&mut m, &motors);
        m.actuator_gainprm_mut().iter_mut().for_each(|g| g.fill(0.0));
        m.actuator_biasprm_mut().iter_mut().for_each(|g| g.fill(0.0));
        Ok(m)
    }

    /// Simulated positions at the log's samples of each window (the window's first sample, the initial state, and
    /// the burn-in left out): `[window][sample][motor]`, flattened.
    pub fn simulate(&self, p: &Params, log: &MotorLog, windows: &[Window]) -> Result<Vec<f64>> {
        let mut data = Data::new(Arc::new(self.model_with(p)?))?;
        // MuJoCo 2.2 takes the armature into the mass matrix from a value mj_setConst computes, not from
        // dof_armature itself: without this, a changed armature has no effect.
        data.set_const()?;
        let model = data.model_arc().clone();
        // Windows are independent: in parallel, each on its own Data (the results do not depend on the threads).
        let parts =
            windows.par_iter().map(|&w| self.simulate_window(&model, p, log, w)).collect::<Result<Vec<Vec<f64>>>>()?;
        Ok(parts.concat())
    }

    fn simulate_window(
        &self,
        model: &Arc<Model>,
        p: &Params,
        log: &MotorLog,
        (start, end): Window,
    ) -> Result<Vec<f64>> {
        let mut data = Data::new(model.clone())?;
        let n = self.motors.len();
        let dt = self.timestep();
        let mut out = Vec::with_capacity((end - start - 1).saturating_sub(self.burn_in) * n);
        let mut history: Vec<Vec<f64>> = vec![Vec::with_capacity((end - start) * self.substeps); n];
        if let Some(pose) = &self.start_pose {
            let q: Vec<f64> = log.motors.iter().map(|m| m.position[start]).collect();
            data.qpos_mut().copy_from_slice(&pose(&q)?);
        }
        for (m, b) in self.motors.iter().enumerate() {
            data.qpos_mut()[b.qpos] = log.motors[m].position[start];
            data.qvel_mut()[b.dof] = self.initial_velocity(log, m, start);
        }
        data.set_time(log.time[start]);
        for i in start..end - 1 {
            for k in 0..self.substeps {
                let t = log.time[i] + k as f64 * (log.time[i + 1] - log.time[i]) / self.substeps as f64;
                for (m, b) in self.motors.iter().enumerate() {
                    let (q, v) = (data.qpos()[b.qpos], data.qvel()[b.dof]);
                    history[m].push(command(log, m, t, Some((q, v))));
                    let u = delayed(log, m, &history[m], log.time[start], t, dt, p.delay_s);
                    data.qfrc_applied_mut()[b.dof] = p.motors[m].torque_constant * u;
                }
                data.step().map_err(|source| Error::Diverged { t, source })?;
            }
            if i + 1 > start + self.burn_in {
                out.extend(self.motors.iter().map(|b| data.qpos()[b.qpos]));
            }
        }
        Ok(out)
    }

    /// The logged velocity, or the slope of a line fitted to the positions around `i`.
    fn initial_velocity(&self, log: &MotorLog, m: usize, i: usize) -> f64 {
        if log.motors[m].velocity.is_some() {
            return log.velocity(m, i);
        }
        let (a, b) = (i.saturating_sub(SLOPE_HALF_WIDTH), (i + SLOPE_HALF_WIDTH).min(log.time.len() - 1));
        let ts = &log.time[a..=b];
        let qs = &log.motors[m].position[a..=b];
        let (tm, qm) = (ts.iter().sum::<f64>() / ts.len() as f64, qs.iter().sum::<f64>() / qs.len() as f64);
        let cov: f64 = ts.iter().zip(qs).map(|(t, q)| (t - tm) * (q - qm)).sum();
        let var: f64 = ts.iter().map(|t| (t - tm) * (t - tm)).sum();
        cov / var
    }

    /// The logged positions at the samples `simulate` returns, in its layout.
    pub fn measured(&self, log: &MotorLog, windows: &[Window]) -> Vec<f64> {
        let mut out = Vec::new();
        for &(start, end) in windows {
            for i in start + 1 + self.burn_in..end {
                out.extend(log.motors.iter().map(|m| m.position[i]));
            }
        }
        out
    }
}

/// Each motor's coupled group: the topmost moving body above its joint, groups joined by equality constraints.
fn trees(model: &Model, motors: &[BenchMotor]) -> Vec<usize> {
    let parent = model.body_parentid();
    let top = |mut b: usize| {
        let mut moving = b;
        while b != 0 {
            if model.body_jntnum()[b] > 0 {
                moving = b;
            }
            b = parent[b] as usize;
        }
        moving
    };
    let mut group: Vec<usize> = (0..model.nbody()).map(top).collect();
    for e in 0..model.neq() {
        let body = |id: i32| -> usize {
            if model.eq_type(e) == mujoco::EqualityType::Joint {
                model.jnt_bodyid()[id as usize] as usize
            } else {
                id as usize
            }
        };
        let (a, b) = (group[body(model.eq_obj1id()[e])], group[body(model.eq_obj2id()[e])]);
        if a != b {
            group.iter_mut().filter(|g| **g == b).for_each(|g| *g = a);
        }
    }
    motors.iter().map(|m| group[model.dof_bodyid()[m.dof] as usize]).collect()
}

/// Consecutive windows of `len` samples over `[from, to)` (the last one may be shorter, never under 3 samples).
pub fn windows(from: usize, to: usize, len: usize) -> Vec<Window> {
    let len = len.max(3);
    let mut out = Vec::new();
    let mut s = from;
    while s + 2 < to {
        out.push((s, (s + len).min(to)));
        s += len - 1; // the next window starts where this one ended: every sample is compared once
    }
    out
}

/// The log's value of a column at time `t` (linear between samples, held beyond the ends).
fn interpolate(time: &[f64], v: &[f64], t: f64) -> f64 {
    let i = time.partition_point(|&x| x <= t);
    if i == 0 {
        return v[0];
    }
    if i >= time.len() {
        return v[v.len() - 1];
    }
    let w = (t - time[i - 1]) / (time[i] - time[i - 1]);
    v[i - 1] + w * (v[i] - v[i - 1])
}

/// Motor `m`'s command at time `t`: the logged torque or current, or the PD law on the state `(q, v)` (the logged
/// one when `state` is None).
fn command(log: &MotorLog, m: usize, t: f64, state: Option<(f64, f64)>) -> f64 {
    let trace = &log.motors[m];
    match &trace.command {
        Command::Torque(u) | Command::Current(u) => interpolate(&log.time, u, t),
        Command::Position { target, kp, kd } => {
            let (q, v) = state.unwrap_or_else(|| {
                let i = log.time.partition_point(|&x| x < t).min(log.time.len() - 1);
                (interpolate(&log.time, &trace.position, t), log.velocity(m, i))
            });
            let at = |c: &[f64]| interpolate(&log.time, c, t);
            at(kp) * (at(target) - q) - at(kd) * v
        }
    }
}

/// The command `delay` before `t`: from this window's history of physics steps (linear between them), or from the
/// log before the window started.
fn delayed(log: &MotorLog, m: usize, history: &[f64], start: f64, t: f64, dt: f64, delay: f64) -> f64 {
    let f = (t - delay - start) / dt;
    if f < 0.0 {
        return command(log, m, t - delay, None);
    }
    let i = (f.floor() as usize).min(history.len() - 1);
    let j = (i + 1).min(history.len() - 1);
    let w = f - i as f64;
    history[i] + w.min(1.0) * (history[j] - history[i])
}

#[cfg(test)]
mod tests {
    use super::*;

    const BENCH: &str = "assets/mjcf/benches/topa_motors.xml";

    const MOTORS: [&str; 10] = [
        "l_hip_roll",
        "l_hip_yaw",
        "l_hip_pitch",
        "l_knee_motor",
        "l_ankle_motor",
        "r_hip_roll",
        "r_hip_yaw",
        "r_hip_pitch",
        "r_knee_motor",
        "r_ankle_motor",
    ];

    /// A 0.5 N·m torque step on every motor of the bench, as a log.
    fn step_log(n: usize) -> MotorLog {
        let mut s = String::from("time");
        for name in MOTORS {
            s.push_str(&format!(",{name}:torque,{name}:position"));
        }
        s.push('\n');
        for i in 0..n {
            s.push_str(&format!("{}{}\n", i as f64 * 0.002, ",0.5,0.0".repeat(MOTORS.len())));
        }
        MotorLog::parse(&s).unwrap()
    }

    #[test]
    fn armature_damping_and_the_torque_constant_shape_the_response() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let log = step_log(100);
        let bench = Bench::load(&root.join(BENCH), &log).unwrap();
        let p = bench.nominal();
        let w = [(0, 100)];
        let base = bench.simulate(&p, &log, &w).unwrap();
        // Motor 0's last position, and the last motor's.
        let end = |v: &[f64]| v[v.len() - MOTORS.len()];
        let mut heavier = p.clone();
        heavier.motors[0].armature *= 3.0;
        let h = bench.simulate(&heavier, &log, &w).unwrap();
        assert!(end(&h) < 0.9 * end(&base), "armature ×3: {} vs {}", end(&h), end(&base));
        // The other motor does not feel it (its own tree).
        assert_eq!(h[h.len() - 1], base[base.len() - 1]);
        let mut trees = bench.tree.clone();
        trees.dedup();
        assert_eq!(trees.len(), MOTORS.len(), "every pendulum is its own tree");
        let mut stronger = p.clone();
        stronger.motors[0].torque_constant = 2.0;
        assert!(end(&bench.simulate(&stronger, &log, &w).unwrap()) > 1.5 * end(&base));
    }
}

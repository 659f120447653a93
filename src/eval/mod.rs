//! Sim2sim evaluation (paper, "Ablation study" and "Robustness evaluation"): every experiment runs on the
//! **closed** model with settings that differ from training on purpose — finer physics timestep, the MJCF's
//! exact integrator, no domain randomisation, no observation noise, no pushes — so that a policy's score is a
//! transfer, not a replay. A policy trained on the open model is run through the paper's map M.

pub mod ablate;
pub mod claims;
pub mod gait;
pub mod groups;
pub mod intervals;
mod nan_json;
pub mod noise;
pub mod push;
pub mod report;
pub mod runner;
pub mod tracking;

use std::path::Path;

use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::sync::Arc;

use nalgebra::DMatrix;
use topa_env::assets;
use topa_env::indices::RobotIndices;
use topa_env::linkage::JointMap;
use topa_env::observation::{Block, ObsLayout};
use topa_env::robot::ModelKind;
use topa_env::sim2sim::Sim2SimConfig;
use topa_env::spec::RobotSpec;
use topa_env::EnvConfig;
use trainer::policy_file::Policy;

/// Settings shared by the experiments.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EvalSettings {
    /// Physics timestep, s (training: 0.005). The policy period is kept: decimation = policy_dt / timestep.
    /// `None`: the sim2sim mode's own timestep if it has one, else 0.0025.
    pub timestep: Option<f64>,
    /// "ideal", "realistic", or the sim2sim file used.
    pub sim2sim_mode: String,
    /// The sensor, estimator, latency and motor models (all off: ideal).
    pub sim2sim: Sim2SimConfig,
    /// Model = the MJCF's RK4, which keeps the linkage exact.
    pub integrator: topa_env::IntegratorChoice,
    /// Standing still on a zero command before each experiment starts, s.
    pub settle_s: f64,
    /// Worker threads (0 = all cores).
    pub threads: usize,
    pub seed: u64,
}

/// The realistic mode's models (configs/sim2sim/realistic.toml, built in).
const REALISTIC: &str = include_str!("../../configs/sim2sim/realistic.toml");

impl EvalSettings {
    /// The physics timestep the experiments run at.
    pub fn timestep(&self) -> f64 {
        self.timestep.unwrap_or(if self.sim2sim.timestep > 0.0 { self.sim2sim.timestep } else { 0.0025 })
    }

    /// Sets the sim2sim mode: "ideal", "realistic", or a TOML file of models (which may start from another with
    /// `base = "…"`; configs/sim2sim/realistic.toml is the reference).
    pub fn with_sim2sim(mut self, spec: &str) -> Result<Self> {
        let cfg = match spec {
            "ideal" => Sim2SimConfig::default(),
            "realistic" => toml::from_str(REALISTIC)
                .map_err(|e| anyhow::anyhow!("built-in configs/sim2sim/realistic.toml: {e}"))?,
            file => {
                let table = trainer::config::load_table(Path::new(file), 0)?;
                toml::Value::Table(table)
                    .try_into()
                    .map_err(|e| anyhow::anyhow!("sim2sim file {file}: {}", e.to_string().replace('\n', " ")))?
            }
        };
        cfg.validate().map_err(|e| anyhow::anyhow!("sim2sim '{spec}': {e}"))?;
        self.sim2sim = cfg;
        self.sim2sim_mode = spec.to_string();
        Ok(self)
    }
}

impl Default for EvalSettings {
    fn default() -> Self {
        EvalSettings {
            timestep: None,
            sim2sim_mode: "ideal".into(),
            sim2sim: Sim2SimConfig::default(),
            integrator: topa_env::IntegratorChoice::Model,
            settle_s: 2.0,
            threads: 0,
            seed: 1,
        }
    }
}

/// A policy ready to act on the robot it is evaluated on: the robot it was trained on, or — for a policy trained
/// on a simplified model (TopA's serial chain, whose spec `approximates` the closed one) — the real robot, through
/// its linkage: observed motor positions, velocities and previous actions are mapped to joint space with the
/// linkage's constant J (the paper's M, computed from the constraints), and the joint-space action back with J⁻¹
/// (motor targets = J⁻¹ · joint targets, since the nominal pose maps the same way).
pub struct PolicyRunner {
    pub policy: Policy,
    pub name: String,
    /// The spec the policy was trained on, and the robot it runs on here.
    trained_on: Arc<RobotSpec>,
    robot: Arc<RobotSpec>,
    /// (J, J⁻¹) where the two differ.
    map: Option<(DMatrix<f64>, DMatrix<f64>)>,
    layout: ObsLayout,
    /// The robot's motor positions in its stand keyframe (what actions are offsets from).
    nominal_motors: Vec<f64>,
    obs_buf: Vec<f32>,
    act_buf: Vec<f32>,
}

/// The spec a policy file names: its `robot`, a spec path or a bundled robot's name.
fn policy_robot(meta: &trainer::policy_file::PolicyMeta) -> Result<PathBuf> {
    let named = meta.robot.as_deref().filter(|r| r.ends_with(".toml"));
    Ok(match named {
        Some(r) => assets::robot_path(r),
        None => {
            assets::robot_path(ModelKind::of_policy(meta.robot.as_deref()).map_err(anyhow::Error::msg)?.spec_path())
        }
    })
}

impl PolicyRunner {
    pub fn load(path: &Path, name: &str) -> Result<Self> {
        let policy = Policy::load(path)?;
        let m = &policy.meta;
        let spec_path = policy_robot(m).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        let (trained_on, trained_model) = RobotSpec::load(&spec_path)?;
        let (robot, model) = match &trained_on.approximates {
            Some(real) => RobotSpec::load(real)?,
            None => (trained_on.clone(), trained_model),
        };
        let n = robot.n_motors();
        let layout = ObsLayout::new(n);
        if m.obs_dim != layout.dim() || m.action_dim != n {
            bail!(
                "{}: a {}→{} policy cannot drive {} ({} observations → {n} motor targets)",
                path.display(),
                m.obs_dim,
                m.action_dim,
                robot.name,
                layout.dim()
            );
        }
        let map = if trained_on.approximates.is_some() {
            for (a, b) in trained_on.motors.iter().zip(&robot.motors) {
                if a.drives != b.joint {
                    bail!(
                        "{}: its motor '{}' drives '{}', not {}'s joint '{}'",
                        trained_on.name,
                        a.actuator,
                        a.drives,
                        robot.name,
                        b.joint
                    );
                }
            }
            let joint_map = JointMap::new(&robot, &model)?;
            let (Some(j), Some(inv)) = (joint_map.matrix(n), joint_map.inverse_matrix(n)) else {
                bail!(
                    "{}: a policy trained on {} needs {}'s linkage to be linear to map its joint-space actions; \
                     this one is nonlinear",
                    path.display(),
                    trained_on.name,
                    robot.name
                );
            };
            Some((j, inv))
        } else {
            None
        };
        let robot = Arc::new(robot);
        let nominal_motors = RobotIndices::resolve(&model, &robot)?.nominal_actuated;
        Ok(PolicyRunner {
            policy,
            name: name.to_string(),
            trained_on: Arc::new(trained_on),
            robot,
            map,
            layout,
            nominal_motors,
            obs_buf: Vec::new(),
            act_buf: Vec::new(),
        })
    }

    /// The name of the robot spec the policy was trained on (e.g. topa_open for the paper's O).
    pub fn trained_on(&self) -> &str {
        &self.trained_on.name
    }

    /// The robot it is evaluated on.
    pub fn robot(&self) -> &RobotSpec {
        &self.robot
    }

    /// The robot's observation layout (what `act` takes).
    pub fn layout(&self) -> ObsLayout {
        self.layout
    }

    /// (J, J⁻¹) between the robot's motor space and the joint space the policy acts in, where the two differ.
    pub fn joint_map(&self) -> Option<&(DMatrix<f64>, DMatrix<f64>)> {
        self.map.as_ref()
    }

    /// The robot's motor positions in its stand pose, rad.
    pub fn nominal_motors(&self) -> &[f64] {
        &self.nominal_motors
    }

    /// The env config to evaluate this policy with: its training config made deterministic, on the closed
    /// model, at the evaluation timestep and the policy's own control period.
    pub fn eval_config(&self, s: &EvalSettings) -> Result<EnvConfig> {
        let train = EnvConfig::from_table(&self.policy.meta.provenance.config.env)?;
        let mut c = train.for_evaluation();
        c.robot = self.robot.path.to_string_lossy().into_owned();
        c.integrator = s.integrator;
        // The evaluation model is the MJCF's: training's solver shortcuts stay in training.
        c.solver_iterations = None;
        c.solver_tolerance = None;
        c.timestep = s.timestep();
        c.sim2sim = s.sim2sim.clone();
        let dec = self.policy.meta.policy_dt / c.timestep;
        if (dec - dec.round()).abs() > 1e-6 || dec.round() < 1.0 {
            bail!(
                "the evaluation timestep {} s does not divide the policy period {} s",
                c.timestep,
                self.policy.meta.policy_dt
            );
        }
        c.decimation = dec.round() as usize;
        c.episode_length_s = 1e9; // experiments end runs themselves
        c.action_scale = self.policy.meta.action_scale;
        c.action_clip = self.policy.meta.action_clip;
        c.validate()?;
        Ok(c)
    }

    /// Actions (the robot's motor space) for the robot's observations, row by row.
    pub fn act(&mut self, obs: &[f32], actions: &mut Vec<f32>) {
        let Some((j, inv)) = &self.map else {
            return self.policy.act(obs, actions);
        };
        let l = self.layout;
        let n = l.n_motors;
        let apply = |m: &DMatrix<f64>, v: &[f32], out: &mut [f32]| {
            for (i, o) in out.iter_mut().enumerate() {
                *o = (0..n).fold(0.0, |acc, k| acc + m[(i, k)] * v[k] as f64) as f32;
            }
        };
        self.obs_buf.clear();
        self.obs_buf.extend_from_slice(obs);
        let mut tmp = vec![0.0f32; n];
        for row in self.obs_buf.chunks_exact_mut(l.dim()) {
            for block in [Block::MotorPos, Block::MotorVel, Block::LastAction] {
                let at = l.offset(block);
                apply(j, &row[at..at + n], &mut tmp);
                row[at..at + n].copy_from_slice(&tmp);
            }
        }
        self.policy.act(&self.obs_buf, &mut self.act_buf);
        actions.clear();
        for a in self.act_buf.chunks_exact(n) {
            apply(inv, a, &mut tmp);
            actions.extend_from_slice(&tmp);
        }
    }
}

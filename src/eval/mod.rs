//! Sim2sim evaluation (paper, "Ablation study" and "Robustness evaluation"): every experiment runs on the
//! **closed** model with settings that differ from training on purpose — finer physics timestep, the MJCF's
//! exact integrator, no domain randomisation, no observation noise, no pushes — so that a policy's score is a
//! transfer, not a replay. A policy trained on the open model is run through the paper's map M.

pub mod ablate;
pub mod gait;
pub mod groups;
pub mod noise;
pub mod push;
pub mod report;
pub mod runner;
pub mod tracking;

use std::path::Path;

use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};
use topa_env::env::{OBS_LAST_ACTION, OBS_Q, OBS_QD};
use topa_env::robot::{self, ModelKind, N_MOTORS};
use topa_env::sim2sim::Sim2SimConfig;
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

/// A policy ready to act on the closed model: motor-space policies directly, joint-space (open-model) policies
/// through M: observed motor positions, velocities and previous actions are mapped to joint space with M, and
/// the joint-space action back to motor space with M⁻¹ (motor targets = M⁻¹ · joint targets, since the
/// nominal pose maps the same way).
pub struct PolicyRunner {
    pub policy: Policy,
    pub name: String,
    trained_on: ModelKind,
    obs_buf: Vec<f32>,
    act_buf: Vec<f32>,
}

impl PolicyRunner {
    pub fn load(path: &Path, name: &str) -> Result<Self> {
        let policy = Policy::load(path)?;
        let m = &policy.meta;
        let trained_on = ModelKind::of_policy(m.robot.as_deref(), m.model.as_deref())
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        if m.obs_dim != topa_env::env::OBS_DIM || m.action_dim != N_MOTORS {
            bail!(
                "{}: a {}→{} policy cannot drive TopA (42 observations → 10 motor targets)",
                path.display(),
                m.obs_dim,
                m.action_dim
            );
        }
        Ok(PolicyRunner { policy, name: name.to_string(), trained_on, obs_buf: Vec::new(), act_buf: Vec::new() })
    }

    pub fn trained_on(&self) -> ModelKind {
        self.trained_on
    }

    /// The env config to evaluate this policy with: its training config made deterministic, on the closed
    /// model, at the evaluation timestep and the policy's own control period.
    pub fn eval_config(&self, s: &EvalSettings) -> Result<EnvConfig> {
        let train = EnvConfig::from_table(&self.policy.meta.provenance.config.env)?;
        let mut c = train.for_evaluation();
        c.model = ModelKind::Closed;
        c.integrator = s.integrator;
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

    /// Actions (motor space) for closed-model observations, rows × 42 → rows × 10.
    pub fn act(&mut self, obs: &[f32], actions: &mut Vec<f32>) {
        match self.trained_on {
            ModelKind::Closed => self.policy.act(obs, actions),
            ModelKind::Open => {
                self.obs_buf.clear();
                self.obs_buf.extend_from_slice(obs);
                for row in self.obs_buf.chunks_exact_mut(topa_env::env::OBS_DIM) {
                    for block in [OBS_Q, OBS_QD, OBS_LAST_ACTION] {
                        let v: [f32; N_MOTORS] = row[block..block + N_MOTORS].try_into().unwrap();
                        row[block..block + N_MOTORS].copy_from_slice(&robot::motor_to_joint(&v));
                    }
                }
                self.policy.act(&self.obs_buf, &mut self.act_buf);
                actions.clear();
                for a in self.act_buf.chunks_exact(N_MOTORS) {
                    let a: [f32; N_MOTORS] = a.try_into().unwrap();
                    actions.extend_from_slice(&robot::joint_to_motor(&a));
                }
            }
        }
    }
}

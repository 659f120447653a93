//! The evaluation's settings, shared by every experiment: physics timestep and integrator, the sim2sim models,
//! settling, threads, seed; and the env config a policy is evaluated with.

use std::path::PathBuf;

use crate::error::{invalid, Error, Result};
use serde::{Deserialize, Serialize};
use topa_env::physics::PhysicsConfig;
use topa_env::policy_runner::PolicyRunner;
use topa_env::sim2sim::Sim2SimConfig;
use topa_env::EnvConfig;

/// Settings shared by the experiments.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EvalSettings {
    /// Physics timestep, s (training: 0.005). The policy period is kept: decimation = policy_dt / timestep.
    /// `None`: the sim2sim mode's own timestep if it has one, else 0.0025.
    pub timestep: Option<f64>,
    /// Which sim2sim models `sim2sim` holds.
    pub sim2sim_mode: Sim2SimMode,
    /// The sensor, estimator, latency and motor models (all off: ideal).
    pub sim2sim: Sim2SimConfig,
    /// Model = the sim2sim mode's own if it names one, else the MJCF's RK4.
    pub integrator: topa_env::IntegratorChoice,
    /// Standing still on a zero command before each experiment starts, s.
    pub settle_s: f64,
    /// Worker threads (0 = all cores).
    pub threads: usize,
    pub seed: u64,
    /// The simulator's physics on top of the policy's training physics (`topa physics`' perturbations).
    #[serde(default, skip_serializing_if = "PhysicsConfig::is_nominal")]
    pub physics: PhysicsConfig,
    /// Constraint solver iterations (None: the MJCF's; training's shortcut stays in training).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solver_iterations: Option<usize>,
}

/// The realistic mode's models (configs/sim2sim/realistic.toml, built in).
const REALISTIC: &str = include_str!("../../configs/sim2sim/realistic.toml");

impl EvalSettings {
    /// The env config to evaluate `runner`'s policy with: its training config made deterministic, on the
    /// robot it runs on, at the evaluation timestep and the policy's own control period.
    pub fn env_config(&self, runner: &PolicyRunner) -> Result<EnvConfig> {
        let s = self;
        let mut c = runner.training_config().for_evaluation();
        c.robot = runner.robot().path.to_string_lossy().into_owned();
        c.integrator = s.integrator();
        // The evaluation model is the MJCF's: training's solver shortcuts stay in training.
        c.solver_iterations = s.solver_iterations;
        c.physics = c.physics.then(&s.physics);
        c.solver_tolerance = None;
        c.timestep = s.timestep();
        c.sim2sim = s.sim2sim.clone();
        let dec = runner.policy.meta.policy_dt / c.timestep;
        if (dec - dec.round()).abs() > 1e-6 || dec.round() < 1.0 {
            invalid!(
                "the evaluation timestep {} s does not divide the policy period {} s",
                c.timestep,
                runner.policy.meta.policy_dt
            );
        }
        c.decimation = dec.round() as usize;
        c.episode_length_s = 1e9; // experiments end runs themselves
        c.action_scale = runner.policy.meta.action_scale;
        c.action_clip = runner.policy.meta.action_clip;
        c.validate()?;
        Ok(c)
    }

    /// The physics timestep the experiments run at.
    /// Whether results made with `other` are comparable with results made with these: every setting but the thread
    /// count (results do not depend on it).
    pub fn same_results_as(&self, other: &EvalSettings) -> Result<bool> {
        let comparable = |s: &EvalSettings| -> Result<serde_json::Value> {
            let mut v = serde_json::to_value(s)?;
            v.as_object_mut().map(|o| o.remove("threads"));
            Ok(v)
        };
        Ok(comparable(self)? == comparable(other)?)
    }

    /// The integrator the experiments run with: the one asked for, else the sim2sim mode's, else the MJCF's.
    pub fn integrator(&self) -> topa_env::IntegratorChoice {
        match self.integrator {
            topa_env::IntegratorChoice::Model => self.sim2sim.integrator,
            chosen => chosen,
        }
    }

    pub fn timestep(&self) -> f64 {
        self.timestep.unwrap_or(if self.sim2sim.timestep > 0.0 { self.sim2sim.timestep } else { 0.0025 })
    }

    /// Sets the sim2sim mode and loads its models.
    pub fn with_sim2sim(mut self, mode: &Sim2SimMode) -> Result<Self> {
        let cfg = match mode {
            Sim2SimMode::Ideal => Sim2SimConfig::default(),
            Sim2SimMode::Realistic => {
                toml::from_str(REALISTIC).map_err(|e| Error::file("built-in configs/sim2sim/realistic.toml", e))?
            }
            Sim2SimMode::File(file) => {
                let table = trainer::config::load_table(file, 0)?;
                toml::Value::Table(table).try_into().map_err(|e: toml::de::Error| {
                    Error::bad_file(format!("sim2sim file {}: {}", file.display(), e.to_string().replace('\n', " ")))
                })?
            }
        };
        cfg.validate().map_err(|e| Error::Invalid(format!("sim2sim '{mode}': {e}")))?;
        self.sim2sim = cfg;
        self.sim2sim_mode = mode.clone();
        Ok(self)
    }
}

/// The sim2sim models an evaluation runs with: none (the simulator's state), the built-in realistic set
/// (configs/sim2sim/realistic.toml), or a TOML file of models (which may start from another with `base = "…"`).
/// Written as "ideal", "realistic" or the file's path, on the command line and in result files.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(into = "String", from = "String")]
pub enum Sim2SimMode {
    Ideal,
    Realistic,
    File(PathBuf),
}

impl From<String> for Sim2SimMode {
    fn from(s: String) -> Self {
        match s.as_str() {
            "ideal" => Sim2SimMode::Ideal,
            "realistic" => Sim2SimMode::Realistic,
            _ => Sim2SimMode::File(PathBuf::from(s)),
        }
    }
}

impl From<Sim2SimMode> for String {
    fn from(m: Sim2SimMode) -> String {
        m.to_string()
    }
}

impl std::str::FromStr for Sim2SimMode {
    type Err = std::convert::Infallible;
    fn from_str(s: &str) -> std::result::Result<Self, Self::Err> {
        Ok(Sim2SimMode::from(s.to_string()))
    }
}

impl std::fmt::Display for Sim2SimMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Sim2SimMode::Ideal => f.write_str("ideal"),
            Sim2SimMode::Realistic => f.write_str("realistic"),
            Sim2SimMode::File(p) => write!(f, "{}", p.display()),
        }
    }
}

impl Default for EvalSettings {
    fn default() -> Self {
        EvalSettings {
            timestep: None,
            sim2sim_mode: Sim2SimMode::Ideal,
            sim2sim: Sim2SimConfig::default(),
            integrator: topa_env::IntegratorChoice::Model,
            settle_s: 2.0,
            threads: 0,
            seed: 1,
            physics: PhysicsConfig::default(),
            solver_iterations: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sim2sim_modes_are_written_as_before() {
        for (mode, text) in [
            (Sim2SimMode::Ideal, "\"ideal\""),
            (Sim2SimMode::Realistic, "\"realistic\""),
            (Sim2SimMode::File("configs/sim2sim/realistic.toml".into()), "\"configs/sim2sim/realistic.toml\""),
        ] {
            assert_eq!(serde_json::to_string(&mode).unwrap(), text);
            assert_eq!(serde_json::from_str::<Sim2SimMode>(text).unwrap(), mode);
        }
        let missing = EvalSettings::default().with_sim2sim(&Sim2SimMode::File("no/such.toml".into()));
        assert!(crate::error::chain(&missing.unwrap_err()).contains("no/such.toml"));
    }

    #[test]
    fn the_integrator_asked_for_wins_over_the_modes_which_wins_over_the_mjcfs() {
        use topa_env::IntegratorChoice::*;
        let ideal = EvalSettings::default().with_sim2sim(&Sim2SimMode::Ideal).unwrap();
        assert_eq!((ideal.integrator(), ideal.timestep()), (Model, 0.0025));
        let realistic = EvalSettings::default().with_sim2sim(&Sim2SimMode::Realistic).unwrap();
        assert_eq!((realistic.integrator(), realistic.timestep()), (Euler, 0.001));
        let rk4 = EvalSettings { integrator: Rk4, ..EvalSettings::default() }.with_sim2sim(&Sim2SimMode::Realistic);
        assert_eq!(rk4.unwrap().integrator(), Rk4);
        // A mode file may name its own; a misspelt one is refused naming the file.
        let dir = std::env::temp_dir().join(format!("topa-integrator-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (own, bad) = (dir.join("own.toml"), dir.join("bad.toml"));
        std::fs::write(&own, "integrator = \"implicit\"\n").unwrap();
        std::fs::write(&bad, "integrator = \"verlet\"\n").unwrap();
        let s = EvalSettings::default().with_sim2sim(&Sim2SimMode::File(own)).unwrap();
        assert_eq!((s.integrator(), s.timestep()), (Implicit, 0.0025));
        let e = EvalSettings::default().with_sim2sim(&Sim2SimMode::File(bad.clone())).unwrap_err();
        let e = crate::error::chain(&e);
        assert!(e.contains(&bad.display().to_string()), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

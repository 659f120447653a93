//! Environment configuration. Defaults are the paper's tables (rewards, domain randomisation) plus the settings
//! the paper leaves open (σ's, command ranges, termination), each chosen and explained here. Read from TOML with
//! unknown keys rejected.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::{EnvError, Result};
pub use crate::integrator::IntegratorChoice;
use crate::topa::ModelKind;

/// The task's settings: the robot, its simulation, commands, rewards, noise, randomisation, pushes, termination,
/// the realistic-sim2sim models and the adversary's bounds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct EnvConfig {
    /// What is trained: the robot (default), or the cart-pole (a one-minute check of an install or a cluster).
    pub task: TaskKind,
    /// The robot: its spec file (a path from the working folder or the repository root), e.g. TopA's closed
    /// chain `assets/robots/topa_closed.toml` (the paper's C) or its serial approximation `topa_open.toml` (O).
    pub robot: String,
    /// Physics timestep, s (paper: policy 50 Hz; 0.005 × 4 = 20 ms).
    pub timestep: f64,
    /// Physics steps per policy step.
    pub decimation: usize,
    /// Integrator override: "model" keeps the MJCF's (RK4: the loop stays within 3e-4 rad under any motor
    /// targets), "euler" is ~3.5× faster per step (loop error up to ~1e-2 rad on hard-stop impacts), "rk4",
    /// "implicit".
    pub integrator: IntegratorChoice,
    /// Override of the MJCF's constraint-solver iterations (none: the model's; TopA's MJCF has 50).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub solver_iterations: Option<usize>,
    /// Override of the MJCF's solver tolerance (none: the model's; TopA's MJCF has 1e-10).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub solver_tolerance: Option<f64>,
    /// Episode length before a time-out, s.
    pub episode_length_s: f64,
    /// Motor target = nominal + action_scale · action, rad per unit action.
    pub action_scale: f64,
    /// Actions are clipped to ±action_clip before scaling (the decay loss keeps them far smaller).
    pub action_clip: f64,
    /// The velocity commands the policy is trained to follow.
    pub commands: CommandConfig,
    /// Reward weights (paper: Table "Rewards") and the kernels' σ's.
    pub rewards: RewardConfig,
    /// Observation noise (paper: Table "Overview of Domain Randomization").
    pub noise: ObsNoiseConfig,
    /// Per-episode friction and mass randomisation (paper: Table "Overview of Domain Randomization").
    pub domain_rand: DomainRandConfig,
    /// Random velocity kicks of the torso (paper: push velocity [0.0, 2.5] m/s, "add").
    pub push: PushConfig,
    /// When an episode ends in a fall.
    pub termination: TerminationConfig,
    /// Realistic sim2sim: state estimator, sensor noise, latency, torque–speed limits (default: all off, the
    /// ideal simulator). In training, `[env.sim2sim.estimator] enabled = true` trains on the estimator's output.
    pub sim2sim: crate::sim2sim::Sim2SimConfig,
    /// The simulator's physics relative to the MJCF's: contact model, solver, friction, motor and torso
    /// parameters, sole shape (default: the MJCF's).
    pub physics: crate::physics::PhysicsConfig,
    /// How far the cyclic adversary may perturb (its channels' bounds).
    pub adversary: AdversaryBounds,
    /// Rough terrain instead of the flat floor (default off: the paper's flat ground).
    pub terrain: crate::terrain::TerrainConfig,
    /// Ground heights around the robot as extra observation values (default off: the paper's blind policy).
    pub height_scan: crate::terrain::HeightScanConfig,
    /// What the policy reads beyond the paper's blocks: without the base velocity, with earlier frames (default:
    /// the paper's observation).
    pub observation: crate::observation::ObservationConfig,
}

/// What is trained.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum TaskKind {
    /// The robot of `robot` (any spec).
    #[default]
    #[serde(alias = "topa")] // what configs said before other robots existed
    Robot,
    Cartpole,
}

/// Bounds of the adversary's perturbations (ours: the paper publishes none; see assets/policies/README.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct AdversaryBounds {
    /// Largest offset of each commanded value (v_x, v_y, w_z), m/s, m/s, rad/s.
    pub max_command_offset: [f64; 3],
    /// Largest tilt of the observed gravity vector, rad.
    pub max_gravity_tilt: f64,
    /// Largest force on each foot, N.
    pub max_foot_force: f64,
    /// Bound of each perturbation value of tasks without their own bounds (the cart-pole's push on the pole, N).
    pub generic_bound: f64,
    /// How long the command offset is held, s: 0 lets it change at every policy step (50 Hz); above 0 it takes
    /// the adversary's value only every `command_hold_s` of an episode (an operator's command changes, not jitter).
    pub command_hold_s: f64,
    /// Keeps a turn in place one under attack: while the env's own command has no linear part and a yaw rate,
    /// the adversary's linear command offset is dropped (its yaw offset still applies). Off, an attacked env never
    /// sees a pure turn in place.
    pub pure_turns_in_place: bool,
}

impl Default for AdversaryBounds {
    fn default() -> Self {
        AdversaryBounds {
            max_command_offset: [0.3, 0.2, 0.5],
            max_gravity_tilt: 0.1,
            max_foot_force: 20.0,
            generic_bound: 1.0,
            command_hold_s: 0.0,
            pure_turns_in_place: false,
        }
    }
}

impl Default for EnvConfig {
    fn default() -> Self {
        EnvConfig {
            task: TaskKind::Robot,
            robot: ModelKind::Closed.spec_path().into(),
            timestep: 0.005,
            decimation: 4,
            integrator: IntegratorChoice::Model,
            solver_iterations: None,
            solver_tolerance: None,
            episode_length_s: 20.0,
            action_scale: 0.25,
            action_clip: 10.0,
            commands: CommandConfig::default(),
            rewards: RewardConfig::default(),
            noise: ObsNoiseConfig::default(),
            domain_rand: DomainRandConfig::default(),
            push: PushConfig::default(),
            termination: TerminationConfig::default(),
            sim2sim: Default::default(),
            physics: Default::default(),
            adversary: AdversaryBounds::default(),
            terrain: crate::terrain::TerrainConfig::default(),
            height_scan: crate::terrain::HeightScanConfig::default(),
            observation: crate::observation::ObservationConfig::default(),
        }
    }
}

impl EnvConfig {
    /// The `[env]` table of a training config, checked: unknown keys and bad values are errors naming them.
    /// Earlier builds named TopA's model (`model = "closed"`/`"open"`): that becomes its spec.
    pub fn from_table(t: &toml::Table) -> Result<EnvConfig> {
        let mut t = t.clone();
        if let Some(m) = t.remove("model") {
            let kind: ModelKind =
                m.as_str().unwrap_or("").parse().map_err(|e: EnvError| {
                    EnvError::Config(format!("[env] model: {e} (or name a spec: robot = \"…\")"))
                })?;
            t.entry("robot").or_insert_with(|| toml::Value::String(kind.spec_path().into()));
        }
        let cfg: EnvConfig = toml::Value::Table(t)
            .try_into()
            .map_err(|e: toml::de::Error| EnvError::Config(format!("[env]: {}", e.to_string().trim_end())))?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Back to a table (to store in a training config).
    pub fn to_table(&self) -> toml::Table {
        toml::Table::try_from(self).expect("an EnvConfig is always a TOML table")
    }
}

/// Velocity commands (v_x, v_y, w_z) in the robot frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct CommandConfig {
    /// Range of the forward velocity command v_x, m/s (the ranges cover the paper's evaluation commands 0.5,
    /// −0.35, ±0.5 m/s and ±1 rad/s with a margin).
    pub lin_vel_x: [f64; 2],
    /// Range of the sideways velocity command v_y, m/s.
    pub lin_vel_y: [f64; 2],
    /// Range of the yaw-rate command w_z, rad/s.
    pub ang_vel_z: [f64; 2],
    /// A new command every this many seconds within an episode, s.
    pub resample_s: f64,
    /// Share of commands that are "stand still" (all zero).
    pub standing_share: f64,
    /// Share of commands that turn in place (v_x = v_y = 0, w_z drawn from `ang_vel_z`); ours, not in the paper:
    /// uniform draws almost never give a pure turn, the command the policies learn last.
    pub turn_share: f64,
    /// Linear commands below this norm are zeroed (a tiny command is indistinguishable from standing), m/s.
    pub min_lin_norm: f64,
}

impl Default for CommandConfig {
    fn default() -> Self {
        CommandConfig {
            lin_vel_x: [-0.5, 0.7],
            lin_vel_y: [-0.6, 0.6],
            ang_vel_z: [-1.2, 1.2],
            resample_s: 5.0,
            standing_share: 0.1,
            turn_share: 0.0,
            min_lin_norm: 0.05,
        }
    }
}

/// The 14 reward terms of the paper (Table "Rewards"): weights exactly as published, σ's ours.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct RewardConfig {
    /// Weight of the linear velocity tracking term exp(−‖v_xy^cmd − v_xy‖²/σ_v) (paper: 3.0).
    pub lin_vel_xy_tracking: f64,
    /// Weight of the yaw-rate tracking term exp(−(ω_z^cmd − ω_z)²/σ_ω) (paper: 1.5).
    pub ang_vel_z_tracking: f64,
    /// Weight of the vertical velocity term v_z² (paper: −1.0).
    pub lin_vel_z: f64,
    /// Weight of the roll and pitch rate term ‖ω_xy‖² (paper: −0.5).
    pub ang_vel_xy: f64,
    /// Weight of the orientation term exp(−‖g_xy‖²/σ_g) (paper: 1.0).
    pub orientation: f64,
    /// Weight of the body-height term exp(−(h_target − h)²/σ_h) (paper: 1.0).
    pub body_height: f64,
    /// Weight of the action-rate term ‖a_t − a_{t−1}‖² (paper: −2.0).
    pub action_rate: f64,
    /// Weight of the hip-roll deviation term exp(−θ_hip_roll²/σ_roll) (paper: 0.5).
    pub hip_roll_deviation: f64,
    /// Weight of the hip-yaw deviation term exp(−θ_hip_yaw²/σ_yaw) (paper: 0.5).
    pub hip_yaw_deviation: f64,
    /// Weight of the ankle-pitch deviation term exp(−θ_ankle_pitch²/σ_pitch) (paper: 0.5).
    pub ankle_pitch_deviation: f64,
    /// Weight of the joint-limit term Σ ReLU beyond the soft joint limits (paper: −5.0).
    pub joint_position_limits: f64,
    /// Weight of the torque-limit term Σ ReLU(|τ| − soft limit) (paper: −1e-3).
    pub motor_torque_limits: f64,
    /// Weight of the feet-slip term Σ ‖v_foot‖ of the feet in contact (paper: −1.0).
    pub feet_slip: f64,
    /// Weight of the feet-air-time term in the form `air_time_form` names (paper: 0.5).
    pub feet_air_time: f64,
    /// Ours, not in the paper (0 there): a foot-clearance term in the form `clearance_form` names.
    pub feet_clearance: f64,
    /// h*, the sole height a moving foot should reach, m.
    pub clearance_target: f64,
    /// σ of the feet-clearance kernel, m².
    pub sigma_clearance: f64,
    /// How the feet-clearance term turns foot heights into reward (see `ClearanceForm`).
    pub clearance_form: ClearanceForm,
    /// σ_v of the linear tracking kernel, (m/s)².
    pub sigma_v: f64,
    /// σ_ω of the yaw-rate tracking kernel, (rad/s)².
    pub sigma_w: f64,
    /// σ_g of the orientation kernel on ‖g_xy‖².
    pub sigma_g: f64,
    /// σ_h of the body-height kernel, m².
    pub sigma_h: f64,
    /// σ_roll of the hip-roll deviation kernel (deviation from the nominal pose, both legs' squares summed), rad².
    pub sigma_roll: f64,
    /// σ_yaw of the hip-yaw deviation kernel (both legs' squares summed), rad².
    pub sigma_yaw: f64,
    /// σ_pitch of the ankle-pitch deviation kernel (both legs' squares summed), rad².
    pub sigma_pitch: f64,
    /// Torso height target h_target, m; 0 = the robot spec's `base_height_target` (TopA: the stand keyframe's
    /// pelvis height, 0.5607 m).
    pub base_height_target: f64,
    /// Air time the feet-air-time term is centred on, s (paper: 0.5).
    pub air_time_target: f64,
    /// Joint limits for the penalty are this fraction of the range, centred (soft limits).
    pub soft_joint_limit: f64,
    /// Torque limits for the penalty are this fraction of each motor's peak torque.
    pub soft_torque_limit: f64,
    /// Multiply each step's reward by the policy period (rewards per second, as legged_gym/rsl_rl do).
    pub scale_by_dt: bool,
    /// Clip each step's total reward at zero from below (legged_gym's `only_positive_rewards`), so that early
    /// in training, when penalties dominate, ending an episode early never pays. Not in the paper; off by default.
    pub only_positive_rewards: bool,
    /// How the feet-air-time term turns a touchdown's air time into reward (see `AirTimeForm`).
    pub air_time_form: AirTimeForm,
}

/// The feet-air-time equation. The paper prints Σ|t_air − 0.5|·𝟙_touchdown with weight +0.5, which pays most for
/// the shortest steps (≈ 0.46 per 40 ms shuffle step) as well as for the longest.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum AirTimeForm {
    /// The paper's equation as printed: Σ|t_air − target|.
    Abs,
    /// legged_gym's Σ(t_air − target), only while a motion is commanded (‖c‖ > 0.1): steps shorter than the
    /// target cost, longer ones pay.
    Signed,
    /// The paper's equation with its sign turned: −Σ|t_air − target| (with the positive weight, a penalty that is
    /// zero for steps of exactly the target air time).
    NegAbs,
    /// IsaacLab's `feet_air_time_positive_biped` (the paper trained in IsaacLab): every step in single stance
    /// pays the shorter of the two feet's time in their current mode (stance or swing), capped at the target,
    /// while a motion is commanded (‖c‖ > 0.1, yaw included so that turning in place steps too).
    PositiveBiped,
}

/// The feet-clearance equation (ours; the paper has no such term).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ClearanceForm {
    /// exp(−Σ_f max(0, h* − h_f)²·tanh(2‖v_f‖)/σ): feet moving over the ground below h* cost, feet at rest or
    /// above it do not (IsaacLab's foot-clearance shape). Measured: standing still is its optimum
    /// (docs/results/experiments.md).
    #[default]
    Kernel,
    /// Σ_f 𝟙(foot f in the air)·min(h_f, h*)/h* while a motion is commanded: pays for lifting a swing foot up to
    /// h*, nothing for standing (with a positive weight, a reward for stepping high instead of a charge for not).
    SwingHeight,
}

impl Default for RewardConfig {
    fn default() -> Self {
        RewardConfig {
            lin_vel_xy_tracking: 3.0,
            ang_vel_z_tracking: 1.5,
            lin_vel_z: -1.0,
            ang_vel_xy: -0.5,
            orientation: 1.0,
            body_height: 1.0,
            action_rate: -2.0,
            hip_roll_deviation: 0.5,
            hip_yaw_deviation: 0.5,
            ankle_pitch_deviation: 0.5,
            joint_position_limits: -5.0,
            motor_torque_limits: -1e-3,
            feet_slip: -1.0,
            feet_air_time: 0.5,
            feet_clearance: 0.0,
            clearance_target: 0.06,
            sigma_clearance: 0.0025,
            sigma_v: 0.25,
            sigma_w: 0.25,
            sigma_g: 0.05,
            sigma_h: 0.002,
            // Wide enough that walking sideways (hip roll ≈ 0.1 rad), turning (hip yaw ≈ 0.2 rad) and pushing
            // off (ankle ≈ ±0.3 rad) keep most of these rewards: tighter kernels made standing still the optimum.
            sigma_roll: 0.1,
            sigma_yaw: 0.1,
            sigma_pitch: 0.3,
            base_height_target: 0.0,
            air_time_target: 0.5,
            soft_joint_limit: 0.95,
            soft_torque_limit: 0.8,
            scale_by_dt: true,
            only_positive_rewards: false,
            air_time_form: AirTimeForm::Abs,
            clearance_form: ClearanceForm::Kernel,
        }
    }
}

/// Observation noise, uniform in ±value and added (paper, Table "Domain randomization").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ObsNoiseConfig {
    /// Add the noise (false: exact observations).
    pub enabled: bool,
    /// Noise bound of the base linear velocity, m/s (paper: 0.1).
    pub lin_vel: f64,
    /// Noise bound of the base angular velocity, rad/s (paper: 0.2).
    pub ang_vel: f64,
    /// Noise bound of the motor positions, rad (paper: 0.01).
    pub motor_pos: f64,
    /// Noise bound of the motor velocities, rad/s (paper: 1.5).
    pub motor_vel: f64,
    /// Noise bound of the gravity vector's components (unit vector; not in the paper's table, 0 = off).
    pub gravity: f64,
}

impl Default for ObsNoiseConfig {
    fn default() -> Self {
        ObsNoiseConfig { enabled: true, lin_vel: 0.1, ang_vel: 0.2, motor_pos: 0.01, motor_vel: 1.5, gravity: 0.0 }
    }
}

use crate::domain_rand::check_range;
pub use crate::domain_rand::DomainRandConfig;

/// Random pushes: the base's horizontal velocity gets a kick of random direction and magnitude.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct PushConfig {
    /// Kick the robot (false: no pushes).
    pub enabled: bool,
    /// Kick magnitude range, m/s (paper: [0, 2.5], "add").
    pub velocity: [f64; 2],
    /// Time between kicks, s.
    pub interval_s: f64,
    /// Curriculum: the largest kick grows linearly from this to `velocity[1]` over the first `curriculum_s` of
    /// each env's experience, m/s.
    pub curriculum_start: f64,
    /// Length of the push curriculum in each env's experience, s (0 = no curriculum: the full range from the start).
    pub curriculum_s: f64,
}

impl Default for PushConfig {
    fn default() -> Self {
        PushConfig { enabled: true, velocity: [0.0, 2.5], interval_s: 8.0, curriculum_start: 0.0, curriculum_s: 0.0 }
    }
}

impl PushConfig {
    /// The largest kick after `experience_s` seconds of an env's experience.
    pub fn max_velocity(&self, experience_s: f64) -> f64 {
        if self.curriculum_s <= 0.0 {
            return self.velocity[1];
        }
        let f = (experience_s / self.curriculum_s).min(1.0);
        self.curriculum_start + (self.velocity[1] - self.curriculum_start) * f
    }
}

/// When an episode ends in a fall.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct TerminationConfig {
    /// A fall ends the episode (false: the episode goes on with the robot on the floor, as an evaluation that
    /// keeps measuring after a fall needs; `RobotEnv::has_fallen` still tells).
    pub enabled: bool,
    /// Torso origin below this height, m.
    pub min_base_height: f64,
    /// Roll or pitch beyond this, rad.
    pub max_tilt: f64,
    /// Any robot body other than the feet touching the floor ends the episode.
    pub body_contact: bool,
}

impl Default for TerminationConfig {
    fn default() -> Self {
        TerminationConfig { enabled: true, min_base_height: 0.3, max_tilt: 1.0, body_contact: true }
    }
}

fn check_positive(name: &str, v: f64) -> Result<()> {
    if !(v.is_finite() && v > 0.0) {
        return Err(EnvError::Config(format!("{name} must be positive, got {v}")));
    }
    Ok(())
}

fn check_share(name: &str, v: f64) -> Result<()> {
    if !(0.0..=1.0).contains(&v) {
        return Err(EnvError::Config(format!("{name} must be in [0, 1], got {v}")));
    }
    Ok(())
}

impl EnvConfig {
    /// Rejects values the env cannot run with, naming the key.
    pub fn validate(&self) -> Result<()> {
        check_positive("timestep", self.timestep)?;
        if self.decimation == 0 {
            return Err(EnvError::Config("decimation must be at least 1".into()));
        }
        if self.solver_iterations == Some(0) {
            return Err(EnvError::Config("solver_iterations must be at least 1 (leave it out for the model's)".into()));
        }
        if let Some(t) = self.solver_tolerance {
            check_positive("solver_tolerance", t)?;
        }
        check_positive("episode_length_s", self.episode_length_s)?;
        check_positive("action_scale", self.action_scale)?;
        check_positive("action_clip", self.action_clip)?;
        check_range("commands.lin_vel_x", self.commands.lin_vel_x)?;
        check_range("commands.lin_vel_y", self.commands.lin_vel_y)?;
        check_range("commands.ang_vel_z", self.commands.ang_vel_z)?;
        check_positive("commands.resample_s", self.commands.resample_s)?;
        let c = &self.commands;
        check_share("commands.standing_share", c.standing_share)?;
        check_share("commands.turn_share", c.turn_share)?;
        if c.standing_share + c.turn_share > 1.0 {
            return Err(EnvError::Config(format!(
                "commands.standing_share + commands.turn_share = {} must be at most 1: lower one of them",
                c.standing_share + c.turn_share
            )));
        }
        let r = &self.rewards;
        for (name, v) in [
            ("rewards.sigma_v", r.sigma_v),
            ("rewards.sigma_w", r.sigma_w),
            ("rewards.sigma_g", r.sigma_g),
            ("rewards.sigma_h", r.sigma_h),
            ("rewards.sigma_roll", r.sigma_roll),
            ("rewards.sigma_yaw", r.sigma_yaw),
            ("rewards.sigma_pitch", r.sigma_pitch),
            ("rewards.soft_joint_limit", r.soft_joint_limit),
            ("rewards.soft_torque_limit", r.soft_torque_limit),
        ] {
            check_positive(name, v)?;
        }
        self.domain_rand.validate()?;
        check_range("push.velocity", self.push.velocity)?;
        check_positive("push.interval_s", self.push.interval_s)?;
        let p = &self.push;
        let start_ok = p.curriculum_start >= p.velocity[0] && p.curriculum_start <= p.velocity[1];
        if !(p.curriculum_s >= 0.0 && (p.curriculum_s == 0.0 || start_ok)) {
            return Err(EnvError::Config(format!(
                "push.curriculum_start must lie in push.velocity {:?} and push.curriculum_s must be ≥ 0",
                p.velocity
            )));
        }
        check_positive("termination.max_tilt", self.termination.max_tilt)?;
        let a = &self.adversary;
        for (name, v) in [
            ("adversary.max_command_offset[0]", a.max_command_offset[0]),
            ("adversary.max_command_offset[1]", a.max_command_offset[1]),
            ("adversary.max_command_offset[2]", a.max_command_offset[2]),
            ("adversary.max_gravity_tilt", a.max_gravity_tilt),
            ("adversary.max_foot_force", a.max_foot_force),
            ("adversary.command_hold_s", a.command_hold_s),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(EnvError::Config(format!("{name} must be ≥ 0, got {v}")));
            }
        }
        self.sim2sim.validate()?;
        self.physics.validate()?;
        self.terrain.validate()?;
        self.height_scan.validate()?;
        Ok(())
    }

    /// The integrator to set on the model, or None to keep the model's.
    pub fn integrator(&self) -> Option<mujoco::Integrator> {
        self.integrator.resolve()
    }

    /// Whether the env reads MuJoCo's sensors (the IMU). The paper's observation comes from the simulator's state,
    /// so sensors are skipped unless a consumer of them is configured.
    pub fn needs_sensors(&self) -> bool {
        self.sim2sim.needs_sensors()
    }

    /// The policy period, s.
    pub fn policy_dt(&self) -> f64 {
        self.timestep * self.decimation as f64
    }

    /// Episode length in policy steps.
    pub fn max_episode_steps(&self) -> usize {
        (self.episode_length_s / self.policy_dt()).round() as usize
    }

    /// Settings for sim2sim evaluation: the same env without randomisation, noise or pushes.
    pub fn for_evaluation(&self) -> EnvConfig {
        let mut c = self.clone();
        c.noise.enabled = false;
        c.domain_rand.enabled = false;
        c.push.enabled = false;
        // The paper's experiments are on flat ground; `topa eval terrain` puts a terrain back.
        c.terrain.enabled = false;
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn push_curriculum_ramps_the_largest_kick_then_holds_it() {
        let p = PushConfig { velocity: [0.0, 2.5], curriculum_start: 1.0, curriculum_s: 100.0, ..Default::default() };
        assert_eq!(p.max_velocity(0.0), 1.0);
        assert!((p.max_velocity(50.0) - 1.75).abs() < 1e-12);
        assert_eq!(p.max_velocity(100.0), 2.5);
        assert_eq!(p.max_velocity(1e6), 2.5);
        assert_eq!(PushConfig::default().max_velocity(0.0), 2.5, "no curriculum: the full range at once");
        let mut cfg = EnvConfig::default();
        cfg.push.curriculum_start = 3.0;
        cfg.push.curriculum_s = 10.0;
        assert!(cfg.validate().unwrap_err().to_string().contains("push.curriculum_start"));
    }
}

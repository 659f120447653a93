//! One TopA environment: its own `Data` (and, with domain randomisation, its own `Model` copy), the paper's
//! observation, action, rewards, commands, pushes, randomisation and terminations.

use std::sync::Arc;

use mujoco::{Data, Model};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub mod drives;
mod ground;
mod observe;
mod randomize;
mod snapshot;

use crate::config::EnvConfig;
use crate::error::{EnvError, Result};
use crate::indices::RobotIndices;
use crate::observation::{HistoryUpdate, ObsLayout};
use crate::perturb::Perturbation;
use crate::rewards::{self, MotorInputs, RewardInputs, N_TERMS, TERM_NAMES};
use crate::sim2sim::Sim2Sim;
use crate::state::{self, quat_of, RobotState};
use crate::symmetry::{self, Symmetry};
use crate::task::{StepOutcome, Task};

/// Puts `cfg`'s simulation settings (timestep, integrator, solver overrides, sensors) on `model`, copying it only
/// when one differs: envs built from one configured model share it until randomisation copies it.
pub(crate) fn configure_model(model: &mut Arc<Model>, cfg: &EnvConfig) -> Result<()> {
    let integrator = cfg.integrator();
    if model.timestep() != cfg.timestep
        || integrator.is_some_and(|i| i != model.integrator())
        || model.sensors_enabled() != cfg.needs_sensors()
        || cfg.solver_iterations.is_some_and(|n| n != model.solver_iterations())
        || cfg.solver_tolerance.is_some_and(|t| t != model.solver_tolerance())
    {
        let m = Arc::make_mut(model);
        m.set_timestep(cfg.timestep)?;
        if let Some(i) = integrator {
            m.set_integrator(i);
        }
        m.set_sensors_enabled(cfg.needs_sensors());
        if let Some(n) = cfg.solver_iterations {
            m.set_solver_iterations(n);
        }
        if let Some(t) = cfg.solver_tolerance {
            m.set_solver_tolerance(t);
        }
    }
    Ok(())
}

/// Model parameters before randomisation, restored at every reset.
#[derive(Debug)]
struct Nominal {
    body_mass: Vec<f64>,
    body_inertia: Vec<[f64; 3]>,
    geom_friction: Vec<[f64; 3]>,
    geom_solref: Vec<[f64; 2]>,
    body_ipos: Vec<[f64; 3]>,
}

pub struct RobotEnv {
    cfg: Arc<EnvConfig>,
    idx: Arc<RobotIndices>,
    nominal: Arc<Nominal>,
    data: Data,
    rng: ChaCha8Rng,
    /// Where the observation's blocks are, for this robot's motor count.
    layout: ObsLayout,
    /// Per-step buffers: the clipped action, the motor targets, what the rewards read per motor.
    action: Vec<f64>,
    target: Vec<f64>,
    motors: MotorInputs,
    /// Policy steps this env has run since it was made (drives the push curriculum).
    experience_steps: u64,
    // Episode state.
    step_count: usize,
    command: [f64; 3],
    command_override: Option<[f64; 3]>,
    perturbation: Perturbation,
    /// A wrench on one body (world frame: force, torque), added to the perturbation's (the viewer's mouse).
    body_wrench: Option<(usize, [f64; 6])>,
    last_action: Vec<f64>,
    /// Earlier frames of proprioception as observed, newest first (`[env.observation] history`).
    history: Vec<f32>,
    air_time: [f64; 2],
    /// Time each foot has been in contact without a break, s.
    contact_time: [f64; 2],
    last_contact: [bool; 2],
    next_resample: usize,
    next_push: usize,
    terms: [f64; N_TERMS],
    robot_state: RobotState,
    /// Time spent in `mj_step` since `take_physics_ns`.
    physics_ns: u64,
    /// A capacity error of the last step (the run must stop: resetting would hide a model that is too small).
    fatal: Option<EnvError>,
    /// Realistic sim2sim (estimator, sensor noise, latency, torque–speed limits), when configured.
    sim2sim: Option<Sim2Sim>,
    /// Where the next reset puts the base (x, y, yaw) instead of the keyframe's place.
    start_pose: Option<[f64; 3]>,
    /// Friction of the ground by place (a course's floors, a terrain's tiles), given to each foot before every step.
    ground_friction: Option<Arc<crate::world::FrictionMap>>,
    /// This episode's randomised friction scale (the ground's map values are scaled by it too).
    friction_scale: f64,
    /// The robot's place on a terrain, when `[env.terrain]` is on.
    terrain: Option<crate::terrain::Placement>,
    /// The last step ended in a fall (the terrain curriculum reads it at the reset that follows).
    fell: bool,
}

impl RobotEnv {
    /// A new env on `model` (shared until domain randomisation gives this env its own copy). `seed` and `index`
    /// pick the env's own random stream, so a batch is deterministic whatever the thread count.
    pub fn new(model: Arc<Model>, cfg: Arc<EnvConfig>, seed: u64, index: u64) -> Result<Self> {
        cfg.validate()?;
        // The spec only: `model` is already the robot in its world (load_robot would compile a terrain again).
        let (spec, _) = crate::spec::RobotSpec::load(&crate::assets::resolve_path(&cfg.robot))?;
        let idx = Arc::new(RobotIndices::resolve(&model, &Arc::new(spec))?);
        Self::with_indices(model, cfg, idx, seed, index)
    }

    /// As `new`, reusing indices already resolved for this model (a batch resolves once).
    pub fn with_indices(
        mut model: Arc<Model>,
        cfg: Arc<EnvConfig>,
        idx: Arc<RobotIndices>,
        seed: u64,
        index: u64,
    ) -> Result<Self> {
        configure_model(&mut model, &cfg)?;
        // Once per env, on its own copy (the torque constant scales the gains: applying twice would square it).
        cfg.sim2sim.actuators.apply(&mut model, &idx)?;
        cfg.physics.apply(&mut model, &idx)?;
        let nominal = Arc::new(Nominal {
            body_mass: model.body_mass().to_vec(),
            body_inertia: model.body_inertia().to_vec(),
            geom_friction: model.geom_friction().to_vec(),
            geom_solref: model.geom_solref().to_vec(),
            body_ipos: model.body_ipos().to_vec(),
        });
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(index);
        let soft = cfg.rewards.soft_joint_limit;
        let n = idx.n_motors;
        let mut motors = MotorInputs::zeros(n);
        motors.joint_soft_limits = idx
            .joint_range
            .iter()
            .map(|&[lo, hi]| {
                let (mid, half) = ((lo + hi) / 2.0, (hi - lo) / 2.0 * soft);
                [mid - half, mid + half]
            })
            .collect();
        motors.torque_soft_limit = idx.torque_limit.iter().map(|t| t * cfg.rewards.soft_torque_limit).collect();
        motors.deviation_groups = idx.deviation_groups.clone();
        let terrain = if cfg.terrain.enabled {
            if model.id(mujoco::ObjType::Hfield, crate::terrain::TERRAIN_NAME).is_err() {
                return Err(EnvError::Config(
                    "[env.terrain] is on but the model has no terrain: build it with assets::load_robot".into(),
                ));
            }
            Some(crate::terrain::Placement::new(crate::terrain::Terrain::shared(&cfg.terrain)?, index, &mut rng))
        } else {
            None
        };
        let ground_friction = terrain.as_ref().map(|t| Arc::new(t.map.friction_map()));
        let sim2sim = if cfg.sim2sim.active() {
            Some(Sim2Sim::new(Arc::new(cfg.sim2sim.clone()), model.clone(), &idx, seed, index)?)
        } else {
            None
        };
        Ok(RobotEnv {
            data: Data::new(model)?,
            layout: cfg.observation.layout(idx.obs_layout().with_scan(cfg.height_scan.grid())),
            history: vec![0.0; cfg.observation.history * idx.obs_layout().frame()],
            action: vec![0.0; n],
            target: vec![0.0; n],
            motors,
            cfg,
            idx,
            nominal,
            rng,
            experience_steps: 0,
            step_count: 0,
            command: [0.0; 3],
            command_override: None,
            perturbation: Perturbation::default(),
            body_wrench: None,
            last_action: vec![0.0; n],
            air_time: [0.0; 2],
            contact_time: [0.0; 2],
            last_contact: [true; 2],
            next_resample: 0,
            next_push: 0,
            terms: [0.0; N_TERMS],
            robot_state: RobotState::default(),
            physics_ns: 0,
            fatal: None,
            sim2sim,
            start_pose: None,
            ground_friction,
            friction_scale: 1.0,
            terrain,
            fell: false,
        })
    }

    pub fn config(&self) -> &EnvConfig {
        &self.cfg
    }
    pub fn indices(&self) -> &RobotIndices {
        &self.idx
    }
    pub fn data(&self) -> &Data {
        &self.data
    }
    /// Mutable access for experiments that edit the state directly (e.g. tests, scripted pushes).
    pub fn data_mut(&mut self) -> &mut Data {
        &mut self.data
    }
    /// The robot's state as of the last reset or step.
    pub fn robot_state(&self) -> &RobotState {
        &self.robot_state
    }
    /// The command the policy sees (own command, or override, plus the perturbation offset).
    pub fn command(&self) -> [f64; 3] {
        let base = self.command_override.unwrap_or(self.command);
        let mut offset = self.perturbation.command_offset;
        if self.cfg.adversary.pure_turns_in_place && base[0] == 0.0 && base[1] == 0.0 && base[2] != 0.0 {
            offset[0] = 0.0;
            offset[1] = 0.0;
        }
        std::array::from_fn(|i| base[i] + offset[i])
    }
    /// Fixes the command (evaluation); `None` returns to random commands.
    pub fn set_command_override(&mut self, c: Option<[f64; 3]>) {
        self.command_override = c;
    }
    pub fn perturbation(&self) -> &Perturbation {
        &self.perturbation
    }
    pub fn set_perturbation_struct(&mut self, p: Perturbation) {
        self.perturbation = p;
    }
    /// A wrench (world frame: force N, torque N·m) on `body` at every physics step until replaced; None removes it.
    pub fn set_body_wrench(&mut self, w: Option<(usize, [f64; 6])>) {
        if let Some((b, _)) = self.body_wrench.take() {
            self.data.xfrc_applied_mut()[b] = [0.0; 6];
        }
        self.body_wrench = w.filter(|(b, _)| *b < self.data.model().raw().nbody as usize);
    }
    /// The body-height reward's target: the config's, or the robot spec's where the config leaves it at 0.
    pub fn base_height_target(&self) -> f64 {
        let t = self.cfg.rewards.base_height_target;
        if t > 0.0 {
            t
        } else {
            self.idx.spec.base_height_target
        }
    }

    /// The realistic-sim2sim state (estimator, sensors), if configured.
    pub fn sim2sim(&self) -> Option<&Sim2Sim> {
        self.sim2sim.as_ref()
    }

    /// The same, mutable (to record the estimator's steps).
    pub fn sim2sim_mut(&mut self) -> Option<&mut Sim2Sim> {
        self.sim2sim.as_mut()
    }

    /// A reset with the base put at (x, y) on the ground, heading `yaw` (rad), in the stand pose: a robot put back
    /// on a course.
    pub fn reset_at(&mut self, obs: &mut [f32], [x, y, yaw]: [f64; 3]) -> Result<()> {
        self.start_pose = Some([x, y, yaw]);
        self.reset(obs)
    }

    /// After editing the state through `data_mut`: recompute derived quantities and the observation.
    pub fn refresh(&mut self, obs: &mut [f32]) -> Result<()> {
        self.data.forward()?;
        state::read_into(&self.data, &self.idx, &mut self.robot_state);
        let sensed = self.sim2sim.as_ref().map(|s| s.latest().clone());
        self.write_obs(obs, sensed.as_ref(), HistoryUpdate::Fill);
        Ok(())
    }

    fn sample_command(&mut self) {
        let c = &self.cfg.commands;
        // One draw picks the kind, so a zero turn_share leaves every seed's command stream as it was.
        let kind = self.rng.random::<f64>();
        if kind < c.standing_share {
            self.command = [0.0; 3];
            return;
        }
        let mut draw = |r: [f64; 2]| if r[1] > r[0] { self.rng.random_range(r[0]..r[1]) } else { r[0] };
        if kind < c.standing_share + c.turn_share {
            self.command = [0.0, 0.0, draw(c.ang_vel_z)];
            return;
        }
        let mut cmd = [draw(c.lin_vel_x), draw(c.lin_vel_y), draw(c.ang_vel_z)];
        if cmd[0].hypot(cmd[1]) < c.min_lin_norm {
            cmd[0] = 0.0;
            cmd[1] = 0.0;
        }
        self.command = cmd;
    }

    fn apply_forces(&mut self) {
        let p = self.perturbation;
        let torso = self.idx.torso_body;
        let feet = self.idx.foot_bodies;
        let b = self.idx.base_qpos;
        let q = quat_of(&self.data.qpos()[b + 3..b + 7]);
        let f_torso = q.transform_vector(&Vector3::from(p.torso_force_local));
        let xfrc = self.data.xfrc_applied_mut();
        xfrc[torso][..3].copy_from_slice(f_torso.as_slice());
        for f in 0..2 {
            xfrc[feet[f]][..3].copy_from_slice(&p.foot_force[f]);
        }
        if let Some((b, w)) = self.body_wrench {
            // On a body the perturbation also pushes, its wrench was written above: add (the torque slots stay
            // ours alone).
            let own = b == torso || feet.contains(&b);
            for i in 0..6 {
                xfrc[b][i] = if i < 3 && own { xfrc[b][i] + w[i] } else { w[i] };
            }
        }
    }

    fn push(&mut self) {
        let lo = self.cfg.push.velocity[0];
        let hi = self.cfg.push.max_velocity(self.experience_steps as f64 * self.cfg.policy_dt());
        let mag = if hi > lo { self.rng.random_range(lo..=hi) } else { lo };
        let dir = self.rng.random_range(0.0..std::f64::consts::TAU);
        let dof = self.idx.base_dof;
        let qvel = self.data.qvel_mut();
        qvel[dof] += mag * dir.cos();
        qvel[dof + 1] += mag * dir.sin();
    }

    fn steps_of(&self, seconds: f64) -> usize {
        ((seconds / self.cfg.policy_dt()).round() as usize).max(1)
    }

    /// The fall test of the termination settings, on the state of the last step (whether or not falls end the
    /// episode).
    pub fn has_fallen(&self) -> bool {
        let t = &self.cfg.termination;
        let s = &self.robot_state;
        self.base_height() < t.min_base_height
            || s.roll.abs() > t.max_tilt
            || s.pitch.abs() > t.max_tilt
            || (t.body_contact && s.body_contact)
    }

    /// Physics steps with the current ctrl; Err or blow-up → false.
    fn simulate(&mut self) -> bool {
        let start = std::time::Instant::now();
        let ok = (0..self.cfg.decimation).all(|_| self.physics_step());
        self.physics_ns += start.elapsed().as_nanos() as u64;
        ok && !self.data.is_unstable()
    }

    /// One `mj_step` with the sim2sim models and perturbations around it; false on an error.
    fn physics_step(&mut self) -> bool {
        if let Some(s) = &mut self.sim2sim {
            s.before_physics_step(&mut self.data, &self.idx);
        }
        self.apply_forces();
        let mut r = self.data.step();
        if let (Ok(()), Some(s)) = (&r, &mut self.sim2sim) {
            r = s.after_physics_step(&self.data, &self.idx, self.cfg.timestep).map_err(|e| match e {
                EnvError::Mujoco(m) => m,
                other => mujoco::MujocoError::Invalid(other.to_string()),
            });
        }
        if let Err(e) = r {
            if matches!(e, mujoco::MujocoError::Capacity { .. }) {
                self.fatal = Some(e.into());
            }
            return false;
        }
        true
    }
}

impl Task for RobotEnv {
    fn obs_dim(&self) -> usize {
        self.layout.dim()
    }
    fn action_dim(&self) -> usize {
        self.idx.n_motors
    }

    fn reset(&mut self, obs: &mut [f32]) -> Result<()> {
        let dim = self.layout.dim();
        if obs.len() != dim {
            return Err(EnvError::Shape(format!("observation buffer has {} values, expected {dim}", obs.len())));
        }
        if self.cfg.domain_rand.enabled {
            self.randomize_model()?;
        }
        self.data.reset_keyframe(self.idx.stand_key)?;
        if self.terrain.is_some() && self.start_pose.is_none() {
            self.place_on_terrain();
        }
        if let Some([x, y, yaw]) = self.start_pose.take() {
            let b = self.idx.base_qpos;
            let q = self.data.qpos()[b + 3..b + 7].to_vec();
            let turn = nalgebra::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw) * quat_of(&q);
            let qpos = self.data.qpos_mut();
            qpos[b] += x;
            qpos[b + 1] += y;
            let c = turn.quaternion();
            qpos[b + 3..b + 7].copy_from_slice(&[c.w, c.i, c.j, c.k]);
        }
        self.lift_onto_ground();
        self.data.set_time(0.0);
        self.data.xfrc_applied_mut().iter_mut().for_each(|w| *w = [0.0; 6]);
        // A small random initial base velocity, so episodes do not all start identically.
        let dof = self.idx.base_dof;
        for i in 0..6 {
            let v = self.rng.random_range(-0.1..=0.1);
            self.data.qvel_mut()[dof + i] = v;
        }
        self.data.forward()?;
        self.step_count = 0;
        self.last_action.iter_mut().for_each(|a| *a = 0.0);
        self.air_time = [0.0; 2];
        self.contact_time = [0.0; 2];
        self.last_contact = [true; 2];
        self.terms = [0.0; N_TERMS];
        self.sample_command();
        self.next_resample = self.steps_of(self.cfg.commands.resample_s);
        self.next_push = self.steps_of(self.cfg.push.interval_s);
        state::read_into(&self.data, &self.idx, &mut self.robot_state);
        let sensed = match &mut self.sim2sim {
            Some(s) => {
                s.reset(&self.data, &self.idx, self.cfg.decimation)?;
                Some(s.sensed())
            }
            None => None,
        };
        self.write_obs(obs, sensed.as_ref(), HistoryUpdate::Fill);
        Ok(())
    }

    fn step(&mut self, action: &[f32], obs: &mut [f32]) -> StepOutcome {
        let n = self.idx.n_motors;
        assert_eq!(action.len(), n, "action has {} values, expected {n}", action.len());
        let clip = self.cfg.action_clip;
        for (a, &v) in self.action.iter_mut().zip(action) {
            let v = v as f64;
            *a = if v.is_finite() { v.clamp(-clip, clip) } else { 0.0 };
        }
        for i in 0..n {
            let [lo, hi] = self.idx.motor_range[i];
            self.target[i] = (self.idx.action_zero[i] + self.cfg.action_scale * self.action[i]).clamp(lo, hi);
        }
        match &mut self.sim2sim {
            Some(s) => s.set_target(&self.target),
            None => {
                for i in 0..n {
                    self.data.ctrl_mut()[self.idx.actuators[i]] = self.target[i];
                }
            }
        }
        self.apply_ground_friction();
        if !self.simulate() {
            self.terms = [0.0; N_TERMS];
            return StepOutcome { reward: 0.0, done: true, time_out: false, diverged: true };
        }
        self.step_count += 1;
        self.experience_steps += 1;
        state::read_into(&self.data, &self.idx, &mut self.robot_state);
        let dt = self.cfg.policy_dt();
        // Contact with a one-step memory, as legged_gym does: a single missed contact is not a touchdown.
        let contact = self.robot_state.foot_contact();
        let filtered: [bool; 2] = std::array::from_fn(|f| contact[f] || self.last_contact[f]);
        let touchdown: [bool; 2] = std::array::from_fn(|f| filtered[f] && self.air_time[f] > 0.0);
        for f in 0..2 {
            self.air_time[f] += dt;
            self.contact_time[f] = if contact[f] { self.contact_time[f] + dt } else { 0.0 };
        }
        let air_at_touchdown = self.air_time;
        // The paper's a_t are position commands: the action rate is measured on the targets (rad).
        let scale_a = self.cfg.action_scale;
        let m = &mut self.motors;
        for i in 0..n {
            m.action[i] = self.action[i] * scale_a;
            m.last_action[i] = self.last_action[i] * scale_a;
            m.joint_pos[i] = self.robot_state.joint_pos[i];
            m.joint_dev[i] = self.robot_state.joint_pos[i] - self.idx.nominal_joints[i];
            m.motor_torque[i] = self.robot_state.motor_torque[i];
        }
        let command = self.command();
        let base_height_target = self.base_height_target();
        let (base_height, foot_height) = (self.base_height(), self.foot_heights());
        let s = &self.robot_state;
        let inputs = RewardInputs {
            command,
            lin_vel: s.lin_vel,
            ang_vel: s.ang_vel,
            gravity: s.gravity,
            base_height,
            base_height_target,
            motors: &self.motors,
            foot_speed: s.foot_speed,
            foot_contact: contact,
            touchdown,
            air_time: air_at_touchdown,
            mode_time: std::array::from_fn(|f| if contact[f] { self.contact_time[f] } else { self.air_time[f] }),
            foot_height,
        };
        let scale = if self.cfg.rewards.scale_by_dt { dt } else { 1.0 };
        let reward = rewards::weighted_terms(&self.cfg.rewards, &inputs, scale, &mut self.terms);
        for f in 0..2 {
            if filtered[f] {
                self.air_time[f] = 0.0;
            }
        }
        self.last_contact = contact;
        self.last_action.copy_from_slice(&self.action);

        self.track_commanded(dt);
        self.fell = self.has_fallen();
        let fell = self.cfg.termination.enabled && self.fell;
        let time_out = !fell && self.step_count >= self.cfg.max_episode_steps();
        if self.step_count >= self.next_resample {
            self.sample_command();
            self.next_resample += self.steps_of(self.cfg.commands.resample_s);
        }
        if self.cfg.push.enabled && self.step_count >= self.next_push {
            self.push();
            self.next_push += self.steps_of(self.cfg.push.interval_s);
        }
        let sensed = self.sim2sim.as_mut().map(|s| s.sensed());
        self.write_obs(obs, sensed.as_ref(), HistoryUpdate::Shift);
        let finite = reward.is_finite() && obs.iter().all(|x| x.is_finite());
        StepOutcome { reward, done: fell || time_out || !finite, time_out, diverged: !finite }
    }

    fn term_names(&self) -> &'static [&'static str] {
        &TERM_NAMES
    }
    fn terms(&self) -> &[f64] {
        &self.terms
    }
    fn symmetry(&self) -> Option<Symmetry> {
        Some(symmetry::for_layout(&self.layout, &self.idx.mirror_perm, &self.idx.mirror_sign))
    }
    fn actor_view(&self) -> trainer::actor_view::ActorView {
        self.cfg.observation.actor_view(&self.layout)
    }
    fn perturbation_channels(&self) -> Vec<trainer::PerturbationChannel> {
        crate::perturb::channels(&self.cfg.adversary)
    }
    fn perturbation_mirror(&self) -> Option<trainer::SignedPermutation> {
        Some(crate::perturb::mirror())
    }
    fn set_perturbation(&mut self, p: &[f32]) {
        let held = self.perturbation;
        self.perturbation = Perturbation::from_adversary(p);
        self.perturbation.torso_force_local = held.torso_force_local;
        // A held command offset changes only at the hold's boundaries, counted from the episode's start (so a
        // snapshot needs nothing beyond the offset itself).
        let hold = self.cfg.adversary.command_hold_s;
        if hold > 0.0 && !self.step_count.is_multiple_of(self.steps_of(hold)) {
            self.perturbation.command_offset = held.command_offset;
        }
    }

    fn take_fatal(&mut self) -> Option<EnvError> {
        self.fatal.take()
    }

    fn take_physics_ns(&mut self) -> u64 {
        std::mem::take(&mut self.physics_ns)
    }

    fn curriculum_level(&self) -> Option<f64> {
        self.terrain.as_ref().filter(|t| t.map.cfg.curriculum.enabled && t.fixed.is_none()).map(|t| t.level as f64)
    }

    fn save_state(&self, f: &mut Vec<f64>, u: &mut Vec<u64>) {
        self.save_snapshot(f, u)
    }

    fn load_state(&mut self, f: &[f64], u: &[u64]) -> Result<(usize, usize)> {
        self.load_snapshot(f, u)
    }
}

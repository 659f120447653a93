//! Realistic sim2sim: what separates the simulator's true state from what the robot's computer sees and does.
//! The policy then reads an IMU with noise and bias, quantised encoders, and a base velocity from the robot's
//! contact-aided Kalman filter (`estimator`) instead of the simulator's; its actions reach the motors late; the
//! motors lose torque with speed. Every model is switchable; all draw from the env's own sim2sim stream, so a
//! seed fixes them and the ideal path's random draws are untouched.
//!
//! The env calls `before_physics_step` and `after_physics_step` around every `mj_step` (the filter runs at the
//! physics rate, as the robot's at its IMU rate) and `sensed` when it writes an observation.

pub mod actuators;
pub mod estimator;
pub mod kinematics;
pub mod sensors;

use std::sync::Arc;

use mujoco::{Data, Model};
use nalgebra::{UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::indices::RobotIndices;
use crate::linkage::JointMap;
use crate::state::{self, quat_of};
use crate::task;
use actuators::ActuatorConfig;
use estimator::{ContactKf, EstimatorConfig, EstimatorInput};
use kinematics::LegKinematics;
use sensors::{Delay, EncoderConfig, Noise3, NoiseConfig};

/// Every realistic-sim2sim model; the default is the ideal simulator (all off).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(deny_unknown_fields, default)]
pub struct Sim2SimConfig {
    /// The policy's linear velocity comes from the contact-aided Kalman filter (else: the simulator's).
    pub estimator: EstimatorSettings,
    /// Gyro noise, rad/s.
    pub gyro: NoiseConfig,
    /// Accelerometer noise, m/s².
    pub accel: NoiseConfig,
    /// Orientation error of the IMU's attitude output (a small rotation per axis), rad.
    pub orientation: NoiseConfig,
    /// Encoder quantisation and velocity noise.
    pub encoders: EncoderConfig,
    /// Sensor and action delays.
    pub latency: LatencyConfig,
    /// Torque–speed limits of the motors.
    pub torque_speed: TorqueSpeedConfig,
    /// The motors' actual armature, damping, friction and torque constant (identified, or a hidden "real robot").
    pub actuators: ActuatorConfig,
    /// Physics timestep for evaluations run in this mode, s (0 = the evaluation's own). The motor drivers run
    /// their PD at kHz rates; MuJoCo applies the PD once per physics step.
    pub timestep: f64,
    /// Integrator for evaluations run in this mode (model = the evaluation's own: the MJCF's). An `--integrator`
    /// given on the command line wins.
    pub integrator: crate::integrator::IntegratorChoice,
}

/// The state estimator: whether it runs, its contact detection, and the filter's noise (flattened into this table).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(deny_unknown_fields, default)]
pub struct EstimatorSettings {
    /// Run the contact-aided Kalman filter and give the policy its velocity.
    pub enabled: bool,
    /// A foot with more normal force than this is in contact (the robot's contact detection), N.
    pub contact_threshold: f64,
    /// The filter's noise densities and variances (keys of this same table).
    #[serde(flatten)]
    pub filter: EstimatorConfig,
}

/// Delays, in whole policy or physics steps.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(deny_unknown_fields, default)]
pub struct LatencyConfig {
    /// The policy sees sensor readings this many policy steps old.
    pub observation_policy_steps: usize,
    /// An action reaches the motors this many policy steps …
    pub action_policy_steps: usize,
    /// … plus this many physics steps after it was computed.
    pub action_physics_steps: usize,
    /// Above `action_physics_steps`: each episode draws its physics-step delay uniformly from
    /// `action_physics_steps..=action_physics_steps_max` (0: a fixed delay). Domain randomisation of latency.
    pub action_physics_steps_max: usize,
}

/// Torque–speed limit of the motors (MuJoCo's actuators have a fixed force range): full torque up to
/// `full_torque_speed`, then falling linearly to zero at `no_load_speed` while the motor drives in the direction it
/// turns; braking keeps the full torque. Per degree of freedom of a leg, in the robot's motor order (TopA: hip
/// roll, yaw, pitch, knee, ankle), the same for both legs; rad/s at the output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(deny_unknown_fields, default)]
pub struct TorqueSpeedConfig {
    /// Limit the motors' torque by their speed (false: MuJoCo's fixed force range).
    pub enabled: bool,
    /// Output speed up to which each leg joint's motor has its full torque, rad/s.
    pub full_torque_speed: Vec<f64>,
    /// Output speed at which each leg joint's motor has no torque left, rad/s.
    pub no_load_speed: Vec<f64>,
}

impl TorqueSpeedConfig {
    /// The table must cover one leg of a robot with `n_motors` motors (two legs of n/2).
    pub fn check_motors(&self, n_motors: usize) -> crate::error::Result<()> {
        if self.enabled && self.full_torque_speed.len() * 2 != n_motors {
            return Err(crate::error::EnvError::Config(format!(
                "sim2sim.torque_speed lists {} speeds per leg, the robot has {} motors per leg",
                self.full_torque_speed.len(),
                n_motors / 2
            )));
        }
        Ok(())
    }

    /// The largest torque in the direction of motion at output speed `speed`, for peak torque `peak`.
    pub fn limit(&self, dof: usize, peak: f64, speed: f64) -> f64 {
        let (w1, w0) = (self.full_torque_speed[dof], self.no_load_speed[dof]);
        let s = speed.abs();
        if s <= w1 {
            peak
        } else if s >= w0 {
            0.0
        } else {
            peak * (w0 - s) / (w0 - w1)
        }
    }
}

impl Sim2SimConfig {
    /// Anything on at all (else the env runs the ideal path, bit for bit as without this module).
    pub fn active(&self) -> bool {
        // (Actuator values act on the model itself, not through the sim2sim state.)
        let l = self.latency;
        self.estimator.enabled
            || self.gyro.enabled
            || self.accel.enabled
            || self.orientation.enabled
            || self.encoders.enabled
            || l.observation_policy_steps + l.action_policy_steps + l.action_physics_steps + l.action_physics_steps_max
                > 0
            || self.torque_speed.enabled
    }

    /// The IMU is read (MuJoCo's sensors must be computed).
    pub fn needs_sensors(&self) -> bool {
        self.estimator.enabled || self.gyro.enabled || self.accel.enabled || self.orientation.enabled
    }

    pub fn validate(&self) -> crate::error::Result<()> {
        for (name, n) in [("gyro", self.gyro), ("accel", self.accel), ("orientation", self.orientation)] {
            if [n.white, n.bias_initial, n.bias_walk].iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
                return Err(crate::error::EnvError::Config(format!(
                    "sim2sim.{name}: noise values must be finite and ≥ 0"
                )));
            }
        }
        let e = &self.encoders;
        if !(e.counts_per_rev >= 0.0 && e.velocity_noise >= 0.0) {
            return Err(crate::error::EnvError::Config(
                "sim2sim.encoders: counts_per_rev and velocity_noise must be ≥ 0".into(),
            ));
        }
        let l = &self.latency;
        if l.action_physics_steps_max != 0 && l.action_physics_steps_max < l.action_physics_steps {
            return Err(crate::error::EnvError::Config(format!(
                "sim2sim.latency: action_physics_steps_max ({}) is below action_physics_steps ({}); it is the top of \
                 the range drawn per episode (0: no range)",
                l.action_physics_steps_max, l.action_physics_steps
            )));
        }
        let t = &self.torque_speed;
        if t.enabled && t.full_torque_speed.len() != t.no_load_speed.len() {
            return Err(crate::error::EnvError::Config(
                "sim2sim.torque_speed: full_torque_speed and no_load_speed need one value per leg joint each".into(),
            ));
        }
        if t.enabled && t.full_torque_speed.iter().zip(&t.no_load_speed).any(|(&w1, &w0)| !(w1 >= 0.0 && w0 > w1)) {
            return Err(crate::error::EnvError::Config(
                "sim2sim.torque_speed: need 0 ≤ full_torque_speed < no_load_speed for every joint".into(),
            ));
        }
        let f = &self.estimator.filter;
        let vals = [
            f.q_position,
            f.q_velocity,
            f.q_foot,
            f.r_foot_position,
            f.r_foot_velocity,
            f.r_foot_height,
            f.swing_scale,
        ];
        if self.estimator.enabled && vals.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(crate::error::EnvError::Config(
                "sim2sim.estimator: every covariance and swing_scale must be positive".into(),
            ));
        }
        if !(self.timestep >= 0.0 && self.timestep.is_finite()) {
            return Err(crate::error::EnvError::Config(
                "sim2sim.timestep must be ≥ 0 (0 = the evaluation's own)".into(),
            ));
        }
        Ok(())
    }
}

/// What the robot's computer knows after a step.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Sensed {
    /// Base linear velocity in the torso frame (estimated, or the simulator's when the filter is off).
    pub lin_vel: [f64; 3],
    pub ang_vel: [f64; 3],
    pub gravity: [f64; 3],
    /// The IMU's attitude output, world ← torso (w, x, y, z): what a robot's driver sends its controller.
    pub orientation: [f64; 4],
    /// Encoder readings of the motors (the actuated joints).
    pub motor_pos: Vec<f64>,
    pub motor_vel: Vec<f64>,
}

/// One env's realistic-sim2sim state.
pub struct Sim2Sim {
    cfg: Arc<Sim2SimConfig>,
    rng: ChaCha8Rng,
    gyro: Noise3,
    accel: Noise3,
    orientation: Noise3,
    kf: ContactKf,
    kin: LegKinematics,
    obs_delay: Delay<Sensed>,
    action_delay: Delay<Vec<f64>>,
    /// The longest action delay a latency range can draw, physics steps (0: a fixed delay).
    action_delay_cap: usize,
    target: Vec<f64>,
    /// Per-physics-step buffers: the delayed targets applied, the motor speeds.
    applied: Vec<f64>,
    speeds: Vec<f64>,
    latest: Sensed,
    /// The IMU's latest attitude and specific-force readings (world ← IMU; IMU frame).
    imu_orientation: UnitQuaternion<f64>,
    imu_accel: [f64; 3],
    /// The estimator's velocity in the world frame, and the IMU orientation it used (for recordings).
    pub estimate_world: Vector3<f64>,
    /// Filter resets after invalid sensor values, since the env was made.
    pub filter_resets: u64,
    peak_torque: Vec<f64>,
    /// Encoder readings → kinematic joints, as the robot's computer maps them (the linkage, or M where linear).
    joint_map: JointMap,
    joints: Vec<f64>,
    joint_vel: Vec<f64>,
    /// When Some, every filter step is appended with the truth beside it (`topa sysid estimator` tunes on these).
    pub recording: Option<Vec<FilterSample>>,
    /// The filter's last restart (base height, feet), for the next recorded sample.
    restart: Option<(f64, Vec<Vector3<f64>>)>,
}

/// One step of the state estimator as the robot's computer ran it, with the simulator's truth beside it.
#[derive(Debug, Clone)]
pub struct FilterSample {
    pub dt: f64,
    pub input: EstimatorInput,
    /// The IMU's true velocity, world frame, m/s.
    pub truth: Vector3<f64>,
    /// The filter's velocity after this step.
    pub estimate: Vector3<f64>,
    /// The filter restarted before this step: base height and feet relative to the base (world frame).
    pub restart: Option<(f64, Vec<Vector3<f64>>)>,
}

/// Standard gravity the accelerometer's specific force is corrected by, m/s² (the MJCF's).
const GRAVITY: f64 = 9.81;

/// The stream offset that separates sim2sim draws from the env's own (whose stream is the env index).
const STREAM_OFFSET: u64 = 1 << 40;

impl Sim2Sim {
    pub fn new(cfg: Arc<Sim2SimConfig>, model: Arc<Model>, idx: &RobotIndices, seed: u64, index: u64) -> Result<Self> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(index + STREAM_OFFSET);
        let delay = cfg.latency;
        let n = idx.n_motors;
        cfg.torque_speed.check_motors(n)?;
        let joint_map = JointMap::new(&idx.spec, &model)?;
        let empty = Sensed { motor_pos: vec![0.0; n], motor_vel: vec![0.0; n], ..Sensed::default() };
        Ok(Sim2Sim {
            kf: ContactKf::new(cfg.estimator.filter.clone(), 2),
            kin: LegKinematics::new(model, idx)?,
            obs_delay: Delay::new(delay.observation_policy_steps, empty.clone()),
            action_delay: Delay::new(0, vec![0.0; n]),
            action_delay_cap: 0,
            rng,
            gyro: Noise3::default(),
            accel: Noise3::default(),
            orientation: Noise3::default(),
            target: vec![0.0; n],
            applied: vec![0.0; n],
            speeds: vec![0.0; n],
            latest: empty,
            imu_orientation: UnitQuaternion::identity(),
            imu_accel: [0.0; 3],
            estimate_world: Vector3::zeros(),
            filter_resets: 0,
            peak_torque: idx.torque_limit.clone(),
            joint_map,
            joints: vec![0.0; n],
            joint_vel: vec![0.0; n],
            recording: None,
            restart: None,
            cfg,
        })
    }

    pub fn config(&self) -> &Sim2SimConfig {
        &self.cfg
    }

    /// The physics steps between a target and its motors this episode (the latency's draw, when a range).
    pub fn action_delay_steps(&self) -> usize {
        self.action_delay.delay()
    }

    /// At an episode's start: new biases, empty delays holding the initial targets, the filter at rest.
    pub fn reset(&mut self, d: &Data, idx: &RobotIndices, decimation: usize) -> Result<()> {
        let c = &self.cfg;
        self.gyro.reset(&c.gyro, &mut self.rng);
        self.accel.reset(&c.accel, &mut self.rng);
        self.orientation.reset(&c.orientation, &mut self.rng);
        let ctrl: Vec<f64> = idx.actuators.iter().map(|&a| d.ctrl()[a]).collect();
        self.target.copy_from_slice(&ctrl);
        let l = c.latency;
        let physics_steps = if l.action_physics_steps_max > l.action_physics_steps {
            self.rng.random_range(l.action_physics_steps..=l.action_physics_steps_max)
        } else {
            l.action_physics_steps
        };
        self.action_delay = Delay::new(l.action_policy_steps * decimation + physics_steps, ctrl);
        self.action_delay_cap = if l.action_physics_steps_max > 0 {
            l.action_policy_steps * decimation + l.action_physics_steps_max
        } else {
            0
        };
        self.sense(d, idx, 0.0)?;
        self.reset_filter()?;
        self.sense_velocity(d, idx);
        self.obs_delay.reset(self.latest.clone());
        Ok(())
    }

    /// The policy's new motor targets (applied through the action delay).
    pub fn set_target(&mut self, target: &[f64]) {
        self.target.copy_from_slice(target);
    }

    /// Before each `mj_step`: the delayed targets and the torque–speed limits go into the model and data.
    pub fn before_physics_step(&mut self, d: &mut Data, idx: &RobotIndices) {
        self.action_delay.shift(&self.target, &mut self.applied);
        for (&a, &u) in idx.actuators.iter().zip(&self.applied) {
            d.ctrl_mut()[a] = u;
        }
        let ts = &self.cfg.torque_speed;
        if ts.enabled {
            // Read before the model is borrowed mutably.
            let speeds = &mut self.speeds;
            for (s, &a) in speeds.iter_mut().zip(&idx.actuators) {
                *s = d.actuator_velocity()[a];
            }
            let per_leg = ts.full_torque_speed.len();
            let m = d.model_mut();
            for i in 0..idx.n_motors {
                let peak = self.peak_torque[i];
                let lim = ts.limit(i % per_leg, peak, speeds[i]);
                // Driving in the direction of motion is limited; braking against it keeps the peak torque.
                m.actuator_forcerange_mut()[idx.actuators[i]] =
                    if speeds[i] >= 0.0 { [-peak, lim] } else { [-lim, peak] };
            }
        }
    }

    /// After each `mj_step` of `dt` seconds: read the sensors, run the filter.
    pub fn after_physics_step(&mut self, d: &Data, idx: &RobotIndices, dt: f64) -> Result<()> {
        self.sense(d, idx, dt)?;
        if self.cfg.estimator.enabled {
            let input = self.filter_input(d, idx);
            let recorded = self.recording.is_some().then(|| input.clone());
            let ok = self.kf.step(dt, &input);
            if let (Some(input), Some(rec)) = (recorded, &mut self.recording) {
                let v = d.object_velocity(mujoco::ObjType::Site, idx.imu_site, false);
                rec.push(FilterSample {
                    dt,
                    input,
                    truth: Vector3::new(v[3], v[4], v[5]),
                    estimate: self.kf.velocity(),
                    restart: self.restart.take(),
                });
            }
            if !ok {
                self.filter_resets += 1;
                if self.filter_resets <= 5 || self.filter_resets.is_power_of_two() {
                    log::warn!(
                        "state estimator: invalid sensor values or a failed update; filter reset (#{})",
                        self.filter_resets
                    );
                }
                self.reset_filter()?;
            }
        }
        self.sense_velocity(d, idx);
        Ok(())
    }

    /// What the policy sees this step: the readings of `observation_policy_steps` ago.
    pub fn sensed(&mut self) -> Sensed {
        self.obs_delay.push(self.latest.clone())
    }

    /// The newest readings (no observation delay).
    pub fn latest(&self) -> &Sensed {
        &self.latest
    }

    /// IMU and encoders (everything but the linear velocity).
    fn sense(&mut self, d: &Data, idx: &RobotIndices, dt: f64) -> Result<()> {
        let Self { cfg: c, rng, latest, gyro, orientation, accel, .. } = self;
        let b = idx.base_qpos;
        let q_true = quat_of(&d.qpos()[b + 3..b + 7]);
        let w_true = [d.qvel()[idx.base_dof + 3], d.qvel()[idx.base_dof + 4], d.qvel()[idx.base_dof + 5]];
        latest.ang_vel = gyro.corrupt(&c.gyro, w_true, dt, rng);
        let err = orientation.corrupt(&c.orientation, [0.0; 3], dt, rng);
        let q_meas = q_true * UnitQuaternion::from_scaled_axis(Vector3::from(err));
        let g = q_meas.inverse_transform_vector(&Vector3::new(0.0, 0.0, -1.0));
        latest.gravity = [g.x, g.y, g.z];
        let o = q_meas.quaternion();
        latest.orientation = [o.w, o.i, o.j, o.k];
        if c.estimator.enabled {
            let a = &d.sensordata()[idx.imu_accel..idx.imu_accel + 3];
            self.imu_accel = accel.corrupt(&c.accel, [a[0], a[1], a[2]], dt, rng);
        }
        for i in 0..idx.n_motors {
            latest.motor_pos[i] = c.encoders.quantise(d.qpos()[idx.actuated_qpos[i]]);
            latest.motor_vel[i] = c.encoders.velocity(d.qvel()[idx.actuated_dof[i]], rng);
        }
        self.imu_orientation = q_meas;
        Ok(())
    }

    /// The linear velocity the policy gets: the filter's (rotated into the measured torso frame), or the truth.
    fn sense_velocity(&mut self, d: &Data, idx: &RobotIndices) {
        let v = if self.cfg.estimator.enabled {
            self.estimate_world = self.kf.velocity();
            self.imu_orientation.inverse_transform_vector(&self.estimate_world)
        } else {
            Vector3::from(state::read_base_velocity(d, idx))
        };
        self.latest.lin_vel = [v.x, v.y, v.z];
    }

    fn filter_input(&mut self, d: &Data, idx: &RobotIndices) -> EstimatorInput {
        let r = self.imu_orientation;
        // Encoders the linkage cannot map (non-finite, out of reach): the filter refuses the non-finite input.
        if self.map_joints().is_err() {
            self.joints.iter_mut().for_each(|q| *q = f64::NAN);
        }
        let feet = self.kin.feet(&self.joints, &self.joint_vel);
        let w = Vector3::from(self.latest.ang_vel);
        let accel = r.transform_vector(&Vector3::from(self.imu_accel)) + Vector3::new(0.0, 0.0, -GRAVITY);
        let (forces, _) = state::contact_forces(d, idx);
        EstimatorInput {
            accel,
            foot_rel: feet.iter().map(|f| r.transform_vector(&f.position)).collect(),
            foot_vel: feet.iter().map(|f| -r.transform_vector(&(w.cross(&f.position) + f.velocity))).collect(),
            contact: forces.iter().map(|&f| f > self.cfg.estimator.contact_threshold).collect(),
            foot_spin: feet.iter().map(|f| (w + f.angular_velocity).norm()).collect(),
        }
    }

    /// Restarts the filter at rest, the base as high above the ground as the feet are below it (what the robot
    /// knows from its own kinematics when it stands).
    fn reset_filter(&mut self) -> Result<()> {
        self.map_joints()?;
        let r = self.imu_orientation;
        let feet: Vec<Vector3<f64>> =
            self.kin.feet(&self.joints, &self.joint_vel).iter().map(|f| r.transform_vector(&f.position)).collect();
        let height = -feet.iter().map(|f| f.z).sum::<f64>() / feet.len() as f64;
        self.kf.reset(height, &feet);
        if self.recording.is_some() {
            self.restart = Some((height, feet));
        }
        Ok(())
    }

    /// Kinematic joints from the latest encoder readings.
    fn map_joints(&mut self) -> Result<()> {
        let (p, v) = (&self.latest.motor_pos, &self.latest.motor_vel);
        self.joint_map.positions(p, &mut self.joints)?;
        self.joint_map.velocities(p, v, &mut self.joint_vel)
    }

    /// Appends the sim2sim state (snapshots for exact resume of a training run that uses it).
    pub fn save(&self, f: &mut Vec<f64>, u: &mut Vec<u64>) {
        for n in [&self.gyro, &self.accel, &self.orientation] {
            f.extend_from_slice(&n.bias);
        }
        self.kf.save(f);
        f.extend_from_slice(&self.target);
        for s in self.obs_delay.items() {
            f.extend(s.lin_vel.iter().chain(&s.ang_vel).chain(&s.gravity).chain(&s.motor_pos).chain(&s.motor_vel));
        }
        for a in self.action_delay.items() {
            f.extend_from_slice(a);
        }
        // A drawn delay pads its queue to the range's top, so that every env's row has one length.
        let n = self.target.len();
        f.extend(std::iter::repeat_n(0.0, n * self.action_delay_cap.saturating_sub(self.action_delay.delay())));
        task::save_rng(&self.rng, u);
        u.push(self.filter_resets);
        if self.cfg.latency.action_physics_steps_max > 0 {
            u.push(self.action_delay.delay() as u64); // this episode's draw sizes the queue above
        }
    }

    /// Inverse of `save`; returns the values consumed.
    pub fn load(&mut self, f: &[f64], u: &[u64]) -> Result<(usize, usize)> {
        let n = self.target.len();
        let ranged = self.cfg.latency.action_physics_steps_max > 0;
        let words = task::RNG_WORDS + 1 + usize::from(ranged);
        if ranged && u.len() >= words {
            self.action_delay = Delay::new(u[words - 1] as usize, vec![0.0; n]);
        }
        let slots = if ranged { self.action_delay_cap } else { self.action_delay.delay() };
        let need = 9 + self.kf.saved_len() + n + self.obs_delay.delay() * (9 + 2 * n) + slots * n;
        if f.len() < need || u.len() < words {
            return Err(crate::error::EnvError::Shape(
                "env snapshot has no (or a different) realistic-sim2sim state for this config".into(),
            ));
        }
        let mut k = 0;
        for n in [&mut self.gyro, &mut self.accel, &mut self.orientation] {
            n.bias.copy_from_slice(&f[k..k + 3]);
            k += 3;
        }
        k += self.kf.load(&f[k..]);
        self.target.copy_from_slice(&f[k..k + n]);
        k += n;
        let per = 9 + 2 * n;
        let items: Vec<Sensed> = (0..self.obs_delay.delay())
            .map(|j| {
                let s = &f[k + j * per..k + (j + 1) * per];
                Sensed {
                    lin_vel: [s[0], s[1], s[2]],
                    ang_vel: [s[3], s[4], s[5]],
                    gravity: [s[6], s[7], s[8]],
                    // Not in snapshots (they predate it, and training never reads it): only the wire does.
                    orientation: [1.0, 0.0, 0.0, 0.0],
                    motor_pos: s[9..9 + n].to_vec(),
                    motor_vel: s[9 + n..9 + 2 * n].to_vec(),
                }
            })
            .collect();
        k += per * items.len();
        self.obs_delay.set_items(items);
        let delayed = self.action_delay.delay();
        let acts: Vec<Vec<f64>> = (0..delayed).map(|j| f[k + j * n..k + (j + 1) * n].to_vec()).collect();
        k += slots * n;
        self.action_delay.set_items(acts);
        self.rng = task::load_rng(u);
        self.filter_resets = u[task::RNG_WORDS];
        Ok((k, words))
    }
}

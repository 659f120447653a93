//! The controller: one `tick` per control period, a sensor frame in, motor targets and PD gains out, through the
//! state machine a robot needs —
//!
//! passive (no torque) → soft start (targets ramp from the measured pose to the stand pose) → policy → damping
//!
//! Damping (zero stiffness, damping only: the robot sinks slowly instead of kicking) is entered from any powered
//! mode on a fall (tilt past `safety.max_tilt_rad`), a stale sensor stream (no valid frame for
//! `safety.stale_periods`), a non-finite reading, a motor outside its range by `safety.range_margin_rad`, or the
//! operator's stop; it is left only by `reset` (to passive). The operator's command moves towards its target at
//! `safety.command_rate` and stays within the policy's ranges. A tick allocates nothing and takes no lock.

use nalgebra::{Quaternion, UnitQuaternion};

use crate::error::FrameRefused;
use crate::network::Networks;
use crate::observation::{tilt, Layout, ObservationWriter, Proprioception};
use crate::spec::{BaseVelocity, ControllerSpec};

/// One control period's readings, in the torso frame. The driver owns the buffers.
#[derive(Debug, Clone, Copy)]
pub struct SensorFrame<'a> {
    /// When the readings were taken, s (the driver's monotonic clock).
    pub timestamp_s: f64,
    /// World ← torso orientation (w, x, y, z), e.g. the IMU's attitude.
    pub orientation: [f64; 4],
    /// Angular velocity, rad/s.
    pub gyro: [f64; 3],
    pub motor_pos: &'a [f64],
    pub motor_vel: &'a [f64],
    /// The base velocity, for a policy that reads it (the driver's estimator, motion capture).
    pub base_velocity: Option<[f64; 3]>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    Passive,
    SoftStart,
    Policy,
    Damping(Fault),
}

/// Why the controller went to damping.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    Tilt,
    Stale,
    NonFinite,
    OutOfRange,
    /// The policy reads the base velocity and the frame had none.
    NoVelocity,
    Stop,
}

/// What goes to the motor drivers: position targets and PD gains (the drives close the loop at their rate).
#[derive(Debug, Clone, PartialEq)]
pub struct MotorCommand {
    pub mode: Mode,
    pub target: Vec<f64>,
    pub kp: Vec<f64>,
    pub kd: Vec<f64>,
}

/// Counters of what was refused or went wrong, for the driver's log.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    pub ticks: u64,
    pub refused_frames: u64,
    pub faults: u64,
}

pub struct Controller {
    spec: ControllerSpec,
    nets: Networks,
    obs: ObservationWriter,
    mode: Mode,
    out: MotorCommand,
    row: Vec<f32>,
    action: Vec<f64>,
    last_action: Vec<f64>,
    /// Motor positions minus the stand pose; the readings mapped to joint space where the policy acts there.
    motor_dev: Vec<f64>,
    joint_pos: Vec<f64>,
    joint_vel: Vec<f64>,
    joint_last: Vec<f64>,
    command: [f64; 3],
    command_target: [f64; 3],
    soft_from: Vec<f64>,
    soft_t0: Option<f64>,
    restart: bool,
    last_frame_s: Option<f64>,
    /// Watchdog periods since the last frame.
    missed: u32,
    pub counters: Counters,
}

impl Controller {
    pub fn new(spec: ControllerSpec, nets: Networks) -> Self {
        let n = spec.n_motors();
        let o = spec.observation;
        let obs = ObservationWriter::new(Layout::new(n, o.base_velocity, o.history));
        Controller {
            nets,
            obs,
            mode: Mode::Passive,
            out: MotorCommand { mode: Mode::Passive, target: vec![0.0; n], kp: vec![0.0; n], kd: vec![0.0; n] },
            row: vec![0.0; o.inputs],
            action: vec![0.0; n],
            last_action: vec![0.0; n],
            motor_dev: vec![0.0; n],
            joint_pos: vec![0.0; n],
            joint_vel: vec![0.0; n],
            joint_last: vec![0.0; n],
            command: [0.0; 3],
            command_target: [0.0; 3],
            soft_from: vec![0.0; n],
            soft_t0: None,
            restart: true,
            last_frame_s: None,
            missed: 0,
            counters: Counters::default(),
            spec,
        }
    }

    pub fn spec(&self) -> &ControllerSpec {
        &self.spec
    }

    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The last command the controller gave.
    pub fn command_sent(&self) -> &MotorCommand {
        &self.out
    }

    /// Passive → soft start (from the pose of the next frame), on a zero command. Ignored in other modes.
    pub fn start(&mut self) {
        if self.mode == Mode::Passive {
            self.mode = Mode::SoftStart;
            self.soft_t0 = None;
            self.command = [0.0; 3];
        }
    }

    /// The operator's stop: damping.
    pub fn stop(&mut self) {
        self.fault(Fault::Stop);
    }

    /// Damping → passive (the only way out of damping).
    pub fn reset(&mut self) {
        if matches!(self.mode, Mode::Damping(_)) {
            self.mode = Mode::Passive;
        }
    }

    /// The operator's command (v_x, v_y, w_z): clamped to the policy's ranges, reached at the command rate.
    pub fn set_command(&mut self, c: [f64; 3]) {
        for (i, v) in c.iter().enumerate() {
            let [lo, hi] = self.spec.command_ranges[i];
            self.command_target[i] = if v.is_finite() { v.clamp(lo, hi) } else { 0.0 };
        }
    }

    /// The command the policy reads now.
    pub fn command(&self) -> [f64; 3] {
        self.command
    }

    fn fault(&mut self, f: Fault) {
        if !matches!(self.mode, Mode::Damping(_)) {
            self.counters.faults += 1;
            self.mode = Mode::Damping(f);
        }
    }

    /// The gap between frames that makes the stream stale whatever the driver's calls: one period more than
    /// `stale_periods` (the watchdog's count of empty periods is what normally trips first).
    pub fn stale_after_s(&self) -> f64 {
        (self.spec.safety.stale_periods + 1.0) * self.spec.control_period_s
    }

    /// Called by the driver once per control period without a frame: damping once `stale_periods` periods in a
    /// row had none (or, for a driver that calls less often, once the last frame is older than that).
    pub fn watchdog(&mut self, now_s: f64) -> &MotorCommand {
        if let Some(t) = self.last_frame_s {
            self.missed += 1;
            if self.missed as f64 >= self.spec.safety.stale_periods || now_s - t > self.stale_after_s() {
                self.fault(Fault::Stale);
            }
        }
        self.hold_last()
    }

    /// The command of the current mode without a new frame: damping and passive as they are, else the last.
    fn hold_last(&mut self) -> &MotorCommand {
        if let Mode::Damping(_) | Mode::Passive = self.mode {
            let scale = self.spec.safety.damping_kd_scale;
            let damping = matches!(self.mode, Mode::Damping(_));
            for (i, m) in self.spec.motors.iter().enumerate() {
                self.out.kp[i] = 0.0;
                self.out.kd[i] = if damping { m.kd * scale } else { 0.0 };
            }
        }
        self.out.mode = self.mode;
        &self.out
    }

    /// One control period. A frame of the wrong size, or not newer than the last, is refused (counted, not acted
    /// on); everything else moves the state machine and gives the motors' command.
    pub fn tick(&mut self, f: &SensorFrame) -> Result<&MotorCommand, FrameRefused> {
        let n = self.spec.n_motors();
        if f.motor_pos.len() != n || f.motor_vel.len() != n {
            self.counters.refused_frames += 1;
            return Err(FrameRefused::WrongSize { got: f.motor_pos.len().min(f.motor_vel.len()), expected: n });
        }
        if self.last_frame_s.is_some_and(|t| f.timestamp_s <= t) || !f.timestamp_s.is_finite() {
            self.counters.refused_frames += 1;
            return Err(FrameRefused::NotNewer);
        }
        if let Some(t) = self.last_frame_s {
            if f.timestamp_s - t > self.stale_after_s() {
                self.fault(Fault::Stale);
            }
        }
        self.last_frame_s = Some(f.timestamp_s);
        self.missed = 0;
        self.counters.ticks += 1;
        let finite = f.orientation.iter().chain(&f.gyro).chain(f.motor_pos).chain(f.motor_vel).all(|v| v.is_finite())
            && f.base_velocity.is_none_or(|v| v.iter().all(|x| x.is_finite()));
        let q = Quaternion::new(f.orientation[0], f.orientation[1], f.orientation[2], f.orientation[3]);
        if !finite || q.norm() < 1e-6 {
            self.fault(Fault::NonFinite);
            return Ok(self.damp_at(f.motor_pos));
        }
        let orientation = UnitQuaternion::from_quaternion(q);
        let powered = matches!(self.mode, Mode::SoftStart | Mode::Policy);
        if powered {
            let margin = self.spec.safety.range_margin_rad;
            let out = self
                .spec
                .motors
                .iter()
                .zip(f.motor_pos)
                .any(|(m, &p)| p < m.range[0] - margin || p > m.range[1] + margin);
            if tilt(&orientation) > self.spec.safety.max_tilt_rad {
                self.fault(Fault::Tilt);
            } else if out {
                self.fault(Fault::OutOfRange);
            } else if self.mode == Mode::Policy
                && self.spec.observation.base_velocity == BaseVelocity::Observed
                && f.base_velocity.is_none()
            {
                self.fault(Fault::NoVelocity);
            }
        }
        match self.mode {
            Mode::Passive => {
                self.out.target.copy_from_slice(f.motor_pos);
                self.restart = true;
                Ok(self.hold_last())
            }
            Mode::Damping(_) => Ok(self.damp_at(f.motor_pos)),
            Mode::SoftStart => Ok(self.soft_start(f)),
            Mode::Policy => Ok(self.policy(f, &orientation)),
        }
    }

    fn damp_at(&mut self, pos: &[f64]) -> &MotorCommand {
        for (t, p) in self.out.target.iter_mut().zip(pos) {
            if p.is_finite() {
                *t = *p;
            }
        }
        self.hold_last()
    }

    fn soft_start(&mut self, f: &SensorFrame) -> &MotorCommand {
        let t0 = *self.soft_t0.get_or_insert_with(|| {
            self.soft_from.copy_from_slice(f.motor_pos);
            f.timestamp_s
        });
        let s = ((f.timestamp_s - t0) / self.spec.safety.soft_start_s).clamp(0.0, 1.0);
        // A smooth step: no jerk at either end.
        let w = s * s * (3.0 - 2.0 * s);
        for (i, m) in self.spec.motors.iter().enumerate() {
            self.out.target[i] = self.soft_from[i] + w * (m.action_zero - self.soft_from[i]);
            self.out.kp[i] = m.kp;
            self.out.kd[i] = m.kd;
        }
        if s >= 1.0 {
            self.mode = Mode::Policy;
            self.restart = true;
            self.last_action.iter_mut().for_each(|a| *a = 0.0);
        }
        self.out.mode = self.mode;
        &self.out
    }

    fn policy(&mut self, f: &SensorFrame, orientation: &UnitQuaternion<f64>) -> &MotorCommand {
        let dt = self.spec.control_period_s;
        for i in 0..3 {
            let step = self.spec.safety.command_rate[i] * dt;
            let d = (self.command_target[i] - self.command[i]).clamp(-step, step);
            self.command[i] += d;
        }
        let n = self.spec.n_motors();
        for (d, (p, m)) in self.motor_dev.iter_mut().zip(f.motor_pos.iter().zip(&self.spec.motors)) {
            *d = p - m.nominal;
        }
        let (pos, vel, last): (&[f64], &[f64], &[f64]) = match &self.spec.joint_map {
            Some([j, _]) => {
                mat_vec(j, &self.motor_dev, &mut self.joint_pos);
                mat_vec(j, f.motor_vel, &mut self.joint_vel);
                mat_vec(j, &self.last_action, &mut self.joint_last);
                (&self.joint_pos, &self.joint_vel, &self.joint_last)
            }
            None => (&self.motor_dev, f.motor_vel, &self.last_action),
        };
        let p = Proprioception {
            orientation,
            gyro: f.gyro,
            motor_dev: pos,
            motor_vel: vel,
            last_action: last,
            command: self.command,
            base_velocity: f.base_velocity.unwrap_or_default(),
        };
        self.obs.write(&p, self.restart, &mut self.row);
        self.restart = false;
        self.nets.act(&self.row, &mut self.action);
        if let Some([_, inv]) = &self.spec.joint_map {
            // Joint-space action → motor space (the joint-space last action is recomputed next tick).
            mat_vec(inv, &self.action, &mut self.joint_last);
            self.action.copy_from_slice(&self.joint_last);
        }
        let clip = self.spec.action_clip;
        for i in 0..n {
            let a = self.action[i];
            let a = if a.is_finite() { a.clamp(-clip, clip) } else { 0.0 };
            self.last_action[i] = a;
            let m = &self.spec.motors[i];
            self.out.target[i] = (m.action_zero + self.spec.action_scale * a).clamp(m.range[0], m.range[1]);
            self.out.kp[i] = m.kp;
            self.out.kd[i] = m.kd;
        }
        self.out.mode = self.mode;
        &self.out
    }
}

/// `out = m · v` for a row-major n × n matrix.
fn mat_vec(m: &[f64], v: &[f64], out: &mut [f64]) {
    let n = v.len();
    for (i, o) in out.iter_mut().enumerate() {
        *o = (0..n).map(|k| m[i * n + k] * v[k]).sum();
    }
}

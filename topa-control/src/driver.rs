//! What a robot's driver implements to run the controller: read the sensors of this period, send the motors'
//! command, tell the time. [`run_period`] is one period of the loop; a driver's main loop calls it at the
//! control rate (from a real-time thread or the motor bus's cycle).
//!
//! ```
//! use topa_control::driver::{Driver, Readings};
//! use topa_control::MotorCommand;
//!
//! /// A robot on some bus: here, readings kept in memory.
//! struct MyRobot { t: f64, pos: Vec<f64>, vel: Vec<f64>, sent: usize }
//!
//! impl Driver for MyRobot {
//!     fn now(&self) -> f64 { self.t }
//!     fn read(&mut self, r: &mut Readings) -> bool {
//!         r.timestamp_s = self.t;
//!         r.orientation = [1.0, 0.0, 0.0, 0.0];
//!         r.gyro = [0.0; 3];
//!         r.motor_pos.copy_from_slice(&self.pos);
//!         r.motor_vel.copy_from_slice(&self.vel);
//!         true // false: nothing arrived this period
//!     }
//!     fn send(&mut self, c: &MotorCommand) {
//!         // write c.target, c.kp, c.kd to the drives
//!         self.sent += 1;
//!     }
//! }
//! ```

use crate::controller::{Controller, MotorCommand, SensorFrame};

/// One period's readings, in buffers the loop owns (sized to the robot once).
#[derive(Debug, Clone, PartialEq)]
pub struct Readings {
    pub timestamp_s: f64,
    /// World ← torso (w, x, y, z).
    pub orientation: [f64; 4],
    pub gyro: [f64; 3],
    pub motor_pos: Vec<f64>,
    pub motor_vel: Vec<f64>,
    /// For a policy that reads the base velocity.
    pub base_velocity: Option<[f64; 3]>,
}

impl Readings {
    pub fn new(n_motors: usize) -> Self {
        Readings {
            timestamp_s: 0.0,
            orientation: [1.0, 0.0, 0.0, 0.0],
            gyro: [0.0; 3],
            motor_pos: vec![0.0; n_motors],
            motor_vel: vec![0.0; n_motors],
            base_velocity: None,
        }
    }

    pub fn frame(&self) -> SensorFrame<'_> {
        SensorFrame {
            timestamp_s: self.timestamp_s,
            orientation: self.orientation,
            gyro: self.gyro,
            motor_pos: &self.motor_pos,
            motor_vel: &self.motor_vel,
            base_velocity: self.base_velocity,
        }
    }
}

pub trait Driver {
    /// The driver's monotonic clock, s (the frames' timestamps are on it).
    fn now(&self) -> f64;
    /// This period's readings into `r`; false when none arrived (the controller's watchdog counts the silence).
    fn read(&mut self, r: &mut Readings) -> bool;
    /// The motors' command for this period.
    fn send(&mut self, c: &MotorCommand);
}

/// One control period: read, tick (or, without readings or with refused ones, the watchdog), send. Returns what
/// was sent.
pub fn run_period<'a>(c: &'a mut Controller, d: &mut impl Driver, r: &mut Readings) -> &'a MotorCommand {
    let got = d.read(r);
    // The time after the read: a driver's read may wait for the frame up to a period.
    let now = d.now();
    let ticked = got && c.tick(&r.frame()).is_ok();
    let out = if ticked { c.command_sent() } else { c.watchdog(now) };
    d.send(out);
    out
}

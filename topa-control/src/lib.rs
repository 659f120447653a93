//! The robot-side controller: what a robot's driver links to run a TopA policy. Every control period the driver
//! hands a [`SensorFrame`] (orientation, gyro, motor positions and velocities, a timestamp) to
//! [`Controller::tick`] and sends the [`MotorCommand`] it returns (position targets and PD gains) to the motor
//! drivers. Inside: the state machine (passive → soft start → policy → damping), the observation as the training
//! env writes it, and the policy's forward pass with its learned velocity estimator — from a controller file
//! that `topa export --controller DIR` writes. No simulator, no training code; a tick allocates nothing.
//!
//! ```no_run
//! use topa_control::{Controller, SensorFrame};
//!
//! let mut c = Controller::load(std::path::Path::new("out/controller")).unwrap();
//! c.start();
//! c.set_command([0.4, 0.0, 0.0]);
//! let (pos, vel) = (vec![0.0; 10], vec![0.0; 10]);
//! let frame = SensorFrame {
//!     timestamp_s: 0.02,
//!     orientation: [1.0, 0.0, 0.0, 0.0],
//!     gyro: [0.0; 3],
//!     motor_pos: &pos,
//!     motor_vel: &vel,
//!     base_velocity: None,
//! };
//! let command = c.tick(&frame).unwrap();
//! // send command.target, command.kp, command.kd to the drives
//! # let _ = command;
//! ```

pub mod controller;
pub mod driver;
pub mod error;
pub mod netem;
pub mod network;
pub mod observation;
pub mod operator;
pub mod remote;
pub mod spec;
pub mod transport;
pub mod wire;
#[cfg(feature = "zenoh")]
pub mod zenoh_carrier;

pub use controller::{Controller, Counters, Fault, Mode, MotorCommand, SensorFrame};
pub use error::{Error, FrameRefused, Result};
pub use spec::ControllerSpec;

impl Controller {
    /// Loads a controller file (`controller.json` or its folder) and its weights, validating both.
    pub fn load(path: &std::path::Path) -> Result<Controller> {
        let (spec, weights) = ControllerSpec::load(path)?;
        let nets = network::Networks::load(&spec, &weights)?;
        Ok(Controller::new(spec, nets))
    }
}

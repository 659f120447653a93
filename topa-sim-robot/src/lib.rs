//! The simulator as a robot on the wire, as `unitree_mujoco` is for Unitree's robots: [`robot::SimRobot`] runs
//! MuJoCo in real time at the physics rate, holds the motors' PD on its side at that rate (as real drives do), and
//! exchanges the wire format (`topa_control::wire`) with a controller in another process — the same controller a
//! robot runs, only its driver differs. Loss, latency and jitter can be put between the two; the drives damp on
//! their own watchdog when the controller falls silent. [`experiments`] runs the tracking and push experiments
//! through the two processes, the evaluation acting as the operator; [`report`] sets them beside the in-process
//! results.

pub mod error;
pub mod experiments;
pub mod report;
pub mod robot;

pub use error::{Error, Result};
pub use robot::{SimRobot, SimRobotConfig};

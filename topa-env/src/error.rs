//! Errors of the environment layer.

use mujoco_sys::MujocoError;

#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    #[error(transparent)]
    Mujoco(#[from] MujocoError),
    /// The loaded model does not match the TopA spec (a name, a limit, an order).
    #[error("model '{model}' does not match the TopA {kind} spec: {problem}")]
    Spec { model: String, kind: &'static str, problem: String },
    /// A configuration value is out of range or inconsistent.
    #[error("invalid environment config: {0}")]
    Config(String),
    /// A buffer or action of the wrong size was passed.
    #[error("{0}")]
    Shape(String),
}

pub type Result<T, E = EnvError> = std::result::Result<T, E>;

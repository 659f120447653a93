//! Errors of the environment layer.

use mujoco::MujocoError;

#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    #[error(transparent)]
    Mujoco(#[from] MujocoError),
    /// A robot spec that does not load or does not match its MJCF (the error names the spec's line).
    #[error(transparent)]
    Spec(#[from] crate::spec::SpecError),
    /// A configuration value is out of range or inconsistent.
    #[error("invalid environment config: {0}")]
    Config(String),
    /// A buffer or action of the wrong size was passed.
    #[error("{0}")]
    Shape(String),
}

pub type Result<T, E = EnvError> = std::result::Result<T, E>;

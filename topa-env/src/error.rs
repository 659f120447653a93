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
    /// A name that is not one of the choices (the message lists them).
    #[error("{0}")]
    Choice(String),
    /// A course file that does not load or whose geometry does not hold (the message names the item).
    #[error("{0}")]
    Course(String),
    /// A policy file that cannot drive this robot (the message says why).
    #[error("{}: {message}", path.display())]
    Policy { path: std::path::PathBuf, message: String },
    /// A policy or checkpoint file that does not load.
    #[error(transparent)]
    Trainer(#[from] trainer::Error),
}

pub type Result<T, E = EnvError> = std::result::Result<T, E>;

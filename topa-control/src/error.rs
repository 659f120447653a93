//! The controller's errors: a controller file that does not load, and a sensor frame it refuses.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("controller file {path}: {message}")]
    File { path: PathBuf, message: String },
    /// A controller spec that does not validate (the message names the key).
    #[error("{0}")]
    Invalid(String),
    #[error("cannot read {path}")]
    Io { path: PathBuf, source: std::io::Error },
}

pub type Result<T> = std::result::Result<T, Error>;

/// Why a sensor frame was refused (it is counted and never acted on).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FrameRefused {
    #[error("the frame has {got} motor values, this robot {expected}")]
    WrongSize { got: usize, expected: usize },
    #[error("the frame is no newer than the last one accepted")]
    NotNewer,
}

//! The learner's errors. Each names the file or setting at fault and, where there is one, the fix; causes from
//! other libraries stay reachable through `source()`.

use std::path::{Path, PathBuf};

pub use crate::config::ConfigError;

/// What an environment's failure is, to the learner that knows no robot: any error of the env's own crate.
pub type EnvFailure = Box<dyn std::error::Error + Send + Sync>;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A training config that does not load or does not validate.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// Reading, creating, writing or renaming a file failed.
    #[error("{action} {}", path.display())]
    Io {
        action: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A checkpoint, policy file, sidecar or metrics file that is malformed, corrupt, of another version or for
    /// another network: the message names the file and what to do.
    #[error("{message}")]
    File {
        message: String,
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync>>,
    },
    /// Settings or inputs the learner refuses (for example an adversary for a task without perturbations).
    #[error("{0}")]
    Invalid(String),
    /// A tensor operation failed (a shape or dtype that does not fit).
    #[error(transparent)]
    Tensor(#[from] candle_core::Error),
    /// The environment failed (its own error is the source).
    #[error("{context}")]
    Env {
        context: &'static str,
        #[source]
        source: EnvFailure,
    },
    /// Encoding a sidecar (JSON) or a tensor file (safetensors) failed.
    #[error("encoding JSON")]
    Json(#[from] serde_json::Error),
    #[error("encoding safetensors")]
    SafeTensors(#[from] safetensors::SafeTensorError),
    /// The TensorBoard event file could not be written.
    #[error("TensorBoard event file in {}", dir.display())]
    TensorBoard {
        dir: PathBuf,
        #[source]
        source: tboard::Error,
    },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An I/O failure on `path`; `action` says what was being done ("cannot read", "creating", …).
    pub fn io<'a>(action: &'static str, path: &'a Path) -> impl FnOnce(std::io::Error) -> Error + 'a {
        move |source| Error::Io { action, path: path.to_path_buf(), source }
    }

    /// An environment's failure while the learner was doing `context`.
    pub fn env(context: &'static str) -> impl FnOnce(EnvFailure) -> Error {
        move |source| Error::Env { context, source }
    }

    /// A file that cannot be used, with its cause.
    pub fn file(message: impl Into<String>, source: impl std::error::Error + Send + Sync + 'static) -> Error {
        Error::File { message: message.into(), source: Some(Box::new(source)) }
    }

    /// A file that cannot be used, for a reason found by our own checks.
    pub fn bad_file(message: impl Into<String>) -> Error {
        Error::File { message: message.into(), source: None }
    }
}

/// Returns early with `Error::Invalid` (the learner's refusal of a setting or input).
macro_rules! invalid {
    ($($arg:tt)*) => { return Err($crate::error::Error::Invalid(format!($($arg)*))) };
}
pub(crate) use invalid;

/// Returns early with a file error found by our own checks.
macro_rules! bad_file {
    ($($arg:tt)*) => { return Err($crate::error::Error::bad_file(format!($($arg)*))) };
}
pub(crate) use bad_file;

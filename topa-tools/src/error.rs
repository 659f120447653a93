//! The errors of the tools: the ONNX export and its check, `topa info`, the config reference and the benchmarks.
//! Each names the file, flag or tool at fault and, where there is one, the fix; the errors of the layers below pass
//! through as they are, causes stay reachable by `source()`.

use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A policy, checkpoint or metrics file that does not load; a trainer that fails.
    #[error(transparent)]
    Trainer(#[from] trainer::Error),
    /// A training config that does not load.
    #[error(transparent)]
    Config(#[from] trainer::config::ConfigError),
    /// A robot, environment config or policy runner that does not load.
    #[error(transparent)]
    Env(#[from] topa_env::EnvError),
    /// A robot spec that does not load or does not match its MJCF.
    #[error(transparent)]
    Spec(#[from] topa_env::spec::SpecError),
    /// A batch of envs failed while stepping (a benchmark's rollout); its message names the cause.
    #[error(transparent)]
    Simulation(trainer::vec_env::EnvFailure),
    /// MuJoCo failed (a model, a simulation, the renderer).
    #[error(transparent)]
    Mujoco(#[from] mujoco::MujocoError),
    /// A training run's config that does not load (boxed: the training run's error is large, and `Result`s stay
    /// small).
    #[error(transparent)]
    Train(Box<topa_train::Error>),
    /// The video writer failed (boxed, as `Train`).
    #[error(transparent)]
    Eval(Box<topa_eval::Error>),
    /// A tensor operation failed (reading a policy's weights).
    #[error(transparent)]
    Tensor(#[from] candle_core::Error),
    /// Reading or running a file failed.
    #[error("{action} {}", path.display())]
    Io {
        action: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file that is malformed or does not fit: an ONNX file that is not a TopA policy model, a policy that cannot
    /// drive its robot, a metrics file without a column (the message names it and the fix).
    #[error("{message}")]
    File {
        message: String,
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync>>,
    },
    /// `--check`: the ONNX file was exported from another policy (its weights checksum differs).
    #[error(
        "{} was not exported from {} (weights checksum {found} vs {expected}): export it again",
        onnx.display(),
        policy.display()
    )]
    NotExportedFrom { onnx: PathBuf, policy: PathBuf, found: String, expected: u32 },
    /// A benchmark that could not run or measure: a worker or tool that failed or printed no result, a schedule
    /// that ended before the timed iterations (the message names it and the fix).
    #[error("{message}")]
    Bench {
        message: String,
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync>>,
    },
    /// The config types' schema and defaults disagree (the config reference cannot be made; the message names the
    /// key).
    #[error("{0}")]
    Schema(String),
    /// Flags or settings that cannot run (the message names them and the fix).
    #[error("{0}")]
    Invalid(String),
    /// A resolved config could not be written as TOML.
    #[error("serialising a resolved config")]
    Toml(#[source] toml::ser::Error),
    /// Encoding a summary or the ONNX metadata (JSON) failed.
    #[error("encoding JSON")]
    Json(#[from] serde_json::Error),
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl From<topa_train::Error> for Error {
    fn from(e: topa_train::Error) -> Error {
        Error::Train(Box::new(e))
    }
}

impl From<topa_eval::Error> for Error {
    fn from(e: topa_eval::Error) -> Error {
        Error::Eval(Box::new(e))
    }
}

impl From<trainer::vec_env::EnvFailure> for Error {
    fn from(e: trainer::vec_env::EnvFailure) -> Error {
        Error::Simulation(e)
    }
}

impl Error {
    /// An I/O failure on `path`; `action` says what was being done ("cannot read", "cannot run", …).
    pub fn io<'a>(action: &'static str, path: &'a Path) -> impl FnOnce(std::io::Error) -> Error + 'a {
        move |source| Error::Io { action, path: path.to_path_buf(), source }
    }

    /// A file that cannot be used, with its cause.
    pub fn file(message: impl Into<String>, source: impl std::error::Error + Send + Sync + 'static) -> Error {
        Error::File { message: message.into(), source: Some(Box::new(source)) }
    }

    /// A file that cannot be used, for a reason found by our own checks.
    pub fn bad_file(message: impl Into<String>) -> Error {
        Error::File { message: message.into(), source: None }
    }

    /// A benchmark that cannot run, with its cause.
    pub fn bench(message: impl Into<String>, source: impl std::error::Error + Send + Sync + 'static) -> Error {
        Error::Bench { message: message.into(), source: Some(Box::new(source)) }
    }

    /// A benchmark that cannot run, for a reason found by our own checks.
    pub fn bad_bench(message: impl Into<String>) -> Error {
        Error::Bench { message: message.into(), source: None }
    }
}

/// Returns early with `Error::Invalid`: flags or settings that cannot run.
macro_rules! invalid {
    ($($arg:tt)*) => { return Err($crate::error::Error::Invalid(format!($($arg)*))) };
}
pub(crate) use invalid;

/// Returns early with a file error found by our own checks.
macro_rules! bad_file {
    ($($arg:tt)*) => { return Err($crate::error::Error::bad_file(format!($($arg)*))) };
}
pub(crate) use bad_file;

/// Returns early with a benchmark error found by our own checks.
macro_rules! bad_bench {
    ($($arg:tt)*) => { return Err($crate::error::Error::bad_bench(format!($($arg)*))) };
}
pub(crate) use bad_bench;

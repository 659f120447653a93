//! The errors of a training run. Each names the file, flag or setting at fault and, where there is one, the fix;
//! the learner's and the environment's errors pass through as they are.

use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The learner failed (a config, checkpoint or policy file; the training itself).
    #[error(transparent)]
    Trainer(#[from] trainer::Error),
    /// A training config that does not load.
    #[error(transparent)]
    Config(#[from] trainer::config::ConfigError),
    /// The environment's config or robot failed.
    #[error(transparent)]
    Env(#[from] topa_env::EnvError),
    /// A config whose `[env]` table does not parse (`what` names the config).
    #[error("{what}")]
    EnvConfig {
        what: String,
        #[source]
        source: topa_env::EnvError,
    },
    /// Creating or reading a file or folder failed.
    #[error("{action} {}", path.display())]
    Io {
        action: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A run folder or metrics file that is not what the command needs (the message says what to give).
    #[error("{0}")]
    Run(String),
    /// Flags or settings that do not go together (the message names them and the fix).
    #[error("{0}")]
    Invalid(String),
    /// MPI could not start, or the ranks disagree.
    #[error("{0}")]
    Ranks(String),
    /// A tensor operation failed.
    #[error(transparent)]
    Tensor(#[from] candle_core::Error),
    /// Encoding a record (JSON) failed.
    #[error("encoding JSON")]
    Json(#[from] serde_json::Error),
    /// Encoding a config (TOML) failed.
    #[error("encoding TOML")]
    Toml(#[from] toml::ser::Error),
    /// Drawing a figure failed.
    #[error("plotting: {0}")]
    Plot(String),
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An I/O failure on `path`; `action` says what was being done ("creating", "cannot read", …).
    pub fn io<'a>(action: &'static str, path: &'a Path) -> impl FnOnce(std::io::Error) -> Error + 'a {
        move |source| Error::Io { action, path: path.to_path_buf(), source }
    }
}

/// Returns early with `Error::Invalid`: flags or settings that do not go together.
macro_rules! invalid {
    ($($arg:tt)*) => { return Err($crate::error::Error::Invalid(format!($($arg)*))) };
}
pub(crate) use invalid;

/// Returns early with `Error::Run`: a run folder or metrics file that is not what the command needs.
macro_rules! run_error {
    ($($arg:tt)*) => { return Err($crate::error::Error::Run(format!($($arg)*))) };
}
pub(crate) use run_error;

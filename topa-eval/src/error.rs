//! The errors of the experiments and their reports. Each names the flag, file or setting at fault and, where there
//! is one, the fix; the errors of the layers below pass through as they are, causes stay reachable by `source()`.

use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A policy, checkpoint or sidecar that does not load.
    #[error(transparent)]
    Trainer(#[from] trainer::Error),
    /// A config file (a sim2sim file) that does not load.
    #[error(transparent)]
    Config(#[from] trainer::config::ConfigError),
    /// A robot, environment config or course that does not load.
    #[error(transparent)]
    Env(#[from] topa_env::EnvError),
    /// MuJoCo failed (a model, a simulation, the renderer).
    #[error(transparent)]
    Mujoco(#[from] mujoco::MujocoError),
    /// A batch of envs failed while stepping (its message names the cause and the fix).
    #[error("{0}")]
    Simulation(trainer::vec_env::EnvFailure),
    /// A training run's config or files (the checkpoints a progress study reads); boxed, as it is large.
    #[error(transparent)]
    Train(Box<topa_train::Error>),
    /// Reading, creating, writing or moving a file failed.
    #[error("{action} {}", path.display())]
    Io {
        action: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A report, recording or page that is malformed or does not fit (the message names it and the fix).
    #[error("{message}")]
    File {
        message: String,
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync>>,
    },
    /// Flags or settings that cannot run (the message names them and the fix).
    #[error("{0}")]
    Invalid(String),
    /// Encoding a report (JSON) failed.
    #[error("encoding JSON")]
    Json(#[from] serde_json::Error),
    /// Writing an MCAP recording failed.
    #[error("writing the MCAP recording")]
    Mcap(#[from] mcap::McapError),
    /// The video could not be made (the message says why).
    #[error("{0}")]
    Video(String),
    /// The GIF encoder failed.
    #[error("encoding the GIF")]
    Gif(#[from] gif::EncodingError),
    /// ffmpeg (the MP4 encoder) could not be run or stopped working.
    #[error("{message}")]
    Ffmpeg {
        message: &'static str,
        #[source]
        source: std::io::Error,
    },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl From<topa_train::Error> for Error {
    fn from(e: topa_train::Error) -> Error {
        Error::Train(Box::new(e))
    }
}

impl From<trainer::vec_env::EnvFailure> for Error {
    fn from(e: trainer::vec_env::EnvFailure) -> Error {
        Error::Simulation(e)
    }
}

impl Error {
    /// An I/O failure on `path`; `action` says what was being done ("cannot read", "creating", …).
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
}

/// Returns early with `Error::Invalid`: flags or settings that cannot run.
macro_rules! invalid {
    ($($arg:tt)*) => { return Err($crate::error::Error::Invalid(format!($($arg)*))) };
}
pub(crate) use invalid;

/// `invalid!` unless `cond` holds.
macro_rules! ensure {
    // The condition is bound first: `!(x >= 0.0)` written in place reads as a negated float comparison.
    ($cond:expr, $($arg:tt)*) => {
        let holds: bool = $cond;
        if !holds {
            $crate::error::invalid!($($arg)*);
        }
    };
}
pub(crate) use ensure;

/// Returns early with a file error found by our own checks.
macro_rules! bad_file {
    ($($arg:tt)*) => { return Err($crate::error::Error::bad_file(format!($($arg)*))) };
}
pub(crate) use bad_file;

/// The message and its causes, as the command line prints them (for tests that look into a cause).
#[cfg(test)]
pub(crate) fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        s = format!("{s}: {c}");
        cause = c.source();
    }
    s
}

//! The errors of system identification. Each names the flag, file, bench or log at fault and, where there is one,
//! the fix; the errors of the layers below pass through as they are, causes stay reachable by `source()`.

use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The environment failed (a robot's linkage, a sim2sim batch, a policy runner).
    #[error(transparent)]
    Env(#[from] topa_env::EnvError),
    /// A robot spec that does not load or does not match its MJCF.
    #[error(transparent)]
    Spec(#[from] topa_env::spec::SpecError),
    /// A batch of envs failed while stepping (a recording of the realistic sim2sim); its message names the cause.
    #[error(transparent)]
    Simulation(trainer::vec_env::EnvFailure),
    /// MuJoCo failed (a model that does not compile or save, a name it does not have).
    #[error(transparent)]
    Mujoco(#[from] mujoco::MujocoError),
    /// A figure that could not be drawn (boxed: the training run's error is large, and `Result`s stay small).
    #[error(transparent)]
    Train(Box<topa_train::Error>),
    /// The evaluation's settings (the realistic sim2sim) or its report writer failed (boxed, as `Train`).
    #[error(transparent)]
    Eval(Box<topa_eval::Error>),
    /// Reading a file failed.
    #[error("{action} {}", path.display())]
    Io {
        action: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A motor log, an excitation, a filter recording or a written file that is malformed or does not load back
    /// (the message names the file, row and column).
    #[error("{message}")]
    File {
        message: String,
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync>>,
    },
    /// A bench MJCF, or a robot hung in the air as a bench, that cannot be used or does not fit the log (the
    /// message names the file, the motor and the fix); MuJoCo's or the XML reader's error as the source.
    #[error("{message}")]
    Bench {
        message: String,
        #[source]
        source: Option<Box<dyn std::error::Error + Send + Sync>>,
    },
    /// The bench simulation became unstable with the parameters tried.
    #[error("the bench simulation diverged at t = {t:.3} s; the parameters are out of reach")]
    Diverged {
        t: f64,
        #[source]
        source: mujoco::MujocoError,
    },
    /// A lock whose holder panicked (another window's simulation): that panic is the error to look at.
    #[error("{0} poisoned")]
    Poisoned(&'static str),
    /// Flags or settings that cannot run (the message names them and the fix).
    #[error("{0}")]
    Invalid(String),
    /// Encoding a sim2sim table (TOML) failed.
    #[error("encoding TOML")]
    Toml(#[from] toml::ser::Error),
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
    /// An I/O failure on `path`; `action` says what was being done ("cannot read the recording", …).
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

    /// A bench that cannot be used, with its cause.
    pub fn bench(message: impl Into<String>, source: impl std::error::Error + Send + Sync + 'static) -> Error {
        Error::Bench { message: message.into(), source: Some(Box::new(source)) }
    }

    /// A bench that cannot be used, for a reason found by our own checks.
    pub fn bad_bench(message: impl Into<String>) -> Error {
        Error::Bench { message: message.into(), source: None }
    }
}

/// Returns early with `Error::Invalid`: flags or settings that cannot run.
macro_rules! invalid {
    ($($arg:tt)*) => { return Err($crate::error::Error::Invalid(format!($($arg)*))) };
}
pub(crate) use invalid;

/// `invalid!` unless `cond` holds. The condition is bound first, so that a float comparison is never negated in
/// place (clippy's `neg_cmp_op_on_partial_ord`); the same in the macros below.
macro_rules! ensure {
    ($cond:expr, $($arg:tt)*) => {{
        let holds: bool = $cond;
        if !holds {
            $crate::error::invalid!($($arg)*);
        }
    }};
}
pub(crate) use ensure;

/// Returns early with a file error found by our own checks.
macro_rules! bad_file {
    ($($arg:tt)*) => { return Err($crate::error::Error::bad_file(format!($($arg)*))) };
}
pub(crate) use bad_file;

/// `bad_file!` unless `cond` holds.
macro_rules! ensure_file {
    ($cond:expr, $($arg:tt)*) => {{
        let holds: bool = $cond;
        if !holds {
            $crate::error::bad_file!($($arg)*);
        }
    }};
}
pub(crate) use ensure_file;

/// `return Err(Error::bad_bench(..))` unless `cond` holds.
macro_rules! ensure_bench {
    ($cond:expr, $($arg:tt)*) => {{
        let holds: bool = $cond;
        if !holds {
            return Err($crate::error::Error::bad_bench(format!($($arg)*)));
        }
    }};
}
pub(crate) use ensure_bench;

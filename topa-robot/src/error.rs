//! The errors of an import and of the stand solver. Each names the model element or file at fault and the fix; the
//! errors of the layers below pass through as they are.

use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A model that MuJoCo refuses, or a simulation that fails.
    #[error(transparent)]
    Mujoco(#[from] mujoco::MujocoError),
    /// A drafted or edited spec that does not load (the message names its line).
    #[error(transparent)]
    Spec(#[from] topa_env::spec::SpecError),
    /// The linkage of a spec that does not solve.
    #[error(transparent)]
    Env(#[from] topa_env::EnvError),
    /// Writing a file failed.
    #[error(transparent)]
    Write(#[from] trainer::Error),
    /// Reading a file failed.
    #[error("cannot read {}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file that is not what it must be (not XML, not TOML).
    #[error("{} is not {what}", path.display())]
    Malformed {
        path: PathBuf,
        what: &'static str,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A model the import cannot make a robot of: the message names the element and what to change.
    #[error("{}: {message}", path.display())]
    Model { path: PathBuf, message: String },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    pub(crate) fn model(path: &Path, message: impl Into<String>) -> Error {
        Error::Model { path: path.to_path_buf(), message: message.into() }
    }

    pub(crate) fn read(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
        move |source| Error::Read { path: path.to_path_buf(), source }
    }

    pub(crate) fn malformed(
        path: &Path,
        what: &'static str,
        source: impl std::error::Error + Send + Sync + 'static,
    ) -> Error {
        Error::Malformed { path: path.to_path_buf(), what, source: Box::new(source) }
    }
}

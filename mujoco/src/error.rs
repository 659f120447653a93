//! One error type for everything that can go wrong between us and MuJoCo.

use std::path::PathBuf;

use crate::obj_type::ObjType;

/// An error from MuJoCo or from using it wrongly. Each variant names the thing at fault and, where there is one,
/// the fix.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MujocoError {
    /// The linked library is not MuJoCo 2.2.x.
    #[error(
        "libmujoco is version {found}, but mujoco-sys needs 2.2.x: install it with `apt-get install -y libmujoco-dev` (Debian bookworm ships 2.2.2)"
    )]
    Version { found: String },
    /// The model file does not exist or cannot be read.
    #[error("cannot read model file {}: {reason}", path.display())]
    MissingFile { path: PathBuf, reason: String },
    /// MuJoCo's parser or compiler rejected the model (its message says where).
    #[error("MuJoCo could not load {source_name}: {message}")]
    Load { source_name: String, message: String },
    /// A fatal `mju_error` raised inside a MuJoCo call; the `Data` must be reset before it is used again.
    #[error("MuJoCo error in {call}: {message}")]
    Fatal { call: &'static str, message: String },
    /// The memory the model preallocates (the MJCF's `<size>`) is too small for what the simulation needed. MuJoCo
    /// would drop the extra contacts or constraint rows silently; we refuse instead.
    #[error(
        "model '{model}': {what} exceeded its preallocated size ({limit}) in {call}: raise `{attribute}` in the \
         MJCF's <size> element (e.g. to {suggested})"
    )]
    Capacity {
        model: String,
        call: &'static str,
        what: &'static str,
        limit: usize,
        attribute: &'static str,
        suggested: usize,
    },
    /// A name that the model does not define.
    #[error("model '{model}' has no {kind} named '{name}'{hint}")]
    NotFound { model: String, kind: ObjType, name: String, hint: String },
    /// No OpenGL context for MuJoCo's renderer (the message says what to install).
    #[error("headless OpenGL: {0}")]
    Gl(String),
    /// An index or size that does not fit the model.
    #[error("{0}")]
    Invalid(String),
}

pub type Result<T, E = MujocoError> = std::result::Result<T, E>;

//! The viewer's errors: each names what failed and what to do.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The policy, its robot or the evaluation settings do not load.
    #[error(transparent)]
    Eval(#[from] topa_eval::Error),
    #[error(transparent)]
    Env(#[from] topa_env::EnvError),
    #[error(transparent)]
    Mujoco(#[from] mujoco::MujocoError),
    /// No window could be opened.
    #[error("cannot open a window: {0} (no display? `topa view --gif FILE` writes the walk to a GIF instead)")]
    Window(String),
    #[error("--level {level} does not exist: the terrain has levels 1 (easiest) to {levels}")]
    Level { level: usize, levels: usize },
    #[error("the simulation diverged at {0:.2} s (reset with R; if it repeats, lower --timestep)")]
    Diverged(f64),
    #[error("cannot write the screenshot {}: {source}", path.display())]
    Screenshot {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

pub type Result<T> = std::result::Result<T, Error>;

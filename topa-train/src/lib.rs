//! Training runs of the robot tasks, between the learner (`trainer`, which knows no robot) and the tasks
//! (`topa-env`): a config file's learner tables and `[env]` table checked together, the envs of each MPI rank,
//! a run started, forked from another run's policy or resumed bit for bit, its checkpoints and policy files, and
//! its learning curves.
//!
//! ```
//! // The preset's config resolved as a run records it: every key of the task's config, defaults included.
//! let preset = topa_env::assets::repo_dir().join("configs/cpu.toml");
//! let (cfg, env) = topa_train::load_config(&preset)?;
//! let resolved = topa_train::with_resolved_env(&cfg)?;
//! assert!(resolved.env.len() > cfg.env.len());
//! assert_eq!(topa_train::config::env_config(&resolved)?.robot, env.robot);
//! # Ok::<(), topa_train::Error>(())
//! ```
//!
//! ```no_run
//! // Train the preset (TopA, closed chain) for its configured iterations into `runs/demo`.
//! let start = topa_train::Start {
//!     config: Some("configs/cpu.toml".into()),
//!     out: Some("runs/demo".into()),
//!     command: "example".into(),
//!     ..Default::default()
//! };
//! let outcome = topa_train::Run::open(&start)?.train(|log| eprintln!("iteration {}", log.iteration))?;
//! println!("policy: {}", outcome.policy.display());
//! # Ok::<(), topa_train::Error>(())
//! ```

pub mod config;
pub mod dashboard;
pub mod error;
#[cfg(feature = "mpi")]
mod mpi_comm;
pub mod plots;
pub mod policy;
pub mod ranks;
pub mod run;

pub use config::{load_config, with_resolved_env};
pub use error::{Error, Result};
pub use policy::{export_checkpoint, export_policy};
pub use run::{Outcome, Run, Start};

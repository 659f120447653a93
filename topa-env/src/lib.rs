//! The TopA robot spec, the paper's training environment, and a rayon-batched implementation of the learner's
//! `VecEnv` (defined by the trainer, which knows no robot) on mujoco-sys.
//!
//! ```
//! use topa_env::{vec_env, EnvConfig, VecEnv};
//!
//! // Two envs of the default task (TopA, closed chain), stepped with zero actions (the stand pose's targets).
//! let cfg = EnvConfig::default();
//! let mut envs = vec_env::task_batch(&cfg, 0, 2, 1, 1)?;
//! envs.reset()?;
//! envs.step(&vec![0.0; 2 * envs.action_dim()])?;
//! assert_eq!(envs.action_dim(), 10);
//! assert_eq!(envs.obs().len(), 2 * envs.obs_dim());
//! assert!(envs.obs().iter().all(|x| x.is_finite()));
//! # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
//! ```

pub mod assets;
pub mod config;
pub mod course;
pub mod domain_rand;
pub mod env;
pub mod error;
pub mod indices;
pub mod integrator;
pub mod linkage;
pub mod mechanism;
pub mod observation;
pub mod perturb;
pub mod physics;
pub mod policy_runner;
pub mod rewards;
pub mod sim2sim;
pub mod spec;
pub mod state;
pub mod symmetry;
pub mod task;
pub mod tasks;
pub mod terrain;
pub mod topa;
pub mod vec_env;
pub mod world;

pub use config::{EnvConfig, IntegratorChoice, TaskKind};
pub use env::RobotEnv;
pub use error::{EnvError, Result};
pub use indices::RobotIndices;
pub use perturb::Perturbation;
pub use symmetry::{SignedPermutation, Symmetry};
pub use task::{StepOutcome, Task};
pub use topa::ModelKind;
pub use trainer::{EnvSnapshot, EpisodeStats, PerturbationChannel, StepTiming, VecEnv};
pub use vec_env::BatchEnv;

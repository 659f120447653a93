//! The TopA robot spec, the paper's training environment, and a rayon-batched implementation of the learner's
//! `VecEnv` (defined by the trainer, which knows no robot) on mujoco-sys.

pub mod assets;
pub mod config;
pub mod course;
pub mod env;
pub mod error;
pub mod indices;
pub mod integrator;
pub mod linkage;
pub mod observation;
pub mod perturb;
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

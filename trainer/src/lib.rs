//! The learning core: networks (fast CPU kernels inside Candle's autograd), PPO with the paper's symmetry and
//! last-layer decay losses, the cyclic adversary, checkpoints and policy files — and the interface it needs from
//! an environment (`vec_env`, `symmetry`), which knows no robot.

pub mod actor_critic;
pub mod adversary;
pub mod checkpoint;
pub mod comm;
pub mod config;
pub mod metrics;
pub mod nn;
pub mod normalizer;
pub mod optim;
pub mod policy_file;
pub mod ppo;
pub mod rng;
pub mod schedule;
pub mod segments;
pub mod storage;
pub mod symmetry;
pub mod tensorfile;
pub mod train;
pub mod vec_env;

pub use config::TrainConfig;
pub use symmetry::{SignedPermutation, Symmetry};
pub use train::{IterationLog, Trainer};
pub use vec_env::{EnvSnapshot, EpisodeStats, PerturbationChannel, StepTiming, VecEnv};

//! The learning core: networks (fast CPU kernels inside Candle's autograd), PPO with the paper's symmetry and
//! last-layer decay losses, the cyclic adversary, checkpoints and policy files — and the interface it needs from
//! an environment (`vec_env`, `symmetry`), which knows no robot.
//!
//! ```
//! use trainer::{SignedPermutation, TrainConfig};
//!
//! // The paper's cyclic schedule: 1000 iterations of the policy alone, then 5 × (200 adversary + 200 policy).
//! let cfg = TrainConfig::default();
//! cfg.validate().unwrap();
//! assert_eq!(cfg.adversary.schedule().total(), 1000 + 5 * (200 + 200));
//!
//! // A mirror map is a signed permutation that undoes itself: left and right swapped, the lateral sign flipped.
//! let s = SignedPermutation { perm: vec![1, 0, 2], sign: vec![1.0, 1.0, -1.0] };
//! let mut mirrored = [0.0; 3];
//! s.apply(&[0.5, 0.7, 0.2], &mut mirrored);
//! assert_eq!(mirrored, [0.7, 0.5, -0.2]);
//! assert!(s.is_involution());
//! ```

pub mod actor_critic;
pub mod actor_view;
pub mod adversary;
pub mod batch;
pub mod checkpoint;
pub mod comm;
pub mod config;
pub mod error;
pub mod estimator;
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
pub mod weight_average;

pub use config::TrainConfig;
pub use error::{Error, Result};
pub use symmetry::{SignedPermutation, Symmetry};
pub use train::{IterationLog, Trainer};
pub use vec_env::{EnvSnapshot, EpisodeStats, PerturbationChannel, StepTiming, VecEnv};

//! `topa bench …`: performance measurements printed as ratios taken in one run (never timed tests).

pub mod env;
pub mod memory;
pub mod mpi;
pub mod physics;
pub mod ppo;
pub mod render;
pub mod train;

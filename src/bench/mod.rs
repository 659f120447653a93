//! `topa bench …`: performance measurements printed as ratios taken in one run (never timed tests).

pub mod physics;

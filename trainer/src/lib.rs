//! The learning core: networks (fast CPU kernels inside Candle's autograd), PPO, symmetry and decay losses,
//! the cyclic adversary, checkpoints.

pub mod nn;

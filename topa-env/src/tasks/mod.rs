//! Small tasks behind the same `Task` trait, for fast learning tests of the trainer.

pub mod cartpole;

pub use cartpole::CartPole;

//! `topa train`'s flags.

use std::path::PathBuf;

use topa_env::ModelKind;

/// `topa train`'s arguments.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct TrainArgs {
    /// TOML preset: configs/paper.toml (the paper's table) or configs/cpu.toml (2-core machine).
    #[arg(long)]
    pub(crate) config: Option<PathBuf>,
    /// TopA's model: closed (the paper's C) or open (the serial baseline O); shorthand for --robot with
    /// assets/robots/topa_closed.toml or topa_open.toml.
    #[arg(long, conflicts_with = "robot")]
    pub(crate) model: Option<ModelKind>,
    /// The robot to train: its spec (a TOML beside its MJCF), e.g. assets/robots/kestrel.toml.
    #[arg(long)]
    pub(crate) robot: Option<PathBuf>,
    /// Seed of the run: the envs' draws and the networks' initialisation (default: the config's).
    #[arg(long)]
    pub(crate) seed: Option<u64>,
    /// Output folder (default runs/<model>[-adversary]-seed<S>).
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// Run the paper's cyclic adversarial schedule (phase 1, then 2/3 × cycles).
    #[arg(long)]
    pub(crate) adversary: bool,
    /// Threads for environments and networks (default: the config's; 0 = all cores).
    #[arg(long)]
    pub(crate) threads: Option<usize>,
    /// Override run.iterations (plain PPO only); with --resume, lengthens or shortens the run.
    #[arg(long)]
    pub(crate) iterations: Option<usize>,
    /// Continue the run in this folder from its latest checkpoint.
    #[arg(long, conflicts_with = "config")]
    pub(crate) resume: Option<PathBuf>,
    /// Start the policy from another run's checkpoint (folder or sidecar), e.g. C+A from C; a blind policy into a
    /// config with `[env.height_scan]` on gets the scan as new inputs with zero weights.
    #[arg(long)]
    pub(crate) init_from: Option<PathBuf>,
    /// No progress bar; a status line every 10 iterations on stderr (for nohup logs).
    #[arg(long)]
    pub(crate) quiet: bool,
}

//! `topa`: the TopA closed-chain biped toolkit — model info, benchmarks, training and sim2sim evaluation.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod bench;
mod info;

#[derive(Parser)]
#[command(
    name = "topa",
    version,
    about = "TopA closed-chain biped: MuJoCo 2.2 simulation, PPO training, sim2sim evaluation"
)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Summarise an MJCF model: sizes, equality constraints, joints, actuators, mass, timestep.
    Info {
        /// The MJCF file.
        model: PathBuf,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Performance benchmarks (ratios measured in one run).
    #[command(subcommand)]
    Bench(BenchCmd),
}

#[derive(Subcommand)]
enum BenchCmd {
    /// mj_step/s of our safe loop vs mujoco-testspeed, and a Data batch on 2 threads vs 1.
    Physics {
        /// The MJCF file (e.g. /usr/share/mujoco/model/humanoid/humanoid.xml).
        model: PathBuf,
        /// Steps per timed run.
        #[arg(long, default_value_t = 20000)]
        steps: usize,
        /// Timed rounds per side (the best is kept).
        #[arg(long, default_value_t = 3)]
        rounds: usize,
        /// Number of Data in the threaded batch.
        #[arg(long, default_value_t = 8)]
        batch: usize,
        /// Skip the mujoco-testspeed comparison.
        #[arg(long)]
        no_testspeed: bool,
    },
    /// env-steps/s of the batched TopA env vs the bare physics bound, for batch sizes × thread counts.
    Env {
        #[arg(long, default_value = "closed")]
        model: topa_env::ModelKind,
        /// Batch sizes.
        #[arg(long, value_delimiter = ',', default_value = "64,512,4096")]
        envs: Vec<usize>,
        /// Thread counts.
        #[arg(long, value_delimiter = ',', default_value = "1,2")]
        threads: Vec<usize>,
        /// Integrator: model (the MJCF's RK4), euler, rk4, implicit.
        #[arg(long, default_value = "model")]
        integrator: String,
        /// Seconds per measurement.
        #[arg(long, default_value_t = 2.0)]
        seconds: f64,
        /// Interleaved rounds (best kept).
        #[arg(long, default_value_t = 3)]
        rounds: usize,
    },
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Cmd::Info { model, json } => info::run(&model, json),
        Cmd::Bench(BenchCmd::Physics { model, steps, rounds, batch, no_testspeed }) => {
            bench::physics::run(&model, steps, rounds, batch, !no_testspeed)
        }
        Cmd::Bench(BenchCmd::Env { model, envs, threads, integrator, seconds, rounds }) => {
            bench::env::run(model, &envs, &threads, &integrator, seconds, rounds)
        }
    }
}

fn main() -> ExitCode {
    // Die quietly when stdout is closed early (`topa info … | head`), like other command-line tools.
    // SAFETY: restoring the default disposition of SIGPIPE at start-up, before any thread exists.
    unsafe { libc::signal(libc::SIGPIPE, libc::SIG_DFL) };
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line: the error and its causes.
            eprintln!("error: {}", format!("{e:#}").replace('\n', " "));
            ExitCode::FAILURE
        }
    }
}

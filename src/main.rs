//! `topa`: the TopA closed-chain biped toolkit — model info, benchmarks, training and sim2sim evaluation.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use topa::eval::ablate::Extent;
use topa::{bench, eval_cmd, info, play, resolve_threads, train_cmd};

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
    /// Summarise an MJCF model (sizes, equality constraints, joints, actuators, mass, timestep) or a robot spec
    /// (motors and the joints they move, stand pose, ranges, mirror, groups, loops, the motor→joint map).
    Info {
        /// The MJCF file, or a robot spec (.toml, e.g. assets/robots/kestrel.toml).
        model: PathBuf,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Performance benchmarks (ratios measured in one run).
    #[command(subcommand)]
    Bench(BenchCmd),
    /// Sim2sim evaluation of a policy on the closed model (the paper's experiments).
    Eval {
        #[command(subcommand)]
        cmd: eval_cmd::EvalCmd,
        #[command(flatten)]
        common: eval_cmd::Common,
    },
    /// All three experiments for O, C and C+A, with the paper's numbers beside ours and the heatmaps.
    Ablate {
        /// Policies trained on the open (serial) model: files, or folders whose *.json policies are all taken
        /// (several seeds: `--o a.json b.json` or `--o assets/policies/O`).
        #[arg(long, num_args = 1..)]
        o: Vec<PathBuf>,
        /// Policies trained on the closed model (files or folders, as --o).
        #[arg(long, num_args = 1..)]
        c: Vec<PathBuf>,
        /// Policies trained on the closed model with the cyclic adversary (files or folders, as --o).
        #[arg(long, num_args = 1..)]
        ca: Vec<PathBuf>,
        /// The paper's full protocol (13 × 13 push grid, 100 noise runs per level) instead of the quick one.
        #[arg(long)]
        full: bool,
        /// Push grid half-range, N (the paper's: 30). A stronger grid separates robust policies that the paper's
        /// grid cannot (it nearly saturates for ours); the paper's numbers beside it are then for ±30 N.
        #[arg(long)]
        push_range: Option<f64>,
        /// Push grid step, N (the paper's: 5; the quick protocol's: 10).
        #[arg(long)]
        push_step: Option<f64>,
        /// Initial states each tracking command runs from (full protocol: 10, quick: 3): a policy that sometimes
        /// stands still on a command from rest shows as a count, not as one reset's coin flip.
        #[arg(long)]
        tracking_starts: Option<usize>,
        /// Instead of running policies: join the ablation.json files of earlier runs (same protocol and settings;
        /// e.g. one per policy, run as each training ended) into one report with the groups' mean ± sd.
        #[arg(long, num_args = 2.., conflicts_with_all = ["o", "c", "ca", "full", "push_range", "push_step", "tracking_starts"])]
        merge: Vec<PathBuf>,
        #[command(flatten)]
        common: eval_cmd::Common,
    },
    /// Run a policy on the closed model with one command; record it to MCAP for Foxglove.
    Play {
        #[arg(long)]
        policy: PathBuf,
        /// Command v_x,v_y,w_z (m/s, m/s, rad/s), e.g. 0.5,0,0.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true, default_value = "0.5,0,0")]
        command: Vec<f64>,
        #[arg(long, default_value_t = 10.0)]
        seconds: f64,
        /// Write an MCAP file (Foxglove: /tf, /scene, /joints, /motors, /base, /command, /contacts, /rewards).
        #[arg(long)]
        record: Option<PathBuf>,
        #[command(flatten)]
        video: eval_cmd::VideoArgs,
        /// Constant torso force (F_x,F_y in N, torso frame) from the command's start, as in the push grid.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        push: Option<Vec<f64>>,
        #[command(flatten)]
        common: eval_cmd::Common,
    },
    /// Export a policy for the robot's computer: ONNX with the observation normaliser in the graph.
    Export {
        /// The policy (.json sidecar).
        #[arg(long)]
        policy: PathBuf,
        /// Output ONNX file.
        #[arg(long)]
        onnx: PathBuf,
        /// Also output `motor_targets` (nominal pose + action scale · clipped action, clamped to the motor range).
        #[arg(long)]
        motor_targets: bool,
        /// Only check that an existing ONNX file was exported from this policy (no writing).
        #[arg(long)]
        check: bool,
    },
    /// Train a policy with PPO (symmetry loss, last-layer decay; --adversary for the cyclic adversary).
    Train {
        /// TOML preset: configs/paper.toml (the paper's table) or configs/cpu.toml (2-core machine).
        #[arg(long)]
        config: Option<PathBuf>,
        /// TopA's model: closed (the paper's C) or open (the serial baseline O); shorthand for --robot with
        /// assets/robots/topa_closed.toml or topa_open.toml.
        #[arg(long, conflicts_with = "robot")]
        model: Option<topa_env::ModelKind>,
        /// The robot to train: its spec (a TOML beside its MJCF), e.g. assets/robots/kestrel.toml.
        #[arg(long)]
        robot: Option<PathBuf>,
        #[arg(long)]
        seed: Option<u64>,
        /// Output folder (default runs/<model>[-adversary]-seed<S>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Run the paper's cyclic adversarial schedule (phase 1, then 2/3 × cycles).
        #[arg(long)]
        adversary: bool,
        /// Threads for environments and networks (default: the config's; 0 = all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Override run.iterations (plain PPO only); with --resume, lengthens or shortens the run.
        #[arg(long)]
        iterations: Option<usize>,
        /// Continue the run in this folder from its latest checkpoint.
        #[arg(long, conflicts_with = "config")]
        resume: Option<PathBuf>,
        /// Start the policy from another run's checkpoint (folder or sidecar), e.g. C+A from C.
        #[arg(long)]
        init_from: Option<PathBuf>,
        /// No progress bar; a status line every 10 iterations on stderr (for nohup logs).
        #[arg(long)]
        quiet: bool,
    },
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
        integrator: topa_env::IntegratorChoice,
        /// Seconds per measurement.
        #[arg(long, default_value_t = 2.0)]
        seconds: f64,
        /// Interleaved rounds (best kept).
        #[arg(long, default_value_t = 3)]
        rounds: usize,
    },
    /// Samples/s of a full PPO update (paper networks, 24 576 samples) at 1 and 2 threads, GFLOP/s, inference
    /// share of an iteration, and the torch reference if given.
    Ppo {
        #[arg(long, value_delimiter = ',', default_value = "1,2")]
        threads: Vec<usize>,
        /// Timed updates per thread count (best kept).
        #[arg(long, default_value_t = 3)]
        repeats: usize,
        /// A Python with torch, to measure trainer/examples/torch_reference.py in the same run.
        #[arg(long)]
        torch_python: Option<String>,
        /// Internal: run one measurement in this process and print JSON.
        #[arg(long, hide = true)]
        worker: bool,
    },
    /// Memory per env and start-up time of a batch, and the largest MuJoCo memory use (stack, contacts,
    /// constraint rows) over walking, pushed and falling episodes against the MJCF's <size>.
    Memory {
        #[arg(long, default_value_t = 4096)]
        envs: usize,
        /// Policy steps per measured workload.
        #[arg(long, default_value_t = 1000)]
        steps: usize,
        /// The policy that walks (and is pushed) in the first workload.
        #[arg(long, default_value = "assets/policies/C.json")]
        policy: PathBuf,
    },
    /// Training on N MPI ranks vs one rank with the same threads: samples/s, communication share and bytes per
    /// iteration (needs a build with `--features mpi` and Open MPI's mpirun).
    Mpi {
        #[arg(long, default_value = "configs/cpu.toml")]
        config: PathBuf,
        #[arg(long, default_value_t = 2)]
        ranks: usize,
        /// Timed iterations per launch.
        #[arg(long, default_value_t = 10)]
        iterations: usize,
        /// Untimed first iterations per launch.
        #[arg(long, default_value_t = 2)]
        warmup: usize,
        /// Interleaved rounds (the fastest of each layout is kept).
        #[arg(long, default_value_t = 2)]
        rounds: usize,
        #[arg(long, default_value = "mpirun")]
        mpirun: String,
    },
    /// Milliseconds per frame of MuJoCo's headless renderer (and of GIF encoding).
    Render {
        #[arg(long, default_value_t = 640)]
        width: usize,
        #[arg(long, default_value_t = 480)]
        height: usize,
        #[arg(long, default_value_t = 200)]
        frames: usize,
        /// fast (the videos' default) or high (multisampling, shadows, reflections).
        #[arg(long, default_value = "fast")]
        quality: topa::video::QualityArg,
    },
    /// Real training iterations of a preset: samples/s, the collect / inference / update split, and their ratio
    /// to the bare physics bound measured in the same run.
    Train {
        #[arg(long, default_value = "configs/cpu.toml")]
        config: PathBuf,
        #[arg(long, value_delimiter = ',', default_value = "1,2")]
        threads: Vec<usize>,
        /// Override the preset's number of envs.
        #[arg(long)]
        envs: Option<usize>,
        /// Timed iterations per thread count.
        #[arg(long, default_value_t = 6)]
        iterations: usize,
        /// Untimed iterations first.
        #[arg(long, default_value_t = 2)]
        warmup: usize,
        /// Override the preset's integrator (euler, rk4, model, implicit).
        #[arg(long)]
        integrator: Option<topa_env::IntegratorChoice>,
        /// Interleaved rounds (the fastest of each thread count is kept).
        #[arg(long, default_value_t = 2)]
        rounds: usize,
        #[arg(long, hide = true)]
        worker: bool,
    },
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Cmd::Info { model, json } => {
            if model.extension().is_some_and(|e| e == "toml") {
                topa::robot_info::run(&model, json)
            } else {
                info::run(&model, json)
            }
        }
        Cmd::Train { config, model, robot, seed, out, adversary, threads, iterations, resume, init_from, quiet } => {
            train_cmd::run(train_cmd::TrainArgs {
                config,
                model,
                robot,
                seed,
                out,
                adversary,
                threads,
                iterations,
                resume,
                init_from,
                quiet,
            })
        }
        Cmd::Eval { cmd, common } => {
            trainer::nn::init_threads(resolve_threads(common.threads))?;
            eval_cmd::run_eval(cmd, common)
        }
        Cmd::Ablate { merge, common, .. } if !merge.is_empty() => eval_cmd::merge_ablations(&merge, common),
        Cmd::Ablate { o, c, ca, full, push_range, push_step, tracking_starts, common, .. } => {
            trainer::nn::init_threads(resolve_threads(common.threads))?;
            let mut extent = if full { Extent::full() } else { Extent::quick() };
            extent.push_range_n = push_range.unwrap_or(extent.push_range_n);
            extent.push_step_n = push_step.unwrap_or(extent.push_step_n);
            extent.tracking_starts = tracking_starts.unwrap_or(extent.tracking_starts);
            eval_cmd::run_ablate(o, c, ca, extent, common)
        }
        Cmd::Export { policy, onnx, motor_targets, check } => {
            if check {
                topa::export::check(&onnx, &policy)?;
                println!("{} was exported from {}", onnx.display(), policy.display());
            } else {
                topa::export::export(&policy, &onnx, motor_targets)?;
                println!(
                    "wrote {} (opset {}, input obs[batch, 42] → action[batch, 10]{})",
                    onnx.display(),
                    topa::export::OPSET,
                    if motor_targets { ", motor_targets[batch, 10]" } else { "" }
                );
            }
            Ok(())
        }
        Cmd::Play { policy, command, seconds, record, video, push, common } => {
            trainer::nn::init_threads(1)?;
            anyhow::ensure!(command.len() == 3, "--command takes three numbers v_x,v_y,w_z, got {}", command.len());
            let torso_force = match push.as_deref() {
                None => None,
                Some([fx, fy]) => Some([*fx, *fy]),
                Some(v) => anyhow::bail!("--push takes two numbers F_x,F_y (N), got {}", v.len()),
            };
            let o = play::PlayOptions {
                command: [command[0], command[1], command[2]],
                seconds,
                record,
                torso_force,
                ..video.options()?
            };
            let s = play::run(&policy, &o, &common.settings()?)?;
            if common.json {
                println!("{}", serde_json::to_string_pretty(&s)?);
            } else {
                let fall = s.fell_at_s.map_or("no fall".to_string(), |t| format!("FELL at {t:.2} s"));
                println!(
                    "command ({:.2}, {:.2}, {:.2}) for {} s: {fall}; mean (v_x, v_y, w_z) = ({:.2}, {:.2}, {:.2}); distance {:.2} m",
                    s.command[0], s.command[1], s.command[2], s.seconds, s.mean_velocity[0], s.mean_velocity[1], s.mean_velocity[2], s.distance_m
                );
                if let Some(r) = &s.recording {
                    println!("recording: {} (open it in Foxglove)", r.display());
                }
                if let Some(v) = &s.video {
                    println!("video: {} ({} frames)", v.display(), s.video_frames);
                }
            }
            Ok(())
        }
        Cmd::Bench(BenchCmd::Physics { model, steps, rounds, batch, no_testspeed }) => {
            bench::physics::run(&model, steps, rounds, batch, !no_testspeed)
        }
        Cmd::Bench(BenchCmd::Ppo { threads, repeats, torch_python, worker }) => {
            if worker {
                let r = bench::ppo::worker(threads[0], repeats)?;
                println!("{}", serde_json::to_string(&r)?);
                Ok(())
            } else {
                bench::ppo::run(&threads, repeats, torch_python.as_deref())
            }
        }
        Cmd::Bench(BenchCmd::Render { width, height, frames, quality }) => {
            bench::render::run(width, height, frames, quality.into())
        }
        Cmd::Bench(BenchCmd::Mpi { config, ranks, iterations, warmup, rounds, mpirun }) => {
            bench::mpi::run(&bench::mpi::Args { config: &config, ranks, iterations, warmup, rounds, mpirun: &mpirun })
        }
        Cmd::Bench(BenchCmd::Memory { envs, steps, policy }) => bench::memory::run(envs, steps, &policy),
        Cmd::Bench(BenchCmd::Train { config, threads, envs, iterations, warmup, integrator, rounds, worker }) => {
            let a =
                bench::train::Args { config: &config, threads: &threads, envs, iterations, warmup, integrator, rounds };
            if worker {
                println!("{}", serde_json::to_string(&bench::train::worker(&a, threads[0])?)?);
                Ok(())
            } else {
                bench::train::run(&a)
            }
        }
        Cmd::Bench(BenchCmd::Env { model, envs, threads, integrator, seconds, rounds }) => {
            bench::env::run(model, &envs, &threads, integrator, seconds, rounds)
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

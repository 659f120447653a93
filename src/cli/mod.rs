//! The `topa` command line as data: every subcommand and flag, parsed by clap. The binary (src/main.rs) runs
//! them; the documentation test parses every command the README and docs/ show with this same parser.

use std::path::PathBuf;

use clap::{Parser, Subcommand};

mod eval;
mod groups;
mod robot;
mod sysid;
mod train;
mod values;
pub(crate) mod view;
pub(crate) mod wire;

pub(crate) use eval::{Common, EvalCmd, PhysicsArgs, QualityArg, Simulation, TerrainArgs, VideoArgs};
pub(crate) use groups::{Groups, Sim2SimArg};
pub(crate) use robot::RobotCmd;
pub(crate) use sysid::SysidCmd;
pub(crate) use train::TrainArgs;
pub(crate) use wire::{ControlArgs, SimRobotArgs};

#[derive(Parser)]
#[command(
    name = "topa",
    version,
    about = "TopA closed-chain biped: MuJoCo 2.2 simulation, PPO training, sim2sim evaluation"
)]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub(crate) command: Cmd,
}

#[derive(Subcommand)]
pub(crate) enum Cmd {
    /// Summarise an MJCF model (sizes, equality constraints, joints, actuators, mass, timestep) or a robot spec
    /// (motors and the joints they move, stand pose, ranges, mirror, groups, loops, the motor→joint map).
    Info {
        /// The MJCF file, or a robot spec (.toml, e.g. assets/robots/kestrel.toml).
        model: PathBuf,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// A robot from its published MJCF: import it, solve its stand pose.
    #[command(subcommand)]
    Robot(RobotCmd),
    /// System identification: excitation trajectories for the motors.
    #[command(subcommand)]
    Sysid(SysidCmd),
    /// Performance benchmarks (ratios measured in one run).
    #[command(subcommand)]
    Bench(BenchCmd),
    /// Training configs: the reference of every key, or one file fully resolved.
    #[command(subcommand)]
    Config(ConfigCmd),
    /// Sim2sim evaluation of a policy on the closed model (the paper's experiments).
    Eval {
        #[command(subcommand)]
        cmd: EvalCmd,
        #[command(flatten)]
        common: Common,
    },
    /// All three experiments for O, C and C+A, with the paper's numbers beside ours and the heatmaps.
    Ablate {
        #[command(flatten)]
        groups: Groups,
        /// The paper's full protocol (13 × 13 push grid, 100 noise runs per level) instead of the quick one.
        #[arg(long)]
        full: bool,
        /// Push grid half-range, N (the paper's: 30). A stronger grid separates robust policies that the paper's
        /// grid cannot (it nearly saturates for ours); the paper's numbers beside it are then for ±30 N.
        #[arg(long, alias = "push-range", value_parser = crate::cli::values::positive)]
        range: Option<f64>,
        /// Push grid step, N (the paper's: 5; the quick protocol's: 10).
        #[arg(long, alias = "push-step", value_parser = crate::cli::values::positive)]
        step: Option<f64>,
        /// Initial states each tracking command runs from (full protocol: 10, quick: 3): a policy that sometimes
        /// stands still on a command from rest shows as a count, not as one reset's coin flip.
        #[arg(long, alias = "tracking-starts", value_parser = crate::cli::values::at_least_one)]
        starts: Option<usize>,
        /// Instead of running policies: join the ablation.json files of earlier runs (same protocol and settings;
        /// e.g. one per policy, run as each training ended) into one report with the groups' mean ± sd; one file
        /// renders that report again (with --field: the real-world test attached).
        #[arg(long, num_args = 1.., conflicts_with_all = ["o", "c", "ca", "full", "range", "step", "starts"])]
        merge: Vec<PathBuf>,
        /// Add the real-world test of these policies (a field.json written by `topa field`) to the report.
        #[arg(long)]
        field: Option<PathBuf>,
        /// Add the terrain test (a terrain.json written by `topa terrain`) to the report.
        #[arg(long)]
        terrain: Option<PathBuf>,
        /// Add the simulator-perturbation test (a physics.json written by `topa physics`) to the report.
        #[arg(long)]
        physics: Option<PathBuf>,
        #[command(flatten)]
        common: Common,
    },
    /// Two ablation reports side by side, a change to the recipe (the variant) against what it would replace (the
    /// baseline): each group's headline measures with the difference's bootstrap 95 % interval and a verdict.
    Compare {
        /// The baseline's ablation.json (written by `topa ablate`).
        #[arg(long)]
        baseline: PathBuf,
        /// The variant's ablation.json: the same protocol and evaluation flags, other policies.
        #[arg(long)]
        variant: PathBuf,
        /// Print JSON instead of Markdown.
        #[arg(long)]
        json: bool,
        /// Folder for compare.md and compare.json.
        #[arg(long, default_value = "out/compare")]
        out: PathBuf,
    },
    /// Every policy of O, C and C+A under perturbations of the simulator (`topa eval physics` per seed): each
    /// group's share of perturbations survived with its 95 % interval, the paper's order checked, a heatmap.
    Physics {
        #[command(flatten)]
        groups: Groups,
        #[command(flatten)]
        protocol: PhysicsArgs,
        /// Instead of running policies: join physics.json files of earlier runs.
        #[arg(long, num_args = 1.., conflicts_with_all = ["o", "c", "ca"])]
        merge: Vec<PathBuf>,
        #[command(flatten)]
        common: Common,
    },
    /// Every policy of O, C and C+A on every terrain type × difficulty (`topa eval terrain` per seed), grouped by
    /// the ground each was trained on: mean success with its 95 % interval, the hardest difficulty per type.
    Terrain {
        #[command(flatten)]
        groups: Groups,
        #[command(flatten)]
        protocol: TerrainArgs,
        /// Instead of running policies: join terrain.json files of earlier runs.
        #[arg(long, num_args = 1.., conflicts_with_all = ["o", "c", "ca"])]
        merge: Vec<PathBuf>,
        #[command(flatten)]
        common: Common,
    },
    /// The paper's real-world test for O, C and C+A: each policy over the course at several top speeds and on a
    /// long operator-driven run, in each sim2sim mode; the groups' numbers with the paper's and its three claims.
    Field {
        #[command(flatten)]
        groups: Groups,
        /// The course file.
        #[arg(long, default_value = "assets/courses/indoor.toml")]
        course: PathBuf,
        /// Top speeds of the operator on the course, m/s.
        #[arg(long, value_delimiter = ',', default_value = "0.3,0.5,0.7")]
        speeds: Vec<f64>,
        /// Simulated minutes of the endurance run.
        #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 40.0)]
        minutes: f64,
        /// Sim2sim modes to run in (ideal, realistic, or files).
        #[arg(long, value_delimiter = ',', default_value = "ideal,realistic")]
        modes: Vec<Sim2SimArg>,
        /// Instead of running policies: join field.json files of earlier runs.
        #[arg(long, num_args = 2.., conflicts_with_all = ["o", "c", "ca"])]
        merge: Vec<PathBuf>,
        #[command(flatten)]
        common: Common,
    },
    /// Run a policy on the closed model with one command; record it to MCAP for Foxglove.
    Play {
        /// The policy file (`assets/policies/<group>/seedN.json`, or a `topa train --out` folder's policy.json).
        #[arg(long)]
        policy: PathBuf,
        /// Command v_x,v_y,w_z (m/s, m/s, rad/s), e.g. 0.5,0,0.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true, default_value = "0.5,0,0")]
        command: Vec<f64>,
        /// Seconds to run, s.
        #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 10.0)]
        seconds: f64,
        /// Write an MCAP file (Foxglove: /tf, /scene, /joints, /motors, /base, /command, /contacts, /rewards).
        #[arg(long)]
        record: Option<PathBuf>,
        #[command(flatten)]
        video: VideoArgs,
        /// Constant torso force (F_x,F_y in N, torso frame) from the command's start, as in the push grid.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        push: Option<Vec<f64>>,
        /// Print the summary as JSON.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        sim: Simulation,
    },
    /// Watch a policy walk, live, in a window: drive it from the keyboard, drag it with the mouse, shove it;
    /// without a display, write the walk to a GIF.
    View(view::ViewArgs),
    /// Rewrite the generated blocks of Markdown pages (`<!-- generated: REPORT SECTION -->` … `<!-- end generated -->`)
    /// from the ablation reports they name, e.g. the README's tables after `topa ablate --merge`.
    Docs {
        /// The pages (default: README.md).
        #[arg(default_value = "README.md")]
        pages: Vec<PathBuf>,
        /// Only compare: fail, naming the pages, when a block differs from its report.
        #[arg(long)]
        check: bool,
    },
    /// Training dashboards: several runs' metrics.csv on one figure, seeds of a group as mean and min–max band.
    Plot {
        /// Run folders (or metrics.csv files), each drawn as its own group.
        runs: Vec<PathBuf>,
        /// A group of runs drawn together, NAME=RUN,RUN… (e.g. C=runs/C-s1,runs/C-s2,runs/C-s3); repeatable.
        #[arg(long)]
        group: Vec<String>,
        /// Output PNG (an SVG is written beside it).
        #[arg(long, default_value = "out/dashboard.png")]
        out: PathBuf,
    },
    /// Export a policy for the robot's computer: ONNX with the observation normaliser in the graph, and/or the
    /// controller file that `topa_control` (the robot-side controller) loads.
    Export {
        /// The policy (.json sidecar).
        #[arg(long)]
        policy: PathBuf,
        /// Output ONNX file.
        #[arg(long, required_unless_present = "controller")]
        onnx: Option<PathBuf>,
        /// Output folder of the controller file (controller.json and the policy's weights).
        #[arg(long)]
        controller: Option<PathBuf>,
        /// Also output `motor_targets` (nominal pose + action scale · clipped action, clamped to the motor range).
        #[arg(long)]
        motor_targets: bool,
        /// Only check that an existing ONNX file was exported from this policy (no writing).
        #[arg(long)]
        check: bool,
    },
    /// Train a policy with PPO (symmetry loss, last-layer decay; --adversary for the cyclic adversary).
    Train(TrainArgs),
    /// Weight averaging: one policy from a run's late checkpoints, the mean of their actor (and estimator) weights,
    /// each checkpoint's normaliser folded in first (Nikishin et al. 2018; SWA). Evaluate it like any policy.
    Average {
        /// A `topa train --out` folder trained with `[run] keep_checkpoints = 0`.
        #[arg(long)]
        run: PathBuf,
        /// The first iteration averaged.
        #[arg(long)]
        from: usize,
        /// Average the checkpoints at multiples of this iteration (and the last).
        #[arg(long, default_value_t = 25)]
        every: usize,
        /// Output policy (`<OUT>.json` and `<OUT>.safetensors`).
        #[arg(long)]
        out: PathBuf,
    },
    /// The simulator as a robot on the wire: MuJoCo in real time, the drives' PD and watchdog on its side, sensor
    /// frames to a controller in another process (`topa control`) and its motor commands back, over UDP.
    SimRobot(SimRobotArgs),
    /// The robot-side controller on a robot on the wire (a real robot's bridge, or `topa sim-robot`): the
    /// state machine, the observation and the policy, one period per sensor frame; operator messages on a socket.
    Control(ControlArgs),
}

#[derive(Subcommand)]
pub(crate) enum ConfigCmd {
    /// Print the configuration reference as Markdown: every table and key with its type, default, the paper
    /// preset's value and description (docs/configuration.md is its output).
    Reference {
        /// The paper preset whose values fill the paper column.
        #[arg(long, default_value = "configs/paper.toml")]
        paper: PathBuf,
    },
    /// Print a training config fully resolved as TOML: its `base` chain merged, every key with its value or default.
    Show {
        /// The config file, e.g. configs/cpu.toml or an experiment that starts from it with `base = "../cpu.toml"`.
        file: PathBuf,
    },
}

#[derive(Subcommand)]
pub(crate) enum BenchCmd {
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
        /// The model: closed (the linkage), open (joint-space action), or the other variants of `topa info`.
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
        #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 2.0)]
        seconds: f64,
        /// Interleaved rounds (best kept).
        #[arg(long, default_value_t = 3)]
        rounds: usize,
        /// Also the same envs on rough terrain (`[env.terrain]` defaults), as a ratio to the flat floor, with
        /// MuJoCo's box contacts and with the vertex contacts.
        #[arg(long)]
        rough: bool,
        /// The envs act with this policy (walking, under its training config) instead of random actions (which
        /// fall); inference is not timed.
        #[arg(long)]
        policy: Option<std::path::PathBuf>,
    },
    /// Samples/s of a full PPO update (paper networks, 24 576 samples) at 1 and 2 threads, GFLOP/s, inference
    /// share of an iteration, and the torch reference if given.
    Ppo {
        /// Thread counts to time the update at, one run each.
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
        /// Envs in the batch whose memory is measured.
        #[arg(long, default_value_t = 4096)]
        envs: usize,
        /// Policy steps per measured workload.
        #[arg(long, default_value_t = 1000)]
        steps: usize,
        /// The policy that walks (and is pushed) in the first workload.
        #[arg(long, default_value = "assets/policies/C/seed1.json")]
        policy: PathBuf,
        /// On the default rough terrain (`[env.terrain]`) instead of the flat floor.
        #[arg(long)]
        rough: bool,
    },
    /// Training on N MPI ranks vs one rank with the same threads: samples/s, communication share and bytes per
    /// iteration (needs a build with `--features mpi` and Open MPI's mpirun).
    Mpi {
        /// The training config whose rollout and update are timed.
        #[arg(long, default_value = "configs/cpu.toml")]
        config: PathBuf,
        /// MPI ranks to compare with one process.
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
        /// The MPI launcher to run the ranks with.
        #[arg(long, default_value = "mpirun")]
        mpirun: String,
    },
    /// Milliseconds per frame of MuJoCo's headless renderer (and of GIF encoding).
    Render {
        /// Frame width, pixels.
        #[arg(long, default_value_t = 640)]
        width: usize,
        /// Frame height, pixels.
        #[arg(long, default_value_t = 480)]
        height: usize,
        /// Frames to render and time.
        #[arg(long, default_value_t = 200)]
        frames: usize,
        /// fast (the videos' default) or high (multisampling, shadows, reflections).
        #[arg(long, default_value = "fast")]
        quality: QualityArg,
    },
    /// Real training iterations of a preset: samples/s, the collect / inference / update split, and their ratio
    /// to the bare physics bound measured in the same run.
    Train {
        /// The training config whose iterations are timed.
        #[arg(long, default_value = "configs/cpu.toml")]
        config: PathBuf,
        /// Thread counts to time it at, one run each.
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

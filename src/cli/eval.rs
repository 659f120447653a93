//! The settings every evaluation command shares, `topa eval`'s experiments, and the video and terrain flags.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};
use topa_env::IntegratorChoice;
use topa_eval::settings::{EvalSettings, Sim2SimMode};
use topa_eval::{physics, terrain};

#[derive(Args, Clone)]
pub(crate) struct Common {
    /// Print results as JSON instead of Markdown tables.
    #[arg(long, global = true)]
    pub(crate) json: bool,
    /// Folder for result files (CSV, JSON, images).
    #[arg(long, global = true, default_value = "out/eval")]
    pub(crate) out: PathBuf,
    #[command(flatten)]
    pub(crate) sim: Simulation,
    /// Worker threads (0 = all cores).
    #[arg(long, global = true, default_value_t = 0)]
    pub(crate) threads: usize,
}

impl Common {
    pub(crate) fn settings(&self) -> Result<EvalSettings> {
        Ok(EvalSettings { threads: self.threads, ..self.sim.settings()? })
    }
}

/// How a policy's robot is simulated: the physics and the sim2sim mode (every command that runs a policy).
#[derive(Args, Clone)]
pub(crate) struct Simulation {
    /// Physics timestep of the evaluation, s (training used 0.005; default 0.0025, or the sim2sim mode's own).
    #[arg(long, global = true, value_parser = crate::cli::values::positive)]
    pub(crate) timestep: Option<f64>,
    /// ideal (the simulator's state), realistic (state estimator, IMU and encoder noise, latency, motor
    /// torque–speed limits: configs/sim2sim/realistic.toml), or a TOML file with your own mix.
    #[arg(long, global = true, default_value = "ideal")]
    pub(crate) sim2sim: Sim2SimMode,
    /// Integrator: model (the sim2sim mode's own, else the MJCF's RK4), euler, rk4, implicit.
    #[arg(long, global = true, default_value = "model")]
    pub(crate) integrator: IntegratorChoice,
    /// Seed for the noise runs and env set-up.
    #[arg(long, global = true, default_value_t = 1)]
    pub(crate) seed: u64,
}

impl Simulation {
    pub(crate) fn settings(&self) -> Result<EvalSettings> {
        Ok(EvalSettings { timestep: self.timestep, integrator: self.integrator, seed: self.seed, ..Default::default() }
            .with_sim2sim(&self.sim2sim)?)
    }
}

/// `--video` and its frame size and rate.
#[derive(Args, Clone, Debug)]
pub(crate) struct VideoArgs {
    /// Render a video with MuJoCo (headless, EGL): .gif, or .mp4 (needs ffmpeg).
    #[arg(long)]
    pub(crate) video: Option<PathBuf>,
    /// Frame size WIDTHxHEIGHT.
    #[arg(long, default_value = "640x480")]
    pub(crate) video_size: topa_eval::video::FrameSize,
    /// Frames per second.
    #[arg(long, default_value_t = 30)]
    pub(crate) fps: u32,
    /// fast (no multisampling, shadows or reflections: ~15 ms a 640×480 frame in software) or high (~150 ms).
    #[arg(long, default_value = "fast")]
    pub(crate) quality: QualityArg,
}

impl VideoArgs {
    pub(crate) fn options(&self) -> Result<topa_eval::play::PlayOptions> {
        let size = (self.video_size.width, self.video_size.height);
        anyhow::ensure!(self.fps > 0, "--fps must be at least 1");
        Ok(topa_eval::play::PlayOptions {
            video: self.video.clone(),
            video_size: size,
            fps: self.fps,
            quality: Some(self.quality.into()),
            ..Default::default()
        })
    }
}

#[derive(Subcommand)]
pub(crate) enum EvalCmd {
    /// The paper's six velocity commands: MAE, mean torque, mean roll/pitch, fall.
    Tracking {
        /// The policy file (`assets/policies/<group>/seedN.json`, or a `topa train --out` folder's policy.json).
        #[arg(long)]
        policy: PathBuf,
        /// Seconds per command (after settling).
        #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 10.0)]
        seconds: f64,
        /// Initial states per command (the row reports their mean, falls and stand-stills).
        #[arg(long, value_parser = crate::cli::values::at_least_one, default_value_t = 10)]
        starts: usize,
    },
    /// Constant torso force on a grid: time to fall, mean t_fall, heatmap (PNG + SVG).
    Push {
        /// The policy file (`assets/policies/<group>/seedN.json`, or a `topa train --out` folder's policy.json).
        #[arg(long)]
        policy: PathBuf,
        /// Grid half-range, N.
        #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 30.0)]
        range: f64,
        /// Grid step, N.
        #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 5.0)]
        step: f64,
        /// Observation window, s.
        #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 10.0)]
        window: f64,
        /// Also render one cell of the grid (the force given by --video-force) as a video.
        #[command(flatten)]
        video: VideoArgs,
        /// The cell to render, F_x,F_y (N).
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true, default_value = "20,0")]
        video_force: Vec<f64>,
    },
    /// Walk forward at 0.5 m/s under Gaussian command noise at the paper's four levels: success rates.
    Noise {
        /// The policy file (`assets/policies/<group>/seedN.json`, or a `topa train --out` folder's policy.json).
        #[arg(long)]
        policy: PathBuf,
        /// Runs per noise level.
        #[arg(long, value_parser = crate::cli::values::at_least_one, default_value_t = 100)]
        runs: usize,
        /// Seconds per run.
        #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 20.0)]
        seconds: f64,
        /// Seconds between noise draws.
        #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 0.5)]
        interval: f64,
    },
    /// Drive the policy over a course (the paper's 100 m indoor test) at several top speeds: time to the goal,
    /// interventions, joint-limit hits, distance off the path; a map of the runs (and a chase-camera video).
    Course {
        /// The policy file (`assets/policies/<group>/seedN.json`, or a `topa train --out` folder's policy.json).
        #[arg(long)]
        policy: PathBuf,
        /// The course file.
        #[arg(long, default_value = "assets/courses/indoor.toml")]
        course: PathBuf,
        /// Top speeds of the operator, m/s (within the policy's forward command range).
        #[arg(long, value_delimiter = ',', default_value = "0.3,0.5,0.7")]
        speeds: Vec<f64>,
        /// Also render the run at the highest speed from a camera behind the robot.
        #[command(flatten)]
        video: VideoArgs,
    },
    /// Every terrain type × difficulty (legged_gym's tiles, blind policy), walking and turning at 0.5 m/s from each
    /// tile's centre: success, progress, tracking MAE, foot slip; a success heatmap (and a video of the hardest
    /// tile every run walked).
    Terrain {
        /// The policy file (`assets/policies/<group>/seedN.json`, or a `topa train --out` folder's policy.json).
        #[arg(long)]
        policy: PathBuf,
        #[command(flatten)]
        protocol: TerrainArgs,
        /// Also render a walk over the hardest tile that every run crossed without a fall.
        #[command(flatten)]
        video: VideoArgs,
    },
    /// Iterations to the bars: every N-th kept checkpoint of one or more runs through the six tracking commands
    /// (no fall, each MAE ≤ 0.15, no stand-still, gait); per run the first checkpoint meeting every bar and the one
    /// from which all later ones do. Train with `[run] keep_checkpoints = 0` to keep them.
    Progress {
        /// A `topa train --out` folder (repeat for several seeds).
        #[arg(long = "run", required = true)]
        runs: Vec<PathBuf>,
        /// Evaluate the checkpoints at multiples of this iteration (and the last).
        #[arg(long, value_parser = crate::cli::values::at_least_one, default_value_t = 100)]
        every: usize,
        /// Seconds per command (after settling).
        #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 10.0)]
        seconds: f64,
        /// Initial states per command.
        #[arg(long, value_parser = crate::cli::values::at_least_one, default_value_t = 10)]
        starts: usize,
        /// Also the standing push grid to ±30 N in steps of this many N (10: the quick protocol's 7×7); a run with
        /// the adversary then has the C+A bar on its mean time to fall.
        #[arg(long, alias = "push-step", value_parser = crate::cli::values::positive)]
        step: Option<f64>,
    },
    /// Checkpoint selection on held-out commands: each kept checkpoint from --from on through validation commands
    /// drawn from the training ranges (never the six tracking commands), the one with the smallest mean
    /// worst-component error, no fall, no stand-still and steps of --min-air-time written as `<OUT>/<run>/policy.json`.
    Select {
        /// A `topa train --out` folder trained with `[run] keep_checkpoints = 0` (repeat for several seeds).
        #[arg(long = "run", required = true)]
        runs: Vec<PathBuf>,
        /// The first iteration a checkpoint may be taken from.
        #[arg(long)]
        from: usize,
        /// Take the checkpoints at multiples of this iteration (and the last).
        #[arg(long, value_parser = crate::cli::values::at_least_one, default_value_t = 25)]
        every: usize,
        /// Validation commands drawn from the training ranges (every third a turn in place).
        #[arg(long, value_parser = crate::cli::values::at_least_one, default_value_t = 12)]
        commands: usize,
        /// Initial states per validation command.
        #[arg(long, value_parser = crate::cli::values::at_least_one, default_value_t = 2)]
        starts: usize,
        /// Seconds per command (after settling).
        #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 10.0)]
        seconds: f64,
        /// The mean air time per step a kept checkpoint must show on the walking validation commands, s (the
        /// tracking bar's 0.2 by default).
        #[arg(long, value_parser = crate::cli::values::positive, default_value_t = topa_eval::claims::MIN_AIR_TIME_S)]
        min_air_time: f64,
    },
    /// The six tracking commands and the centre push cells under perturbations of the simulator (contact model,
    /// solver, integrator, timestep, friction, motors, torso, soles, latency), one at a time and combined: per
    /// perturbation the bars met or missed, the share survived, a heatmap.
    Physics {
        /// The policy file (`assets/policies/<group>/seedN.json`, or a `topa train --out` folder's policy.json).
        #[arg(long)]
        policy: PathBuf,
        #[command(flatten)]
        protocol: PhysicsArgs,
    },
    /// A long run under an operator-like joystick (speed changes, turns, stops, hand noise, occasional pushes):
    /// interventions and their causes.
    Endurance {
        /// The policy file (`assets/policies/<group>/seedN.json`, or a `topa train --out` folder's policy.json).
        #[arg(long)]
        policy: PathBuf,
        /// Simulated minutes per run.
        #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 40.0)]
        minutes: f64,
        /// Runs side by side (each with its own operator).
        #[arg(long, value_parser = crate::cli::values::at_least_one, default_value_t = 1)]
        runs: usize,
    },
    /// The base velocity as the robot knows it — a velocity-free policy's learned estimate, the Kalman filter's
    /// (with `--sim2sim realistic` or a file) — against the truth, on one walk through a cycle of commands.
    Velocity {
        /// Policy files, or folders whose *.json policies are all taken (the seeds of a group): one walk each.
        #[arg(long, num_args = 1.., required = true)]
        policy: Vec<PathBuf>,
        /// A second sim2sim file whose Kalman filter runs on the same walks, e.g. the one `topa sysid estimator`
        /// tuned (velocity-free policies only: one that reads the filter would walk differently).
        #[arg(long)]
        tuned_filter: Option<PathBuf>,
        /// Seconds of walking.
        #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 48.0)]
        seconds: f64,
        /// Seconds per command of the cycle.
        #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 4.0)]
        command_seconds: f64,
    },
}

/// The terrain test's protocol.
#[derive(Args, Clone, Debug)]
pub(crate) struct TerrainArgs {
    /// Difficulty levels from the easiest to the hardest of the terrain's ranges.
    #[arg(long, value_parser = crate::cli::values::at_least_one, default_value_t = 5)]
    pub(crate) levels: usize,
    /// Runs per tile and command (each from its own random heading).
    #[arg(long, value_parser = crate::cli::values::at_least_one, default_value_t = 2)]
    pub(crate) runs: usize,
    /// Seconds per run (after settling).
    #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 10.0)]
    pub(crate) seconds: f64,
    /// Only these tile types, comma-separated (default: the terrain's), e.g. stairs_up,stairs_down.
    #[arg(long, value_delimiter = ',')]
    pub(crate) types: Vec<topa_env::terrain::TileKind>,
    /// Height samples this far apart instead of the terrain's, m (a finer field has steeper stair risers).
    #[arg(long, value_parser = crate::cli::values::positive)]
    pub(crate) resolution: Option<f64>,
    /// Box contacts with the ground: prisms (MuJoCo's, the evaluation's) or vertices (what a training config may
    /// choose, to measure what it changes).
    #[arg(long, default_value = "prisms")]
    pub(crate) contacts: topa_env::terrain::BoxContacts,
}

impl TerrainArgs {
    pub(crate) fn protocol(self) -> terrain::Protocol {
        let (levels, runs, window_s) = (self.levels, self.runs, self.seconds);
        let (types, resolution, contacts) = (self.types, self.resolution, self.contacts);
        terrain::Protocol { levels, runs, window_s, types, resolution, contacts }
    }
}

/// The perturbation study's matrix and protocol.
#[derive(Args, Clone, Debug)]
pub(crate) struct PhysicsArgs {
    /// The perturbation matrix (TOML; default: the built-in configs/physics/matrix.toml).
    #[arg(long)]
    pub(crate) matrix: Option<PathBuf>,
    /// Initial states per tracking command.
    #[arg(long, value_parser = crate::cli::values::at_least_one, default_value_t = 2)]
    pub(crate) starts: usize,
    /// Seconds per tracking command and per push (after settling).
    #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 10.0)]
    pub(crate) seconds: f64,
    /// The push cells' force, N: (F_x, F_y) ∈ {−F, 0, F}².
    #[arg(long, value_parser = crate::cli::values::positive, default_value_t = 10.0)]
    pub(crate) push_force: f64,
    /// Then, for each case a policy fails, search the smallest perturbation that flips it (bisection between
    /// nominal and the case; a few more runs per failed case).
    #[arg(long)]
    pub(crate) fragility: bool,
}

impl PhysicsArgs {
    pub(crate) fn load(&self) -> Result<(physics::matrix::Matrix, physics::Protocol)> {
        anyhow::ensure!(self.starts >= 1, "--starts must be at least 1 (initial states per tracking command)");
        anyhow::ensure!(self.seconds > 2.0, "--seconds must be longer than the 2 s transient, got {}", self.seconds);
        anyhow::ensure!(self.push_force > 0.0, "--push-force must be positive, got {}", self.push_force);
        let m = physics::matrix::Matrix::load(self.matrix.as_deref())?;
        let p = physics::Protocol {
            tracking_window_s: self.seconds,
            tracking_starts: self.starts,
            push_force_n: self.push_force,
            push_window_s: self.seconds,
            ..Default::default()
        };
        Ok((m, p))
    }
}

/// `--quality` on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum QualityArg {
    Fast,
    High,
}

impl From<QualityArg> for mujoco::render::Quality {
    fn from(q: QualityArg) -> mujoco::render::Quality {
        match q {
            QualityArg::Fast => mujoco::render::Quality::Fast,
            QualityArg::High => mujoco::render::Quality::High,
        }
    }
}

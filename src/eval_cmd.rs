//! `topa eval <experiment>`: one experiment on one policy (or a run's checkpoints) — run, print (Markdown or
//! JSON), write results to a folder. The settings every evaluation command shares (`Common`) live here too.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};

use topa_env::IntegratorChoice;

use crate::eval::settings::{EvalSettings, Sim2SimMode};
use crate::eval::{
    course, course_map, endurance, heatmaps, noise, progress, progress_plot, push, report, terrain, terrain_map,
    tracking,
};
use topa_env::policy_runner::PolicyRunner;

#[derive(Args, Clone)]
pub struct Common {
    /// Print results as JSON instead of Markdown tables.
    #[arg(long, global = true)]
    pub json: bool,
    /// Folder for result files (CSV, JSON, images).
    #[arg(long, global = true, default_value = "out/eval")]
    pub out: PathBuf,
    /// Physics timestep of the evaluation, s (training used 0.005; default 0.0025, or the sim2sim mode's own).
    #[arg(long, global = true)]
    pub timestep: Option<f64>,
    /// ideal (the simulator's state), realistic (state estimator, IMU and encoder noise, latency, motor
    /// torque–speed limits: configs/sim2sim/realistic.toml), or a TOML file with your own mix.
    #[arg(long, global = true, default_value = "ideal")]
    pub sim2sim: Sim2SimMode,
    /// Integrator: model (the sim2sim mode's own, else the MJCF's RK4), euler, rk4, implicit.
    #[arg(long, global = true, default_value = "model")]
    pub integrator: IntegratorChoice,
    /// Seed for the noise runs and env set-up.
    #[arg(long, global = true, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads (0 = all cores).
    #[arg(long, global = true, default_value_t = 0)]
    pub threads: usize,
}

impl Common {
    pub fn settings(&self) -> Result<EvalSettings> {
        EvalSettings {
            timestep: self.timestep,
            integrator: self.integrator,
            seed: self.seed,
            threads: self.threads,
            ..Default::default()
        }
        .with_sim2sim(&self.sim2sim)
    }
}

/// `--video` and its frame size and rate.
#[derive(Args, Clone, Debug)]
pub struct VideoArgs {
    /// Render a video with MuJoCo (headless, EGL): .gif, or .mp4 (needs ffmpeg).
    #[arg(long)]
    pub video: Option<PathBuf>,
    /// Frame size WIDTHxHEIGHT.
    #[arg(long, default_value = "640x480")]
    pub video_size: crate::video::FrameSize,
    /// Frames per second.
    #[arg(long, default_value_t = 30)]
    pub fps: u32,
    /// fast (no multisampling, shadows or reflections: ~15 ms a 640×480 frame in software) or high (~150 ms).
    #[arg(long, default_value = "fast")]
    pub quality: crate::video::QualityArg,
}

impl VideoArgs {
    pub fn options(&self) -> Result<crate::play::PlayOptions> {
        let size = (self.video_size.width, self.video_size.height);
        anyhow::ensure!(self.fps > 0, "--fps must be at least 1");
        Ok(crate::play::PlayOptions {
            video: self.video.clone(),
            video_size: size,
            fps: self.fps,
            quality: Some(self.quality.into()),
            ..Default::default()
        })
    }
}

#[derive(Subcommand)]
pub enum EvalCmd {
    /// The paper's six velocity commands: MAE, mean torque, mean roll/pitch, fall.
    Tracking {
        #[arg(long)]
        policy: PathBuf,
        /// Seconds per command (after settling).
        #[arg(long, default_value_t = 10.0)]
        seconds: f64,
        /// Initial states per command (the row reports their mean, falls and stand-stills).
        #[arg(long, default_value_t = 10)]
        starts: usize,
    },
    /// Constant torso force on a grid: time to fall, mean t_fall, heatmap (PNG + SVG).
    Push {
        #[arg(long)]
        policy: PathBuf,
        /// Grid half-range, N.
        #[arg(long, default_value_t = 30.0)]
        range: f64,
        /// Grid step, N.
        #[arg(long, default_value_t = 5.0)]
        step: f64,
        /// Observation window, s.
        #[arg(long, default_value_t = 10.0)]
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
        #[arg(long)]
        policy: PathBuf,
        /// Runs per noise level.
        #[arg(long, default_value_t = 100)]
        runs: usize,
        /// Seconds per run.
        #[arg(long, default_value_t = 20.0)]
        seconds: f64,
        /// Seconds between noise draws.
        #[arg(long, default_value_t = 0.5)]
        interval: f64,
    },
    /// Drive the policy over a course (the paper's 100 m indoor test) at several top speeds: time to the goal,
    /// interventions, joint-limit hits, distance off the path; a map of the runs (and a chase-camera video).
    Course {
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
        #[arg(long, default_value_t = 100)]
        every: usize,
        /// Seconds per command (after settling).
        #[arg(long, default_value_t = 10.0)]
        seconds: f64,
        /// Initial states per command.
        #[arg(long, default_value_t = 10)]
        starts: usize,
        /// Also the standing push grid to ±30 N in steps of this many N (10: the quick protocol's 7×7); a run with
        /// the adversary then has the C+A bar on its mean time to fall.
        #[arg(long)]
        push_step: Option<f64>,
    },
    /// A long run under an operator-like joystick (speed changes, turns, stops, hand noise, occasional pushes):
    /// interventions and their causes.
    Endurance {
        #[arg(long)]
        policy: PathBuf,
        /// Simulated minutes per run.
        #[arg(long, default_value_t = 40.0)]
        minutes: f64,
        /// Runs side by side (each with its own operator).
        #[arg(long, default_value_t = 1)]
        runs: usize,
    },
}

pub(crate) fn print_json<T: serde::Serialize>(v: &T) -> Result<()> {
    println!("{}", serde_json::to_string_pretty(v)?);
    Ok(())
}

pub fn run_eval(cmd: EvalCmd, c: Common) -> Result<()> {
    let s = c.settings()?;
    std::fs::create_dir_all(&c.out)?;
    let paper = report::paper()?;
    match cmd {
        EvalCmd::Tracking { policy, seconds, starts } => {
            let mut r = PolicyRunner::load(&policy, "policy")?;
            let rows = tracking::run(&mut r, &s, seconds, 2.0_f64.min(seconds / 2.0), starts)?;
            report::write_json(&c.out, "tracking.json", &rows)?;
            report::write_text(&c.out, "tracking.csv", &report::tracking_csv(&rows))?;
            if c.json {
                return print_json(&rows);
            }
            println!("{}", report::tracking_markdown(&[("ours", &rows)], Some(&paper)));
            println!("{}", report::gait_markdown(&[("ours", &rows)]));
        }
        EvalCmd::Push { policy, range, step, window, video, video_force } => {
            if video.video.is_some() {
                anyhow::ensure!(video_force.len() == 2, "--video-force takes F_x,F_y");
                let o = crate::play::PlayOptions {
                    command: [0.0; 3],
                    seconds: window,
                    torso_force: Some([video_force[0], video_force[1]]),
                    ..video.options()?
                };
                let p = crate::play::run(&policy, &o, &s)?;
                let fall = p.fell_at_s.map_or("no fall".into(), |t| format!("fell at {t:.2} s"));
                eprintln!(
                    "video of the ({}, {}) N cell: {} ({fall})",
                    video_force[0],
                    video_force[1],
                    p.video.unwrap().display()
                );
            }
            let mut r = PolicyRunner::load(&policy, "policy")?;
            let grid = push::run(&mut r, &s, range, step, window, [0.0; 3])?;
            report::write_json(&c.out, "push.json", &grid)?;
            report::write_text(&c.out, "push.csv", &report::push_csv(&grid))?;
            heatmaps::push_heatmaps(
                &[("policy".into(), &grid)],
                &c.out.join("push_heatmap.png"),
                &c.out.join("push_heatmap.svg"),
            )?;
            if c.json {
                return print_json(&grid);
            }
            println!("{}", report::push_markdown(&[("ours", &grid)], Some(&paper)));
            println!("heatmap: {}", c.out.join("push_heatmap.png").display());
        }
        EvalCmd::Noise { policy, runs, seconds, interval } => {
            let mut r = PolicyRunner::load(&policy, "policy")?;
            let rows = noise::run(&mut r, &s, runs, seconds, interval)?;
            report::write_json(&c.out, "noise.json", &rows)?;
            report::write_text(&c.out, "noise.csv", &report::noise_csv(&rows))?;
            if c.json {
                return print_json(&rows);
            }
            println!("{}", report::noise_markdown(&[("ours", &rows)], Some(&paper)));
        }
        EvalCmd::Course { policy, course, speeds, video } => {
            let map = topa_env::course::Course::load(&topa_env::assets::resolve_path(&course.to_string_lossy()))
                .map_err(anyhow::Error::msg)?;
            let mut r = PolicyRunner::load(&policy, "policy")?;
            let result = course::run(&mut r, &map, &s, &speeds, None)?;
            report::write_json(&c.out, "course.json", &result)?;
            let png = c.out.join("course_map.png");
            let title = format!("{} on {} ({} sim2sim)", policy.display(), map.name, c.sim2sim);
            course_map::course_map(&map, &result, &title, &png)?;
            if let Some(file) = &video.video {
                let top = speeds.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                let out = course_video(&mut r, &map, &s, top, file, &video)?;
                eprintln!("video of the {top} m/s run: {}", out.display());
            }
            if c.json {
                return print_json(&result);
            }
            println!("{}", course::markdown(&result));
            println!("map: {}", png.display());
        }
        EvalCmd::Terrain { policy, protocol, video } => {
            let mut r = PolicyRunner::load(&policy, "policy")?;
            let result = terrain::run(&mut r, &s, &protocol.protocol())?;
            report::write_json(&c.out, "terrain.json", &result)?;
            report::write_text(&c.out, "terrain.md", &terrain::markdown(&result))?;
            let (png, svg) = (c.out.join("terrain_success.png"), c.out.join("terrain_success.svg"));
            let title = format!("{} ({} sim2sim)", policy.display(), c.sim2sim);
            terrain_map::success_map(&result, &title, &png, &svg)?;
            if let Some(file) = &video.video {
                match hardest_tile(&result) {
                    Some((kind, level)) => {
                        let out = terrain_video(&mut r, &s, &result, (kind, level), file, &video)?;
                        eprintln!(
                            "video of {} at difficulty {:.2}: {}",
                            kind.name(),
                            result.terrain.difficulty(level),
                            out.display()
                        );
                    }
                    None => eprintln!("no video: no tile was crossed by every run without a fall"),
                }
            }
            if c.json {
                return print_json(&result);
            }
            println!("{}", terrain::markdown(&result));
            println!("heatmap: {}", png.display());
        }
        EvalCmd::Progress { runs, every, seconds, starts, push_step } => {
            let p = progress::Protocol { every, seconds, starts, push_step };
            let results = runs.iter().map(|r| progress::run(r, p, &s, &c.out)).collect::<Result<Vec<_>>>()?;
            report::write_json(&c.out, "progress.json", &results)?;
            let protocol = p.describe(&s);
            let md = progress::markdown(&results, &protocol);
            report::write_text(&c.out, "progress.md", &md)?;
            progress_plot::figure(&results, &c.out.join("progress.png"), &c.out.join("progress.svg"))?;
            if c.json {
                return print_json(&results);
            }
            println!("{md}");
        }
        EvalCmd::Endurance { policy, minutes, runs } => {
            let mut r = PolicyRunner::load(&policy, "policy")?;
            let result = endurance::run(&mut r, &s, minutes, runs, &endurance::Operator::default())?;
            report::write_json(&c.out, "endurance.json", &result)?;
            if c.json {
                return print_json(&result);
            }
            println!("{}", endurance::markdown(&result));
        }
    }
    Ok(())
}

/// The course at one top speed again, rendered from behind the robot.
fn course_video(
    r: &mut PolicyRunner,
    map: &topa_env::course::Course,
    s: &EvalSettings,
    speed: f64,
    file: &std::path::Path,
    video: &VideoArgs,
) -> Result<PathBuf> {
    let o = video.options()?;
    let mut rec: Option<crate::video::VideoRecorder> = None;
    let mut watch = |t: f64, env: &mut topa_env::RobotEnv| -> Result<()> {
        if rec.is_none() {
            rec = Some(crate::video::VideoRecorder::create(
                file,
                env,
                o.video_size,
                o.fps,
                o.quality.unwrap_or(mujoco_sys::render::Quality::Fast),
            )?);
        }
        let v = rec.as_mut().unwrap();
        let torso = env.indices().torso_body;
        v.follow(torso, 2.2, env.robot_state().yaw.to_degrees(), -25.0);
        let text = crate::video::overlay(env, t);
        v.advance(t, env, &text)
    };
    course::run(r, map, s, &[speed], Some(&mut watch))?;
    rec.ok_or_else(|| anyhow::anyhow!("the course run rendered no frame"))?.finish()
}

/// The hardest tile every run crossed without a fall (ties: the later type, stairs and obstacles before flat):
/// (type, level).
fn hardest_tile(r: &terrain::TerrainResult) -> Option<(topa_env::terrain::TileKind, usize)> {
    let types = &r.terrain.types;
    let level = |d: f64| (0..r.terrain.levels).find(|&l| r.terrain.difficulty(l) == d).unwrap_or(0);
    r.success_grid()
        .into_iter()
        .filter(|c| c.2 >= 1.0)
        .map(|(k, d, _)| (k, level(d)))
        .max_by_key(|&(k, l)| (l, types.iter().position(|&t| t == k)))
}

/// One walk over a terrain tile, rendered from behind the robot.
fn terrain_video(
    r: &mut PolicyRunner,
    s: &EvalSettings,
    result: &terrain::TerrainResult,
    (kind, level): (topa_env::terrain::TileKind, usize),
    file: &std::path::Path,
    video: &VideoArgs,
) -> Result<PathBuf> {
    use topa_env::Task;
    let o = video.options()?;
    let mut cfg = s.env_config(r)?;
    cfg.terrain = result.terrain.clone();
    let (_, model) = topa_env::assets::load_robot(&cfg)?;
    let mut env = topa_env::RobotEnv::new(model, std::sync::Arc::new(cfg.clone()), s.seed, 0)?;
    let column = cfg.terrain.types.iter().position(|&k| k == kind).unwrap_or(0);
    env.set_terrain_tile(Some((level, column)))?;
    let mut obs = vec![0.0; env.obs_dim()];
    env.reset(&mut obs)?;
    env.set_command_override(Some([0.0; 3]));
    let mut rec = crate::video::VideoRecorder::create(
        file,
        &env,
        o.video_size,
        o.fps,
        o.quality.unwrap_or(mujoco_sys::render::Quality::Fast),
    )?;
    let dt = cfg.policy_dt();
    let (settle, total) = ((s.settle_s / dt).round() as usize, ((s.settle_s + result.window_s) / dt).round() as usize);
    let mut actions = Vec::new();
    for k in 0..total {
        if k == settle {
            env.set_command_override(Some(terrain::COMMANDS[0].1));
        }
        r.act(&obs, &mut actions);
        let done = env.step(&actions, &mut obs).done;
        let t = (k + 1) as f64 * dt;
        rec.follow(env.indices().torso_body, 2.2, env.robot_state().yaw.to_degrees() + 30.0, -20.0);
        let text = crate::video::overlay(&env, t);
        rec.advance(t, &mut env, &text)?;
        if done {
            break;
        }
    }
    rec.finish()
}

/// The terrain test's protocol.
#[derive(Args, Clone, Debug)]
pub struct TerrainArgs {
    /// Difficulty levels from the easiest to the hardest of the terrain's ranges.
    #[arg(long, default_value_t = 5)]
    pub levels: usize,
    /// Runs per tile and command (each from its own random heading).
    #[arg(long, default_value_t = 2)]
    pub runs: usize,
    /// Seconds per run (after settling).
    #[arg(long, default_value_t = 10.0)]
    pub seconds: f64,
    /// Only these tile types, comma-separated (default: the terrain's), e.g. stairs_up,stairs_down.
    #[arg(long, value_delimiter = ',')]
    pub types: Vec<topa_env::terrain::TileKind>,
    /// Height samples this far apart instead of the terrain's, m (a finer field has steeper stair risers).
    #[arg(long)]
    pub resolution: Option<f64>,
    /// Box contacts with the ground: prisms (MuJoCo's, the evaluation's) or vertices (what a training config may
    /// choose, to measure what it changes).
    #[arg(long, default_value = "prisms")]
    pub contacts: topa_env::terrain::BoxContacts,
}

impl TerrainArgs {
    pub fn protocol(self) -> terrain::Protocol {
        let (levels, runs, window_s) = (self.levels, self.runs, self.seconds);
        let (types, resolution, contacts) = (self.types, self.resolution, self.contacts);
        terrain::Protocol { levels, runs, window_s, types, resolution, contacts }
    }
}

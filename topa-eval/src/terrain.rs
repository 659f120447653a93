//! `topa eval terrain`: a policy on every terrain type × difficulty, walking and turning for a fixed time from the
//! centre of a tile (legged_gym's tiles, made large enough that the run stays on its own tile). Per cell: success
//! (no fall), progress along the command, tracking MAE and foot slip; the tiles sit at the soles' nominal
//! friction, so that the map measures the ground's shape alone.

use serde::{Deserialize, Serialize};
use topa_env::policy_runner::PolicyRunner;
use topa_env::terrain::{BoxContacts, TerrainConfig, TileKind};
use topa_env::{EnvConfig, RobotEnv};

use super::runner::{run_batch, Experiment};
use super::settings::EvalSettings;
use crate::error::{ensure, Result};

/// The commands each tile is walked with: (name, v_x m/s, v_y m/s, w_z rad/s).
pub const COMMANDS: [(&str, [f64; 3]); 2] = [("walk", [0.5, 0.0, 0.0]), ("turn", [0.5, 0.0, 0.5])];

/// Sliding friction of the evaluation tiles: TopA's soles' own (MuJoCo takes the larger of the two).
const NOMINAL_FRICTION: f64 = 1.0;

/// One terrain type at one difficulty under one command, over its runs.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TerrainCell {
    pub kind: TileKind,
    pub difficulty: f64,
    pub command: String,
    pub runs: usize,
    /// Share of runs without a fall.
    pub success: f64,
    /// Distance covered along the commanded direction over the distance commanded (mean over runs; a fallen run
    /// counts what it covered before the fall).
    pub progress: f64,
    /// Mean |error| of v_x, v_y, w_z while standing (mean over runs that did not fall at once).
    pub mae: f64,
    /// Mean horizontal speed of a foot in contact, m/s.
    pub foot_slip: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TerrainResult {
    pub window_s: f64,
    pub settings: EvalSettings,
    /// The evaluation terrain (its tiles, with their parameters at each difficulty).
    pub terrain: TerrainConfig,
    pub cells: Vec<TerrainCell>,
}

impl TerrainResult {
    /// Success over both commands, per (type, difficulty), in `cells` order of types then difficulties.
    pub fn success_grid(&self) -> Vec<(TileKind, f64, f64)> {
        let mut out: Vec<(TileKind, f64, f64)> = Vec::new();
        for c in &self.cells {
            match out.iter_mut().find(|(k, d, _)| *k == c.kind && *d == c.difficulty) {
                Some(cell) => cell.2 = (cell.2 + c.success) / 2.0,
                None => out.push((c.kind, c.difficulty, c.success)),
            }
        }
        out
    }

    /// The hardest difficulty of `kind` walked without a fall by every run of every command, if any.
    pub fn hardest_walked(&self, kind: TileKind) -> Option<f64> {
        self.success_grid().iter().filter(|(k, _, s)| *k == kind && *s >= 1.0).map(|c| c.1).reduce(f64::max)
    }

    /// Mean success over every cell (the single number `topa ablate` shows).
    pub fn mean_success(&self) -> f64 {
        self.cells.iter().map(|c| c.success).sum::<f64>() / self.cells.len().max(1) as f64
    }
}

/// What `topa eval terrain` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Protocol {
    /// Difficulty levels from the easiest to the hardest of the terrain's ranges.
    pub levels: usize,
    /// Runs per tile and command.
    pub runs: usize,
    /// Seconds per run.
    pub window_s: f64,
    /// Only these tile types (empty: the terrain's).
    pub types: Vec<TileKind>,
    /// Height samples this far apart instead of the terrain's, m (a finer field has steeper stair risers).
    pub resolution: Option<f64>,
    /// Box contacts with the ground (MuJoCo's prisms unless measuring what a training choice changes).
    pub contacts: BoxContacts,
}

impl Default for Protocol {
    fn default() -> Self {
        let contacts = BoxContacts::Prisms;
        Protocol { levels: 5, runs: 2, window_s: 10.0, types: Vec::new(), resolution: None, contacts }
    }
}

/// The evaluation's terrain: the training terrain's types and parameters (or the defaults for a flat-trained
/// policy) on `levels` rows spanning the same difficulties, tiles large enough for a `window_s` run at 0.5 m/s,
/// at nominal friction, started at each tile's centre.
pub fn evaluation_terrain(train: &EnvConfig, p: &Protocol) -> TerrainConfig {
    let base = if train.terrain.enabled { train.terrain.clone() } else { TerrainConfig::default() };
    let reach = COMMANDS.iter().map(|(_, c)| c[0].hypot(c[1])).fold(0.0, f64::max) * p.window_s;
    let mut t = TerrainConfig {
        enabled: true,
        levels: p.levels,
        tile_size: base.tile_size.max(2.0 * (reach + 1.0)),
        border: 1.0,
        friction: [NOMINAL_FRICTION, NOMINAL_FRICTION],
        types: if p.types.is_empty() { base.types.clone() } else { p.types.clone() },
        resolution: p.resolution.unwrap_or(base.resolution),
        contacts: p.contacts,
        ..base
    };
    t.curriculum.enabled = false;
    t.curriculum.start_level_max = 0;
    t.curriculum.start_spread = 0.0;
    t
}

struct Walk {
    /// Per env: its command, tile kind and difficulty index.
    commands: Vec<[f64; 3]>,
    dt: f64,
    covered: Vec<f64>,
    abs_err: Vec<[f64; 3]>,
    steps: Vec<usize>,
    slip: Vec<(f64, usize)>,
    tiles: Vec<(usize, usize)>,
}

impl Experiment for Walk {
    fn prepare(&mut self, env: usize, task: &mut RobotEnv) -> Result<()> {
        task.set_terrain_tile(Some(self.tiles[env]))?;
        Ok(())
    }
    fn setup(&mut self, env: usize, task: &mut RobotEnv) {
        task.set_command_override(Some(self.commands[env]));
    }
    fn observe(&mut self, env: usize, _t: f64, task: &RobotEnv, _fallen: bool) {
        let s = task.robot_state();
        let c = self.commands[env];
        // Progress: the base's velocity along the commanded linear velocity (both in the torso frame).
        let norm = c[0].hypot(c[1]);
        if norm > 0.0 {
            self.covered[env] += (s.lin_vel[0] * c[0] + s.lin_vel[1] * c[1]) / norm * self.dt;
        }
        let v = [s.lin_vel[0], s.lin_vel[1], s.ang_vel[2]];
        for i in 0..3 {
            self.abs_err[env][i] += (v[i] - c[i]).abs();
        }
        self.steps[env] += 1;
        for (f, touching) in s.foot_contact().iter().enumerate() {
            if *touching {
                self.slip[env].0 += s.foot_speed[f];
                self.slip[env].1 += 1;
            }
        }
    }
}

/// Every type × `levels` difficulties × both commands × `runs` starts, `window_s` each (the protocol's).
pub fn run(runner: &mut PolicyRunner, settings: &EvalSettings, p: &Protocol) -> Result<TerrainResult> {
    let (levels, runs, window_s) = (p.levels, p.runs, p.window_s);
    ensure!(levels >= 2, "terrain evaluation needs at least 2 difficulty levels (--levels ≥ 2)");
    ensure!(runs >= 1, "terrain evaluation needs at least one run per cell (--runs ≥ 1)");
    ensure!(window_s > 0.0, "terrain evaluation needs a positive run length (--seconds)");
    let mut cfg = settings.env_config(runner)?;
    cfg.terrain = evaluation_terrain(runner.training_config(), p);
    cfg.validate()?;
    let types = cfg.terrain.types.clone();
    let mut tiles = Vec::new();
    let mut commands = Vec::new();
    for col in 0..types.len() {
        for level in 0..levels {
            for (_, c) in COMMANDS {
                for _ in 0..runs {
                    tiles.push((level, col));
                    commands.push(c);
                }
            }
        }
    }
    let n = tiles.len();
    let mut exp = Walk {
        commands,
        dt: cfg.policy_dt(),
        covered: vec![0.0; n],
        abs_err: vec![[0.0; 3]; n],
        steps: vec![0; n],
        slip: vec![(0.0, 0); n],
        tiles,
    };
    let fell = run_batch(runner, &cfg, settings, n, window_s, &mut exp, "terrain")?;
    let mut cells = Vec::new();
    let per_cell = COMMANDS.len() * runs;
    for (col, &kind) in types.iter().enumerate() {
        for level in 0..levels {
            for (k, (name, c)) in COMMANDS.iter().enumerate() {
                let first = (col * levels + level) * per_cell + k * runs;
                let ids: Vec<usize> = (first..first + runs).collect();
                let mean = |f: &dyn Fn(usize) -> Option<f64>| {
                    let v: Vec<f64> = ids.iter().filter_map(|&i| f(i)).collect();
                    if v.is_empty() {
                        f64::NAN
                    } else {
                        v.iter().sum::<f64>() / v.len() as f64
                    }
                };
                let commanded = c[0].hypot(c[1]) * window_s;
                cells.push(TerrainCell {
                    kind,
                    difficulty: cfg.terrain.difficulty(level),
                    command: name.to_string(),
                    runs,
                    success: ids.iter().filter(|&&i| fell[i].is_none()).count() as f64 / runs as f64,
                    progress: mean(&|i| Some(exp.covered[i] / commanded)),
                    mae: mean(&|i| {
                        (exp.steps[i] > 0).then(|| exp.abs_err[i].iter().sum::<f64>() / 3.0 / exp.steps[i] as f64)
                    }),
                    foot_slip: mean(&|i| (exp.slip[i].1 > 0).then(|| exp.slip[i].0 / exp.slip[i].1 as f64)),
                });
            }
        }
    }
    Ok(TerrainResult { window_s, settings: settings.clone(), terrain: cfg.terrain, cells })
}

/// The result as Markdown: one row per type × difficulty × command.
pub fn markdown(r: &TerrainResult) -> String {
    let mut s = format!(
        "Terrain: {:.0} s per run from each tile's centre; mean success {:.0} %\n\n| terrain | difficulty | command | success | progress | MAE | foot slip (m/s) |\n|---|---:|---|---:|---:|---:|---:|\n",
        r.window_s,
        100.0 * r.mean_success()
    );
    for c in &r.cells {
        s.push_str(&format!(
            "| {} | {:.2} | {} | {:.0} % | {:.2} | {:.3} | {:.3} |\n",
            c.kind.name(),
            c.difficulty,
            c.command,
            100.0 * c.success,
            c.progress,
            c.mae,
            c.foot_slip
        ));
    }
    s
}

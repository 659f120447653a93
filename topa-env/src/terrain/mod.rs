//! Rough terrain as data: a grid of tiles, one column per tile type (flat, rough, slopes, stairs, obstacles) and
//! one row per difficulty level, generated from `[env.terrain]` and a seed of its own, laid out as one MuJoCo
//! height field (legged_gym's terrain grid, sized for TopA). Heights are kept here too: the env spawns robots on
//! the ground, measures its base and feet above it, and the curriculum moves robots between rows.

mod curriculum;
mod mjcf;
mod scan;
mod tiles;

use std::sync::{Arc, Mutex, Weak};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

pub use curriculum::{level_change, next_level, CurriculumConfig, LevelChange};
pub use mjcf::TERRAIN_NAME;
pub use scan::HeightScanConfig;

use crate::error::{EnvError, Result};
use crate::world::FrictionMap;

/// What a tile holds. "Up" and "down" are seen from the tile's centre, where a robot starts: on `stairs_up` it
/// climbs as it walks out (the centre is a pit), on `stairs_down` it descends (the centre is a summit).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum TileKind {
    Flat,
    Rough,
    SlopeUp,
    SlopeDown,
    RoughSlope,
    StairsUp,
    StairsDown,
    Obstacles,
}

impl std::str::FromStr for TileKind {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        TileKind::ALL.into_iter().find(|k| k.name() == s).ok_or_else(|| {
            let names: Vec<&str> = TileKind::ALL.iter().map(|k| k.name()).collect();
            format!("no tile type '{s}': use one of {}", names.join(", "))
        })
    }
}

impl TileKind {
    pub const ALL: [TileKind; 8] = [
        TileKind::Flat,
        TileKind::Rough,
        TileKind::SlopeUp,
        TileKind::SlopeDown,
        TileKind::RoughSlope,
        TileKind::StairsUp,
        TileKind::StairsDown,
        TileKind::Obstacles,
    ];

    pub fn name(self) -> &'static str {
        match self {
            TileKind::Flat => "flat",
            TileKind::Rough => "rough",
            TileKind::SlopeUp => "slope_up",
            TileKind::SlopeDown => "slope_down",
            TileKind::RoughSlope => "rough_slope",
            TileKind::StairsUp => "stairs_up",
            TileKind::StairsDown => "stairs_down",
            TileKind::Obstacles => "obstacles",
        }
    }
}

/// `[env.terrain]`. Pairs `[a, b]` are a parameter's value on the easiest row (difficulty 0) and the hardest
/// (difficulty 1), linear in between. Defaults are legged_gym's terrain scaled to TopA's 0.4 m legs (ANYmal's are
/// ~0.55 m, and its stairs reach 0.23 m): steps to 0.10 m, slopes to 15°, rough to ±3 cm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct TerrainConfig {
    /// Off (default): the robot's own flat floor, as in the paper.
    pub enabled: bool,
    /// The terrain's own random stream: one seed, one terrain, whatever the run's seed.
    pub seed: u64,
    /// One column per entry (list a type twice to give it twice the robots).
    pub types: Vec<TileKind>,
    /// Difficulty levels, one row each; row 0 is the easiest.
    pub levels: usize,
    /// Side of a square tile, m.
    pub tile_size: f64,
    /// Flat ground around the grid, m.
    pub border: f64,
    /// Distance between height samples, m (a stair's riser is one sample wide, so it leans by this much).
    pub resolution: f64,
    /// Flat square at each tile's centre where robots start, side in m.
    pub platform: f64,
    /// Random bumps: heights uniform in ±this, m (on `rough` and `rough_slope`).
    pub rough_height: [f64; 2],
    /// Distance between independent bumps, m (heights are interpolated in between).
    pub rough_cell: f64,
    /// Slope of `slope_*` and `rough_slope`, degrees.
    pub slope_deg: [f64; 2],
    /// Stair step height, m.
    pub step_height: [f64; 2],
    /// Stair tread, m.
    pub step_width: f64,
    /// Height of the discrete obstacles (raised or sunk, at random), m.
    pub obstacle_height: [f64; 2],
    /// Side of an obstacle, uniform in this range, m.
    pub obstacle_size: [f64; 2],
    /// Obstacles per square metre of tile (legged_gym: 20 on an 8 m tile of ANYmal's; ours 20 on a 4 m tile).
    pub obstacle_density: f64,
    /// Sliding friction of the ground, uniform per tile in this range (the feet take the tile's value).
    pub friction: [f64; 2],
    /// Where robots start and how they move between rows.
    pub curriculum: CurriculumConfig,
}

impl Default for TerrainConfig {
    fn default() -> Self {
        TerrainConfig {
            enabled: false,
            seed: 0,
            types: TileKind::ALL.to_vec(),
            levels: 10,
            tile_size: 4.0,
            border: 3.0,
            resolution: 0.05,
            platform: 1.5,
            rough_height: [0.005, 0.03],
            rough_cell: 0.1,
            slope_deg: [0.0, 15.0],
            step_height: [0.02, 0.10],
            step_width: 0.25,
            obstacle_height: [0.02, 0.08],
            obstacle_size: [0.2, 0.6],
            obstacle_density: 1.25,
            friction: [0.5, 1.0],
            curriculum: CurriculumConfig::default(),
        }
    }
}

fn check(ok: bool, what: &str) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(EnvError::Config(format!("[env.terrain] {what}")))
    }
}

impl TerrainConfig {
    pub fn validate(&self) -> Result<()> {
        if !self.enabled {
            return Ok(());
        }
        check(!self.types.is_empty(), "types is empty: list at least one tile type, e.g. [\"flat\"]")?;
        check(self.levels >= 1, "levels must be at least 1")?;
        check(self.resolution > 0.0 && self.resolution <= 0.2, "resolution must be in (0, 0.2] m")?;
        check(self.tile_size >= 4.0 * self.resolution, "tile_size must be at least 4 samples (4 × resolution)")?;
        check(self.border >= 0.0, "border must be ≥ 0 m")?;
        check(
            self.platform > 0.0 && self.platform < self.tile_size,
            "platform must be positive and smaller than tile_size",
        )?;
        check(
            self.obstacle_density >= 0.0 && self.obstacle_density <= 100.0,
            "obstacle_density must be in [0, 100] per m²",
        )?;
        check(self.rough_cell >= self.resolution, "rough_cell must be at least the resolution")?;
        check(self.step_width >= self.resolution, "step_width must be at least the resolution")?;
        for (name, [a, b]) in [
            ("rough_height", self.rough_height),
            ("step_height", self.step_height),
            ("obstacle_height", self.obstacle_height),
        ] {
            check(a >= 0.0 && b >= 0.0 && a.is_finite() && b.is_finite(), &format!("{name} must be ≥ 0 m"))?;
        }
        check(
            (0.0..60.0).contains(&self.slope_deg[0]) && (0.0..60.0).contains(&self.slope_deg[1]),
            "slope_deg must be in [0, 60) degrees",
        )?;
        check(
            self.obstacle_size[0] > 0.0 && self.obstacle_size[0] <= self.obstacle_size[1],
            "obstacle_size must be [min, max] with 0 < min ≤ max",
        )?;
        check(
            self.friction[0] > 0.0 && self.friction[0] <= self.friction[1],
            "friction must be [min, max] with 0 < min ≤ max",
        )?;
        let samples = (self.extent()[0] / self.resolution) * (self.extent()[1] / self.resolution);
        check(
            samples <= 4.0e6,
            &format!("has {samples:.0} height samples (over 4 million): raise resolution or shrink the grid"),
        )?;
        self.curriculum.validate(self.levels)
    }

    /// Size of the whole field, border included, m (x: levels, y: types).
    pub fn extent(&self) -> [f64; 2] {
        [
            self.levels as f64 * self.tile_size + 2.0 * self.border,
            self.types.len() as f64 * self.tile_size + 2.0 * self.border,
        ]
    }

    /// Difficulty of a row, 0 (easiest) to 1.
    pub fn difficulty(&self, level: usize) -> f64 {
        if self.levels <= 1 {
            1.0
        } else {
            level as f64 / (self.levels - 1) as f64
        }
    }
}

/// A generated terrain: heights on a regular grid over `[0, extent]`, x along the difficulty levels.
#[derive(Debug, Clone)]
pub struct Terrain {
    pub cfg: TerrainConfig,
    /// Samples along x and y.
    pub nx: usize,
    pub ny: usize,
    /// Grid spacing along x and y, m (the resolution, adjusted to fit the extent exactly).
    pub dx: f64,
    pub dy: f64,
    /// Heights, m, row-major: sample (i, j) at x = i·dx, y = j·dy is `heights[j * nx + i]`.
    pub heights: Vec<f32>,
    /// Sliding friction per tile, `[level * types + column]`.
    pub friction: Vec<f64>,
}

impl Terrain {
    /// The terrain `cfg` describes (deterministic: each tile draws from its own stream of `cfg.seed`).
    pub fn generate(cfg: &TerrainConfig) -> Result<Terrain> {
        cfg.validate()?;
        let [w, h] = cfg.extent();
        let nx = (w / cfg.resolution).round() as usize + 1;
        let ny = (h / cfg.resolution).round() as usize + 1;
        let (dx, dy) = (w / (nx - 1) as f64, h / (ny - 1) as f64);
        let mut t = Terrain { cfg: cfg.clone(), nx, ny, dx, dy, heights: vec![0.0; nx * ny], friction: Vec::new() };
        let cols = cfg.types.len();
        for level in 0..cfg.levels {
            for (col, &kind) in cfg.types.iter().enumerate() {
                let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
                rng.set_stream((level * cols + col) as u64);
                let tile = tiles::generate(kind, cfg, cfg.difficulty(level), &mut rng);
                t.friction.push(tiles::friction(cfg, &mut rng));
                t.paste(level, col, &tile);
            }
        }
        Ok(t)
    }

    /// The terrain of `cfg`, generated once per process and shared (every env of a batch reads the same heights).
    pub fn shared(cfg: &TerrainConfig) -> Result<Arc<Terrain>> {
        static CACHE: Mutex<Vec<Weak<Terrain>>> = Mutex::new(Vec::new());
        let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
        cache.retain(|w| w.strong_count() > 0);
        if let Some(t) = cache.iter().filter_map(Weak::upgrade).find(|t| t.cfg == *cfg) {
            return Ok(t);
        }
        let t = Arc::new(Terrain::generate(cfg)?);
        cache.push(Arc::downgrade(&t));
        Ok(t)
    }

    /// Copies a tile's heights (`tiles::Tile`, sampled at this grid's points inside the tile) into place.
    fn paste(&mut self, level: usize, col: usize, tile: &tiles::Tile) {
        let c = self.tile_center(level, col);
        let half = self.cfg.tile_size / 2.0;
        let (i0, i1) = self.index_range(c[0] - half, c[0] + half, self.dx);
        let (j0, j1) = self.index_range(c[1] - half, c[1] + half, self.dy);
        for j in j0..j1 {
            for i in i0..i1 {
                let (u, v) = (i as f64 * self.dx - c[0], j as f64 * self.dy - c[1]);
                self.heights[j * self.nx + i] = tile.height(u, v) as f32;
            }
        }
    }

    /// Sample indices whose coordinate lies in `[lo, hi)`.
    fn index_range(&self, lo: f64, hi: f64, d: f64) -> (usize, usize) {
        ((lo / d - 1e-9).ceil().max(0.0) as usize, (hi / d - 1e-9).ceil().max(0.0) as usize)
    }

    /// Centre of the tile of `level` (x) and `column` (y), m.
    pub fn tile_center(&self, level: usize, column: usize) -> [f64; 2] {
        let (b, l) = (self.cfg.border, self.cfg.tile_size);
        [b + (level as f64 + 0.5) * l, b + (column as f64 + 0.5) * l]
    }

    /// The tile under (x, y), if any: (level, column).
    pub fn tile_at(&self, x: f64, y: f64) -> Option<(usize, usize)> {
        let (b, l) = (self.cfg.border, self.cfg.tile_size);
        let (fx, fy) = ((x - b) / l, (y - b) / l);
        (fx >= 0.0 && fy >= 0.0 && (fx as usize) < self.cfg.levels && (fy as usize) < self.cfg.types.len())
            .then_some((fx as usize, fy as usize))
    }

    /// Ground height at (x, y), m: bilinear between samples (MuJoCo draws two triangles per cell, so this is
    /// within a cell's height difference of what the feet touch); the edge's height off the field.
    pub fn height_at(&self, x: f64, y: f64) -> f64 {
        let fx = (x / self.dx).clamp(0.0, (self.nx - 1) as f64);
        let fy = (y / self.dy).clamp(0.0, (self.ny - 1) as f64);
        let (i, j) = ((fx as usize).min(self.nx - 2), (fy as usize).min(self.ny - 2));
        let (tx, ty) = (fx - i as f64, fy - j as f64);
        let h = |i: usize, j: usize| self.heights[j * self.nx + i] as f64;
        let lo = h(i, j) * (1.0 - tx) + h(i + 1, j) * tx;
        let hi = h(i, j + 1) * (1.0 - tx) + h(i + 1, j + 1) * tx;
        lo * (1.0 - ty) + hi * ty
    }

    /// The highest ground within `r` of (x, y) (on a 5 × 5 pattern): where a robot can be put down.
    pub fn max_height_near(&self, x: f64, y: f64, r: f64) -> f64 {
        let mut m = f64::NEG_INFINITY;
        for a in -2..=2 {
            for b in -2..=2 {
                m = m.max(self.height_at(x + r * a as f64 / 2.0, y + r * b as f64 / 2.0));
            }
        }
        m
    }

    /// The ground's friction by place: one patch per tile, the border at the easiest tile's friction.
    pub fn friction_map(&self) -> FrictionMap {
        let half = self.cfg.tile_size / 2.0;
        let cols = self.cfg.types.len();
        let patches = (0..self.cfg.levels)
            .flat_map(|l| (0..cols).map(move |c| (l, c)))
            .map(|(l, c)| {
                let p = self.tile_center(l, c);
                ([p[0] - half, p[1] - half], [p[0] + half, p[1] + half], self.friction[l * cols + c])
            })
            .collect();
        FrictionMap { patches, default: self.cfg.friction[1] }
    }
}

#[cfg(test)]
mod tests;

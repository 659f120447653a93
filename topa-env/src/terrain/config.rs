//! What `[env.terrain]` says: the tile types and the grid's parameters, each a pair from the easiest row to the
//! hardest.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::curriculum::CurriculumConfig;
use crate::error::{EnvError, Result};

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
    type Err = crate::error::EnvError;
    fn from_str(s: &str) -> std::result::Result<Self, crate::error::EnvError> {
        TileKind::ALL.into_iter().find(|k| k.name() == s).ok_or_else(|| {
            let names: Vec<&str> = TileKind::ALL.iter().map(|k| k.name()).collect();
            crate::error::EnvError::Choice(format!("no tile type '{s}': use one of {}", names.join(", ")))
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

/// How a box (a sole, the torso) collides with the terrain.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum BoxContacts {
    /// MuJoCo's own: a convex penetration test per triangular prism under the box, a contact per prism touched.
    #[default]
    Prisms,
    /// The box's corners against the field's triangles and the field's samples against the box, reduced to the
    /// four contacts spanning the patch and the deepest (`mujoco::hfield_box`): cheaper, fewer constraints.
    Vertices,
}

impl std::str::FromStr for BoxContacts {
    type Err = crate::error::EnvError;
    fn from_str(s: &str) -> std::result::Result<Self, crate::error::EnvError> {
        match s {
            "prisms" => Ok(BoxContacts::Prisms),
            "vertices" => Ok(BoxContacts::Vertices),
            _ => {
                Err(crate::error::EnvError::Choice(format!("no box contacts '{s}': use prisms (MuJoCo's) or vertices")))
            }
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
    /// How boxes collide with the terrain; evaluation uses MuJoCo's `prisms` whatever training used.
    pub contacts: BoxContacts,
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
            contacts: BoxContacts::Prisms,
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

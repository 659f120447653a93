//! Rough terrain as data: a grid of tiles, one column per tile type (flat, rough, slopes, stairs, obstacles) and
//! one row per difficulty level, generated from `[env.terrain]` and a seed of its own, laid out as one MuJoCo
//! height field (legged_gym's terrain grid, sized for TopA). Heights are kept here too: the env spawns robots on
//! the ground, measures its base and feet above it, and the curriculum moves robots between rows.

mod config;
mod curriculum;
mod field;
mod mjcf;
mod placement;
mod scan;
mod tiles;

pub use config::{BoxContacts, TerrainConfig, TileKind};
pub use curriculum::{level_change, next_level, CurriculumConfig, LevelChange};
pub use field::Terrain;
pub use mjcf::TERRAIN_NAME;
pub use placement::Placement;
pub use scan::HeightScanConfig;

#[cfg(test)]
mod tests;

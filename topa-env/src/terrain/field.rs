//! A generated terrain: the heights of every tile on one grid, the friction of each tile, and where things are.

use std::sync::{Arc, Mutex, Weak};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::config::TerrainConfig;
use super::tiles;
use crate::error::Result;
use crate::world::FrictionMap;

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

    /// Whether (level, column) is a tile of this grid.
    pub fn has_tile(&self, level: usize, column: usize) -> bool {
        level < self.cfg.levels && column < self.cfg.types.len()
    }

    /// The tile under (x, y), if any: (level, column).
    pub fn tile_at(&self, x: f64, y: f64) -> Option<(usize, usize)> {
        let (b, l) = (self.cfg.border, self.cfg.tile_size);
        let (fx, fy) = ((x - b) / l, (y - b) / l);
        (fx >= 0.0 && fy >= 0.0 && self.has_tile(fx as usize, fy as usize)).then_some((fx as usize, fy as usize))
    }

    /// Ground height at (x, y), m: bilinear between samples (MuJoCo draws two triangles per cell, so this is
    /// within a cell's height difference of what the feet touch); the edge's height off the field.
    pub fn height_at(&self, x: f64, y: f64) -> f64 {
        tiles::bilinear([x / self.dx, y / self.dy], [self.nx, self.ny], |i, j| self.heights[j * self.nx + i] as f64)
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

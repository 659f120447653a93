//! One tile's heights as a function of the place on it (legged_gym's terrain_utils, as closed forms rather than
//! edits of a height array, so that a tile is independent of the grid's resolution).

use rand::RngExt;
use rand_chacha::ChaCha8Rng;

use super::config::{TerrainConfig, TileKind};

/// A value of `[easiest, hardest]` at difficulty `d`.
/// Bilinear interpolation on an `n[0]` × `n[1]` grid of samples `at(i, j)`, at `f` in sample units (clamped to the
/// grid).
pub(super) fn bilinear(f: [f64; 2], n: [usize; 2], at: impl Fn(usize, usize) -> f64) -> f64 {
    let fx = f[0].clamp(0.0, (n[0] - 1) as f64);
    let fy = f[1].clamp(0.0, (n[1] - 1) as f64);
    let (i, j) = ((fx as usize).min(n[0] - 2), (fy as usize).min(n[1] - 2));
    let (tx, ty) = (fx - i as f64, fy - j as f64);
    let lo = at(i, j) * (1.0 - tx) + at(i + 1, j) * tx;
    let hi = at(i, j + 1) * (1.0 - tx) + at(i + 1, j + 1) * tx;
    lo * (1.0 - ty) + hi * ty
}

fn lerp([a, b]: [f64; 2], d: f64) -> f64 {
    a + (b - a) * d
}

/// The square pattern of pyramids and stairs: distance inwards from the tile's edge, capped at the platform.
enum Shape {
    Flat,
    /// Height grows by `rise` per metre inwards (negative: a pit).
    Pyramid {
        rise: f64,
    },
    /// One `step` per `tread` inwards (negative: stairs down into a pit).
    Stairs {
        step: f64,
        tread: f64,
    },
}

/// Random heights on a coarse square grid, interpolated.
struct Bumps {
    cell: f64,
    n: usize,
    values: Vec<f64>,
}

pub(super) struct Tile {
    half: f64,
    platform_half: f64,
    shape: Shape,
    bumps: Option<Bumps>,
    /// (min corner, max corner, height) in tile coordinates; the last one containing a point wins.
    obstacles: Vec<([f64; 2], [f64; 2], f64)>,
}

impl Tile {
    /// Height at (u, v) from the tile's centre, m.
    pub(super) fn height(&self, u: f64, v: f64) -> f64 {
        let inward = self.half - u.abs().max(v.abs()).max(self.platform_half);
        let inward = inward.max(0.0);
        let mut h = match self.shape {
            Shape::Flat => 0.0,
            Shape::Pyramid { rise } => rise * inward,
            Shape::Stairs { step, tread } => step * (inward / tread + 1e-9).floor(),
        };
        if let Some(b) = &self.bumps {
            h += bilinear([(u + self.half) / b.cell, (v + self.half) / b.cell], [b.n, b.n], |i, j| {
                b.values[j * b.n + i]
            });
        }
        let on_platform = u.abs() < self.platform_half && v.abs() < self.platform_half;
        if !on_platform {
            if let Some((_, _, oh)) = self
                .obstacles
                .iter()
                .rev()
                .find(|(lo, hi, _)| (lo[0]..hi[0]).contains(&u) && (lo[1]..hi[1]).contains(&v))
            {
                h += oh;
            }
        }
        h
    }
}

/// The tile of `kind` at difficulty `d` (0–1), its randomness drawn from `rng`.
pub(super) fn generate(kind: TileKind, cfg: &TerrainConfig, d: f64, rng: &mut ChaCha8Rng) -> Tile {
    let half = cfg.tile_size / 2.0;
    let slope = lerp(cfg.slope_deg, d).to_radians().tan();
    let step = lerp(cfg.step_height, d);
    let shape = match kind {
        TileKind::Flat | TileKind::Rough | TileKind::Obstacles => Shape::Flat,
        TileKind::SlopeUp => Shape::Pyramid { rise: -slope },
        TileKind::SlopeDown | TileKind::RoughSlope => Shape::Pyramid { rise: slope },
        TileKind::StairsUp => Shape::Stairs { step: -step, tread: cfg.step_width },
        TileKind::StairsDown => Shape::Stairs { step, tread: cfg.step_width },
    };
    let bumps = matches!(kind, TileKind::Rough | TileKind::RoughSlope).then(|| {
        let amp = lerp(cfg.rough_height, d);
        let n = (cfg.tile_size / cfg.rough_cell).ceil() as usize + 1;
        let values = (0..n * n).map(|_| if amp > 0.0 { rng.random_range(-amp..=amp) } else { 0.0 }).collect();
        Bumps { cell: cfg.rough_cell, n, values }
    });
    let mut obstacles = Vec::new();
    if kind == TileKind::Obstacles {
        let h = lerp(cfg.obstacle_height, d);
        let [lo, hi] = cfg.obstacle_size;
        let count = (cfg.obstacle_density * cfg.tile_size * cfg.tile_size).round() as usize;
        for _ in 0..count {
            let (w, l) = (rng.random_range(lo..=hi), rng.random_range(lo..=hi));
            let (x, y) = (rng.random_range(-half..half - w), rng.random_range(-half..half - l));
            // Raised or sunk, full or half height (legged_gym's discrete obstacles).
            let oh = [-h, -h / 2.0, h / 2.0, h][rng.random_range(0..4)];
            obstacles.push(([x, y], [x + w, y + l], oh));
        }
    }
    Tile { half, platform_half: cfg.platform / 2.0, shape, bumps, obstacles }
}

/// A tile's sliding friction.
pub(super) fn friction(cfg: &TerrainConfig, rng: &mut ChaCha8Rng) -> f64 {
    let [lo, hi] = cfg.friction;
    if hi > lo {
        rng.random_range(lo..=hi)
    } else {
        lo
    }
}

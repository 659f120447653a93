use super::*;

fn cfg() -> TerrainConfig {
    TerrainConfig { enabled: true, levels: 4, ..Default::default() }
}

fn column(cfg: &TerrainConfig, kind: TileKind) -> usize {
    cfg.types.iter().position(|&k| k == kind).unwrap()
}

#[test]
fn a_seed_fixes_the_terrain_and_another_seed_changes_it() {
    let a = Terrain::generate(&cfg()).unwrap();
    let b = Terrain::generate(&cfg()).unwrap();
    assert_eq!(a.heights, b.heights);
    assert_eq!(a.friction, b.friction);
    let c = Terrain::generate(&TerrainConfig { seed: 1, ..cfg() }).unwrap();
    assert_ne!(a.heights, c.heights);
}

#[test]
fn tiles_follow_their_type_and_grow_harder_by_row() {
    let cfg = cfg();
    let t = Terrain::generate(&cfg).unwrap();
    let l = cfg.tile_size;
    // Flat tiles and the border are at 0.
    let flat = t.tile_center(3, column(&cfg, TileKind::Flat));
    assert_eq!(t.height_at(flat[0] + 1.0, flat[1] - 1.3), 0.0);
    assert_eq!(t.height_at(0.5, 0.5), 0.0);
    // Stairs down: the centre is a summit of whole steps, each tread one step lower outwards.
    let col = column(&cfg, TileKind::StairsDown);
    let step = cfg.step_height[1];
    let c = t.tile_center(3, col);
    let steps = ((l - cfg.platform) / 2.0 / cfg.step_width).floor();
    assert!((t.height_at(c[0], c[1]) - steps * step).abs() < 1e-5, "{}", t.height_at(c[0], c[1]));
    let mid_tread = |k: f64| t.height_at(c[0] + l / 2.0 - (k + 0.5) * cfg.step_width, c[1]);
    assert!((mid_tread(0.0) - 0.0).abs() < 1e-5 && (mid_tread(1.0) - step).abs() < 1e-5);
    // Stairs up: a pit of the same depth; easier rows have lower steps.
    let up = t.tile_center(3, column(&cfg, TileKind::StairsUp));
    assert!((t.height_at(up[0], up[1]) + steps * step).abs() < 1e-5);
    let easy = t.tile_center(0, col);
    assert!((t.height_at(easy[0], easy[1]) - steps * cfg.step_height[0]).abs() < 1e-5);
    // Slopes: the rise per metre is the configured angle.
    let s = t.tile_center(3, column(&cfg, TileKind::SlopeUp));
    let (h1, h2) = (t.height_at(s[0] + 1.0, s[1]), t.height_at(s[0] + 1.5, s[1]));
    assert!(((h2 - h1) / 0.5 - cfg.slope_deg[1].to_radians().tan()).abs() < 1e-3, "{h1} {h2}");
    // Rough: bounded by the row's amplitude, not flat.
    let r = t.tile_center(3, column(&cfg, TileKind::Rough));
    let hs: Vec<f64> = (0..50).map(|i| t.height_at(r[0] - 1.9 + 0.077 * i as f64, r[1] + 0.3)).collect();
    assert!(hs.iter().all(|h| h.abs() <= cfg.rough_height[1] + 1e-6));
    assert!(hs.iter().any(|h| h.abs() > cfg.rough_height[1] / 4.0));
    // Obstacles leave the platform flat.
    let o = t.tile_center(3, column(&cfg, TileKind::Obstacles));
    assert_eq!(t.height_at(o[0] + 0.3, o[1] - 0.3), 0.0);
}

#[test]
fn tiles_are_found_by_place_and_friction_is_per_tile() {
    let cfg = cfg();
    let t = Terrain::generate(&cfg).unwrap();
    let c = t.tile_center(2, 5);
    assert_eq!(t.tile_at(c[0], c[1]), Some((2, 5)));
    assert_eq!(t.tile_at(0.1, 0.1), None);
    let map = t.friction_map();
    assert_eq!(map.at(c), t.friction[2 * cfg.types.len() + 5]);
    assert!(t.friction.iter().all(|f| (cfg.friction[0]..=cfg.friction[1]).contains(f)));
    assert!(t.friction.iter().any(|&f| f != t.friction[0]));
}

#[test]
fn bad_terrain_settings_are_named() {
    let bad = [
        (TerrainConfig { types: vec![], ..cfg() }, "types"),
        (TerrainConfig { resolution: 0.0, ..cfg() }, "resolution"),
        (TerrainConfig { platform: 9.0, ..cfg() }, "platform"),
        (TerrainConfig { step_height: [0.02, -0.1], ..cfg() }, "step_height"),
        (TerrainConfig { friction: [0.8, 0.4], ..cfg() }, "friction"),
        (TerrainConfig { resolution: 0.001, ..cfg() }, "samples"),
        (
            TerrainConfig { curriculum: CurriculumConfig { start_level_max: 4, ..Default::default() }, ..cfg() },
            "start_level_max",
        ),
    ];
    for (c, what) in bad {
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains(what) && e.contains("terrain"), "{what}: {e}");
    }
    assert!(TerrainConfig { types: vec![], ..Default::default() }.validate().is_ok(), "off is not checked");
}

#[test]
fn the_curriculum_moves_up_after_walking_far_and_down_after_falling_or_lagging() {
    use rand::SeedableRng;
    let c = CurriculumConfig::default();
    assert_eq!(level_change(&c, 4.0, 2.5, 3.0, false), LevelChange::Up);
    assert_eq!(level_change(&c, 4.0, 2.5, 3.0, true), LevelChange::Down);
    assert_eq!(level_change(&c, 4.0, 1.0, 3.0, false), LevelChange::Down);
    assert_eq!(level_change(&c, 4.0, 1.6, 3.0, false), LevelChange::Stay);
    assert_eq!(level_change(&c, 4.0, 0.0, 0.0, false), LevelChange::Stay, "standing still as commanded");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    assert_eq!(next_level(3, 10, LevelChange::Up, &mut rng), 4);
    assert_eq!(next_level(0, 10, LevelChange::Down, &mut rng), 0);
    let solved: Vec<usize> = (0..50).map(|_| next_level(9, 10, LevelChange::Up, &mut rng)).collect();
    assert!(solved.iter().all(|&l| l < 10) && solved.iter().any(|&l| l < 9));
}

#[test]
fn a_height_scan_must_mirror_onto_itself() {
    let on = HeightScanConfig { enabled: true, ..Default::default() };
    assert!(on.validate().is_ok());
    assert_eq!(on.grid(), (7, 5));
    let lopsided = HeightScanConfig { y: vec![-0.3, 0.0, 0.2], ..on.clone() };
    let e = lopsided.validate().unwrap_err().to_string();
    assert!(e.contains("height_scan") && e.contains("symmetric"), "{e}");
    let empty = HeightScanConfig { x: vec![], ..on };
    assert!(empty.validate().unwrap_err().to_string().contains("points"));
    assert_eq!(HeightScanConfig::default().grid(), (0, 0), "off: no values");
}

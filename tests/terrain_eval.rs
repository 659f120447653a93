//! `topa eval terrain`: the shipped flat-trained C policy on every tile type at the easiest and the hardest
//! difficulty — its cells, its physics (it walks the flat tile, the hardest stairs up are higher than its feet
//! lift) and its figure; bad arguments.

use std::path::Path;

use topa_env::policy_runner::PolicyRunner;
use topa_env::terrain::TileKind;
use topa_eval::settings::EvalSettings;
use topa_eval::{terrain, terrain_map};

fn c_policy() -> PolicyRunner {
    PolicyRunner::load(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/policies/C/seed1.json")), "C").unwrap()
}

#[test]
fn a_flat_policy_walks_flat_tiles_and_not_the_hardest_stairs_up() {
    let mut r = c_policy();
    let settings = EvalSettings { settle_s: 0.5, ..Default::default() };
    let p = terrain::Protocol { levels: 2, runs: 1, window_s: 3.0, ..Default::default() };
    let res = terrain::run(&mut r, &settings, &p).unwrap();
    let types = res.terrain.types.len();
    assert_eq!(res.cells.len(), types * 2 * terrain::COMMANDS.len());
    assert!(res.terrain.tile_size >= 2.0 * 0.5 * 3.0, "a run stays on its tile");
    let cell = |kind: TileKind, d: f64, cmd: &str| {
        res.cells.iter().find(|c| c.kind == kind && c.difficulty == d && c.command == cmd).unwrap().clone()
    };
    let flat = cell(TileKind::Flat, 0.0, "walk");
    assert_eq!(flat.success, 1.0);
    assert!(flat.progress > 0.6 && flat.progress < 1.3, "progress {}", flat.progress);
    assert!(flat.mae < 0.2 && flat.foot_slip < 0.3, "{flat:?}");
    // 10 cm steps: more than the 5 cm the flat-trained policy lifts its feet; its walk ends in a fall or stalls.
    let stairs = cell(TileKind::StairsUp, 1.0, "walk");
    assert!(stairs.success < 1.0 || stairs.progress < flat.progress, "{stairs:?}");
    assert_eq!(res.hardest_walked(TileKind::Flat), Some(1.0));
    let dir = std::env::temp_dir().join(format!("topa-terrain-eval-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (png, svg) = (dir.join("t.png"), dir.join("t.svg"));
    terrain_map::success_map(&res, "C", &png, &svg).unwrap();
    assert!(std::fs::metadata(&png).unwrap().len() > 5_000);
    let md = terrain::markdown(&res);
    assert!(md.contains("stairs_up") && md.contains("| flat | 0.00 | walk | 100 % |"), "{md}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn bad_terrain_evaluations_are_refused() {
    let mut r = c_policy();
    let s = EvalSettings::default();
    let p = terrain::Protocol::default();
    let e = terrain::run(&mut r, &s, &terrain::Protocol { levels: 1, ..p.clone() }).unwrap_err().to_string();
    assert!(e.contains("--levels"), "{e}");
    let e = terrain::run(&mut r, &s, &terrain::Protocol { runs: 0, ..p.clone() }).unwrap_err().to_string();
    assert!(e.contains("--runs"), "{e}");
    let e = terrain::run(&mut r, &s, &terrain::Protocol { resolution: Some(0.0), ..p }).unwrap_err().to_string();
    assert!(e.contains("resolution"), "{e}");
}

//! The robot on generated terrain: the height field MuJoCo collides with is the one the env measures from, robots
//! start on their tile's ground, the curriculum moves them between rows, and an env on terrain resumes bit for
//! bit from a snapshot.

use std::sync::Arc;

use topa_env::terrain::{BoxContacts, Terrain, TerrainConfig, TileKind, TERRAIN_NAME};
use topa_env::{assets, EnvConfig, ModelKind, RobotEnv, Task};

fn on_terrain(levels: usize) -> EnvConfig {
    let mut c = EnvConfig { robot: ModelKind::Closed.spec_path().into(), ..EnvConfig::default() };
    c.noise.enabled = false;
    c.push.enabled = false;
    c.terrain = TerrainConfig { enabled: true, levels, ..Default::default() };
    c
}

fn env(cfg: &EnvConfig, index: u64) -> RobotEnv {
    let (_, model) = assets::load_robot(cfg).unwrap();
    RobotEnv::new(model, Arc::new(cfg.clone()), 3, index).unwrap()
}

fn column(cfg: &EnvConfig, kind: TileKind) -> usize {
    cfg.terrain.types.iter().position(|&k| k == kind).unwrap()
}

/// Steps with zero actions (the stand pose held by the PD loops); returns whether the robot fell.
fn stand(e: &mut RobotEnv, steps: usize) -> bool {
    let mut obs = vec![0.0; e.obs_dim()];
    let zero = vec![0.0; e.action_dim()];
    (0..steps).any(|_| e.step(&zero, &mut obs).done && e.has_fallen())
}

#[test]
fn the_feet_touch_the_heights_the_env_measures_from() {
    for contacts in [BoxContacts::Prisms, BoxContacts::Vertices] {
        feet_touch_the_measured_ground(contacts);
    }
}

fn feet_touch_the_measured_ground(contacts: BoxContacts) {
    let mut cfg = on_terrain(4);
    cfg.terrain.contacts = contacts;
    let map = Terrain::shared(&cfg.terrain).unwrap();
    let mut e = env(&cfg, 0);
    // Rough ground: ±2 cm bumps every 10 cm, random, so a transposed or flipped field would not match.
    // Without a policy the stand pose holds ~0.5 s on ±2 cm bumps (row 2 of 4).
    e.set_terrain_tile(Some((2, column(&cfg, TileKind::Rough)))).unwrap();
    let mut obs = vec![0.0; e.obs_dim()];
    e.reset(&mut obs).unwrap();
    assert!(!stand(&mut e, 15), "the robot fell standing on rough ground ({contacts:?})");
    let d = e.data();
    let field = d.model().id(mujoco::ObjType::Geom, TERRAIN_NAME).unwrap();
    let touching: Vec<_> =
        d.contacts().iter().filter(|c| c.geom1 as usize == field || c.geom2 as usize == field).collect();
    assert!(touching.len() >= 2, "{} contacts with the terrain ({contacts:?})", touching.len());
    if contacts == BoxContacts::Vertices {
        assert!(touching.len() <= 2 * mujoco::hfield_box::MAX_CONTACTS, "{} contacts", touching.len());
    }
    for c in touching {
        let ground = map.height_at(c.pos[0], c.pos[1]);
        assert!((c.pos[2] - ground).abs() < 0.01, "contact at z {:.4}, terrain {:.4} ({contacts:?})", c.pos[2], ground);
    }
    let stand_height = e.base_height_target();
    assert!((e.base_height() - stand_height).abs() < 0.03, "{} vs {stand_height}", e.base_height());
}

#[test]
fn robots_start_on_their_tiles_ground() {
    let cfg = on_terrain(4);
    let map = Terrain::shared(&cfg.terrain).unwrap();
    let mut e = env(&cfg, 0);
    let col = column(&cfg, TileKind::StairsDown);
    e.set_terrain_tile(Some((3, col))).unwrap();
    let mut obs = vec![0.0; e.obs_dim()];
    e.reset(&mut obs).unwrap();
    let [x, y, z] = e.robot_state().base_pos;
    assert_eq!(map.tile_at(x, y), Some((3, col)));
    let summit = map.height_at(x, y);
    assert!(summit > 0.4, "the stairs' summit is {summit} m");
    assert!((z - summit - e.base_height_target()).abs() < 0.02, "base at {z}, ground {summit}");
    assert!(!stand(&mut e, 25));
    assert!((e.base_height() - e.base_height_target()).abs() < 0.02);
    assert!(e.set_terrain_tile(Some((4, 0))).is_err(), "a row past the grid is refused");
}

#[test]
fn the_curriculum_moves_a_robot_down_when_it_lags_and_up_when_it_walked_far() {
    let mut cfg = on_terrain(6);
    cfg.episode_length_s = 2.0;
    cfg.terrain.curriculum.start_level_max = 3;
    let mut e = env(&cfg, 1);
    let mut obs = vec![0.0; e.obs_dim()];
    e.reset(&mut obs).unwrap();
    e.set_command_override(Some([0.7, 0.0, 0.0]));
    let mut level = e.terrain_level().unwrap();
    // Standing while commanded to walk: down a row per episode, to row 0.
    for _ in 0..4 {
        stand(&mut e, 100);
        e.reset(&mut obs).unwrap();
        let now = e.terrain_level().unwrap();
        assert_eq!(now, level.saturating_sub(1));
        level = now;
    }
    assert_eq!(level, 0);
    assert_eq!(e.curriculum_level(), Some(0.0));
    // Carried 3 m from the start (more than half a 4 m tile) within the episode: up a row.
    stand(&mut e, 10);
    let b = e.indices().base_qpos;
    e.data_mut().qpos_mut()[b] += 3.0;
    let mut o2 = vec![0.0; e.obs_dim()];
    e.refresh(&mut o2).unwrap();
    stand(&mut e, 1);
    e.reset(&mut obs).unwrap();
    assert_eq!(e.terrain_level(), Some(1));
}

#[test]
fn an_env_on_terrain_resumes_bit_for_bit() {
    let mut cfg = on_terrain(4);
    cfg.episode_length_s = 0.5;
    let run = |e: &mut RobotEnv, obs: &mut Vec<f32>, n: usize| -> Vec<f32> {
        let a: Vec<f32> = (0..e.action_dim()).map(|i| 0.3 * (i as f32 - 4.5) / 5.0).collect();
        let mut trace = Vec::new();
        for _ in 0..n {
            if e.step(&a, obs).done {
                e.reset(obs).unwrap();
            }
            trace.extend_from_slice(obs);
            trace.push(e.terrain_level().unwrap() as f32);
        }
        trace
    };
    let mut a = env(&cfg, 2);
    let mut obs = vec![0.0; a.obs_dim()];
    a.reset(&mut obs).unwrap();
    run(&mut a, &mut obs, 40);
    let (mut f, mut u) = (Vec::new(), Vec::new());
    a.save_state(&mut f, &mut u);
    let mut obs_b = obs.clone();
    let expected = run(&mut a, &mut obs, 60);
    let mut b = env(&cfg, 5);
    let mut scratch = vec![0.0; b.obs_dim()];
    b.reset(&mut scratch).unwrap();
    let (nf, nu) = b.load_state(&f, &u).unwrap();
    assert_eq!((nf, nu), (f.len(), u.len()));
    assert_eq!(run(&mut b, &mut obs_b, 60), expected);
}

#[test]
fn the_height_scan_reads_the_ground_around_the_robot_in_its_heading_frame() {
    let mut cfg = on_terrain(4);
    cfg.height_scan.enabled = true;
    let map = Terrain::shared(&cfg.terrain).unwrap();
    let mut e = env(&cfg, 0);
    let (nx, ny) = cfg.height_scan.grid();
    assert_eq!(e.obs_dim(), 42 + nx * ny);
    let col = column(&cfg, TileKind::StairsDown);
    e.set_terrain_tile(Some((3, col))).unwrap();
    let mut obs = vec![0.0; e.obs_dim()];
    e.reset(&mut obs).unwrap();
    // Put the base over the stairs' flank, heading 30° off +x, 0.6 m above the local ground.
    let c = map.tile_center(3, col);
    let (x0, y0, yaw) = (c[0] + 1.1, c[1] - 0.2, 30f64.to_radians());
    let z0 = map.height_at(x0, y0) + 0.6;
    let b = e.indices().base_qpos;
    let q = e.data_mut().qpos_mut();
    q[b..b + 7].copy_from_slice(&[x0, y0, z0, (yaw / 2.0).cos(), 0.0, 0.0, (yaw / 2.0).sin()]);
    e.refresh(&mut obs).unwrap();
    let target = e.base_height_target();
    let mut k = 42;
    let mut spread = (f64::INFINITY, f64::NEG_INFINITY);
    for &x in &cfg.height_scan.x {
        for &y in &cfg.height_scan.y {
            let (px, py) = (x0 + yaw.cos() * x - yaw.sin() * y, y0 + yaw.sin() * x + yaw.cos() * y);
            let want = (z0 - map.height_at(px, py) - target).clamp(-1.0, 1.0);
            assert!((obs[k] as f64 - want).abs() < 1e-5, "point ({x}, {y}): {} vs {want}", obs[k]);
            spread = (spread.0.min(want), spread.1.max(want));
            k += 1;
        }
    }
    assert!(spread.1 - spread.0 > 0.15, "the scan crosses several steps: {spread:?}");
    // The mirror maps swap the scan's left and right points.
    let sym = e.symmetry().unwrap();
    let mirrored: Vec<f32> = (0..obs.len()).map(|i| sym.obs.sign[i] * obs[sym.obs.perm[i]]).collect();
    assert_eq!(mirrored[42], obs[42 + ny - 1]);
    // Flat-trained configs are unchanged: no scan, 42 values.
    assert_eq!(env(&on_terrain(4), 0).obs_dim(), 42);
}

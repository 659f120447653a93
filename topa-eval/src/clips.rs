//! Videos of one experiment's run, rendered from behind the robot: the course at one top speed, and a walk over
//! the hardest terrain tile every run crossed.

use std::path::PathBuf;

use topa_env::policy_runner::PolicyRunner;

use crate::error::{Error, Result};
use crate::play::PlayOptions;
use crate::settings::EvalSettings;
use crate::terrain::TerrainResult;

/// The course at one top speed again, rendered from behind the robot.
pub fn course(
    r: &mut PolicyRunner,
    map: &topa_env::course::Course,
    s: &EvalSettings,
    speed: f64,
    file: &std::path::Path,
    o: &PlayOptions,
) -> Result<PathBuf> {
    let mut rec: Option<crate::video::VideoRecorder> = None;
    let mut watch = |t: f64, env: &mut topa_env::RobotEnv| -> Result<()> {
        if rec.is_none() {
            rec = Some(crate::video::VideoRecorder::create(
                file,
                env,
                o.video_size,
                o.fps,
                o.quality.unwrap_or(mujoco::render::Quality::Fast),
            )?);
        }
        let v = rec.as_mut().unwrap();
        let torso = env.indices().torso_body;
        v.follow(torso, 2.2, env.robot_state().yaw.to_degrees(), -25.0);
        let text = crate::video::overlay(env, t);
        v.advance(t, env, &text)
    };
    crate::course::run(r, map, s, &[speed], Some(&mut watch))?;
    rec.ok_or_else(|| Error::Video("the course run rendered no frame".into()))?.finish()
}

/// The hardest tile every run crossed without a fall (ties: the later type, stairs and obstacles before flat):
/// (type, level).
pub fn hardest_tile(r: &TerrainResult) -> Option<(topa_env::terrain::TileKind, usize)> {
    let types = &r.terrain.types;
    let level = |d: f64| (0..r.terrain.levels).find(|&l| r.terrain.difficulty(l) == d).unwrap_or(0);
    r.success_grid()
        .into_iter()
        .filter(|c| c.2 >= 1.0)
        .map(|(k, d, _)| (k, level(d)))
        .max_by_key(|&(k, l)| (l, types.iter().position(|&t| t == k)))
}

/// One walk over a terrain tile, rendered from behind the robot.
pub fn terrain_tile(
    r: &mut PolicyRunner,
    s: &EvalSettings,
    result: &TerrainResult,
    (kind, level): (topa_env::terrain::TileKind, usize),
    file: &std::path::Path,
    o: &PlayOptions,
) -> Result<PathBuf> {
    use topa_env::Task;
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
        o.quality.unwrap_or(mujoco::render::Quality::Fast),
    )?;
    let dt = cfg.policy_dt();
    let (settle, total) = ((s.settle_s / dt).round() as usize, ((s.settle_s + result.window_s) / dt).round() as usize);
    let mut actions = Vec::new();
    for k in 0..total {
        if k == settle {
            env.set_command_override(Some(crate::terrain::COMMANDS[0].1));
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

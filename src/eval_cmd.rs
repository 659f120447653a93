//! `topa eval <experiment>`: one experiment on one policy (or a run's checkpoints) — run, print (Markdown or
//! JSON), write results to a folder. The settings every evaluation command shares (`Common`) live here too.

use std::path::PathBuf;

use anyhow::Result;

use crate::cli::{Common, EvalCmd, VideoArgs};
use topa_env::policy_runner::PolicyRunner;
use topa_eval::settings::EvalSettings;
use topa_eval::{
    course, course_map, endurance, heatmaps, noise, progress, progress_plot, push, report, terrain, terrain_map,
    tracking,
};

pub(crate) fn print_json<T: serde::Serialize>(v: &T) -> Result<()> {
    println!("{}", serde_json::to_string_pretty(v)?);
    Ok(())
}

pub(crate) fn run_eval(cmd: EvalCmd, c: Common) -> Result<()> {
    let s = c.settings()?;
    std::fs::create_dir_all(&c.out)?;
    let paper = report::paper()?;
    match cmd {
        EvalCmd::Tracking { policy, seconds, starts } => {
            let mut r = PolicyRunner::load(&policy, "policy")?;
            let rows = tracking::run(&mut r, &s, seconds, 2.0_f64.min(seconds / 2.0), starts)?;
            report::write_json(&c.out, "tracking.json", &rows)?;
            report::write_text(&c.out, "tracking.csv", &report::tracking_csv(&rows))?;
            if c.json {
                return print_json(&rows);
            }
            println!("{}", report::tracking_markdown(&[("ours", &rows)], Some(&paper)));
            println!("{}", report::gait_markdown(&[("ours", &rows)]));
        }
        EvalCmd::Push { policy, range, step, window, video, video_force } => {
            if video.video.is_some() {
                anyhow::ensure!(video_force.len() == 2, "--video-force takes F_x,F_y");
                let o = topa_eval::play::PlayOptions {
                    command: [0.0; 3],
                    seconds: window,
                    torso_force: Some([video_force[0], video_force[1]]),
                    ..video.options()?
                };
                let p = topa_eval::play::run(&policy, &o, &s)?;
                let fall = p.fell_at_s.map_or("no fall".into(), |t| format!("fell at {t:.2} s"));
                eprintln!(
                    "video of the ({}, {}) N cell: {} ({fall})",
                    video_force[0],
                    video_force[1],
                    p.video.unwrap().display()
                );
            }
            let mut r = PolicyRunner::load(&policy, "policy")?;
            let grid = push::run(&mut r, &s, range, step, window, [0.0; 3])?;
            report::write_json(&c.out, "push.json", &grid)?;
            report::write_text(&c.out, "push.csv", &report::push_csv(&grid))?;
            heatmaps::push_heatmaps(
                &[("policy".into(), &grid)],
                &c.out.join("push_heatmap.png"),
                &c.out.join("push_heatmap.svg"),
            )?;
            if c.json {
                return print_json(&grid);
            }
            println!("{}", report::push_markdown(&[("ours", &grid)], Some(&paper)));
            println!("heatmap: {}", c.out.join("push_heatmap.png").display());
        }
        EvalCmd::Noise { policy, runs, seconds, interval } => {
            let mut r = PolicyRunner::load(&policy, "policy")?;
            let rows = noise::run(&mut r, &s, runs, seconds, interval)?;
            report::write_json(&c.out, "noise.json", &rows)?;
            report::write_text(&c.out, "noise.csv", &report::noise_csv(&rows))?;
            if c.json {
                return print_json(&rows);
            }
            println!("{}", report::noise_markdown(&[("ours", &rows)], Some(&paper)));
        }
        EvalCmd::Course { policy, course, speeds, video } => {
            let map = topa_env::course::Course::load(&topa_env::assets::resolve_path(&course.to_string_lossy()))
                .map_err(anyhow::Error::msg)?;
            let mut r = PolicyRunner::load(&policy, "policy")?;
            let result = course::run(&mut r, &map, &s, &speeds, None)?;
            report::write_json(&c.out, "course.json", &result)?;
            let png = c.out.join("course_map.png");
            let title = format!("{} on {} ({} sim2sim)", policy.display(), map.name, c.sim2sim);
            course_map::course_map(&map, &result, &title, &png)?;
            if let Some(file) = &video.video {
                let top = speeds.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                let out = course_video(&mut r, &map, &s, top, file, &video)?;
                eprintln!("video of the {top} m/s run: {}", out.display());
            }
            if c.json {
                return print_json(&result);
            }
            println!("{}", course::markdown(&result));
            println!("map: {}", png.display());
        }
        EvalCmd::Terrain { policy, protocol, video } => {
            let mut r = PolicyRunner::load(&policy, "policy")?;
            let result = terrain::run(&mut r, &s, &protocol.protocol())?;
            report::write_json(&c.out, "terrain.json", &result)?;
            report::write_text(&c.out, "terrain.md", &terrain::markdown(&result))?;
            let (png, svg) = (c.out.join("terrain_success.png"), c.out.join("terrain_success.svg"));
            let title = format!("{} ({} sim2sim)", policy.display(), c.sim2sim);
            terrain_map::success_map(&result, &title, &png, &svg)?;
            if let Some(file) = &video.video {
                match hardest_tile(&result) {
                    Some((kind, level)) => {
                        let out = terrain_video(&mut r, &s, &result, (kind, level), file, &video)?;
                        eprintln!(
                            "video of {} at difficulty {:.2}: {}",
                            kind.name(),
                            result.terrain.difficulty(level),
                            out.display()
                        );
                    }
                    None => eprintln!("no video: no tile was crossed by every run without a fall"),
                }
            }
            if c.json {
                return print_json(&result);
            }
            println!("{}", terrain::markdown(&result));
            println!("heatmap: {}", png.display());
        }
        EvalCmd::Progress { runs, every, seconds, starts, push_step } => {
            let p = progress::Protocol { every, seconds, starts, push_step };
            let results = runs.iter().map(|r| progress::run(r, p, &s, &c.out)).collect::<Result<Vec<_>>>()?;
            report::write_json(&c.out, "progress.json", &results)?;
            let protocol = p.describe(&s);
            let md = progress::markdown(&results, &protocol);
            report::write_text(&c.out, "progress.md", &md)?;
            progress_plot::figure(&results, &c.out.join("progress.png"), &c.out.join("progress.svg"))?;
            if c.json {
                return print_json(&results);
            }
            println!("{md}");
        }
        EvalCmd::Endurance { policy, minutes, runs } => {
            let mut r = PolicyRunner::load(&policy, "policy")?;
            let result = endurance::run(&mut r, &s, minutes, runs, &endurance::Operator::default())?;
            report::write_json(&c.out, "endurance.json", &result)?;
            if c.json {
                return print_json(&result);
            }
            println!("{}", endurance::markdown(&result));
        }
    }
    Ok(())
}

/// The course at one top speed again, rendered from behind the robot.
fn course_video(
    r: &mut PolicyRunner,
    map: &topa_env::course::Course,
    s: &EvalSettings,
    speed: f64,
    file: &std::path::Path,
    video: &VideoArgs,
) -> Result<PathBuf> {
    let o = video.options()?;
    let mut rec: Option<topa_eval::video::VideoRecorder> = None;
    let mut watch = |t: f64, env: &mut topa_env::RobotEnv| -> Result<()> {
        if rec.is_none() {
            rec = Some(topa_eval::video::VideoRecorder::create(
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
        let text = topa_eval::video::overlay(env, t);
        v.advance(t, env, &text)
    };
    course::run(r, map, s, &[speed], Some(&mut watch))?;
    rec.ok_or_else(|| anyhow::anyhow!("the course run rendered no frame"))?.finish()
}

/// The hardest tile every run crossed without a fall (ties: the later type, stairs and obstacles before flat):
/// (type, level).
fn hardest_tile(r: &terrain::TerrainResult) -> Option<(topa_env::terrain::TileKind, usize)> {
    let types = &r.terrain.types;
    let level = |d: f64| (0..r.terrain.levels).find(|&l| r.terrain.difficulty(l) == d).unwrap_or(0);
    r.success_grid()
        .into_iter()
        .filter(|c| c.2 >= 1.0)
        .map(|(k, d, _)| (k, level(d)))
        .max_by_key(|&(k, l)| (l, types.iter().position(|&t| t == k)))
}

/// One walk over a terrain tile, rendered from behind the robot.
fn terrain_video(
    r: &mut PolicyRunner,
    s: &EvalSettings,
    result: &terrain::TerrainResult,
    (kind, level): (topa_env::terrain::TileKind, usize),
    file: &std::path::Path,
    video: &VideoArgs,
) -> Result<PathBuf> {
    use topa_env::Task;
    let o = video.options()?;
    let mut cfg = s.env_config(r)?;
    cfg.terrain = result.terrain.clone();
    let (_, model) = topa_env::assets::load_robot(&cfg)?;
    let mut env = topa_env::RobotEnv::new(model, std::sync::Arc::new(cfg.clone()), s.seed, 0)?;
    let column = cfg.terrain.types.iter().position(|&k| k == kind).unwrap_or(0);
    env.set_terrain_tile(Some((level, column)))?;
    let mut obs = vec![0.0; env.obs_dim()];
    env.reset(&mut obs)?;
    env.set_command_override(Some([0.0; 3]));
    let mut rec = topa_eval::video::VideoRecorder::create(
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
            env.set_command_override(Some(terrain::COMMANDS[0].1));
        }
        r.act(&obs, &mut actions);
        let done = env.step(&actions, &mut obs).done;
        let t = (k + 1) as f64 * dt;
        rec.follow(env.indices().torso_body, 2.2, env.robot_state().yaw.to_degrees() + 30.0, -20.0);
        let text = topa_eval::video::overlay(&env, t);
        rec.advance(t, &mut env, &text)?;
        if done {
            break;
        }
    }
    rec.finish()
}

//! `topa eval <experiment>`: one experiment on one policy (or a run's checkpoints) — run, print (Markdown or
//! JSON), write results to a folder. The settings every evaluation command shares (`Common`) live here too.

use anyhow::Result;

use crate::cli::{Common, EvalCmd};
use crate::print::print_json;
use topa_env::policy_runner::PolicyRunner;
use topa_eval::{
    course, course_map, endurance, heatmaps, noise, progress, progress_plot, push, report, select, terrain,
    terrain_map, tracking, velocity,
};

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
            println!("{}", report::tracking_markdown(&[(group_of(&r), &rows)], Some(&paper)));
            println!("{}", report::gait_markdown(&[(group_of(&r), &rows)]));
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
            println!("{}", report::push_markdown(&[(group_of(&r), &grid)], Some(&paper)));
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
            println!("{}", report::noise_markdown(&[(group_of(&r), &rows)], Some(&paper)));
        }
        EvalCmd::Course { policy, course, speeds, video } => {
            let map = topa_env::course::Course::load(&topa_env::assets::resolve_path(&course.to_string_lossy()))
                .map_err(anyhow::Error::msg)?;
            let mut r = PolicyRunner::load(&policy, "policy")?;
            let result = course::run(&mut r, &map, &s, &speeds, None)?;
            report::write_json(&c.out, "course.json", &result)?;
            let png = c.out.join("course_map.png");
            let title = format!("{} on {} ({} sim2sim)", policy.display(), map.name, c.sim.sim2sim);
            course_map::course_map(&map, &result, &title, &png)?;
            if let Some(file) = &video.video {
                let top = speeds.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                let out = topa_eval::clips::course(&mut r, &map, &s, top, file, &video.options()?)?;
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
            let title = format!("{} ({} sim2sim)", policy.display(), c.sim.sim2sim);
            terrain_map::success_map(&result, &title, &png, &svg)?;
            if let Some(file) = &video.video {
                match topa_eval::clips::hardest_tile(&result) {
                    Some((kind, level)) => {
                        let out = topa_eval::clips::terrain_tile(
                            &mut r,
                            &s,
                            &result,
                            (kind, level),
                            file,
                            &video.options()?,
                        )?;
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
        EvalCmd::Progress { runs, every, seconds, starts, step: push_step } => {
            let p = progress::Protocol { every, seconds, starts, push_step };
            let results = runs.iter().map(|r| progress::run(r, p, &s, &c.out)).collect::<Result<Vec<_>, _>>()?;
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
        EvalCmd::Select { runs, from, every, commands, starts, seconds, min_air_time } => {
            let p = select::Protocol { from, every, commands, starts, seconds, min_air_time_s: min_air_time };
            let results = runs.iter().map(|r| select::run(r, p, &s, &c.out)).collect::<Result<Vec<_>, _>>()?;
            report::write_json(&c.out, "select.json", &results)?;
            let md = select::markdown(&results, &p.describe(&s));
            report::write_text(&c.out, "select.md", &md)?;
            if c.json {
                return print_json(&results);
            }
            println!("{md}");
        }
        EvalCmd::Physics { policy, protocol } => {
            let (m, p) = protocol.load()?;
            // Its row is labelled by the model it trained on (O: the serial approximation), as `topa physics` does.
            let open = PolicyRunner::load(&policy, "policy")?.trained_on().contains("open");
            let group = if open { topa_eval::results::Group::O } else { topa_eval::results::Group::C };
            let policies = [(group, policy)];
            let r = topa_eval::physics::report::run(&policies, &s, &m, &p)?;
            return crate::groups_cmd::report_physics(r, protocol.fragility, &c);
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
        EvalCmd::Velocity { policy, tuned_filter, seconds, command_seconds } => {
            let policies = topa_eval::results::policy_files("policy", &policy)?;
            let tuned = match &tuned_filter {
                Some(f) => Some((f, s.clone().with_sim2sim(&topa_eval::settings::Sim2SimMode::File(f.clone()))?)),
                None => None,
            };
            let load = |p: &std::path::PathBuf| Ok(PolicyRunner::load(p, "policy")?);
            let second = tuned.as_ref().map(|(f, t)| (*f, t));
            let result = velocity::run_policies(&policies, load, &s, second, seconds, command_seconds)?;
            report::write_json(&c.out, "velocity.json", &result)?;
            let md = velocity::report_markdown(&result);
            report::write_text(&c.out, "velocity.md", &md)?;
            if c.json {
                return print_json(&result);
            }
            println!("{md}");
        }
    }
    Ok(())
}

/// The row name of a policy's results: its paper group (so the paper's numbers for that group print beside ours),
/// or "ours" for a robot the paper has no numbers for.
fn group_of(r: &PolicyRunner) -> &'static str {
    r.paper_group().unwrap_or("ours")
}

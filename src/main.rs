//! `topa`: the TopA closed-chain biped toolkit — model info, benchmarks, training and sim2sim evaluation. This
//! crate is the command line only (the clap tree and its dispatch); the work lives in the library crates.

mod carriage;
mod cli;
mod eval_cmd;
mod groups_cmd;
mod print;
mod robot_cmd;
mod sysid_cmd;
mod train_cmd;
mod view_cmd;
mod wire_cmd;

use std::process::ExitCode;

use clap::Parser;

use cli::{BenchCmd, Cli, Cmd, ConfigCmd};
use topa_eval::ablate::Extent;
use topa_eval::play;
use topa_tools::{bench, config_reference, info};
use trainer::nn::resolve_threads;

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Cmd::Info { model, json } => {
            if model.extension().is_some_and(|e| e == "toml") {
                Ok(topa_tools::robot_info::run(&model, json)?)
            } else {
                Ok(info::run(&model, json)?)
            }
        }
        Cmd::Train(args) => train_cmd::run(args),
        Cmd::Eval { cmd, common } => {
            trainer::nn::init_threads(resolve_threads(common.threads))?;
            eval_cmd::run_eval(cmd, common)
        }
        Cmd::Ablate { merge, field, terrain, physics, common, .. } if !merge.is_empty() => {
            groups_cmd::merge_ablations(&merge, [field.as_deref(), terrain.as_deref(), physics.as_deref()], common)
        }
        Cmd::Ablate { groups, full, range, step, starts, field, terrain, physics, common, .. } => {
            trainer::nn::init_threads(resolve_threads(common.threads))?;
            let mut extent = if full { Extent::full() } else { Extent::quick() };
            extent.push_range_n = range.unwrap_or(extent.push_range_n);
            extent.push_step_n = step.unwrap_or(extent.push_step_n);
            extent.tracking_starts = starts.unwrap_or(extent.tracking_starts);
            groups_cmd::run_ablate(groups, extent, [field.as_deref(), terrain.as_deref(), physics.as_deref()], common)
        }
        Cmd::Compare { baseline, variant, json, out } => groups_cmd::compare(&baseline, &variant, json, &out),
        Cmd::Physics { merge, protocol, common, .. } if !merge.is_empty() => {
            trainer::nn::init_threads(resolve_threads(common.threads))?;
            let r = topa_eval::physics::report::merge(&merge)?;
            groups_cmd::report_physics(r, protocol.fragility, &common)
        }
        Cmd::Physics { groups, protocol, common, .. } => {
            trainer::nn::init_threads(resolve_threads(common.threads))?;
            let policies = groups.policies()?;
            let (m, p) = protocol.load()?;
            let r = topa_eval::physics::report::run(&policies, &common.settings()?, &m, &p)?;
            groups_cmd::report_physics(r, protocol.fragility, &common)
        }
        Cmd::Terrain { merge, common, .. } if !merge.is_empty() => {
            groups_cmd::report_terrain(&topa_eval::terrain_report::merge(&merge)?, &common)
        }
        Cmd::Terrain { groups, protocol, common, .. } => {
            trainer::nn::init_threads(resolve_threads(common.threads))?;
            let policies = groups.policies()?;
            let p = protocol.protocol();
            let r = topa_eval::terrain_report::run(&policies, &common.settings()?, &p)?;
            groups_cmd::report_terrain(&r, &common)
        }
        Cmd::Robot(cmd) => robot_cmd::run(cmd),
        Cmd::SimRobot(a) => wire_cmd::sim_robot(a),
        Cmd::Control(a) => wire_cmd::control(a),
        Cmd::Sysid(cmd) => sysid_cmd::run(cmd),
        Cmd::Field { merge, common, .. } if !merge.is_empty() => groups_cmd::merge_field(&merge, common),
        Cmd::Field { groups, course, speeds, minutes, modes, common, .. } => {
            trainer::nn::init_threads(resolve_threads(common.threads))?;
            let extent = topa_eval::field::FieldExtent {
                course,
                speeds,
                endurance_minutes: minutes,
                modes: modes.into_iter().map(|m| m.0).collect(),
                operator: Default::default(),
            };
            groups_cmd::run_field(groups, extent, common)
        }
        Cmd::Docs { pages, check } => Ok(topa_eval::doc_blocks::run(&pages, check)?),
        Cmd::Plot { runs, group, out } => {
            if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)?;
            }
            let layout = topa_train::dashboard::plot(&runs, &group, &out)?;
            println!("{} panels → {} (and {})", layout.len(), out.display(), out.with_extension("svg").display());
            Ok(())
        }
        Cmd::Average { run, from, every, out } => {
            if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)?;
            }
            let named = out.extension().is_some_and(|e| e == "json" || e == "safetensors");
            let stem = if named { out.with_extension("") } else { out.clone() };
            let (file, its) = topa_train::policy::average_run(&run, from, every, &stem)?;
            println!("wrote {} (the weight average of iterations {its:?})", file.display());
            Ok(())
        }
        Cmd::Export { policy, onnx, controller, motor_targets, check } => {
            if let Some(dir) = &controller {
                anyhow::ensure!(!check, "--check checks an ONNX file: drop --controller");
                let spec = topa_tools::controller_export::export(&policy, dir)?;
                println!(
                    "wrote {} ({} motors, {} inputs, base velocity {:?})",
                    dir.join("controller.json").display(),
                    spec.n_motors(),
                    spec.observation.inputs,
                    spec.observation.base_velocity
                );
            }
            let Some(onnx) = onnx else { return Ok(()) };
            if check {
                topa_tools::export::check(&onnx, &policy)?;
                println!("{} was exported from {}", onnx.display(), policy.display());
            } else {
                let (obs, n) = topa_tools::export::export(&policy, &onnx, motor_targets)?;
                let targets = if motor_targets { format!(", motor_targets[batch, {n}]") } else { String::new() };
                println!(
                    "wrote {} (opset {}, input obs[batch, {obs}] → action[batch, {n}]{targets})",
                    onnx.display(),
                    topa_tools::export::OPSET,
                );
            }
            Ok(())
        }
        Cmd::Play { policy, command, seconds, record, video, push, json, sim } => {
            trainer::nn::init_threads(1)?;
            anyhow::ensure!(command.len() == 3, "--command takes three numbers v_x,v_y,w_z, got {}", command.len());
            let torso_force = match push.as_deref() {
                None => None,
                Some([fx, fy]) => Some([*fx, *fy]),
                Some(v) => anyhow::bail!("--push takes two numbers F_x,F_y (N), got {}", v.len()),
            };
            let o = play::PlayOptions {
                command: [command[0], command[1], command[2]],
                seconds,
                record,
                torso_force,
                ..video.options()?
            };
            let s = play::run(&policy, &o, &sim.settings()?)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&s)?);
            } else {
                let fall = s.fell_at_s.map_or("no fall".to_string(), |t| format!("FELL at {t:.2} s"));
                println!(
                    "command ({:.2}, {:.2}, {:.2}) for {} s: {fall}; mean (v_x, v_y, w_z) = ({:.2}, {:.2}, {:.2}); distance {:.2} m",
                    s.command[0], s.command[1], s.command[2], s.seconds, s.mean_velocity[0], s.mean_velocity[1], s.mean_velocity[2], s.distance_m
                );
                if let Some(r) = &s.recording {
                    println!("recording: {} (open it in Foxglove)", r.display());
                }
                if let Some(v) = &s.video {
                    println!("video: {} ({} frames)", v.display(), s.video_frames);
                }
            }
            Ok(())
        }
        Cmd::View(a) => view_cmd::run(a),
        Cmd::Config(ConfigCmd::Reference { paper }) => {
            print!("{}", config_reference::reference(&paper)?);
            Ok(())
        }
        Cmd::Config(ConfigCmd::Show { file }) => {
            print!("{}", config_reference::show(&file)?);
            Ok(())
        }
        Cmd::Bench(BenchCmd::Physics { model, steps, rounds, batch, no_testspeed }) => {
            Ok(bench::physics::run(&model, steps, rounds, batch, !no_testspeed)?)
        }
        Cmd::Bench(BenchCmd::Ppo { threads, repeats, torch_python, worker }) => {
            if worker {
                let r = bench::ppo::worker(threads[0], repeats)?;
                println!("{}", serde_json::to_string(&r)?);
                Ok(())
            } else {
                Ok(bench::ppo::run(&threads, repeats, torch_python.as_deref())?)
            }
        }
        Cmd::Bench(BenchCmd::Render { width, height, frames, quality }) => {
            Ok(bench::render::run(width, height, frames, quality.into())?)
        }
        Cmd::Bench(BenchCmd::Mpi { config, ranks, iterations, warmup, rounds, mpirun }) => {
            Ok(bench::mpi::run(&bench::mpi::Args {
                config: &config,
                ranks,
                iterations,
                warmup,
                rounds,
                mpirun: &mpirun,
            })?)
        }
        Cmd::Bench(BenchCmd::Memory { envs, steps, policy, rough: terrain }) => {
            Ok(bench::memory::run(envs, steps, &policy, terrain)?)
        }
        Cmd::Bench(BenchCmd::Train { config, threads, envs, iterations, warmup, integrator, rounds, worker }) => {
            let a =
                bench::train::Args { config: &config, threads: &threads, envs, iterations, warmup, integrator, rounds };
            if worker {
                println!("{}", serde_json::to_string(&bench::train::worker(&a, threads[0])?)?);
                Ok(())
            } else {
                Ok(bench::train::run(&a)?)
            }
        }
        Cmd::Bench(BenchCmd::Env { model, envs, threads, integrator, seconds, rounds, rough: terrain, policy }) => {
            let (kind, policy) = (model, policy.as_deref());
            Ok(bench::env::run(&bench::env::EnvBench {
                kind,
                envs: &envs,
                threads: &threads,
                integrator,
                seconds,
                rounds,
                terrain,
                policy,
            })?)
        }
    }
}

fn main() -> ExitCode {
    // Die quietly when stdout is closed early (`topa info … | head`), like other command-line tools.
    // SAFETY: restoring the default disposition of SIGPIPE at start-up, before any thread exists.
    unsafe { libc::signal(libc::SIGPIPE, libc::SIG_DFL) };
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // The error and its causes on one line; a cause that shows a file excerpt (a TOML error's line and
            // caret) keeps its layout.
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

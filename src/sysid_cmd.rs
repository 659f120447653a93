//! `topa sysid …`: the identification tools on the command line.

use std::sync::Arc;

use crate::cli::SysidCmd;
use anyhow::{Context, Result};

use topa_sysid::bench::Params;
use topa_sysid::excite::{self, CommandKind, Design};
use topa_sysid::fit::FitOptions;
use topa_sysid::identify::{self, Plan};
use topa_sysid::log::MotorLog;
use topa_sysid::synthetic::{self, SensorModel};

pub(crate) fn run(cmd: SysidCmd) -> Result<()> {
    match cmd {
        SysidCmd::Excite { robot, motors, shape, kind, amplitude, band, duration, rate, fade, seed, out } => {
            anyhow::ensure!(band.len() == 2, "--band takes LOW,HIGH in Hz, e.g. 0.5,15");
            let d = Design {
                shape,
                amplitude,
                band: [band[0], band[1]],
                duration_s: duration,
                rate_hz: rate,
                fade_s: fade,
                seed,
            };
            d.check()?;
            let (spec, model) =
                topa_env::spec::RobotSpec::load(&topa_env::assets::resolve_path(&robot.to_string_lossy()))?;
            let spec = Arc::new(spec);
            let idx = topa_env::RobotIndices::resolve(&model, &spec)?;
            let all: Vec<(String, f64)> = spec
                .motors
                .iter()
                .zip(&idx.nominal_actuated)
                .map(|(m, &q)| (m.actuator.clone(), if kind == CommandKind::Position { q } else { 0.0 }))
                .collect();
            let chosen: Vec<(String, f64)> = if motors.is_empty() {
                all
            } else {
                motors
                    .iter()
                    .map(|name| {
                        all.iter().find(|(n, _)| n == name).cloned().with_context(|| {
                            let names: Vec<&str> = all.iter().map(|(n, _)| n.as_str()).collect();
                            format!("--motors: {} has no motor '{name}' (its motors: {})", spec.name, names.join(", "))
                        })
                    })
                    .collect::<Result<_>>()?
            };
            if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)?;
            }
            topa_eval::report::write_text(
                out.parent().unwrap_or(std::path::Path::new(".")),
                &out.file_name().context("--out names a file")?.to_string_lossy(),
                &excite::csv(&d, kind, &chosen),
            )?;
            let png = out.with_file_name(format!(
                "{}_spectrum.png",
                out.file_stem().map_or("excite".into(), |s| s.to_string_lossy().into_owned())
            ));
            topa_sysid::spectrum_plot::plot(&d, &d.signal(0), &png)?;
            let share = excite::energy_in_band(&d.signal(0), rate, d.band);
            println!(
                "{}: {} motors × {} samples ({:?} {:?}, {:.0} % of the energy in {}–{} Hz); spectrum: {}",
                out.display(),
                chosen.len(),
                d.samples(),
                kind,
                shape,
                100.0 * share,
                d.band[0],
                d.band[1],
                png.display()
            );
        }
        SysidCmd::Simulate {
            bench,
            robot,
            excitation,
            hidden_seed,
            hidden_delay,
            counts_per_rev,
            position_noise,
            seed,
            out,
        } => {
            let mut exc = synthetic::read_excitation(&excitation)?;
            let b = topa_sysid::robot::bench_or_hung(&bench, robot.as_deref(), &exc)?.0;
            synthetic::drive_gains_from_model(&b, &mut exc);
            let mut truth = synthetic::hidden(&b.nominal(), hidden_seed);
            if let Some(d) = hidden_delay {
                truth.delay_s = d;
            }
            let sensors = SensorModel { counts_per_rev, position_noise, seed };
            let log = synthetic::record(&b, &exc, &truth, &sensors)?;
            let dir = out.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(std::path::Path::new("."));
            let name = out.file_name().context("--out names a file")?.to_string_lossy().into_owned();
            topa_eval::report::write_text(dir, &name, &log.to_csv())?;
            let stem = out.file_stem().map_or("log".into(), |s| s.to_string_lossy().into_owned());
            topa_eval::report::write_json(dir, &format!("{stem}_truth.json"), &truth)?;
            println!(
                "{}: {} motors × {} samples; hidden values in {}/{stem}_truth.json; sensor noise floor {:.2e} rad",
                out.display(),
                log.motors.len(),
                log.time.len(),
                dir.display(),
                sensors.floor()
            );
        }
        SysidCmd::Estimator { policy, seconds, recording, held_out_recording, seed, out } => {
            let md = topa_sysid::tuning::run(
                &policy,
                seconds,
                recording.as_deref(),
                held_out_recording.as_deref(),
                seed,
                &out,
            )?;
            println!("{md}\nresults: {} (estimator.toml, estimator.md, estimator.json)", out.display());
        }
        SysidCmd::Fit {
            bench,
            robot,
            log,
            held_out_log,
            held_out,
            fit,
            window,
            burn_in,
            max_delay,
            range,
            torque_constant,
            max_evaluations,
            truth,
            out,
        } => {
            let data = MotorLog::read(&log)?;
            let (mut b, mjcf) = topa_sysid::robot::bench_or_hung(&bench, robot.as_deref(), &data)?;
            let closed_loop =
                data.motors.iter().all(|m| matches!(m.command, topa_sysid::log::Command::Position { .. }));
            let window = window.unwrap_or(if closed_loop { 5.0 } else { 0.5 });
            // A hung leg's slowest PD mode takes about a second to forget a window's initial state; a bench load 0.1 s.
            let burn_in = burn_in.unwrap_or(match (closed_loop, robot.is_some()) {
                (true, true) => 1.0,
                (true, false) => 0.1,
                _ => 0.0,
            });
            b.burn_in = (burn_in / data.step()).round() as usize;
            let held = held_out_log.as_deref().map(MotorLog::read).transpose()?;
            if let Some(h) = &held {
                let names = |l: &MotorLog| l.motors.iter().map(|m| m.name.clone()).collect::<Vec<_>>();
                anyhow::ensure!(
                    names(h) == names(&data),
                    "--held-out-log has other motors ({}) than --log ({})",
                    names(h).join(", "),
                    names(&data).join(", ")
                );
            }
            let mut start = b.nominal();
            start.motors.iter_mut().for_each(|m| m.torque_constant = torque_constant);
            let truth: Option<Params> = truth
                .map(|f| -> Result<Params> {
                    let text = std::fs::read_to_string(&f).with_context(|| format!("--truth {}", f.display()))?;
                    let p: Params = serde_json::from_str(&text).with_context(|| {
                        format!("--truth {} is not a *_truth.json of `topa sysid simulate`", f.display())
                    })?;
                    anyhow::ensure!(
                        p.motors.len() == b.motors.len(),
                        "--truth {} has {} motors, the log {}",
                        f.display(),
                        p.motors.len(),
                        b.motors.len()
                    );
                    Ok(p)
                })
                .transpose()?;
            let plan = Plan {
                bench: &b,
                log: &data,
                log_path: &log,
                held_out: held.as_ref(),
                held_out_fraction: if held.is_some() { 0.0 } else { held_out },
                window_s: window,
                options: FitOptions { kinds: fit, window: 0, max_delay, range, max_evaluations },
                start: start.clone(),
                truth,
            };
            let id = identify::identify(&plan)?;
            let (md, xml, sim2sim) = identify::write(&id, &b, &data, held.as_ref(), &start, &mjcf, &out)?;
            println!("{md}");
            if !id.fit.converged {
                eprintln!(
                    "warning: the fit did not converge ({}); its best values are above, with their intervals",
                    id.fit.termination
                );
            }
            println!(
                "results: {} (identified.json, identified.md, fit.png, {}{})",
                out.display(),
                xml.display(),
                sim2sim
            );
        }
    }
    Ok(())
}

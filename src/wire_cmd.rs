//! `topa sim-robot` and `topa control`: each builds its side from the flags and runs it; the loops live in
//! `topa_sim_robot` and `topa_control::remote`.

use std::ops::ControlFlow;
use std::sync::mpsc::TryRecvError;
use std::time::Instant;

use anyhow::{Context, Result};
use topa_control::driver::Driver;
use topa_control::netem::Impairment;
use topa_control::remote::{serve, OperatorLink, RemoteRobot};
use topa_control::Controller;
use topa_eval::course::CourseResult;
use topa_eval::results::{PushGrid, TrackingRow};
use topa_eval::settings::EvalSettings;
use topa_sim_robot::experiments::{Operator, Protocol};
use topa_sim_robot::report::{WireResults, WireRun};
use topa_sim_robot::{SimRobot, SimRobotConfig};

use crate::carriage::{names, Carriage};
use crate::cli::wire::{ControlArgs, SimRobotArgs};

pub(crate) fn sim_robot(a: SimRobotArgs) -> Result<()> {
    let settings = EvalSettings { seed: a.seed, ..Default::default() }.with_sim2sim(&a.sim2sim)?;
    let impairment = Impairment { loss: a.loss, latency_s: a.latency_ms * 1e-3, jitter_s: a.jitter_ms * 1e-3 };
    let watchdog_s = a.watchdog_ms.map(|ms| ms * 1e-3);
    let rc = SimRobotConfig { impairment, watchdog_s, seed: a.seed, frame_hz: a.frame_hz };
    let course = match &a.course {
        Some(path) => Some(
            topa_env::course::Course::load(&topa_env::assets::resolve_path(&path.to_string_lossy()))
                .map_err(anyhow::Error::msg)?,
        ),
        None => None,
    };
    let carriage = Carriage::open(&a.carriage, a.listen, a.peer)?;
    let link = carriage.link(names::SENSORS, Some(names::COMMAND), a.listen, a.peer)?;
    let mut robot = match &course {
        Some(course) => SimRobot::on_course(&a.policy, course, &settings, &rc, link)?,
        None => SimRobot::for_policy(&a.policy, &settings, &rc, link)?,
    };
    let (physics_dt, period_s) = (robot.env().config().timestep, robot.control_period_s());
    eprintln!(
        "simulated robot on {} ({} sim2sim, physics {:.0} Hz, control period {:.0} ms) → controller {}; on its gantry until a soft start",
        a.listen,
        a.sim2sim,
        1.0 / physics_dt,
        period_s * 1e3,
        a.peer
    );
    if let Some(course) = &course {
        let op = Operator::over(carriage.link(names::OPERATOR, None, a.operator_listen, a.operator)?);
        return course_experiment(&a, &settings, &mut robot, course, op);
    }
    if a.tracking || a.push.is_some() {
        let op = Operator::over(carriage.link(names::OPERATOR, None, a.operator_listen, a.operator)?);
        return experiment(&a, &settings, &mut robot, op);
    }
    let t0 = Instant::now();
    let mut last_report = 0.0;
    loop {
        robot.step()?;
        let t = t0.elapsed().as_secs_f64();
        if a.seconds.is_some_and(|s| t >= s) {
            break;
        }
        if t - last_report >= 2.0 {
            last_report = t;
            let s = robot.env().robot_state();
            eprintln!(
                "t {t:5.1} s | {} | v_x {:+.2} v_y {:+.2} w_z {:+.2}{} | {:?}",
                robot.mode().map_or("waiting".to_string(), |m| format!("{m:?}")),
                s.lin_vel[0],
                s.lin_vel[1],
                s.ang_vel[2],
                if robot.env().has_fallen() { " | fallen" } else { "" },
                robot.counters
            );
        }
    }
    Ok(())
}

pub(crate) fn control(a: ControlArgs) -> Result<()> {
    anyhow::ensure!(a.command.len() == 3, "--command takes three values, v_x,v_y,w_z (e.g. 0.5,0,0)");
    let mut c = Controller::load(&a.controller)?;
    let (n, period) = (c.spec().n_motors(), c.spec().control_period_s);
    let carriage = Carriage::open(&a.carriage, a.listen, a.peer)?;
    let mut robot = RemoteRobot::over(carriage.link(names::COMMAND, Some(names::SENSORS), a.listen, a.peer)?, c.spec());
    let mut operator = OperatorLink::over(carriage.link(
        names::OPERATOR_REPLY,
        Some(names::OPERATOR),
        a.operator_listen,
        a.operator,
    )?);
    c.set_command([a.command[0], a.command[1], a.command[2]]);
    if a.start {
        c.start();
    }
    eprintln!(
        "controller on {} ({} motors, {:.0} Hz) ↔ robot {}; operator messages on {} from {}",
        a.listen,
        n,
        1.0 / period,
        a.peer,
        a.operator_listen,
        a.operator
    );
    let keys = if a.keyboard {
        let rx = topa_tools::operator_keys::spawn();
        anyhow::ensure!(rx.is_some(), "--keyboard needs a terminal");
        eprintln!("{}", topa_tools::operator_keys::HELP);
        rx
    } else {
        None
    };
    let pad = if a.gamepad {
        let rx = topa_tools::operator_pad::spawn(c.spec().command_ranges);
        anyhow::ensure!(rx.is_some(), "--gamepad: this system offers no gamepad interface (see the warning above)");
        eprintln!("{}", topa_tools::operator_pad::HELP);
        rx
    } else {
        None
    };
    let mut log = a.record.as_deref().map(topa_tools::control_log::ControlLog::create).transpose()?;
    let t0 = Instant::now();
    let mut last_report = 0.0;
    let mut last_mode = c.mode();
    let mut last_frame = f64::NAN;
    serve(&mut c, &mut robot, Some(&mut operator), |c, r, sent| {
        let mut quit = false;
        if let Some(rx) = &keys {
            loop {
                match rx.try_recv() {
                    Ok(m) => m.apply(c),
                    Err(TryRecvError::Empty) => break,
                    // The key reader ended: Ctrl-C at the terminal.
                    Err(TryRecvError::Disconnected) => {
                        quit = true;
                        break;
                    }
                }
            }
        }
        if let Some(rx) = &pad {
            // The pad's thread runs as long as the process: its queue never closes.
            while let Ok(m) = rx.try_recv() {
                m.apply(c);
            }
        }
        let t = t0.elapsed().as_secs_f64();
        if let Some(log) = &mut log {
            let fresh = r.timestamp_s != last_frame;
            log.record(t, fresh.then_some(r), sent, c.command());
        }
        last_frame = r.timestamp_s;
        if sent.mode != last_mode {
            eprintln!("mode {:?} → {:?}", last_mode, sent.mode);
            last_mode = sent.mode;
        }
        if t - last_report >= 5.0 {
            last_report = t;
            eprintln!("t {t:5.1} s | {:?} | command {:?} | {:?}", sent.mode, c.command(), c.counters);
        }
        if quit || a.seconds.is_some_and(|s| t >= s) {
            c.stop();
            return ControlFlow::Break(());
        }
        ControlFlow::Continue(())
    });
    // The stop's damping command goes out before the process ends.
    let now = robot.now();
    robot.send(c.watchdog(now));
    eprintln!(
        "controller stopped: {:?}; socket: accepted {}, refused {}",
        c.counters,
        robot.link().receiver.accepted,
        robot.link().receiver.refused
    );
    if let Some(log) = log {
        let dropped = log.dropped;
        eprintln!("recorded {} ({dropped} messages dropped)", log.finish()?.display());
    }
    Ok(())
}

/// Reads the in-process result that `--compare` names.
fn in_process<T: serde::de::DeserializeOwned>(path: &Option<std::path::PathBuf>, what: &str) -> Result<Option<T>> {
    let Some(path) = path else { return Ok(None) };
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    Ok(Some(serde_json::from_str(&text).with_context(|| format!("{}: not the {what}", path.display()))?))
}

/// `--tracking` or `--push` through the controller, the page printed and written with its JSON.
fn experiment(a: &SimRobotArgs, settings: &EvalSettings, robot: &mut SimRobot, mut op: Operator) -> Result<()> {
    let p = Protocol { settle_s: settings.settle_s, window_s: a.window, transient_s: 2.0 };
    if let Some(magnitudes) = &a.push {
        anyhow::ensure!(
            magnitudes.iter().all(|m| m.is_finite() && *m > 0.0),
            "--push takes positive force magnitudes in N, e.g. 20,30"
        );
        let grid = in_process::<PushGrid>(&a.compare, "push.json of `topa eval push`")?;
        let forces: Vec<[f64; 2]> =
            magnitudes.iter().flat_map(|&m| [[m, 0.0], [-m, 0.0], [0.0, m], [0.0, -m]]).collect();
        let fell_at = topa_sim_robot::experiments::push(robot, &mut op, &p, &forces)?;
        let results =
            WireResults::Push { forces: &forces, fell_at: &fell_at, window_s: a.window, in_process: grid.as_ref() };
        return finish(a, robot, results);
    }
    let compare = in_process::<Vec<TrackingRow>>(&a.compare, "tracking.json of `topa eval tracking`")?;
    let rows = topa_sim_robot::experiments::run(robot, &mut op, &p)?;
    finish(a, robot, WireResults::Tracking { rows: &rows, in_process: compare.as_deref() })
}

/// `--course` through the controller: one run per top speed, the page printed and written with its JSON.
fn course_experiment(
    a: &SimRobotArgs,
    settings: &EvalSettings,
    robot: &mut SimRobot,
    course: &topa_env::course::Course,
    mut op: Operator,
) -> Result<()> {
    let compare = in_process::<CourseResult>(&a.compare, "course.json of `topa eval course`")?;
    let limit_s = topa_eval::course::time_limit_s(course, &a.speeds);
    let mut runs = Vec::new();
    for &speed in &a.speeds {
        runs.push(topa_sim_robot::experiments::course(robot, &mut op, settings.settle_s, course, speed, limit_s)?);
    }
    finish(a, robot, WireResults::Course { course: &course.name, runs: &runs, in_process: compare.as_ref() })
}

fn finish(a: &SimRobotArgs, robot: &SimRobot, results: WireResults) -> Result<()> {
    let policy = a.policy.display().to_string();
    let run = WireRun {
        policy: &policy,
        sim2sim: a.sim2sim.to_string(),
        carrier: if a.carriage.zenoh { "Zenoh (peers on loopback TCP)" } else { "loopback UDP" },
        loss: a.loss,
        latency_ms: a.latency_ms,
        jitter_ms: a.jitter_ms,
        results,
        counters: &robot.counters,
    };
    let page = topa_sim_robot::report::markdown(&run);
    println!("{page}");
    if let Some(path) = &a.out {
        trainer::tensorfile::write_atomic(path, serde_json::to_string_pretty(&run)?.as_bytes())?;
        trainer::tensorfile::write_atomic(&path.with_extension("md"), page.as_bytes())?;
    }
    Ok(())
}

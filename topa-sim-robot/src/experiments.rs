//! The tracking, push and course experiments through the two processes: the evaluation is the operator. For each run it
//! puts the robot back on its gantry at the stand pose, asks the controller (over its operator socket) to restart
//! from a soft start, waits for the policy to take over, settles on a zero command, then gives the command (or
//! pushes the torso) for the window — measuring what the in-process experiments measure (`topa_eval::tracking`,
//! `topa_eval::push`).

use std::net::SocketAddr;

use topa_control::operator::OperatorMessage;
use topa_control::transport::Link;
use topa_control::{wire, Mode};
use topa_env::course::Course;
use topa_eval::course::{wall_geoms, CourseFollower, CourseRun};
use topa_eval::driver::Driver;
use topa_eval::gait::GaitAccumulator;
use topa_eval::results::{TrackingRow, COMMANDS};
use topa_eval::tracking::{combine, StartResult, TrackingAccumulator};

use crate::error::{Error, Result};
use crate::robot::SimRobot;

/// How long the controller may take to start the policy after a restart, s (its soft start included).
const START_TIMEOUT_S: f64 = 15.0;

/// The experiment's timing, as `topa eval tracking`'s.
#[derive(Debug, Clone, Copy)]
pub struct Protocol {
    /// Zero command after the policy took over, s.
    pub settle_s: f64,
    /// The command's window, s.
    pub window_s: f64,
    /// The start of the window that "ours" skips, s.
    pub transient_s: f64,
}

/// The operator's socket towards the controller.
pub struct Operator {
    link: Link,
    seq: u32,
    buf: Vec<u8>,
    t0: std::time::Instant,
}

impl Operator {
    pub fn bind(local: SocketAddr, controller_operator: SocketAddr) -> Result<Operator> {
        let link = Link::bind(local, controller_operator).map_err(|source| Error::Socket { addr: local, source })?;
        Ok(Operator::over(link))
    }

    /// Operator messages over `link` (UDP or Zenoh).
    pub fn over(link: Link) -> Operator {
        Operator { link, seq: 0, buf: Vec::new(), t0: std::time::Instant::now() }
    }

    pub fn send(&mut self, m: &OperatorMessage) {
        let t = self.t0.elapsed().as_secs_f64();
        let d = wire::encode_operator(m, crate::robot::PEER_ID, self.seq, t, &mut self.buf);
        self.seq = self.seq.wrapping_add(1);
        let _ = self.link.send(d);
    }
}

/// One run: the robot back on its gantry, the controller restarted, the policy settled on a zero command; then
/// `command` (and a constant torso force, N, in the torso's frame) for the window, `observe` called every control
/// period of it with the time into the window and whether the robot has fallen by then. Returns when it first fell.
fn episode(
    robot: &mut SimRobot,
    op: &mut Operator,
    p: &Protocol,
    command: [f64; 3],
    torso_force: [f64; 2],
    mut observe: impl FnMut(&SimRobot, f64, bool),
) -> Result<Option<f64>> {
    let t_policy = restart(robot, op)?;
    let mut fell_at = None;
    let mut started = false;
    loop {
        if !robot.step()? {
            continue;
        }
        let t = robot.env().time() - t_policy;
        if t >= p.settle_s + p.window_s {
            break;
        }
        if t < p.settle_s {
            if robot.env().has_fallen() && fell_at.is_none() {
                fell_at = Some(0.0);
            }
            continue;
        }
        if !started {
            op.send(&OperatorMessage { command, ..Default::default() });
            let env = robot.env_mut();
            let mut push = *env.perturbation();
            push.torso_force_local = [torso_force[0], torso_force[1], 0.0];
            env.set_perturbation_struct(push);
            started = true;
        }
        let tw = t - p.settle_s;
        if fell_at.is_none() && robot.env().has_fallen() {
            fell_at = Some(tw);
        }
        observe(robot, tw, fell_at.is_some());
    }
    let env = robot.env_mut();
    let mut calm = *env.perturbation();
    calm.torso_force_local = [0.0; 3];
    env.set_perturbation_struct(calm);
    Ok(fell_at)
}

/// The six commands, one run each, through the controller on the other side of the wire.
pub fn run(robot: &mut SimRobot, op: &mut Operator, p: &Protocol) -> Result<Vec<TrackingRow>> {
    let dt = robot.control_period_s();
    let mut rows = Vec::new();
    for (key, _, command) in COMMANDS {
        let (mut ours, mut whole, mut gait) =
            (TrackingAccumulator::default(), TrackingAccumulator::default(), GaitAccumulator::default());
        let fell_at = episode(robot, op, p, command, [0.0; 2], |robot, tw, fallen| {
            let env = robot.env();
            whole.add_state(command, env.robot_state());
            if tw > p.transient_s && !fallen {
                ours.add_state(command, env.robot_state());
                gait.add(env, dt);
            }
        })?;
        let start = StartResult { ours: ours.finish(), whole: whole.finish(), gait, fell_at };
        let row = combine(key, command, &[start]);
        log::info!("{key}: MAE {:.3}{}", row.mae, if row.fell { " (fell)" } else { "" });
        rows.push(row);
    }
    Ok(rows)
}

/// Constant torso forces (F_x, F_y), N, one run each on a zero command, through the controller: the time of
/// each run's fall (None: it stood the window), as the in-process push grid measures it.
pub fn push(robot: &mut SimRobot, op: &mut Operator, p: &Protocol, forces: &[[f64; 2]]) -> Result<Vec<Option<f64>>> {
    let mut out = Vec::new();
    for &f in forces {
        let fell = episode(robot, op, p, [0.0; 3], f, |_, _, _| {})?;
        log::info!("push ({}, {}) N: {}", f[0], f[1], fell.map_or("stood".into(), |t| format!("fell at {t:.2} s")));
        out.push(fell);
    }
    Ok(out)
}

/// One run over `course` at `top_speed` through the controller, the operator steering as `topa eval course`'s
/// does (a command each control period over the operator socket). An intervention puts the robot back on its
/// gantry behind its furthest progress and restarts the controller; the clock runs only while the policy walks
/// (after `settle_s` on a zero command), since the in-process course puts the robot back standing at once.
pub fn course(
    robot: &mut SimRobot,
    op: &mut Operator,
    settle_s: f64,
    course: &Course,
    top_speed: f64,
    limit_s: f64,
) -> Result<CourseRun> {
    let driver = Driver::new(top_speed, &robot.env().config().commands)?;
    let walls = wall_geoms(robot.env().data().model());
    let mut follower = CourseFollower::new(driver, robot.env().indices().n_motors);
    let dt = robot.control_period_s();
    let start = course.start();
    robot.set_home(Some([start.xy[0], start.xy[1], start.heading]));
    let mut t = 0.0;
    'put_back: loop {
        let t_policy = restart(robot, op)?;
        while robot.env().time() - t_policy < settle_s {
            robot.step()?;
        }
        loop {
            if !robot.step()? {
                continue;
            }
            let command = follower.command(course, robot.env());
            op.send(&OperatorMessage { command, ..Default::default() });
            t += dt;
            if let Some(back) = follower.observe(course, robot.env(), &walls, t) {
                log::info!("course at {top_speed} m/s: intervention at t = {t:.1} s; put back at {back:?}");
                robot.set_home(Some(back));
                continue 'put_back;
            }
            if t >= limit_s && !follower.done() {
                follower.finish(t, false);
            }
            if follower.done() {
                break 'put_back;
            }
        }
    }
    let run = follower.into_run();
    log::info!(
        "course at {top_speed} m/s: {} in {:.1} s, {} interventions",
        if run.finished { "reached the goal" } else { "did not reach the goal" },
        run.time_s,
        run.interventions()
    );
    Ok(run)
}

/// The robot back on its gantry and the controller restarted (stop, reset, start on a zero command): steps
/// until its policy took over; returns the simulated time at which it did.
fn restart(robot: &mut SimRobot, op: &mut Operator) -> Result<f64> {
    robot.reset()?;
    let restart = OperatorMessage { command: [0.0; 3], stop: true, reset: true, start: true };
    op.send(&restart);
    wait_for_policy(robot, op, &restart)
}

/// Steps the held robot until the controller's soft start lowered it and its policy took over; returns the
/// simulated time at which it did. The restart is sent again each second until the controller answers.
fn wait_for_policy(robot: &mut SimRobot, op: &mut Operator, restart: &OperatorMessage) -> Result<f64> {
    let (mut waited, mut since_send) = (0.0, 0.0);
    let dt = robot.control_period_s() / robot.env().config().decimation as f64;
    while robot.mode() != Some(Mode::Policy) {
        robot.step()?;
        waited += dt;
        since_send += dt;
        if robot.held() && since_send > 1.0 {
            op.send(restart);
            since_send = 0.0;
        }
        if waited > START_TIMEOUT_S {
            return Err(Error::NoController(format!(
                "the controller did not start the policy within {START_TIMEOUT_S} s of a restart: is `topa control` \
                 running, listening for the operator where --operator points, and sending to this robot's --listen?"
            )));
        }
    }
    Ok(robot.env().time())
}

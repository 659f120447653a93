//! The tracking experiment through the two processes: the evaluation is the operator. For each of the six
//! commands it puts the robot back on its gantry at the stand pose, asks the controller (over its operator socket)
//! to restart from a soft start, waits for the policy to take over, settles on a zero command, then gives the
//! command for the window — measuring exactly what the in-process experiment measures (`topa_eval::tracking`).

use std::net::SocketAddr;

use topa_control::operator::OperatorMessage;
use topa_control::transport::Link;
use topa_control::{wire, Mode};
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
        Ok(Operator { link, seq: 0, buf: Vec::new(), t0: std::time::Instant::now() })
    }

    pub fn send(&mut self, m: &OperatorMessage) {
        let t = self.t0.elapsed().as_secs_f64();
        let d = wire::encode_operator(m, crate::robot::PEER_ID, self.seq, t, &mut self.buf);
        self.seq = self.seq.wrapping_add(1);
        let _ = self.link.send(d);
    }
}

/// The six commands, one run each, through the controller on the other side of the wire.
pub fn run(robot: &mut SimRobot, op: &mut Operator, p: &Protocol) -> Result<Vec<TrackingRow>> {
    let dt = robot.control_period_s();
    let mut rows = Vec::new();
    for (key, _, command) in COMMANDS {
        robot.reset()?;
        let restart = OperatorMessage { command: [0.0; 3], stop: true, reset: true, start: true };
        op.send(&restart);
        let t_policy = wait_for_policy(robot, op, &restart)?;
        let (mut ours, mut whole, mut gait) =
            (TrackingAccumulator::default(), TrackingAccumulator::default(), GaitAccumulator::default());
        let mut fell_at = None;
        let mut commanded = false;
        loop {
            if !robot.step()? {
                continue;
            }
            let env = robot.env();
            let t = env.time() - t_policy;
            if t >= p.settle_s + p.window_s {
                break;
            }
            if t < p.settle_s {
                if env.has_fallen() && fell_at.is_none() {
                    fell_at = Some(0.0);
                }
                continue;
            }
            if !commanded {
                op.send(&OperatorMessage { command, ..Default::default() });
                commanded = true;
            }
            let tw = t - p.settle_s;
            if fell_at.is_none() && env.has_fallen() {
                fell_at = Some(tw);
            }
            whole.add_state(command, env.robot_state());
            if tw > p.transient_s && fell_at.is_none() {
                ours.add_state(command, env.robot_state());
                gait.add(env, dt);
            }
        }
        let start = StartResult { ours: ours.finish(), whole: whole.finish(), gait, fell_at };
        let row = combine(key, command, &[start]);
        log::info!("{key}: MAE {:.3}{}", row.mae, if row.fell { " (fell)" } else { "" });
        rows.push(row);
    }
    Ok(rows)
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

//! A robot on the wire (a real one's bridge, or `topa sim-robot`): the [`Driver`] that takes its sensor frames off
//! a link (UDP, or Zenoh) and sends it motor commands, and the controller's loop around it — a tick every control period on
//! its own clock with the newest frame (the watchdog when none came), an operator on its own socket.

use std::net::SocketAddr;
use std::ops::ControlFlow;
use std::time::{Duration, Instant};

use crate::controller::{Controller, MotorCommand};
use crate::driver::{run_period, Driver, Readings};
use crate::operator::OperatorMessage;
use crate::spec::ControllerSpec;
use crate::transport::Link;
use crate::wire;

/// The controller's peer id on the wire.
pub const PEER_ID: u32 = 0x4354_524c; // "CTRL"

/// The robot's socket pair as a driver. Frames are stamped with this side's clock on arrival: the two sides'
/// clocks are not synchronised, and the state machine's timing (soft start, staleness) is this side's.
pub struct RemoteRobot {
    link: Link,
    robot: u32,
    n: usize,
    seq: u32,
    t0: Instant,
    period: Duration,
    buf: Vec<u8>,
    next_tick: Option<Duration>,
    /// Frames that passed the wire check but did not decode (cannot happen for a checked frame; counted anyway).
    pub undecodable: u64,
}

impl RemoteRobot {
    /// Binds `local` and talks to the robot at `robot`, the one `spec` was made for (frames of another robot are
    /// refused); the controller ticks every control period of the spec.
    pub fn bind(local: SocketAddr, robot: SocketAddr, spec: &ControllerSpec) -> std::io::Result<RemoteRobot> {
        Ok(RemoteRobot::over(Link::bind(local, robot)?, spec))
    }

    /// The robot at the other end of `link` (UDP or Zenoh), the one `spec` was made for.
    pub fn over(mut link: Link, spec: &ControllerSpec) -> RemoteRobot {
        let (n_motors, period_s) = (spec.n_motors(), spec.control_period_s);
        let id = wire::robot_id(spec.motors.iter().map(|m| m.name.as_str()));
        link.receiver.robot = Some(id);
        RemoteRobot {
            link,
            robot: id,
            n: n_motors,
            seq: 0,
            t0: Instant::now(),
            period: Duration::from_secs_f64(period_s),
            buf: Vec::with_capacity(wire::size(wire::COMMAND, n_motors)),
            next_tick: None,
            undecodable: 0,
        }
    }

    /// The socket, with its counters (accepted, refused, superseded, strangers).
    pub fn link(&self) -> &Link {
        &self.link
    }
}

impl Driver for RemoteRobot {
    fn now(&self) -> f64 {
        self.t0.elapsed().as_secs_f64()
    }

    /// Sleeps to the next tick of the control clock, then takes the newest frame that came since the last tick
    /// (false when none did). The controller ticks at its own rate, whatever rate the robot sends at.
    fn read(&mut self, r: &mut Readings) -> bool {
        let n = self.n;
        let now = self.t0.elapsed();
        let next = self.next_tick.unwrap_or(now);
        // Fallen behind by more than a period (a stalled process): the clock starts again from now.
        let next = if now > next + self.period { now } else { next };
        if next > now {
            std::thread::sleep(next - now);
        }
        self.next_tick = Some(next + self.period);
        let Ok(Some(d)) = self.link.poll(|d| wire::check(d, wire::SENSORS, n).map(|h| h.0)) else {
            return false;
        };
        if wire::decode_sensors(d, r).is_err() {
            self.undecodable += 1;
            return false;
        }
        r.timestamp_s = self.t0.elapsed().as_secs_f64();
        true
    }

    fn send(&mut self, c: &MotorCommand) {
        let t = self.t0.elapsed().as_secs_f64();
        let d = wire::encode_command(c, PEER_ID, self.robot, self.seq, t, &mut self.buf);
        self.seq = self.seq.wrapping_add(1);
        // A robot not listening (yet) refuses the datagram; the stream goes on.
        let _ = self.link.send(d);
    }
}

/// The operator's socket: messages from one peer, newest first.
pub struct OperatorLink {
    link: Link,
}

impl OperatorLink {
    pub fn bind(local: SocketAddr, operator: SocketAddr) -> std::io::Result<OperatorLink> {
        Ok(OperatorLink { link: Link::bind(local, operator)? })
    }

    /// Operator messages over `link` (UDP or Zenoh).
    pub fn over(link: Link) -> OperatorLink {
        OperatorLink { link }
    }

    /// The newest operator message since the last call, if any.
    pub fn poll(&mut self) -> Option<OperatorMessage> {
        let d = self.link.poll(|d| wire::check(d, wire::OPERATOR, 0).map(|h| h.0)).ok()??;
        wire::decode_operator(d).ok().map(|(_, m)| m)
    }

    pub fn link(&self) -> &Link {
        &self.link
    }
}

/// Runs the controller against the robot until `each` breaks: one tick per control period, then the operator's newest message, then `each` with what the controller saw and sent (to record,
/// display, or read a keyboard).
pub fn serve(
    c: &mut Controller,
    robot: &mut RemoteRobot,
    mut operator: Option<&mut OperatorLink>,
    mut each: impl FnMut(&mut Controller, &Readings, &MotorCommand) -> ControlFlow<()>,
) {
    let mut r = Readings::new(c.spec().n_motors());
    let mut sent = MotorCommand {
        mode: c.mode(),
        target: vec![0.0; r.motor_pos.len()],
        kp: vec![0.0; r.motor_pos.len()],
        kd: vec![0.0; r.motor_pos.len()],
    };
    loop {
        let out = run_period(c, robot, &mut r);
        sent.mode = out.mode;
        sent.target.copy_from_slice(&out.target);
        sent.kp.copy_from_slice(&out.kp);
        sent.kd.copy_from_slice(&out.kd);
        if let Some(m) = operator.as_mut().and_then(|o| o.poll()) {
            m.apply(c);
        }
        if each(c, &r, &sent).is_break() {
            return;
        }
    }
}

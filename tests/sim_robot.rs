//! The controller and the simulated robot as two processes on the wire: the tracking experiment through them,
//! on a clean and on a lossy, jittery network, and the failure drills of either side going silent.

use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use topa_control::driver::Readings;
use topa_control::netem::Impairment;
use topa_control::remote::{serve, RemoteRobot};
use topa_control::{wire, Controller, Fault, Mode};
use topa_eval::settings::{EvalSettings, Sim2SimMode};
use topa_sim_robot::experiments::{Operator, Protocol};
use topa_sim_robot::{SimRobot, SimRobotConfig};

const POLICY: &str = "assets/policies/CA/seed1.json";

/// The real-time tests take turns: two simulations keeping real time beside each other on a small machine would
/// measure the machine, not the robot.
static REAL_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn tempdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("topa-sim-robot-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A loopback address with a port free at the moment.
fn free_addr() -> SocketAddr {
    UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap()
}

struct Ports {
    robot: SocketAddr,
    controller: SocketAddr,
    operator_in: SocketAddr,
    operator: SocketAddr,
}

impl Ports {
    fn new() -> Ports {
        Ports { robot: free_addr(), controller: free_addr(), operator_in: free_addr(), operator: free_addr() }
    }
}

/// `topa control` in its own process.
fn spawn_control(dir: &Path, p: &Ports, start: bool) -> Child {
    spawn_control_over(dir, p, start, None)
}

/// `topa control` in its own process, over Zenoh under `zenoh_prefix` where one is given.
fn spawn_control_over(dir: &Path, p: &Ports, start: bool, zenoh_prefix: Option<&str>) -> Child {
    let a = |s: SocketAddr| s.to_string();
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_topa"));
    cmd.args(["control", "--controller"]).arg(dir);
    if let Some(prefix) = zenoh_prefix {
        cmd.args(["--zenoh", "--zenoh-prefix", prefix]);
    }
    cmd.args(["--listen", &a(p.controller), "--peer", &a(p.robot)]);
    cmd.args(["--operator-listen", &a(p.operator_in), "--operator", &a(p.operator), "--seconds", "300"]);
    if start {
        cmd.arg("--start");
    }
    cmd.stdout(Stdio::null()).stderr(Stdio::null()).spawn().expect("topa control starts")
}

fn robot(p: &Ports, impairment: Impairment) -> SimRobot {
    let link = topa_control::transport::Link::bind(p.robot, p.controller).unwrap();
    robot_over(impairment, link)
}

fn robot_over(impairment: Impairment, link: topa_control::transport::Link) -> SimRobot {
    let settings = EvalSettings::default().with_sim2sim(&Sim2SimMode::Realistic).unwrap();
    let cfg = SimRobotConfig { impairment, watchdog_s: None, seed: 3, frame_hz: None };
    SimRobot::for_policy(Path::new(POLICY), &settings, &cfg, link).unwrap()
}

fn export(tag: &str) -> PathBuf {
    let dir = tempdir(tag);
    topa_tools::controller_export::export(Path::new(POLICY), &dir).unwrap();
    dir
}

/// The six commands through the two processes; returns the worst MAE and whether any run fell — or None when a
/// run fell while the machine stalled the simulation (reported: that measures the machine, not the network).
fn tracking(tag: &str, impairment: Impairment) -> Option<(f64, bool, topa_sim_robot::robot::Counters)> {
    let p = Ports::new();
    let r = robot(&p, impairment);
    let op = Operator::bind(p.operator, p.operator_in).unwrap();
    tracking_with(tag, &p, r, op, None)
}

/// As `tracking`, with the robot and operator given (their links made), the controller over Zenoh where a prefix
/// is given.
fn tracking_with(
    tag: &str,
    p: &Ports,
    mut r: SimRobot,
    mut op: Operator,
    zenoh_prefix: Option<&str>,
) -> Option<(f64, bool, topa_sim_robot::robot::Counters)> {
    let dir = export(tag);
    let mut child = spawn_control_over(&dir, p, false, zenoh_prefix);
    let protocol = Protocol { settle_s: 1.0, window_s: 4.0, transient_s: 2.0 };
    let rows = topa_sim_robot::experiments::run(&mut r, &mut op, &protocol);
    child.kill().ok();
    child.wait().ok();
    std::fs::remove_dir_all(dir).ok();
    let rows = rows.unwrap();
    assert_eq!(rows.len(), 6);
    let worst = rows.iter().map(|r| r.mae).fold(0.0, f64::max);
    let (fell, c) = (rows.iter().any(|r| r.fell), r.counters.clone());
    if fell && stalled(&c) {
        eprintln!(
            "skipped: this machine stalled the simulation {:.0} ms (the controller rightly damped)",
            c.max_lag_s * 1e3
        );
        return None;
    }
    Some((worst, fell, c))
}

/// Whether the simulation fell behind real time by the controller's staleness (two 20 ms periods): then no frame
/// went out for that long, and a fall measures the machine's load, not the network.
fn stalled(c: &topa_sim_robot::robot::Counters) -> bool {
    c.max_lag_s >= 0.04
}

#[test]
fn through_two_processes_the_robot_walks_the_six_commands_and_survives_a_lossy_network() {
    let _turn = REAL_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let Some((worst, fell, c)) = tracking("clean", Impairment::default()) else { return };
    assert!(!fell, "a run fell on a clean network: {c:?}");
    assert!(worst < 0.15, "worst MAE {worst} through the wire (in process the policy tracks within 0.11)");
    assert_eq!((c.lost_to_controller, c.lost_from_controller, c.commands_refused), (0, 0, 0));
    assert!(c.frames_sent > 6 * 5 * 1000, "a frame every physics step: {c:?}");

    let lossy = Impairment { loss: 0.05, latency_s: 0.0, jitter_s: 0.002 };
    let Some((worst, fell, c)) = tracking("lossy", lossy) else { return };
    assert!(!fell, "a run fell with 5 % loss and 2 ms jitter: {c:?}");
    assert!(worst < 0.2, "worst MAE {worst} on the lossy network");
    let sent = c.frames_sent as f64;
    assert!((c.lost_to_controller as f64 / sent - 0.05).abs() < 0.02, "the network lost what was asked: {c:?}");
    assert!(c.lost_from_controller > 0, "commands are lost too: {c:?}");
}

/// The same through Zenoh (a build with `--features zenoh`): the wire's datagrams as samples between two peers.
#[cfg(feature = "zenoh")]
#[test]
fn over_zenoh_the_robot_walks_the_six_commands() {
    use topa_control::transport::Link;
    use topa_control::zenoh_carrier::ZenohSession;
    let _turn = REAL_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let p = Ports::new();
    let prefix = format!("topa-test-{}", std::process::id());
    let session = ZenohSession::open(&[format!("tcp/{}", p.robot)], &[format!("tcp/{}", p.controller)]).unwrap();
    let key = |k: &str| format!("{prefix}/{k}");
    let link = Link::zenoh(session.carrier(key("sensors"), Some(key("command"))).unwrap());
    let r = robot_over(Impairment::default(), link);
    let op = Operator::over(Link::zenoh(session.carrier(key("operator"), None).unwrap()));
    let Some((worst, fell, c)) = tracking_with("zenoh", &p, r, op, Some(&prefix)) else { return };
    assert!(!fell, "a run fell over Zenoh: {c:?}");
    assert!(worst < 0.15, "worst MAE {worst} over Zenoh");
    assert_eq!(c.commands_refused, 0);
}

/// The controller killed: the simulated robot's drives damp on their own watchdog (five control periods) and
/// count it.
#[test]
fn a_killed_controller_leaves_the_drives_damping_within_the_watchdog() {
    let _turn = REAL_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = export("killed");
    let p = Ports::new();
    let mut r = robot(&p, Impairment::default());
    let mut child = spawn_control(&dir, &p, true);
    let started = Instant::now();
    while r.mode() != Some(Mode::Policy) {
        r.step().unwrap();
        assert!(started.elapsed() < Duration::from_secs(20), "the controller never took the robot");
    }
    for _ in 0..200 {
        r.step().unwrap();
    }
    assert_eq!(r.counters.watchdog_trips, 0, "no trip while the controller runs");
    child.kill().unwrap();
    child.wait().ok();
    let killed = r.env().time();
    while !r.watchdog_tripped() {
        r.step().unwrap();
        assert!(r.env().time() - killed < 1.0, "the drives never noticed the silence");
    }
    let after = r.env().time() - killed;
    let period = r.control_period_s();
    assert!(after <= 5.0 * period + 0.005, "damping {after} s after the last command (watchdog 5 periods)");
    assert_eq!(r.mode(), Some(Mode::Damping(Fault::Stale)));
    assert_eq!(r.counters.watchdog_trips, 1);
    std::fs::remove_dir_all(dir).ok();
}

/// The robot gone silent: the controller over UDP damps within three control periods of its last frame.
#[test]
fn a_silent_robot_is_damped_by_the_controller_within_three_periods() {
    let _turn = REAL_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = export("silent");
    let mut c = Controller::load(&dir).unwrap();
    let n = c.spec().n_motors();
    let period = c.spec().control_period_s;
    let (robot_addr, ctl_addr) = (free_addr(), free_addr());
    let mut driver = RemoteRobot::bind(ctl_addr, robot_addr, c.spec()).unwrap();
    let robot_id = wire::robot_id(c.spec().motors.iter().map(|m| m.name.as_str()));
    let sender = UdpSocket::bind(robot_addr).unwrap();
    // The robot sends 50 frames at the control rate from another thread, then stops.
    let feeder = std::thread::spawn(move || {
        let mut r = Readings::new(n);
        let mut buf = Vec::new();
        let mut last = Instant::now();
        for seq in 0..50u32 {
            std::thread::sleep(Duration::from_secs_f64(period));
            r.timestamp_s = seq as f64 * period;
            sender.send_to(wire::encode_sensors(&r, 9, robot_id, seq, &mut buf), ctl_addr).unwrap();
            last = Instant::now();
        }
        last
    });
    let mut damped_at = None;
    let t0 = Instant::now();
    serve(&mut c, &mut driver, None, |_, _, sent| {
        if let Mode::Damping(f) = sent.mode {
            damped_at = Some((Instant::now(), f));
            return std::ops::ControlFlow::Break(());
        }
        assert!(t0.elapsed() < Duration::from_secs(10), "never damped");
        std::ops::ControlFlow::Continue(())
    });
    let last_frame = feeder.join().unwrap();
    let (at, fault) = damped_at.unwrap();
    assert_eq!(fault, Fault::Stale);
    let late = at.duration_since(last_frame).as_secs_f64();
    assert!(late <= 3.0 * period + 0.005, "damping {late} s after the last frame (3 periods = {} s)", 3.0 * period);
    assert!(late >= 2.0 * period, "damping {late} s after the last frame: before two periods of silence");
    assert!(c.counters.ticks >= 40, "the frames before drove the controller: {:?}", c.counters);
    std::fs::remove_dir_all(dir).ok();
}

/// A controller file for another robot with as many motors (Cassie's, against TopA): each side refuses the other's
/// datagrams by the robot id and counts them; the robot stays on its gantry.
#[test]
fn a_controller_for_another_robot_is_refused_on_the_wire() {
    let _turn = REAL_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempdir("other-robot");
    topa_tools::controller_export::export(Path::new("assets/policies/cassie/seed1.json"), &dir).unwrap();
    let p = Ports::new();
    let mut r = robot(&p, Impairment::default());
    let mut child = spawn_control(&dir, &p, true);
    let started = Instant::now();
    while started.elapsed() < Duration::from_secs(3) {
        r.step().unwrap();
    }
    child.kill().ok();
    child.wait().ok();
    assert!(r.counters.commands_refused > 10, "Cassie's commands were refused: {:?}", r.counters);
    assert_eq!(r.counters.commands_applied, 0);
    assert!(r.held(), "the robot never left its gantry");
    std::fs::remove_dir_all(dir).ok();
}

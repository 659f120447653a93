//! One simulated robot on the wire. Every physics step, in real time: the newest motor command is taken off the
//! socket (through the impaired network, if one is set), the drives' PD acts with its targets and gains, and the
//! robot's readings go out as a sensor frame (or at `frame_hz`). Before a controller takes it, the robot hangs on
//! its gantry (the simulation holds still while frames keep flowing); the first soft-start command lowers it.
//! Without a fresh command for `watchdog_s` the drives damp on their own and the event is logged, as real drives do
//! when their master falls silent.

use std::net::SocketAddr;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use topa_control::driver::Readings;
use topa_control::netem::{Impairment, Netem};
use topa_control::transport::Link;
use topa_control::{wire, Mode, MotorCommand};
use topa_env::course::Course;
use topa_env::policy_runner::PolicyRunner;
use topa_env::task::Task;
use topa_env::vec_env::BatchEnv;
use topa_env::RobotEnv;
use topa_eval::settings::EvalSettings;

use crate::error::{Error, Result};

/// This side's peer id on the wire.
pub const PEER_ID: u32 = 0x5349_4d52; // "SIMR"

/// The robot's drives, frames and the network between it and the controller (its link is made by the caller).
#[derive(Debug, Clone)]
pub struct SimRobotConfig {
    /// Loss, latency and jitter on both directions.
    pub impairment: Impairment,
    /// The drives damp when no valid command came for this long, s (None: five control periods — a lossy link
    /// loses two or three commands in a row now and then, a dead controller sends none).
    pub watchdog_s: Option<f64>,
    /// Seed of the network's draws.
    pub seed: u64,
    /// Sensor frames per second (None: one per physics step, as drives report at their bus rate).
    pub frame_hz: Option<f64>,
}

/// What the robot counted: the wire, the watchdog, and how well it kept real time.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct Counters {
    pub frames_sent: u64,
    pub commands_applied: u64,
    /// Commands refused by the wire check (size, checksum, peer, an older sequence number).
    pub commands_refused: u64,
    /// Commands that arrived after a newer one (reordered by jitter) and were not applied.
    pub commands_late: u64,
    /// Datagrams the impaired network dropped, towards the controller and from it.
    pub lost_to_controller: u64,
    pub lost_from_controller: u64,
    pub watchdog_trips: u64,
    /// Physics steps that started more than one step late, and the worst lag, s.
    pub overruns: u64,
    pub max_lag_s: f64,
}

/// The drives' current setpoints.
struct Drives {
    target: Vec<f64>,
    kp: Vec<f64>,
    kd: Vec<f64>,
    /// The mode of the last command applied (None since the last reset).
    mode: Option<Mode>,
    applied_seq: Option<u32>,
}

pub struct SimRobot {
    batch: BatchEnv<RobotEnv>,
    obs: Vec<f32>,
    link: Link,
    up: Netem,
    down: Netem,
    drives: Drives,
    /// The drives' own damping (the MJCF's), N·m·s/rad: what the watchdog applies.
    damping_kd: Vec<f64>,
    held: bool,
    /// Where a reset puts the robot (x, y, yaw; None: the env's own start).
    home: Option<[f64; 3]>,
    watchdog_s: f64,
    last_command_wall: Option<f64>,
    silent: bool,
    readings: Readings,
    decoded: MotorCommand,
    buf: Vec<u8>,
    seq: u32,
    t0: Instant,
    steps: u64,
    dt: f64,
    decimation: u64,
    frame_every: u64,
    robot_id: u32,
    pub counters: Counters,
}

impl SimRobot {
    /// A robot from a one-env batch (its config says the physics and the realistic models), on its gantry, talking
    /// over `link` (a UDP socket towards the controller, or a Zenoh link).
    pub fn new(batch: BatchEnv<RobotEnv>, cfg: &SimRobotConfig, mut link: Link) -> Result<SimRobot> {
        cfg.impairment.validate()?;
        let env = &batch.tasks()[0];
        // Commands from a controller made for another robot are refused (and counted).
        let robot_id = wire::robot_id(env.indices().spec.motors.iter().map(|m| m.actuator.as_str()));
        link.receiver.robot = Some(robot_id);
        let n = env.indices().n_motors;
        let m = env.data().model();
        let damping_kd = env.indices().actuators.iter().map(|&a| -m.actuator_biasprm()[a][2]).collect();
        let (dt, decimation) = (env.config().timestep, env.config().decimation as u64);
        let obs = vec![0.0; env.obs_dim()];
        let mut robot = SimRobot {
            batch,
            obs,
            link,
            up: Netem::new(cfg.impairment, cfg.seed),
            down: Netem::new(cfg.impairment, cfg.seed.wrapping_add(1)),
            drives: Drives { target: vec![0.0; n], kp: vec![0.0; n], kd: vec![0.0; n], mode: None, applied_seq: None },
            damping_kd,
            held: true,
            home: None,
            watchdog_s: cfg.watchdog_s.unwrap_or(5.0 * dt * decimation as f64),
            last_command_wall: None,
            silent: false,
            readings: Readings::new(n),
            decoded: MotorCommand { mode: Mode::Passive, target: vec![0.0; n], kp: vec![0.0; n], kd: vec![0.0; n] },
            buf: Vec::new(),
            seq: 0,
            t0: Instant::now(),
            steps: 0,
            dt,
            decimation,
            robot_id,
            frame_every: cfg.frame_hz.map_or(1, |hz| ((1.0 / (hz * dt)).round() as u64).max(1)),
            counters: Counters::default(),
        };
        robot.reset()?;
        Ok(robot)
    }

    /// The robot the policy `policy` was trained for, with its physics, in `settings`' sim2sim mode.
    pub fn for_policy(policy: &Path, settings: &EvalSettings, cfg: &SimRobotConfig, link: Link) -> Result<SimRobot> {
        let runner = PolicyRunner::load(policy, "robot")?;
        let env = settings.env_config(&runner)?;
        SimRobot::new(topa_env::vec_env::robot_batch(&env, 1, settings.seed, 1)?, cfg, link)
    }

    /// The robot on `course`'s floors and walls at its start (falls are the course's interventions, so episodes
    /// do not end on them), for the policy `policy`, in `settings`' sim2sim mode.
    pub fn on_course(
        policy: &Path,
        course: &Course,
        settings: &EvalSettings,
        cfg: &SimRobotConfig,
        link: Link,
    ) -> Result<SimRobot> {
        let runner = PolicyRunner::load(policy, "robot")?;
        let mut env = settings.env_config(&runner)?;
        env.termination.enabled = false;
        let (model, friction) = course.compile(runner.robot())?;
        let mut batch = topa_env::vec_env::robot_batch_on(model, &env, 1, settings.seed, 1)?;
        batch.tasks_mut()[0].set_ground_friction(Some(Arc::new(friction)));
        let mut robot = SimRobot::new(batch, cfg, link)?;
        let start = course.start();
        robot.set_home(Some([start.xy[0], start.xy[1], start.heading]));
        robot.reset()?;
        Ok(robot)
    }

    /// Where the next reset puts the robot: (x, y, yaw) on the ground, or None for the env's own start.
    pub fn set_home(&mut self, pose: Option<[f64; 3]>) {
        self.home = pose;
    }

    pub fn local_addr(&self) -> std::io::Result<SocketAddr> {
        self.link.local_addr()
    }

    pub fn env(&self) -> &RobotEnv {
        &self.batch.tasks()[0]
    }

    pub fn env_mut(&mut self) -> &mut RobotEnv {
        &mut self.batch.tasks_mut()[0]
    }

    /// The mode of the last command the drives applied (None since the last reset).
    pub fn mode(&self) -> Option<Mode> {
        self.drives.mode
    }

    /// Whether the robot hangs on its gantry (no controller has started it since the last reset).
    pub fn held(&self) -> bool {
        self.held
    }

    pub fn control_period_s(&self) -> f64 {
        self.dt * self.decimation as f64
    }

    /// The robot back on its gantry at the stand pose (at its home, if one is set), drives passive.
    pub fn reset(&mut self) -> Result<()> {
        let Self { batch, obs, home, .. } = self;
        match *home {
            Some(pose) => batch.tasks_mut()[0].reset_at(obs, pose)?,
            None => batch.tasks_mut()[0].reset(obs)?,
        }
        self.held = true;
        self.drives.mode = None;
        self.drives.kp.iter_mut().for_each(|k| *k = 0.0);
        self.drives.kd.iter_mut().for_each(|k| *k = 0.0);
        Ok(())
    }

    fn wall(&self) -> f64 {
        self.t0.elapsed().as_secs_f64()
    }

    /// One physics step in real time (or, on the gantry, one step of waiting). Returns whether a control period
    /// began with it (on the simulation's clock: the experiments measure once a period).
    pub fn step(&mut self) -> Result<bool> {
        let due = self.steps as f64 * self.dt;
        let now = self.wall();
        if due > now {
            std::thread::sleep(Duration::from_secs_f64(due - now));
        } else {
            let lag = now - due;
            self.counters.max_lag_s = self.counters.max_lag_s.max(lag);
            self.counters.overruns += u64::from(lag > self.dt);
        }
        let now = self.wall().max(due);
        let period = self.steps.is_multiple_of(self.decimation);
        if self.steps.is_multiple_of(self.frame_every) {
            self.send_frame(now);
        }
        self.deliver_frames(now);
        self.steps += 1;
        self.receive(now);
        self.watchdog(now);
        if !self.held {
            let d = &self.drives;
            let env = &mut self.batch.tasks_mut()[0];
            if !env.step_drives(&d.target, &d.kp, &d.kd) {
                return Err(Error::Diverged(env.time()));
            }
        }
        Ok(period)
    }

    fn send_frame(&mut self, now: f64) {
        let env = &self.batch.tasks()[0];
        let s = env.readings();
        let r = &mut self.readings;
        r.timestamp_s = env.time();
        r.orientation = s.orientation;
        r.gyro = s.gyro;
        r.base_velocity = Some(s.lin_vel);
        r.motor_pos.copy_from_slice(s.motor_pos);
        r.motor_vel.copy_from_slice(s.motor_vel);
        let d = wire::encode_sensors(r, PEER_ID, self.robot_id, self.seq, &mut self.buf);
        self.seq = self.seq.wrapping_add(1);
        self.up.push(now, d);
        self.counters.frames_sent += 1;
    }

    /// Frames whose time through the network has come go out.
    fn deliver_frames(&mut self, now: f64) {
        let Self { up, link, .. } = self;
        up.deliver(now, |d| {
            // A controller not yet listening refuses the datagram: the frame is simply lost, as on a real bus.
            let _ = link.send(d);
        });
        self.counters.lost_to_controller = self.up.lost;
    }

    fn receive(&mut self, now: f64) {
        let n = self.drives.target.len();
        let refused_before = self.link.receiver.refused;
        if let Ok(Some(d)) = self.link.poll(|d| wire::check(d, wire::COMMAND, n).map(|h| h.0)) {
            self.down.push(now, d);
        }
        self.counters.commands_refused += self.link.receiver.refused - refused_before;
        let Self { down, decoded, drives, counters, held, last_command_wall, silent, .. } = self;
        down.deliver(now, |d| {
            let Ok(h) = wire::decode_command(d, decoded) else { return };
            if drives.applied_seq.is_some_and(|s| h.seq <= s) {
                counters.commands_late += 1;
                return;
            }
            if *held && decoded.mode != Mode::SoftStart {
                return; // on the gantry only a start lowers the robot
            }
            *held = false;
            drives.applied_seq = Some(h.seq);
            drives.mode = Some(decoded.mode);
            drives.target.copy_from_slice(&decoded.target);
            drives.kp.copy_from_slice(&decoded.kp);
            drives.kd.copy_from_slice(&decoded.kd);
            counters.commands_applied += 1;
            *last_command_wall = Some(now);
            if *silent {
                log::info!("simulated robot: the controller is back; drives follow its commands again");
                *silent = false;
            }
        });
        self.counters.lost_from_controller = self.down.lost;
    }

    /// The drives' own watchdog: damping at the current pose when the controller fell silent.
    fn watchdog(&mut self, now: f64) {
        let Some(t) = self.last_command_wall else { return };
        if self.held || self.silent || now - t <= self.watchdog_s {
            return;
        }
        self.silent = true;
        self.counters.watchdog_trips += 1;
        log::warn!(
            "simulated robot: no command for {:.0} ms — drives damping (watchdog trip #{})",
            (now - t) * 1e3,
            self.counters.watchdog_trips
        );
        let pos = &self.batch.tasks()[0].robot_state().motor_pos;
        let d = &mut self.drives;
        d.target.copy_from_slice(pos);
        d.kp.iter_mut().for_each(|k| *k = 0.0);
        d.kd.copy_from_slice(&self.damping_kd);
        d.mode = Some(Mode::Damping(topa_control::Fault::Stale));
    }

    /// Whether the drives are damping on their own watchdog.
    pub fn watchdog_tripped(&self) -> bool {
        self.silent
    }
}

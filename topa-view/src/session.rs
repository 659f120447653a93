//! The simulation behind the window: one policy on its robot under the evaluation settings, stepped on demand,
//! with the keys' command, shoves and the mouse's wrench applied, and a fall answered by a reset (counted).

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use topa_env::course::Course;
use topa_eval::course::CourseFollower;
use topa_eval::driver::Driver;

use topa_env::policy_runner::PolicyRunner;
use topa_env::terrain::TileKind;
use topa_env::{assets, RobotEnv, Task};
use topa_eval::settings::EvalSettings;
use topa_eval::terrain;

use crate::controls::{Action, Controls};
use crate::error::{Error, Result};

/// A shove's force, N: the push experiment's grid edge (`topa eval push` default range).
pub const SHOVE_N: f64 = 30.0;
/// How long a shove lasts, s.
pub const SHOVE_S: f64 = 1.0;
/// How long a fallen robot lies before it is put back, simulated s.
const LIE_S: f64 = 1.0;
/// Time constant of the measured velocity shown (the policy's gait oscillates within a step), s.
const SHOWN_VELOCITY_TAU_S: f64 = 0.5;

/// Where the robot walks.
#[derive(Debug, Clone, PartialEq)]
pub enum Ground {
    Flat,
    /// A tile of the terrain evaluation's (`topa eval terrain`): its kind and level (0 the easiest of
    /// `TERRAIN_LEVELS`).
    Tile(TileKind, usize),
    /// A course (`topa eval course`), the course's operator driving at this top speed (m/s) until a key takes
    /// over.
    Course(PathBuf, f64),
}

/// A course under way: the map, its operator, and whether the operator drives.
struct CourseDrive {
    course: Course,
    follower: CourseFollower,
    walls: HashSet<usize>,
    autopilot: bool,
}

/// Difficulty levels of the terrain tiles, as `topa eval terrain` makes them by default.
pub const TERRAIN_LEVELS: usize = 5;

/// Why the robot was last put back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum State {
    Walking,
    /// Fell at this simulated time; lying until the reset.
    Fallen(f64),
}

pub struct Session {
    env: RobotEnv,
    runner: PolicyRunner,
    obs: Vec<f32>,
    actions: Vec<f32>,
    pub controls: Controls,
    /// Simulated time since the last reset, s.
    t: f64,
    state: State,
    pub falls: usize,
    /// Resets by key (the user's interventions).
    pub resets: usize,
    /// Torso-frame force of the shove under way and when it ends.
    shove: Option<([f64; 2], f64)>,
    /// The measured (v_x, v_y, w_z), torso frame, low-pass filtered for display.
    shown_velocity: [f64; 3],
    course: Option<CourseDrive>,
    /// The policy's own estimate of (v_x, v_y), torso frame, for a policy with a learned estimator.
    learned: Option<[f64; 2]>,
    /// Puts the course's operator back on the course after a key took over (the course follower's `G`).
    interventions: usize,
}

impl Session {
    /// `policy` on its robot on `ground`, evaluation settings `settings`, starting with `command`.
    pub fn new(policy: &Path, settings: &EvalSettings, ground: &Ground, command: [f64; 3]) -> Result<Session> {
        let runner = PolicyRunner::load(policy, "policy")?;
        let mut cfg = settings.env_config(&runner)?;
        // The viewer decides when a fallen robot is put back; it walks as long as the user watches.
        cfg.episode_length_s = 1.0e9;
        let mut course = None;
        let model = match ground {
            Ground::Flat => assets::load_robot(&cfg)?.1,
            Ground::Tile(kind, level) => {
                if *level >= TERRAIN_LEVELS {
                    return Err(Error::Level { level: level + 1, levels: TERRAIN_LEVELS });
                }
                let p = terrain::Protocol { levels: TERRAIN_LEVELS, types: vec![*kind], ..Default::default() };
                cfg.terrain = terrain::evaluation_terrain(runner.training_config(), &p);
                assets::load_robot(&cfg)?.1
            }
            Ground::Course(file, speed) => {
                let map = Course::load(&assets::resolve_path(&file.to_string_lossy()))?;
                let (model, friction) = map.compile(runner.robot())?;
                // The course's operator judges falls (as `topa eval course` does).
                cfg.termination.enabled = false;
                let follower = CourseFollower::new(Driver::new(*speed, &cfg.commands)?, runner.robot().n_motors());
                let walls = topa_eval::course::wall_geoms(&model);
                course = Some((CourseDrive { course: map, follower, walls, autopilot: true }, friction));
                model
            }
        };
        let c = &runner.training_config().commands;
        let ranges = [c.lin_vel_x, c.lin_vel_y, c.ang_vel_z];
        let mut env = RobotEnv::new(model, Arc::new(cfg), settings.seed, 0)?;
        if let Ground::Tile(_, level) = ground {
            env.set_terrain_tile(Some((*level, 0)))?;
        }
        let course = course.map(|(drive, friction)| {
            env.set_ground_friction(Some(Arc::new(friction)));
            drive
        });
        let obs = vec![0.0; env.obs_dim()];
        let mut s = Session {
            env,
            runner,
            obs,
            actions: Vec::new(),
            controls: Controls::new(command, ranges),
            t: 0.0,
            state: State::Walking,
            falls: 0,
            resets: 0,
            shove: None,
            shown_velocity: [0.0; 3],
            course,
            learned: None,
            interventions: 0,
        };
        s.reset()?;
        Ok(s)
    }

    pub fn env(&self) -> &RobotEnv {
        &self.env
    }

    pub fn env_mut(&mut self) -> &mut RobotEnv {
        &mut self.env
    }

    /// The policy's period, s.
    pub fn dt(&self) -> f64 {
        self.env.config().policy_dt()
    }

    /// Simulated time since the last reset, s.
    pub fn time(&self) -> f64 {
        self.t
    }

    pub fn state(&self) -> State {
        self.state
    }

    /// The measured (v_x, v_y, w_z) in the torso frame, low-pass filtered over half a second.
    pub fn shown_velocity(&self) -> [f64; 3] {
        self.shown_velocity
    }

    fn reset(&mut self) -> Result<()> {
        match &self.course {
            Some(c) => {
                let p = c.course.start();
                self.env.reset_at(&mut self.obs, [p.xy[0], p.xy[1], p.heading])?;
            }
            None => self.env.reset(&mut self.obs)?,
        }
        self.env.set_perturbation_struct(Default::default());
        self.t = 0.0;
        self.state = State::Walking;
        self.shove = None;
        self.shown_velocity = [0.0; 3];
        Ok(())
    }

    /// Applies a key's action. Returns false for Quit.
    pub fn apply(&mut self, a: Action) -> Result<bool> {
        match a {
            Action::Quit => return Ok(false),
            Action::Reset => {
                self.resets += 1;
                self.reset()?;
            }
            Action::Shove(dir) => self.shove = Some(([dir[0] * SHOVE_N, dir[1] * SHOVE_N], self.t + SHOVE_S)),
            Action::Autopilot => {
                if let Some(c) = &mut self.course {
                    c.autopilot = !c.autopilot;
                }
            }
            other => {
                // A key that commands the robot takes it over from the course's operator.
                if let (Some(c), Action::Command { .. } | Action::Stop) = (&mut self.course, other) {
                    c.autopilot = false;
                }
                self.controls.apply(other)
            }
        }
        Ok(true)
    }

    /// The torso-frame force of the shove under way, N.
    pub fn shove(&self) -> Option<[f64; 2]> {
        self.shove.map(|s| s.0)
    }

    /// One policy period; `wrench` is the mouse's (body, world-frame force and torque), if a body is dragged.
    pub fn step(&mut self, wrench: Option<(usize, [f64; 6])>) -> Result<()> {
        if let State::Fallen(at) = self.state {
            if self.t - at >= LIE_S {
                self.reset()?;
            } else {
                self.t += self.dt();
            }
            return Ok(());
        }
        if let Some(c) = self.course.as_ref().filter(|c| c.autopilot) {
            let cmd = c.follower.command(&c.course, &self.env);
            self.controls.set_command(cmd);
        }
        self.env.set_command_override(Some(self.controls.command));
        let mut p = *self.env.perturbation();
        p.torso_force_local = match self.shove {
            Some((f, until)) if self.t < until => [f[0], f[1], 0.0],
            _ => {
                self.shove = None;
                [0.0; 3]
            }
        };
        self.env.set_perturbation_struct(p);
        self.env.set_body_wrench(wrench);
        self.runner.act(&self.obs, &mut self.actions);
        self.learned = self.runner.policy.estimate().map(|e| [e[0], e[1]]);
        let out = self.env.step(&self.actions, &mut self.obs);
        self.t += self.dt();
        if out.diverged {
            return Err(Error::Diverged(self.t));
        }
        let s = self.env.robot_state();
        let a = self.dt() / SHOWN_VELOCITY_TAU_S;
        for (v, now) in self.shown_velocity.iter_mut().zip([s.lin_vel[0], s.lin_vel[1], s.ang_vel[2]]) {
            *v += a * (now - *v);
        }
        if let Some(c) = &mut self.course {
            // The course's operator: a fall, a wall or no progress puts the robot back on the path.
            let falls = c.follower.observe(&c.course, &self.env, &c.walls, self.t);
            if let Some(pose) = falls.filter(|_| !c.follower.done()) {
                self.interventions += 1;
                self.env.reset_at(&mut self.obs, pose)?;
            }
            if c.follower.done() && c.autopilot {
                // At the goal: the operator stops.
                c.autopilot = false;
                self.controls.command = [0.0; 3];
            }
        }
        if out.done {
            self.falls += 1;
            self.state = State::Fallen(self.t);
            self.env.set_body_wrench(None);
        }
        Ok(())
    }

    /// The overlay: labels and values.
    /// `real_time`: simulated seconds per wall-clock second achieved (None in lockstep, where frames set the pace).
    pub fn overlay(&self, real_time: Option<f64>) -> (String, String) {
        let c = self.controls.command;
        let v = self.shown_velocity;
        let mut labels = String::from("command (vx vy wz)\nmeasured");
        let mut values = format!("{:+.2} {:+.2} {:+.2}\n{:+.2} {:+.2} {:+.2}", c[0], c[1], c[2], v[0], v[1], v[2]);
        if let Some(s) = self.env.sim2sim().filter(|_| self.env.config().sim2sim.estimator.enabled) {
            let e = s.latest().lin_vel;
            labels.push_str("\nKalman filter (vx vy)");
            values.push_str(&format!("\n{:+.2} {:+.2}", e[0], e[1]));
        }
        if let Some(e) = self.learned {
            labels.push_str("\npolicy's estimate (vx vy)");
            values.push_str(&format!("\n{:+.2} {:+.2}", e[0], e[1]));
        }
        let state = match (self.state, self.controls.paused, self.shove) {
            (State::Fallen(_), _, _) => "FELL".to_string(),
            (_, true, _) => "paused".to_string(),
            (_, _, Some((f, _))) => format!("shoved ({:+.0}, {:+.0}) N", f[0], f[1]),
            _ => "walking".to_string(),
        };
        if let Some(c) = &self.course {
            labels.push_str("\ncourse\ninterventions");
            let who = if c.autopilot { "operator (G: you)" } else { "you (G: operator)" };
            let (done, length) = (c.follower.progress_m(), c.course.path.length());
            values.push_str(&format!("\n{done:.0} / {length:.0} m, {who}\n{}", self.interventions));
        }
        labels.push_str("\ntime\nspeed\nfalls / resets\nstate");
        let pace = real_time.map_or("lockstep".to_string(), |r| format!("achieved {r:.2}x"));
        values.push_str(&format!(
            "\n{:.1} s\n{:.3}x ({pace})\n{} / {}\n{state}",
            self.t,
            self.controls.speed(),
            self.falls,
            self.resets
        ));
        (labels, values)
    }
}

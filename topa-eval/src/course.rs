//! The paper's real-world test in simulation: a policy driven over a course (`assets/courses/*.toml`) by the
//! operator of `driver.rs`, at several top speeds at once (one env each). A fall, a touch of a wall or no progress
//! for `STUCK_S` is an intervention: the robot is put back, standing, on the path just behind its furthest
//! progress (`RESTART_BACK_M`, so that it does not stand on the threshold it tripped on), and the clock runs on —
//! as a person walking beside it would do. Reported per speed: time to the goal, interventions by cause,
//! joint-limit hits per minute (the paper's reason O failed), distance off the path.

use std::collections::HashSet;

use mujoco::ObjType;
use serde::{Deserialize, Serialize};
use topa_env::course::{Course, WALL_PREFIX};
use topa_env::policy_runner::PolicyRunner;
use topa_env::{RobotEnv, VecEnv};

use super::driver::Driver;
use super::settings::EvalSettings;
use crate::error::{ensure, Result};

/// No progress along the path for this long is an intervention ("stuck"), s.
pub const STUCK_S: f64 = 20.0;
/// Progress of less than this in `STUCK_S` is none (a swaying robot creeps forward by millimetres), m.
pub const STUCK_PROGRESS_M: f64 = 0.1;
/// A robot put back stands this far behind its furthest progress, m.
pub const RESTART_BACK_M: f64 = 0.3;
/// A joint within this distance of its range's end is at its limit, rad.
pub const JOINT_LIMIT_MARGIN: f64 = 0.02;
/// Standing still on a zero command before the clock starts, s.
const SETTLE_S: f64 = 1.0;

/// Counts entries of joints into the last `JOINT_LIMIT_MARGIN` of their ranges.
#[derive(Debug, Clone)]
pub struct LimitCounter {
    at: Vec<bool>,
    pub hits: usize,
}

impl LimitCounter {
    pub fn new(joints: usize) -> Self {
        LimitCounter { at: vec![false; joints], hits: 0 }
    }
    pub fn observe(&mut self, joint_pos: &[f64], range: &[[f64; 2]]) {
        for (j, (q, [lo, hi])) in joint_pos.iter().zip(range).enumerate() {
            let at = *q < lo + JOINT_LIMIT_MARGIN || *q > hi - JOINT_LIMIT_MARGIN;
            self.hits += usize::from(at && !self.at[j]);
            self.at[j] = at;
        }
    }
    /// After the robot was put back (standing, away from every limit).
    pub fn restart(&mut self) {
        self.at.iter_mut().for_each(|a| *a = false);
    }
}

/// One run of one policy over the course at one top speed.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct CourseRun {
    pub top_speed: f64,
    pub finished: bool,
    /// Time to the goal, or the time limit when it did not finish, s.
    pub time_s: f64,
    pub falls: usize,
    pub wall_contacts: usize,
    pub stuck: usize,
    /// Entries of any joint into the last `JOINT_LIMIT_MARGIN` of its range, per minute.
    pub joint_limit_hits_per_min: f64,
    pub mean_off_path_m: f64,
    pub max_off_path_m: f64,
    /// Furthest progress along the path, m.
    pub progress_m: f64,
    /// Where the torso was, every 0.25 s (for the map), and where interventions happened.
    #[serde(skip)]
    pub trajectory: Vec<[f64; 2]>,
    #[serde(skip)]
    pub intervention_at: Vec<[f64; 2]>,
}

impl CourseRun {
    pub fn interventions(&self) -> usize {
        self.falls + self.wall_contacts + self.stuck
    }
    /// Finished without an intervention.
    pub fn clean(&self) -> bool {
        self.finished && self.interventions() == 0
    }
}

/// A policy's runs over one course.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct CourseResult {
    pub course: String,
    pub length_m: f64,
    pub runs: Vec<CourseRun>,
}

impl CourseResult {
    /// The fastest run with no intervention, s.
    pub fn best_clean_time(&self) -> Option<f64> {
        self.runs.iter().filter(|r| r.clean()).map(|r| r.time_s).min_by(f64::total_cmp)
    }
    /// Whether some run reached the goal (with or without help).
    pub fn finished(&self) -> bool {
        self.runs.iter().any(|r| r.finished)
    }
    pub fn max_joint_limit_hits_per_min(&self) -> f64 {
        self.runs.iter().map(|r| r.joint_limit_hits_per_min).fold(0.0, f64::max)
    }
}

/// The bookkeeping of one run over a course: the operator's command, progress, interventions and where to put
/// the robot back, joint-limit hits. `run` drives one per env; `topa sim-robot --course` drives one through the
/// controller on the wire.
pub struct CourseFollower {
    driver: Driver,
    run: CourseRun,
    progress: f64,
    /// Progress when `last_progress_t` was last set.
    progress_mark: f64,
    last_progress_t: f64,
    off_path_sum: f64,
    steps: usize,
    limits: LimitCounter,
    done: bool,
}

/// Called after every step with the time and the first env (e.g. to render it).
pub type Watch<'a> = &'a mut dyn FnMut(f64, &mut RobotEnv) -> Result<()>;

/// Runs `runner` over `course` at each of `speeds`; the time limit is four times the course at the slowest speed
/// plus two minutes.
pub fn run(
    runner: &mut PolicyRunner,
    course: &Course,
    s: &EvalSettings,
    speeds: &[f64],
    mut watch: Option<Watch>,
) -> Result<CourseResult> {
    ensure!(!speeds.is_empty(), "--speeds: give at least one top speed");
    let mut cfg = s.env_config(runner)?;
    cfg.termination.enabled = false; // falls are interventions, counted here
    let ranges = cfg.commands.clone();
    let drivers = speeds.iter().map(|&v| Driver::new(v, &ranges)).collect::<Result<Vec<_>>>()?;
    let (model, friction) = course.compile(runner.robot())?;
    let friction = std::sync::Arc::new(friction);
    let walls = wall_geoms(&model);
    let mut batch = topa_env::vec_env::robot_batch_on(model, &cfg, speeds.len(), s.seed, s.threads)?;
    batch.reset()?;
    let start = course.start();
    for i in 0..speeds.len() {
        let (task, obs) = batch.env_mut(i);
        task.set_ground_friction(Some(friction.clone()));
        task.reset_at(obs, [start.xy[0], start.xy[1], start.heading])?;
        task.set_command_override(Some([0.0; 3]));
    }
    let n_motors = runner.robot().n_motors();
    let mut followers: Vec<CourseFollower> =
        drivers.into_iter().map(|driver| CourseFollower::new(driver, n_motors)).collect();
    let dt = cfg.policy_dt();
    let settle = (SETTLE_S / dt).round() as usize;
    let limit_s = time_limit_s(course, speeds);
    let mut actions = Vec::new();
    let mut k = 0usize;
    while followers.iter().any(|f| !f.done) {
        let t = k.saturating_sub(settle) as f64 * dt;
        if k >= settle {
            for (i, f) in followers.iter_mut().enumerate().filter(|(_, f)| !f.done) {
                let task = &mut batch.tasks_mut()[i];
                let c = f.command(course, task);
                task.set_command_override(Some(c));
            }
        }
        runner.act(batch.obs(), &mut actions);
        batch.step(&actions)?;
        k += 1;
        if k <= settle {
            continue;
        }
        let t = t + dt;
        for (i, f) in followers.iter_mut().enumerate().filter(|(_, f)| !f.done) {
            let (task, obs) = batch.env_mut(i);
            if let Some(restart) = f.observe(course, task, &walls, t) {
                task.reset_at(obs, restart)?;
            }
            if t >= limit_s && !f.done {
                f.finish(t, false);
            }
            if f.done {
                batch.set_parked(i, true); // a finished run stands still while the slower ones go on
            }
        }
        if let Some(w) = watch.as_mut() {
            w(t, &mut batch.tasks_mut()[0])?;
        }
    }
    Ok(CourseResult {
        course: course.name.clone(),
        length_m: course.path.length(),
        runs: followers.into_iter().map(CourseFollower::into_run).collect(),
    })
}

/// The course's wall geoms in `model` (a touch is an intervention).
pub fn wall_geoms(model: &mujoco::Model) -> HashSet<usize> {
    (0..model.ngeom())
        .filter(|&g| model.name_of(ObjType::Geom, g).is_some_and(|n| n.starts_with(WALL_PREFIX)))
        .collect()
}

/// A run's time limit: four times the course at the slowest of `speeds`, plus two minutes, s.
pub fn time_limit_s(course: &Course, speeds: &[f64]) -> f64 {
    let slowest = speeds.iter().cloned().fold(f64::INFINITY, f64::min);
    4.0 * course.path.length() / slowest + 120.0
}

impl CourseFollower {
    pub fn new(driver: Driver, n_motors: usize) -> Self {
        CourseFollower {
            driver,
            run: CourseRun {
                top_speed: driver.top_speed,
                finished: false,
                time_s: 0.0,
                falls: 0,
                wall_contacts: 0,
                stuck: 0,
                joint_limit_hits_per_min: 0.0,
                mean_off_path_m: 0.0,
                max_off_path_m: 0.0,
                progress_m: 0.0,
                trajectory: Vec::new(),
                intervention_at: Vec::new(),
            },
            progress: 0.0,
            progress_mark: 0.0,
            last_progress_t: 0.0,
            off_path_sum: 0.0,
            steps: 0,
            limits: LimitCounter::new(n_motors),
            done: false,
        }
    }

    /// The operator's velocity command for the robot in `task` now.
    pub fn command(&self, course: &Course, task: &RobotEnv) -> [f64; 3] {
        let st = task.robot_state();
        self.driver.command(course, self.progress, [st.base_pos[0], st.base_pos[1]], st.yaw)
    }

    /// How far along the path the robot has come, m.
    pub fn progress_m(&self) -> f64 {
        self.progress
    }

    /// Whether the run reached the goal or its time limit.
    pub fn done(&self) -> bool {
        self.done
    }

    pub fn into_run(self) -> CourseRun {
        self.run
    }

    /// Bookkeeping after a step at time `t` (s since the clock started; a control period of the policy's each
    /// call); the pose to put the robot back at when an intervention is due.
    pub fn observe(&mut self, course: &Course, task: &RobotEnv, walls: &HashSet<usize>, t: f64) -> Option<[f64; 3]> {
        let st = task.robot_state();
        let xy = [st.base_pos[0], st.base_pos[1]];
        let (near, off) = course.path.project(xy, self.progress - 1.0, self.progress + 2.0);
        if off < 1.0 && near.s > self.progress {
            self.progress = near.s;
        }
        if self.progress > self.progress_mark + STUCK_PROGRESS_M {
            self.progress_mark = self.progress;
            self.last_progress_t = t;
        }
        self.steps += 1;
        self.off_path_sum += off;
        self.run.max_off_path_m = self.run.max_off_path_m.max(off);
        if self.steps.is_multiple_of((0.25 / task.config().policy_dt()).round().max(1.0) as usize) {
            self.run.trajectory.push(xy);
        }
        self.limits.observe(&st.joint_pos, &task.indices().joint_range);
        let goal = course.path.at(course.path.length()).xy;
        if self.progress > course.path.length() - 2.0 * course.goal_radius
            && topa_env::course::path::dist(xy, goal) < course.goal_radius
        {
            self.finish(t, true);
            return None;
        }
        let touches_wall = task
            .data()
            .contacts()
            .iter()
            .any(|c| walls.contains(&(c.geom1 as usize)) || walls.contains(&(c.geom2 as usize)));
        let cause = if touches_wall {
            &mut self.run.wall_contacts
        } else if task.has_fallen() || course.material_at(xy).is_none() {
            // Off every floor patch is off the course: in a building, a fall down a step or into a wall.
            &mut self.run.falls
        } else if t - self.last_progress_t > STUCK_S {
            &mut self.run.stuck
        } else {
            return None;
        };
        *cause += 1;
        self.run.intervention_at.push(xy);
        self.last_progress_t = t;
        self.progress_mark = self.progress;
        self.limits.restart();
        let back = course.path.at(self.progress - RESTART_BACK_M);
        Some([back.xy[0], back.xy[1], back.heading])
    }

    /// Ends the run at time `t`, at the goal or not.
    pub fn finish(&mut self, t: f64, reached: bool) {
        self.done = true;
        self.run.finished = reached;
        self.run.time_s = t;
        self.run.progress_m = self.progress;
        self.run.mean_off_path_m = self.off_path_sum / self.steps.max(1) as f64;
        self.run.joint_limit_hits_per_min = self.limits.hits as f64 / (t / 60.0).max(1e-9);
    }
}

/// The runs as a Markdown table.
pub fn markdown(r: &CourseResult) -> String {
    let mut s = format!(
        "Course {} ({:.0} m)\n\n| top speed (m/s) | goal | time | interventions (falls / walls / stuck) | joint-limit hits/min | off path mean / max (m) |\n|---|---|---|---|---|---|\n",
        r.course, r.length_m
    );
    for run in &r.runs {
        s.push_str(&format!(
            "| {:.2} | {} | {} | {} ({} / {} / {}) | {:.1} | {:.2} / {:.2} |\n",
            run.top_speed,
            if run.finished { "yes" } else { "no" },
            minutes(run.time_s),
            run.interventions(),
            run.falls,
            run.wall_contacts,
            run.stuck,
            run.joint_limit_hits_per_min,
            run.mean_off_path_m,
            run.max_off_path_m
        ));
    }
    s.push_str(&match r.best_clean_time() {
        Some(t) => format!("\nBest clean time (goal, no intervention): {}\n", minutes(t)),
        None => "\nNo clean run (every run needed an intervention or missed the goal).\n".into(),
    });
    s
}

/// Seconds as "m:ss".
pub fn minutes(t: f64) -> String {
    let t = t.round() as u64;
    format!("{}:{:02}", t / 60, t % 60)
}

//! The paper's 40-minute demonstration in simulation: a long run on the robot's flat floor under an operator who
//! drives like a person with a joystick — a new intention every few seconds (walk at some speed, turn, turn on the
//! spot, step sideways, back up, stop), reached through the stick's ramp, with hand noise on top — and now and then
//! a shove from a passer-by. A fall is an intervention: the robot is stood up where it lies and the run goes on.
//! Each intervention is put down to what was happening: a push, a turn, walking or standing.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use topa_env::config::CommandConfig;
use topa_env::policy_runner::PolicyRunner;
use topa_env::{Perturbation, VecEnv};
use trainer::actor_critic::standard_normal;

use super::course::LimitCounter;
use super::settings::EvalSettings;
use crate::error::{ensure, Result};

/// The operator's habits.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Operator {
    /// A new intention every U(lo, hi) s.
    pub hold_s: [f64; 2],
    /// Stick ramps: m/s² for v_x, v_y and rad/s² for w_z.
    pub ramp: [f64; 2],
    /// Hand noise (sd) on (v, w), per policy step.
    pub noise: [f64; 2],
    /// A push every U(lo, hi) s, of U(lo, hi) N on the torso in a random horizontal direction, for `push_s`.
    pub push_every_s: [f64; 2],
    pub push_force: [f64; 2],
    pub push_s: f64,
}

impl Default for Operator {
    fn default() -> Self {
        Operator {
            hold_s: [2.0, 8.0],
            ramp: [1.0, 2.0],
            noise: [0.03, 0.05],
            push_every_s: [30.0, 90.0],
            push_force: [20.0, 40.0],
            push_s: 0.3,
        }
    }
}

/// What an endurance run counted.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct EnduranceRun {
    pub minutes: f64,
    pub interventions: usize,
    /// Interventions by what was happening: a push in the last 2 s, a turn, walking, standing.
    pub during_push: usize,
    pub during_turn: usize,
    pub during_walk: usize,
    pub during_stand: usize,
    /// Minutes until the first intervention (the whole run when there was none).
    pub minutes_to_first: f64,
    pub pushes: usize,
    pub distance_m: f64,
    pub joint_limit_hits_per_min: f64,
}

/// A random intention within the policy's command ranges.
fn intention(r: &mut ChaCha8Rng, c: &CommandConfig) -> [f64; 3] {
    let vmax = c.lin_vel_x[1];
    let wmax = c.ang_vel_z[1].min(-c.ang_vel_z[0]);
    let side = c.lin_vel_y[1].min(-c.lin_vel_y[0]).min(0.3);
    let u: f64 = r.random();
    let sign = if r.random::<bool>() { 1.0 } else { -1.0 };
    match u {
        u if u < 0.15 => [0.0; 3],
        u if u < 0.55 => [r.random_range(0.1..=vmax), 0.0, r.random_range(-0.3..=0.3)],
        u if u < 0.75 => [r.random_range(0.1..=vmax), 0.0, sign * r.random_range(0.3..=wmax)],
        u if u < 0.85 => [0.0, 0.0, sign * r.random_range(0.3..=wmax)],
        u if u < 0.93 => [0.0, sign * r.random_range(0.1..=side), 0.0],
        _ => [r.random_range(c.lin_vel_x[0]..=-0.1), 0.0, 0.0],
    }
}

fn towards(x: f64, target: f64, step: f64) -> f64 {
    x + (target - x).clamp(-step, step)
}

/// `runs` envs for `minutes` each under `op`; env i's operator is seeded with (seed, i).
pub fn run(
    runner: &mut PolicyRunner,
    s: &EvalSettings,
    minutes: f64,
    runs: usize,
    op: &Operator,
) -> Result<Vec<EnduranceRun>> {
    ensure!(minutes > 0.0 && runs > 0, "--minutes and --runs must be positive");
    let mut cfg = s.env_config(runner)?;
    cfg.termination.enabled = false;
    let ranges = cfg.commands.clone();
    let mut batch = topa_env::vec_env::robot_batch(&cfg, runs, s.seed, s.threads)?;
    batch.reset()?;
    let dt = cfg.policy_dt();
    let steps = (minutes * 60.0 / dt).round() as usize;
    struct State {
        rng: ChaCha8Rng,
        target: [f64; 3],
        stick: [f64; 3],
        next_intention: f64,
        next_push: f64,
        push_until: f64,
        last_push: f64,
        limits: LimitCounter,
        last_xy: [f64; 2],
        run: EnduranceRun,
    }
    let n_motors = runner.robot().n_motors();
    let mut st: Vec<State> = (0..runs)
        .map(|i| {
            let mut rng = ChaCha8Rng::seed_from_u64(s.seed);
            rng.set_stream(1000 + i as u64);
            let next_push = rng.random_range(op.push_every_s[0]..=op.push_every_s[1]);
            State {
                rng,
                target: [0.0; 3],
                stick: [0.0; 3],
                next_intention: 1.0,
                next_push,
                push_until: -1.0,
                last_push: f64::NEG_INFINITY,
                limits: LimitCounter::new(n_motors),
                last_xy: [0.0; 2],
                run: EnduranceRun { minutes, minutes_to_first: minutes, ..Default::default() },
            }
        })
        .collect();
    let mut actions = Vec::new();
    for k in 0..steps {
        let t = k as f64 * dt;
        for (i, e) in st.iter_mut().enumerate() {
            if t >= e.next_intention {
                e.target = intention(&mut e.rng, &ranges);
                e.next_intention = t + e.rng.random_range(op.hold_s[0]..=op.hold_s[1]);
            }
            for (j, ramp) in [op.ramp[0], op.ramp[0], op.ramp[1]].into_iter().enumerate() {
                e.stick[j] = towards(e.stick[j], e.target[j], ramp * dt);
            }
            let (nv, nw) = (op.noise[0], op.noise[1]);
            let noisy = [
                (e.stick[0] + nv * standard_normal(&mut e.rng)).clamp(ranges.lin_vel_x[0], ranges.lin_vel_x[1]),
                (e.stick[1] + nv * standard_normal(&mut e.rng)).clamp(ranges.lin_vel_y[0], ranges.lin_vel_y[1]),
                (e.stick[2] + nw * standard_normal(&mut e.rng)).clamp(ranges.ang_vel_z[0], ranges.ang_vel_z[1]),
            ];
            let task = &mut batch.tasks_mut()[i];
            task.set_command_override(Some(noisy));
            let mut p = Perturbation::default();
            if t >= e.next_push {
                e.push_until = t + op.push_s;
                e.last_push = t;
                e.run.pushes += 1;
                e.next_push = t + e.rng.random_range(op.push_every_s[0]..=op.push_every_s[1]);
                let (f, dir) = (
                    e.rng.random_range(op.push_force[0]..=op.push_force[1]),
                    e.rng.random_range(0.0..std::f64::consts::TAU),
                );
                p.torso_force_local = [f * dir.cos(), f * dir.sin(), 0.0];
                task.set_perturbation_struct(p);
            } else if t >= e.push_until && task.perturbation().torso_force_local != [0.0; 3] {
                task.set_perturbation_struct(p);
            }
        }
        runner.act(batch.obs(), &mut actions);
        batch.step(&actions)?;
        let t = t + dt;
        for (i, e) in st.iter_mut().enumerate() {
            let (task, obs) = batch.env_mut(i);
            let rs = task.robot_state();
            let xy = [rs.base_pos[0], rs.base_pos[1]];
            e.run.distance_m += (xy[0] - e.last_xy[0]).hypot(xy[1] - e.last_xy[1]);
            e.last_xy = xy;
            e.limits.observe(&rs.joint_pos, &task.indices().joint_range);
            if task.has_fallen() {
                let r = &mut e.run;
                if r.interventions == 0 {
                    r.minutes_to_first = t / 60.0;
                }
                r.interventions += 1;
                let c = task.command();
                if t - e.last_push < 2.0 {
                    r.during_push += 1;
                } else if c[2].abs() > 0.3 {
                    r.during_turn += 1;
                } else if c[0].hypot(c[1]) > 0.05 {
                    r.during_walk += 1;
                } else {
                    r.during_stand += 1;
                }
                let yaw = rs.yaw;
                task.reset_at(obs, [xy[0], xy[1], yaw])?;
                e.limits.restart();
                e.stick = [0.0; 3];
                e.push_until = t;
                e.last_xy = xy;
            }
        }
    }
    Ok(st
        .into_iter()
        .map(|e| EnduranceRun { joint_limit_hits_per_min: e.limits.hits as f64 / minutes, ..e.run })
        .collect())
}

/// The runs as a Markdown table.
pub fn markdown(runs: &[EnduranceRun]) -> String {
    let mut s = String::from(
        "| run | minutes | interventions (push / turn / walk / stand) | first after (min) | pushes | distance (m) | joint-limit hits/min |\n|---|---|---|---|---|---|---|\n",
    );
    for (i, r) in runs.iter().enumerate() {
        s.push_str(&format!(
            "| {} | {:.0} | {} ({} / {} / {} / {}) | {:.1} | {} | {:.0} | {:.1} |\n",
            i + 1,
            r.minutes,
            r.interventions,
            r.during_push,
            r.during_turn,
            r.during_walk,
            r.during_stand,
            r.minutes_to_first,
            r.pushes,
            r.distance_m,
            r.joint_limit_hits_per_min
        ));
    }
    s
}

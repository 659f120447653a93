//! `topa bench memory`: what a batch of TopA envs costs in memory and start-up time, and how much of the memory
//! MuJoCo preallocates for each (the MJCF's `<size>`) the simulation actually uses — measured over walking,
//! pushed and falling episodes at both integrators. These numbers set (and justify) `<size>` in
//! `assets/mjcf/common/options.xml`.

use std::time::Instant;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use topa_env::{EnvConfig, ModelKind, VecEnv};
use trainer::policy_file::Policy;

use crate::error::{Error, Result};

/// Resident set size and minor page faults of this process.
fn rss_and_faults() -> (usize, i64) {
    let rss = std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().nth(1).and_then(|v| v.parse::<usize>().ok()))
        .map_or(0, |pages| pages * 4096);
    // Field 10 of /proc/self/stat (minflt), counted after the command name's closing parenthesis (field 2).
    let faults = std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| s.rsplit_once(')').and_then(|(_, rest)| rest.split_whitespace().nth(7)?.parse::<i64>().ok()))
        .unwrap_or(0);
    (rss, faults)
}

/// Largest stack (mjtNum), contacts and constraint rows any env needed.
#[derive(Debug, Default, Clone, Copy)]
struct Use {
    stack: usize,
    contacts: usize,
    rows: usize,
    steps: usize,
    episodes: usize,
}

/// Steps `n` envs for `steps` policy steps, acting with `policy` (or uniformly random actions in ±`random`),
/// recording the largest MuJoCo memory use.
fn measure(cfg: &EnvConfig, n: usize, steps: usize, policy: Option<&mut Policy>, random: f32) -> Result<Use> {
    let mut v = topa_env::vec_env::robot_batch(cfg, n, 7, 0)?;
    v.reset()?;
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut actions = vec![0.0f32; n * v.action_dim()];
    let mut u = Use::default();
    let mut policy = policy;
    for _ in 0..steps {
        match policy.as_deref_mut() {
            Some(p) => p.act(v.obs(), &mut actions),
            None => actions.iter_mut().for_each(|a| *a = rng.random_range(-random..random)),
        }
        v.step(&actions)?;
        for t in v.tasks() {
            let (stack, con, efc) = t.data().max_use();
            u.stack = u.stack.max(stack);
            u.contacts = u.contacts.max(con);
            u.rows = u.rows.max(efc);
        }
        u.steps += n;
        let s = v.take_episode_stats();
        u.episodes += s.episodes + s.diverged;
    }
    Ok(u)
}

pub fn run(envs: usize, steps: usize, policy: &std::path::Path, terrain: bool) -> Result<()> {
    let mut cfg = EnvConfig { robot: ModelKind::Closed.spec_path().into(), ..EnvConfig::default() };
    cfg.terrain.enabled = terrain;
    // The training preset's physics and the paper's pushes (up to 2.5 m/s): the hardest contacts training sees.
    cfg.integrator = topa_env::IntegratorChoice::Euler;
    let (rss0, faults0) = rss_and_faults();
    let start = Instant::now();
    let mut v = topa_env::vec_env::robot_batch(&cfg, envs, 1, 0)?;
    v.reset()?;
    let ready = start.elapsed().as_secs_f64();
    let (rss1, faults1) = rss_and_faults();
    let t = &v.tasks()[0];
    let model_bytes = t.data().model().memory_bytes();
    let data_bytes = t.data().memory_bytes();
    let m = t.data().model();
    let (nstack, nconmax, njmax) = (m.nstack(), m.nconmax(), m.njmax());
    let ground = if terrain { "on the default terrain" } else { "on the flat floor" };
    println!("{envs} TopA envs (closed model {ground}, domain randomisation on: each env owns its model copy)\n");
    println!("| per env | bytes |");
    println!("|---|---:|");
    println!("| model copy (mjModel + buffer) | {model_bytes} |");
    println!("| data (mjData + buffer + stack of {nstack} mjtNum) | {data_bytes} |");
    println!("| resident set growth ÷ envs | {} |", (rss1.saturating_sub(rss0)) / envs);
    println!(
        "\nready to step (build + first reset of every env): {ready:.2} s; {} minor page faults (goals: ≤ 0.5 MB per env, ≤ 3 s for 4096 envs)\n",
        faults1 - faults0
    );
    drop(v);

    let mut p = Policy::load(policy).map_err(|e| Error::file(format!("walking policy {}", policy.display()), e))?;
    println!(
        "largest use over {steps} policy steps × 64 envs per row (walking: {}, random: falling):\n",
        policy.display()
    );
    println!("| integrator | episodes | stack (mjtNum) | contacts | constraint rows |");
    println!("|---|---|---:|---:|---:|");
    let mut worst = Use::default();
    for integ in [topa_env::IntegratorChoice::Euler, topa_env::IntegratorChoice::Rk4] {
        let mut c = cfg.clone();
        c.integrator = integ;
        c.push.velocity = [0.0, 2.5];
        let walking = measure(&c, 64, steps, Some(&mut p), 0.0)?;
        let falling = measure(&c, 64, steps, None, 3.0)?;
        // Evaluation goes on after a fall (tracking): the robot lies on the floor, torso and shanks in contact.
        c.termination.enabled = false;
        let lying = measure(&c, 64, steps, None, 3.0)?;
        for (what, u) in [
            ("walking, pushed up to 2.5 m/s", walking),
            ("random actions: falls end episodes", falling),
            ("random actions, no termination: lying, thrashing", lying),
        ] {
            println!("| {integ} | {} ({what}) | {} | {} | {} |", u.episodes, u.stack, u.contacts, u.rows);
            worst.stack = worst.stack.max(u.stack);
            worst.contacts = worst.contacts.max(u.contacts);
            worst.rows = worst.rows.max(u.rows);
        }
    }
    println!("| **size** (MJCF) | | {nstack} | {nconmax} | {njmax} |");
    println!(
        "| **margin** | | {:.1}× | {:.1}× | {:.1}× |",
        nstack as f64 / worst.stack.max(1) as f64,
        nconmax as f64 / worst.contacts.max(1) as f64,
        njmax as f64 / worst.rows.max(1) as f64
    );
    Ok(())
}

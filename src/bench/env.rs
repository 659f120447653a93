//! `topa bench env`: env-steps/s of the batched TopA VecEnv for several batch sizes and thread counts, against
//! the bare physics bound (mj_step/s of one Data ÷ decimation × threads), measured in the same run
//! (best of interleaved rounds).

use std::time::Instant;

use anyhow::Result;
use mujoco_sys::Data;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use topa_env::{assets, EnvConfig, ModelKind, VecEnv};

/// Single-thread mj_step/s of the model the envs use, stepping the stand pose with small random targets.
pub fn physics_steps_per_second(cfg: &EnvConfig, seconds: f64) -> Result<f64> {
    let batch = topa_env::vec_env::robot_batch(cfg, 1, 0, 1)?;
    let env = &batch.tasks()[0];
    let model = env.data().model_arc().clone();
    let mut d = Data::new(model.clone())?;
    d.reset_keyframe(env.indices().stand_key)?;
    let key_ctrl = model.key_ctrl(env.indices().stand_key).to_vec();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let (mut steps, start) = (0usize, Instant::now());
    while start.elapsed().as_secs_f64() < seconds {
        for (c, k) in d.ctrl_mut().iter_mut().zip(&key_ctrl) {
            *c = k + rng.random_range(-0.05..0.05);
        }
        for _ in 0..100 {
            d.step()?;
        }
        steps += 100;
        if d.is_unstable() || d.qpos()[2] < 0.3 {
            d.reset_keyframe(env.indices().stand_key)?;
        }
    }
    Ok(steps as f64 / start.elapsed().as_secs_f64())
}

/// env-steps/s of `n` batched envs on `threads` threads stepping random actions for `seconds`.
pub fn env_steps_per_second(cfg: &EnvConfig, n: usize, threads: usize, seconds: f64) -> Result<f64> {
    let mut v = topa_env::vec_env::robot_batch(cfg, n, 1, threads)?;
    v.reset()?;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let actions: Vec<Vec<f32>> =
        (0..8).map(|_| (0..n * v.action_dim()).map(|_| rng.random_range(-0.3..0.3)).collect()).collect();
    v.step(&actions[0])?; // warm-up: first-touch of buffers, thread start
    let (mut steps, start) = (0usize, Instant::now());
    while start.elapsed().as_secs_f64() < seconds {
        v.step(&actions[steps % actions.len()])?;
        steps += 1;
    }
    Ok((steps * n) as f64 / start.elapsed().as_secs_f64())
}

pub fn run(
    kind: ModelKind,
    envs: &[usize],
    threads: &[usize],
    integrator: topa_env::IntegratorChoice,
    seconds: f64,
    rounds: usize,
    terrain: bool,
) -> Result<()> {
    let mut cfg = EnvConfig { robot: kind.spec_path().into(), ..EnvConfig::default() };
    cfg.integrator = integrator;
    // The same envs on the terrain of `[env.terrain]`'s defaults, measured in the same rounds: its cost against
    // the flat floor's (height-field contacts) is the number that matters, not a bound of its own.
    let on_terrain = terrain.then(|| {
        let mut t = cfg.clone();
        t.terrain.enabled = true;
        t
    });
    // Best of `rounds` for every measurement, the rounds interleaved, so a burst of load from other tenants of
    // this machine hits all configurations alike rather than one.
    let configs: Vec<(usize, usize)> = envs.iter().flat_map(|&n| threads.iter().map(move |&t| (n, t))).collect();
    let mut best = vec![0.0f64; configs.len()];
    let mut best_terrain = vec![0.0f64; configs.len()];
    let mut phys = 0.0f64;
    for _ in 0..rounds.max(1) {
        phys = phys.max(physics_steps_per_second(&cfg, seconds)?);
        for (i, &(n, t)) in configs.iter().enumerate() {
            best[i] = best[i].max(env_steps_per_second(&cfg, n, t, seconds)?);
            if let Some(tc) = &on_terrain {
                best_terrain[i] = best_terrain[i].max(env_steps_per_second(tc, n, t, seconds)?);
            }
        }
    }
    let bound1 = phys / cfg.decimation as f64;
    println!(
        "model {} ({}), timestep {} s × decimation {}, integrator {}",
        kind.name(),
        assets::model_path(kind).display(),
        cfg.timestep,
        cfg.decimation,
        integrator
    );
    println!("bare physics: {phys:.0} mj_step/s on 1 thread → bound {bound1:.0} env-steps/s per thread\n");
    println!("| envs | threads | env-steps/s | ratio to bound | speed-up vs 1 thread |");
    println!("|-----:|--------:|------------:|---------------:|---------------------:|");
    for (i, &(n, t)) in configs.iter().enumerate() {
        let sps = best[i];
        let base = configs.iter().position(|&(n1, _)| n1 == n).map_or(sps, |j| best[j]);
        let bound = bound1 * t as f64;
        println!("| {n:>4} | {t:>7} | {sps:>11.0} | {:>14.3} | {:>20.2} |", sps / bound, sps / base);
    }
    if on_terrain.is_some() {
        println!("\non the terrain ([env.terrain] defaults), same rounds:\n");
        println!("| envs | threads | env-steps/s | terrain / flat |");
        println!("|-----:|--------:|------------:|---------------:|");
        for (i, &(n, t)) in configs.iter().enumerate() {
            println!("| {n:>4} | {t:>7} | {:>11.0} | {:>14.3} |", best_terrain[i], best_terrain[i] / best[i]);
        }
    }
    println!("\ngoals: ratio ≥ 0.9 of the bound (Euler, 512 envs × 2 threads), ≥ 1.9× from 1 to 2 threads; terrain ≥ 0.8 of flat");
    Ok(())
}

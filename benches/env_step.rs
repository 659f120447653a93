//! The batched env step (512 TopA envs, the CPU preset's physics: Euler at 5 ms, 4 steps per action) at 1 and 2
//! threads, against the bare physics bound measured in the same run (one Data's mj_step/s ÷ decimation ×
//! threads). Prints each ratio to the bound (goal ≥ 0.9) and the 2-thread speed-up.

use anyhow::Result;
use topa_env::{EnvConfig, IntegratorChoice, ModelKind};
use topa_tools::bench::env::{env_steps_per_second, physics_steps_per_second};

fn main() -> Result<()> {
    let mut cfg = EnvConfig { robot: ModelKind::Closed.spec_path().into(), ..EnvConfig::default() };
    cfg.integrator = IntegratorChoice::Euler;
    let envs = 512;
    let (mut bound, mut rates) = (0.0f64, [0.0f64; 2]);
    for _ in 0..3 {
        bound = bound.max(physics_steps_per_second(&cfg, 1.0)?);
        for (t, r) in rates.iter_mut().enumerate() {
            *r = r.max(env_steps_per_second(&cfg, envs, t + 1, 2.0)?);
        }
    }
    let per_thread_bound = bound / cfg.decimation as f64;
    println!("env step: {envs} TopA envs, Euler, best of 3 interleaved rounds");
    for (t, r) in rates.iter().enumerate() {
        let threads = t + 1;
        println!(
            "  {threads} thread(s): {r:>8.0} env-steps/s, bound {:>8.0}, ratio {:.3}   (goal ≥ 0.9)",
            per_thread_bound * threads as f64,
            r / (per_thread_bound * threads as f64)
        );
    }
    println!("  2 threads / 1: {:.2}×", rates[1] / rates[0]);
    Ok(())
}

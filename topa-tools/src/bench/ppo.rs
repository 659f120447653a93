//! `topa bench ppo`: samples/s of one full PPO update (the paper's networks, 5 epochs × 4 minibatches, symmetry
//! and decay on) at 24 576 samples, at 1 and 2 threads, with GFLOP/s (≈ 16.8 MFLOP per sample); the share of a
//! real TopA iteration spent in the rollout's inference; and, if a Python with torch is given, the torch
//! reference (trainer/examples/torch_reference.py) measured in the same run. Where the CPU has AVX-512, the same
//! update with the AVX2 kernel (`NN_GEMM=avx2`) is measured beside it, for the kernel's gain. Ours, the AVX2
//! kernel and torch alternate over two rounds, the best of each kept.
//!
//! Thread counts are fixed once per process (rayon's global pool, candle's pool), so each count runs in a child
//! process of this binary (`--worker`), one after the other.

use std::process::Command;
use std::time::Instant;

use serde::{Deserialize, Serialize};
use topa_env::VecEnv;
use trainer::Trainer;

use crate::error::{Error, Result};

const FLOP_PER_SAMPLE: f64 = 16.8e6;

#[derive(Debug, Serialize, Deserialize)]
pub struct WorkerResult {
    pub threads: usize,
    /// Best of `repeats` full PPO updates on 24 576 samples.
    pub update_s: f64,
    pub samples_per_s: f64,
    pub gflops: f64,
    /// A TopA iteration (1024 envs × 24 steps, the CPU preset's env): seconds in env stepping, inference, update.
    pub iteration_env_s: f64,
    pub iteration_inference_s: f64,
    pub iteration_update_s: f64,
}

/// Runs in the child: one TopA trainer with the paper's networks and 24 576 samples per iteration.
pub fn worker(threads: usize, repeats: usize) -> Result<WorkerResult> {
    trainer::nn::init_threads(threads)?;
    let (mut cfg, env_cfg) = topa_train::load_config(&topa_env::assets::repo_dir().join("configs/cpu.toml"))?;
    cfg.run.num_envs = 1024;
    cfg.run.steps_per_env = 24;
    cfg.run.threads = threads;
    cfg.network.actor_hidden = vec![512, 256, 128];
    cfg.network.critic_hidden = vec![512, 256, 128];
    let env: Box<dyn VecEnv> = Box::new(topa_env::vec_env::robot_batch(&env_cfg, cfg.run.num_envs, 1, 0)?);
    let mut t = Trainer::new(cfg, env, false)?;
    t.iterate()?; // warm-up: buffers, first-touch, thread start
    let log = t.iterate()?.ok_or_else(|| Error::bad_bench("iteration"))?;
    let mut best = log.update_s;
    for _ in 1..repeats {
        best = best.min(t.iterate()?.ok_or_else(|| Error::bad_bench("iteration"))?.update_s);
    }
    let samples = 24_576.0;
    Ok(WorkerResult {
        threads,
        update_s: best,
        samples_per_s: samples / best,
        gflops: samples * FLOP_PER_SAMPLE / best / 1e9,
        iteration_env_s: log.collect_s - log.inference_s,
        iteration_inference_s: log.inference_s,
        iteration_update_s: log.update_s,
    })
}

/// One worker process; `kernel` sets `NN_GEMM` in its environment (None: the CPU's best kernel).
fn run_worker(threads: usize, repeats: usize, kernel: Option<&str>) -> Result<WorkerResult> {
    let exe = std::env::current_exe().map_err(|e| Error::bench("locating the topa binary", e))?;
    let mut cmd = Command::new(exe);
    cmd.args(["bench", "ppo", "--worker", "--threads", &threads.to_string(), "--repeats", &repeats.to_string()]);
    if let Some(k) = kernel {
        cmd.env("NN_GEMM", k);
    }
    super::worker_result(cmd, threads)
}

fn torch_samples_per_s(python: &str, threads: usize) -> Result<f64> {
    let script = topa_env::assets::repo_dir().join("trainer/examples/torch_reference.py");
    let out = Command::new(python)
        .arg(&script)
        .args(["--threads", &threads.to_string()])
        .output()
        .map_err(Error::io("cannot run", std::path::Path::new(python)))?;
    let text = String::from_utf8_lossy(&out.stdout);
    text.lines()
        .find_map(|l| l.split("best: ").nth(1).and_then(|r| r.split_whitespace().next()).and_then(|v| v.parse().ok()))
        .ok_or_else(|| {
            Error::bad_bench(format!(
                "torch reference printed no 'best:' line:\n{text}{}",
                String::from_utf8_lossy(&out.stderr)
            ))
        })
}

pub fn run(threads: &[usize], repeats: usize, torch_python: Option<&str>) -> Result<()> {
    println!("PPO update: paper networks [512, 256, 128] (actor, critic), 24 576 samples, 5 epochs × 4 minibatches,");
    println!("symmetry and decay losses on; best of {repeats} updates in each of two rounds; ≈ 16.8 MFLOP per sample.");
    let kernel = trainer::nn::gemm_kernel();
    let ab = kernel == "AVX-512";
    println!(
        "Machine: {}; matrix kernel: {kernel}{}.\n",
        trainer::segments::this_machine(),
        if ab { " (beside it the AVX2 kernel)" } else { "" }
    );
    println!("| threads | ours samples/s | GFLOP/s | torch samples/s | ours / torch | AVX2 kernel samples/s | AVX-512 / AVX2 | TopA iteration: env / inference / update (s) |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---|");
    let start = Instant::now();
    for &t in threads {
        // Two rounds, each ours, then the AVX2 kernel (where AVX-512 is), then torch; the best of each is kept, so
        // a slow spell of this shared machine does not fall on one side only.
        let (mut r, mut narrow, mut torch): (Option<WorkerResult>, Option<f64>, Option<f64>) = (None, None, None);
        for _ in 0..2 {
            let ours = run_worker(t, repeats, None)?;
            if r.as_ref().is_none_or(|b| ours.samples_per_s > b.samples_per_s) {
                r = Some(ours);
            }
            if ab {
                let x = run_worker(t, repeats, Some("avx2"))?.samples_per_s;
                narrow = Some(narrow.map_or(x, |b: f64| b.max(x)));
            }
            if let Some(py) = torch_python {
                let x = torch_samples_per_s(py, t)?;
                torch = Some(torch.map_or(x, |b: f64| b.max(x)));
            }
        }
        let r = r.expect("two rounds ran");
        let it_total = r.iteration_env_s + r.iteration_inference_s + r.iteration_update_s;
        println!(
            "| {t} | {:.0} | {:.0} | {} | {} | {} | {} | {:.2} / {:.2} / {:.2} (inference {:.0} % of the iteration) |",
            r.samples_per_s,
            r.gflops,
            torch.map_or("–".into(), |x| format!("{x:.0}")),
            torch.map_or("–".into(), |x| format!("{:.2}", r.samples_per_s / x)),
            narrow.map_or("–".into(), |x| format!("{x:.0}")),
            narrow.map_or("–".into(), |x| format!("{:.2}", r.samples_per_s / x)),
            r.iteration_env_s,
            r.iteration_inference_s,
            r.iteration_update_s,
            100.0 * r.iteration_inference_s / it_total
        );
    }
    if torch_python.is_none() {
        println!("\n(torch column: pass --torch-python /path/to/python with torch installed)");
    }
    eprintln!("bench took {:.0} s", start.elapsed().as_secs_f64());
    Ok(())
}

//! `topa bench …`: performance measurements printed as ratios taken in one run (never timed tests).

pub mod env;
pub mod memory;
pub mod mpi;
pub mod physics;
pub mod ppo;
pub mod render;
pub mod train;

use anyhow::{bail, Context, Result};

/// Runs a benchmark's worker process (the binary with `--worker`: one thread count in a fresh process, so its
/// thread pools are its own) and reads the JSON result it prints last.
fn worker_result<T: serde::de::DeserializeOwned>(mut cmd: std::process::Command, threads: usize) -> Result<T> {
    let out = cmd.output()?;
    if !out.status.success() {
        bail!("bench worker ({threads} threads) failed: {}", String::from_utf8_lossy(&out.stderr));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text.lines().last().context("bench worker printed nothing")?;
    Ok(serde_json::from_str(line)?)
}

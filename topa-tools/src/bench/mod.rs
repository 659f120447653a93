//! `topa bench …`: performance measurements printed as ratios taken in one run (never timed tests).

pub mod env;
pub mod memory;
pub mod mpi;
pub mod physics;
pub mod ppo;
pub mod render;
pub mod train;

use crate::error::{bad_bench, Error, Result};

/// Runs a benchmark's worker process (the binary with `--worker`: one thread count in a fresh process, so its
/// thread pools are its own) and reads the JSON result it prints last.
fn worker_result<T: serde::de::DeserializeOwned>(mut cmd: std::process::Command, threads: usize) -> Result<T> {
    let out = cmd.output().map_err(Error::io("cannot run", std::path::Path::new(cmd.get_program())))?;
    if !out.status.success() {
        bad_bench!("bench worker ({threads} threads) failed: {}", String::from_utf8_lossy(&out.stderr));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text.lines().last().ok_or_else(|| Error::bad_bench("bench worker printed nothing"))?;
    serde_json::from_str(line)
        .map_err(|e| Error::bench(format!("bench worker ({threads} threads) printed no result: {line:?}"), e))
}

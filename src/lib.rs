//! TopA: the closed-chain biped of "Robust RL Control for Bipedal Locomotion with Closed Kinematic Chains" —
//! the command-line layer: model info, benchmarks, training runs, sim2sim evaluation, plots and recordings.
//! The crates below it: `mujoco-sys` (MuJoCo 2.2), `topa-env` (robot, env, VecEnv), `trainer` (PPO, adversary).

pub mod bench;
pub mod cli;
pub mod config_reference;
pub mod dashboard;
pub mod doc_blocks;
pub mod eval;
pub mod eval_cmd;
pub mod export;
pub mod groups_cmd;
pub mod info;
#[cfg(feature = "mpi")]
pub mod mpi_comm;
pub mod play;
pub mod plots;
pub mod recording;
pub mod robot_info;
pub mod sysid;
pub mod sysid_cmd;
pub mod train_cmd;
pub mod video;

/// Threads to use: `n`, or every core for 0.
pub fn resolve_threads(n: usize) -> usize {
    if n == 0 {
        std::thread::available_parallelism().map_or(1, |p| p.get())
    } else {
        n
    }
}

/// Today's date (UTC) as YYYY-MM-DD, for provenance records.
pub fn today() -> String {
    let days =
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs() / 86400) as i64;
    // Howard Hinnant's civil-from-days.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + if m <= 2 { 1 } else { 0 };
    format!("{y:04}-{m:02}-{d:02}")
}

//! Training spread over MPI ranks, launched the way users launch it (`mpirun -np 2 topa train …`): the ranks keep
//! bit-identical weights, 2 ranks × E envs learn like 1 rank × 2E, a killed rank ends the job and the last
//! checkpoint resumes. Built only with `--features mpi` (test.sh asks for it; setup installs Open MPI).
#![cfg(feature = "mpi")]

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const TOPA: &str = env!("CARGO_BIN_EXE_topa");

/// One MPI job at a time: each already runs two ranks on this machine's cores.
static ONE_JOB: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn one_job() -> std::sync::MutexGuard<'static, ()> {
    ONE_JOB.lock().unwrap_or_else(|e| e.into_inner())
}

fn tempdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("topa-mpi-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn mpirun(np: usize) -> Command {
    let mut c = Command::new("mpirun");
    c.args(["-np", &np.to_string(), "--oversubscribe"])
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .arg(TOPA);
    c
}

fn run(mut c: Command) -> Output {
    let out = c.output().expect("mpirun (install Open MPI: TOPA_MPI=1 scripts/setup.sh)");
    let text = String::from_utf8_lossy(&out.stderr).to_string() + &String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{c:?} failed:\n{text}");
    out
}

/// The cart-pole set-up of the PPO tests as a config file, with `envs` envs in all.
fn cartpole_file(dir: &Path, envs: usize, iterations: usize) -> PathBuf {
    let mut cfg = common::cartpole_config(1, iterations);
    cfg.run.num_envs = envs;
    cfg.run.checkpoint_every = 5;
    let path = dir.join(format!("cartpole-{envs}.toml"));
    std::fs::write(&path, toml::to_string(&cfg).unwrap()).unwrap();
    path
}

/// The ranks' final weight digests, in rank order, from their "rank r/N: policy weights crc32 …" reports
/// (searched anywhere in the output: mpirun may interleave the ranks' lines).
fn digests(out: &Output) -> Vec<String> {
    let text = String::from_utf8_lossy(&out.stderr);
    let mut d: Vec<(usize, String)> = text
        .match_indices(": policy weights crc32 ")
        .filter_map(|(at, m)| {
            let before = &text[..at];
            let rank = before[before.rfind("rank ")? + 5..].split('/').next()?.parse().ok()?;
            Some((rank, text[at + m.len()..].chars().take(8).collect()))
        })
        .collect();
    d.sort();
    d.into_iter().map(|(_, c)| c).collect()
}

/// Mean episode length per iteration (iterations that ended no episode are skipped).
fn lengths(run: &Path) -> Vec<f64> {
    let (header, rows) = trainer::metrics::read_csv(&run.join("metrics.csv")).unwrap();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (ep, len) = (col("episodes"), col("mean_length"));
    rows.iter().filter(|r| r[ep] > 0.0).map(|r| r[len]).collect()
}

fn train(np: usize, config: &Path, out: &Path) -> Output {
    let mut c = mpirun(np);
    c.args(["train", "--quiet", "--threads", "1", "--config"]).arg(config).arg("--out").arg(out);
    run(c)
}

#[test]
fn two_ranks_keep_identical_weights_and_learn_like_one_rank_with_all_the_envs() {
    let _one = one_job();
    let dir = tempdir("learn");
    let (two, one) = (dir.join("two"), dir.join("one"));
    let out = train(2, &cartpole_file(&dir, 32, 40), &two);
    let d = digests(&out);
    assert_eq!(d.len(), 2, "both ranks report: {}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(d[0], d[1], "the ranks' weights differ");
    assert!(String::from_utf8_lossy(&out.stderr).contains("2 MPI ranks × 16 envs"));
    // One process with all 32 envs (the envs are seeded the same way: env i of rank r is env 16r + i).
    train(1, &cartpole_file(&dir, 32, 40), &one);
    let (l2, l1) = (lengths(&two), lengths(&one));
    let best = |l: &[f64]| l.iter().cloned().fold(0.0, f64::max);
    let late = |l: &[f64]| l[l.len() - 5..].iter().sum::<f64>() / 5.0;
    eprintln!("2 ranks: first {:.1}, best {:.1}, last 5 {:.1}", l2[0], best(&l2), late(&l2));
    eprintln!("1 rank:  first {:.1}, best {:.1}, last 5 {:.1}", l1[0], best(&l1), late(&l1));
    // Both start unable to balance, both learn (200 = a whole episode), and the late episode lengths agree
    // within 25 % of an episode (rank 1 samples its own actions and advantages are normalised per rank, so the
    // curves are alike, not identical).
    assert!(l2[0] < 40.0 && l1[0] < 40.0, "a fresh policy does not balance yet: {} / {}", l2[0], l1[0]);
    assert!(best(&l2) > 150.0 && best(&l1) > 150.0, "both learn: {} / {}", best(&l2), best(&l1));
    assert!((late(&l2) - late(&l1)).abs() < 50.0, "late lengths {} vs {}", late(&l2), late(&l1));
    // Communication is reported per iteration.
    let (header, rows) = trainer::metrics::read_csv(&two.join("metrics.csv")).unwrap();
    let bytes = header.iter().position(|h| h == "comm_bytes").unwrap();
    assert!(rows[2][bytes] > 0.0, "comm bytes recorded");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn the_topa_task_learns_to_stand_on_two_ranks_and_on_one() {
    let _one = one_job();
    let dir = tempdir("topa");
    let base = concat!(env!("CARGO_MANIFEST_DIR"), "/configs/cpu.toml");
    let cfg_path = dir.join("stand.toml");
    std::fs::write(
        &cfg_path,
        format!(
            "base = \"{base}\"\n[run]\nnum_envs = 64\niterations = 40\ncheckpoint_every = 40\n\
             [network]\ninit_noise_std = 0.5\n[ppo]\nlearning_rate = 1e-3\n\
             [env.commands]\nstanding_share = 1.0\nturn_share = 0.0\n[env.push]\nenabled = false\n"
        ),
    )
    .unwrap();
    for np in [2, 1] {
        let out = dir.join(format!("np{np}"));
        train(np, &cfg_path, &out);
        let l = lengths(&out);
        // Standing only (no commands, no pushes) from a quieter start: episodes end by falls, ever later.
        let (first, last) = (l[..5].iter().sum::<f64>() / 5.0, l[l.len() - 5..].iter().sum::<f64>() / 5.0);
        eprintln!("{np} rank(s): mean episode length {first:.0} → {last:.0} policy steps (first / last 5 iterations)");
        assert!(last > 2.0 * first, "{np} rank(s): standing does not improve ({first:.0} → {last:.0})");
    }
    std::fs::remove_dir_all(dir).ok();
}

/// The PID of rank `rank` among the processes running with `needle` in their command line.
fn rank_pid(needle: &str, rank: usize) -> Option<u32> {
    std::fs::read_dir("/proc").ok()?.filter_map(|e| e.ok()?.file_name().to_str()?.parse::<u32>().ok()).find(|pid| {
        let cmd = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
        let env = std::fs::read(format!("/proc/{pid}/environ")).unwrap_or_default();
        let has = |hay: &[u8], s: &str| hay.windows(s.len()).any(|w| w == s.as_bytes());
        has(&cmd, needle) && !has(&cmd, "mpirun") && has(&env, &format!("OMPI_COMM_WORLD_RANK={rank}\0"))
    })
}

#[test]
fn a_killed_rank_ends_the_job_and_the_last_checkpoint_resumes_exactly() {
    let _one = one_job();
    let dir = tempdir("kill");
    let cfg = cartpole_file(&dir, 16, 100_000);
    let run_dir = dir.join("run");
    let mut c = mpirun(2);
    c.args(["train", "--quiet", "--threads", "1", "--config"]).arg(&cfg).arg("--out").arg(&run_dir);
    let job = c.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    let latest = run_dir.join("checkpoints/latest.json");
    let start = Instant::now();
    while !latest.exists() {
        assert!(start.elapsed() < Duration::from_secs(120), "no checkpoint after 2 minutes");
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(Duration::from_millis(500));
    let pid = rank_pid(run_dir.to_str().unwrap(), 1).expect("rank 1 is running");
    Command::new("kill").args(["-9", &pid.to_string()]).status().unwrap();
    let out = job.wait_with_output().unwrap();
    let text = String::from_utf8_lossy(&out.stderr).to_string() + &String::from_utf8_lossy(&out.stdout);
    assert!(!out.status.success(), "the job ends with an error when a rank dies");
    assert!(text.contains("rank 1") && text.contains("signal 9"), "mpirun names the dead rank:\n{text}");
    // The checkpoint on disk is whole: resume it (2 ranks) to 5 iterations past it…
    let side: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&latest).unwrap()).unwrap();
    let at = side["iteration"].as_u64().unwrap() as usize;
    let mut c = mpirun(2);
    c.args(["train", "--quiet", "--resume"]).arg(&run_dir).args(["--iterations", &(at + 5).to_string()]);
    let resumed = digests(&run(c));
    // … and it ends on the weights of a straight run to the same iteration.
    let straight_cfg = cartpole_file(&dir, 16, at + 5);
    let straight = digests(&train(2, &straight_cfg, &dir.join("straight")));
    assert_eq!(resumed, straight, "resumed after the kill vs a straight run to iteration {}", at + 5);
    // Another rank count is refused with what to do.
    let mut c = mpirun(1);
    c.args(["train", "--quiet", "--resume"]).arg(&run_dir);
    let out = c.output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("written by 2 MPI rank(s)") && err.contains("mpirun -np 2"), "{err}");
    std::fs::remove_dir_all(dir).ok();
}

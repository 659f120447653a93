//! `topa bench mpi`: the same training config on N MPI ranks against one rank with the same total threads,
//! run by `mpirun` one after the other (interleaved rounds, fastest kept): samples/s, their ratio, the share
//! of an iteration spent in communication and the bytes each rank moves per iteration.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::error::{bad_bench, invalid, Error, Result};

pub struct Args<'a> {
    pub config: &'a Path,
    pub ranks: usize,
    pub iterations: usize,
    pub warmup: usize,
    pub rounds: usize,
    pub mpirun: &'a str,
}

/// One launch's numbers, averaged over its timed iterations.
#[derive(Debug, Clone, Copy, Default)]
struct Launch {
    samples_per_s: f64,
    comm_share: f64,
    comm_s: f64,
    bytes_per_iteration: f64,
}

pub fn run(a: &Args) -> Result<()> {
    if a.ranks < 2 {
        invalid!("--ranks must be at least 2 (it is compared with one rank)");
    }
    let exe = std::env::current_exe().map_err(|e| Error::bench("locating the topa binary", e))?;
    let dir = std::env::temp_dir().join(format!("topa-bench-mpi-{}", std::process::id()));
    let mut best: [Option<Launch>; 2] = [None, None];
    for round in 0..a.rounds {
        for (k, (np, threads)) in [(1, a.ranks), (a.ranks, 1)].into_iter().enumerate() {
            let out = dir.join(format!("r{round}-np{np}"));
            let l = launch(a, &exe, np, threads, &out)?;
            eprintln!(
                "round {round}: {np} rank(s) × {threads} thread(s): {:.0} samples/s, comm {:.1}%",
                l.samples_per_s,
                100.0 * l.comm_share
            );
            if best[k].is_none_or(|b| l.samples_per_s > b.samples_per_s) {
                best[k] = Some(l);
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
    let (one, many) = (best[0].expect("one round"), best[1].expect("one round"));
    println!("| layout | samples/s | comm share | comm s/it | MB per rank per iteration |");
    println!("|---|---:|---:|---:|---:|");
    for (name, l) in [(format!("1 rank × {} threads", a.ranks), one), (format!("{} ranks × 1 thread", a.ranks), many)]
    {
        println!(
            "| {name} | {:.0} | {:.1}% | {:.4} | {:.2} |",
            l.samples_per_s,
            100.0 * l.comm_share,
            l.comm_s,
            l.bytes_per_iteration / 1e6
        );
    }
    println!(
        "\n{} ranks / 1 rank (same threads): {:.2}× samples/s; communication {:.1}% of an iteration, {:.2} MB per rank \
         per iteration (fastest of {} interleaved rounds, {} timed iterations after {} warm-up)",
        a.ranks,
        many.samples_per_s / one.samples_per_s,
        100.0 * many.comm_share,
        many.bytes_per_iteration / 1e6,
        a.rounds,
        a.iterations,
        a.warmup
    );
    Ok(())
}

fn launch(a: &Args, exe: &Path, np: usize, threads: usize, out: &PathBuf) -> Result<Launch> {
    let total = a.warmup + a.iterations;
    let status = Command::new(a.mpirun)
        .args(["-np", &np.to_string(), "--oversubscribe"])
        .arg(exe)
        .args(["train", "--quiet", "--threads", &threads.to_string(), "--iterations", &total.to_string()])
        .arg("--config")
        .arg(a.config)
        .arg("--out")
        .arg(out)
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .stdout(std::process::Stdio::null())
        .status()
        .map_err(|e| {
            Error::bench(format!("starting {} (install Open MPI: TOPA_MPI=1 scripts/setup.sh)", a.mpirun), e)
        })?;
    if !status.success() {
        bad_bench!("mpirun -np {np} topa train failed ({status})");
    }
    let (header, rows) = trainer::metrics::read_csv(&out.join("metrics.csv"))?;
    let col =
        |name: &str| header.iter().position(|h| h == name).ok_or_else(|| Error::bad_file(format!("no column {name}")));
    let (samples, collect, update, comm, bytes) =
        (col("samples")?, col("collect_s")?, col("update_s")?, col("comm_s")?, col("comm_bytes")?);
    let rows = &rows[a.warmup.min(rows.len())..];
    if rows.is_empty() {
        bad_bench!("no timed iterations in {}", out.display());
    }
    let sum = |c: usize| rows.iter().map(|r| r[c]).sum::<f64>();
    let wall = sum(collect) + sum(update);
    let n = rows.len() as f64;
    let per_iteration = (rows.last().unwrap()[samples] - rows[0][samples]) / (n - 1.0).max(1.0);
    Ok(Launch {
        samples_per_s: per_iteration * n / wall,
        comm_share: sum(comm) / wall,
        comm_s: sum(comm) / n,
        bytes_per_iteration: sum(bytes) / n,
    })
}

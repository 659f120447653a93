//! `topa train`: a run (`topa_train::Run`) with a progress bar, or a status line every 10 iterations.

use anyhow::Result;
use indicatif::{ProgressBar, ProgressStyle};
use topa_train::{Run, Start};

use crate::cli::TrainArgs;
use trainer::IterationLog;

fn progress_line(log: &IterationLog, total: usize) -> String {
    let e = &log.episodes;
    let phase = match log.phase.number() {
        1 => "phase 1".to_string(),
        p => format!("phase {p} c{}", log.cycle),
    };
    // Envs that start together (a new run, a fork) also time out together, so most iterations end no episode.
    let episodes = if e.episodes == 0 {
        "no episode ended".to_string()
    } else {
        format!("return {:.2} | length {:.0}", e.mean_return, e.mean_length)
    };
    let comm = if log.comm.calls > 0 {
        format!(
            " | comm {:.0}% {:.1} MB",
            100.0 * log.comm.seconds / log.wall_time_delta(),
            log.comm.bytes as f64 / 1e6
        )
    } else {
        String::new()
    };
    format!(
        "it {}/{total} {phase} | {episodes} | {:.0} samples/s{comm}{}",
        log.iteration,
        log.fps,
        if e.diverged > 0 { format!(" | {} diverged", e.diverged) } else { String::new() }
    )
}

/// The command as a user would retype it: `topa` and the arguments, whatever the binary's path.
fn command_line() -> String {
    std::iter::once("topa".to_string()).chain(std::env::args().skip(1)).collect::<Vec<_>>().join(" ")
}

pub(crate) fn run(args: TrainArgs) -> Result<()> {
    let run = Run::open(&Start {
        config: args.config,
        robot: args.model.map(|m| m.spec_path().to_string()).or(args.robot.map(|r| r.to_string_lossy().into_owned())),
        seed: args.seed,
        out: args.out,
        adversary: args.adversary,
        threads: args.threads,
        iterations: args.iterations,
        resume: args.resume,
        init_from: args.init_from,
        command: command_line(),
    })?;
    let lead = run.is_lead();
    if let Some(n) = &run.notice {
        eprintln!("{n}");
    }
    if run.ranks() > 1 && lead {
        eprintln!(
            "{} MPI ranks × {} envs; after an interruption: mpirun -np {} topa train --resume {}",
            run.ranks(),
            run.trainer.env.num_envs(),
            run.ranks(),
            run.out.display()
        );
    }
    let (rank, ranks, out) = (run.trainer.comm.rank(), run.ranks(), run.out.clone());
    let total = run.trainer.total_iterations();
    let bar = if args.quiet || !lead { ProgressBar::hidden() } else { ProgressBar::new(total as u64) };
    bar.set_style(ProgressStyle::with_template("{bar:30} {msg} | ETA {eta}").unwrap());
    bar.set_position(run.trainer.iteration as u64);
    let o = run.train(|log| {
        bar.set_position(log.iteration as u64);
        bar.set_message(progress_line(log, total));
        if args.quiet && lead && log.iteration % 10 == 0 {
            say(&progress_line(log, total));
        }
    })?;
    bar.finish();
    if let Some(crc) = o.weights_crc {
        say(&format!("rank {rank}/{ranks}: policy weights crc32 {crc:08x}"));
    }
    let Some(metrics) = o.metrics else { return Ok(()) };
    println!(
        "trained {} iterations ({} samples, {:.0} s this session) → {}",
        o.iterations,
        o.samples,
        o.seconds,
        o.policy.display()
    );
    let curve = o.curve.map_or("none".to_string(), |c| c.display().to_string());
    println!("metrics: {}, TensorBoard: {}, curve: {curve}", metrics.display(), out.join("tb").display());
    Ok(())
}

/// One line to stderr in a single write: `eprintln!` writes a formatted line piece by piece, and the lines of
/// MPI ranks sharing one stderr then interleave mid-line.
fn say(line: &str) {
    use std::io::Write;
    let _ = std::io::stderr().lock().write_all(format!("{line}\n").as_bytes());
}

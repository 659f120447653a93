//! Per-iteration scalars to `metrics.csv` (one row per iteration, each reward term a column) and to a TensorBoard
//! event file (`tb/`), which TensorBoard and most experiment trackers read.

use std::fs::OpenOptions;
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

use crate::ppo::UpdateStats;
use crate::train::IterationLog;

pub struct MetricsWriter {
    csv_path: PathBuf,
    csv: std::fs::File,
    columns: Vec<String>,
    perturbation_columns: usize,
    tb: tboard::EventWriter<std::fs::File>,
    tb_dir: PathBuf,
}

fn update_columns(prefix: &str) -> Vec<String> {
    [
        "surrogate",
        "value_loss",
        "entropy",
        "symmetry_loss",
        "decay_loss",
        "estimator_loss",
        "estimator_rmse",
        "kl",
        "lr",
        "clip_fraction",
        "grad_norm",
        "skipped",
    ]
    .iter()
    .map(|c| format!("{prefix}_{c}"))
    .collect()
}

fn update_values(u: &Option<UpdateStats>) -> Vec<f64> {
    match u {
        Some(u) => vec![
            u.surrogate,
            u.value_loss,
            u.entropy,
            u.symmetry_loss,
            u.decay_loss,
            u.estimator_loss,
            u.estimator_rmse,
            u.kl,
            u.learning_rate,
            u.clip_fraction,
            u.grad_norm,
            u.skipped as f64,
        ],
        None => vec![f64::NAN; 12],
    }
}

impl MetricsWriter {
    /// Opens `dir/metrics.csv` and a new event file under `dir/tb/`, with a column per reward term and per
    /// perturbation channel (`perturb_<name>`). When resuming at `resume_iteration`, rows after it (written before
    /// the interruption, and about to be redone) are dropped.
    pub fn open(
        dir: &Path,
        term_names: &[String],
        perturbation_names: &[String],
        resume_iteration: Option<usize>,
    ) -> Result<Self> {
        std::fs::create_dir_all(dir).map_err(Error::io("creating", dir))?;
        let mut columns: Vec<String> = [
            "iteration",
            "phase",
            "cycle",
            "samples",
            "wall_time_s",
            "fps",
            "collect_s",
            "inference_s",
            "update_s",
            "comm_s",
            "comm_bytes",
            "episodes",
            "mean_return",
            "mean_length",
            "time_out_share",
            "diverged",
            "mean_step_reward",
            "action_std",
            "curriculum_level",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        columns.extend(perturbation_names.iter().map(|p| format!("perturb_{p}")));
        let perturbation_columns = perturbation_names.len();
        columns.extend(update_columns("policy"));
        columns.extend(update_columns("adversary"));
        columns.extend(term_names.iter().map(|t| format!("rew_{t}")));
        let csv_path = dir.join("metrics.csv");
        let header = columns.join(",");
        // On resume keep the rows up to the checkpoint (later ones are about to be redone), re-ordered into the
        // current columns by name, so a run continued by a newer build keeps its history.
        let kept = match (resume_iteration, std::fs::read_to_string(&csv_path)) {
            (Some(it), Ok(text)) => {
                let mut lines = text.lines();
                let old: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
                let index: Vec<Option<usize>> = columns.iter().map(|c| old.iter().position(|o| o == c)).collect();
                lines
                    .filter(|l| l.split(',').next().and_then(|v| v.parse::<usize>().ok()).is_some_and(|i| i <= it))
                    .map(|l| {
                        let cells: Vec<&str> = l.split(',').collect();
                        let row: Vec<&str> =
                            index.iter().map(|i| i.and_then(|i| cells.get(i).copied()).unwrap_or("")).collect();
                        format!("{}\n", row.join(","))
                    })
                    .collect::<String>()
            }
            _ => String::new(),
        };
        crate::tensorfile::write_atomic(&csv_path, format!("{header}\n{kept}").as_bytes())?;
        let csv = OpenOptions::new().append(true).open(&csv_path).map_err(Error::io("cannot open", &csv_path))?;
        let tb_dir = dir.join("tb");
        let tb = open_events(&tb_dir, resume_iteration)?;
        Ok(MetricsWriter { csv_path, csv, columns, perturbation_columns, tb, tb_dir })
    }

    pub fn csv_path(&self) -> &Path {
        &self.csv_path
    }

    pub fn write(&mut self, log: &IterationLog) -> Result<()> {
        let e = &log.episodes;
        let mut values = vec![
            log.iteration as f64,
            log.phase.number() as f64,
            log.cycle as f64,
            log.samples as f64,
            log.wall_time_s,
            log.fps,
            log.collect_s,
            log.inference_s,
            log.update_s,
            log.comm.seconds,
            log.comm.bytes as f64,
            e.episodes as f64,
            e.mean_return,
            e.mean_length,
            e.time_out_share,
            e.diverged as f64,
            log.mean_step_reward,
            log.action_std,
            e.curriculum_level.unwrap_or(f64::NAN),
        ];
        // Zeros while no adversary acts (phase 1, or a run without one).
        values.extend((0..self.perturbation_columns).map(|i| log.perturbation.get(i).copied().unwrap_or(0.0)));
        values.extend(update_values(&log.policy));
        values.extend(update_values(&log.adversary));
        values.extend(e.mean_terms.iter().copied());
        values.resize(self.columns.len(), f64::NAN);
        let row: Vec<String> = values.iter().map(|v| if v.is_nan() { String::new() } else { format!("{v}") }).collect();
        let io = || Error::io("writing", &self.csv_path);
        writeln!(self.csv, "{}", row.join(",")).map_err(io())?;
        self.csv.flush().map_err(io())?;
        let step = log.iteration as i64;
        for (name, v) in self.columns.iter().zip(&values).skip(1) {
            if v.is_nan() || (e.episodes == 0 && is_episode_column(name)) {
                continue;
            }
            self.tb
                .write_scalar(step, &tb_tag(name), *v as f32)
                .map_err(|source| Error::TensorBoard { dir: self.tb_dir.clone(), source })?;
        }
        self.tb.flush().map_err(|source| Error::TensorBoard { dir: self.tb_dir.clone(), source })?;
        Ok(())
    }
}

/// A new event file under `tb`. On resume, the records of the earlier files up to the checkpoint's iteration are
/// carried into it and the earlier files removed: iterations after the checkpoint are about to be redone, and
/// TensorBoard (or any other reader) would otherwise show them twice. The new file is complete before an old one
/// goes, and records are keyed by (step, tag), so an interrupted rewrite leaves no duplicate either.
fn open_events(tb: &Path, resume_iteration: Option<usize>) -> Result<tboard::EventWriter<std::fs::File>> {
    let te = |source: tboard::Error| Error::TensorBoard { dir: tb.to_path_buf(), source };
    let mut old: Vec<PathBuf> = match (resume_iteration, std::fs::read_dir(tb)) {
        (Some(_), Ok(entries)) => entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with("events.out.tfevents")))
            .collect(),
        _ => Vec::new(),
    };
    old.sort();
    let mut kept: std::collections::BTreeMap<(i64, String), tboard::tensorboard::Event> = Default::default();
    for f in &old {
        let file = std::fs::File::open(f).map_err(Error::io("cannot read", f))?;
        // A run killed mid-write leaves a torn last record: what precedes it is whole (CRC-checked).
        for event in tboard::SummaryReader::new(std::io::BufReader::new(file)).map_while(|e| e.ok()) {
            let Some(tboard::tensorboard::event::What::Summary(summary)) = &event.what else { continue };
            let tag = summary.value.first().map_or(String::new(), |v| v.tag.clone());
            if event.step as usize <= resume_iteration.unwrap_or(0) {
                kept.insert((event.step, tag), event);
            }
        }
    }
    let mut writer = tboard::EventWriter::create(tb).map_err(te)?;
    for event in kept.into_values() {
        writer.write_event(event).map_err(te)?;
    }
    writer.flush().map_err(te)?;
    for f in old.iter().filter(|f| Some(*f) != writer.filename()) {
        std::fs::remove_file(f).map_err(Error::io("cannot remove", f))?;
    }
    Ok(writer)
}

/// Columns that describe the episodes that ended in an iteration (meaningless when none did).
pub fn is_episode_column(name: &str) -> bool {
    name.starts_with("rew_") || ["mean_return", "mean_length", "time_out_share"].contains(&name)
}

/// Groups scalars in TensorBoard: "episode/…", "policy/…", "adversary/…", "reward/…", "perf/…".
fn tb_tag(column: &str) -> String {
    if let Some(t) = column.strip_prefix("rew_") {
        return format!("reward/{t}");
    }
    for p in ["policy_", "adversary_", "perturb_"] {
        if let Some(t) = column.strip_prefix(p) {
            return format!("{}/{t}", p.trim_end_matches('_'));
        }
    }
    match column {
        "fps" | "collect_s" | "inference_s" | "update_s" | "comm_s" | "comm_bytes" | "wall_time_s" | "samples" => {
            format!("perf/{column}")
        }
        _ => format!("episode/{column}"),
    }
}

/// Reads `metrics.csv` back: column names and rows (empty cells as NaN). For plots and tests.
pub fn read_csv(path: &Path) -> Result<(Vec<String>, Vec<Vec<f64>>)> {
    let text = std::fs::read_to_string(path).map_err(Error::io("cannot read", path))?;
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap_or("").split(',').map(str::to_string).collect();
    let rows = lines.map(|l| l.split(',').map(|v| v.parse().unwrap_or(f64::NAN)).collect()).collect();
    Ok((header, rows))
}

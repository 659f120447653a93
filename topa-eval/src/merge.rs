//! Reports joined from several files (`--merge`), one refusal rule for every kind: each part must be the report
//! its command writes, run with the same protocol and evaluation settings as the first; every policy's weights
//! must be the ones the policy file holds now (a seed retrained in place after it was measured is refused) and the
//! same in every part; and no policy may count twice. What joins beyond that (the field test's sim2sim modes) is
//! the kind's own rule.

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;

use crate::error::{ensure, Error, Result};
use crate::settings::EvalSettings;

/// A report that `--merge` can join.
pub trait Mergeable: DeserializeOwned {
    /// Its file's name (`ablation.json`), for messages.
    const FILE: &'static str;
    /// The command that writes it (`topa ablate`), for messages.
    const COMMAND: &'static str;
    /// What must be the same in every part, comparable, and in words for a refusal.
    fn protocol(&self) -> (serde_json::Value, String);
    /// The evaluation settings every part must share (None in files written before reports recorded them).
    fn settings(&self) -> Option<&EvalSettings>;
    /// Each policy measured, with the CRC-32 of the weights measured (None in files from before weights were
    /// recorded).
    fn measured(&self) -> Vec<(PathBuf, Option<u32>)>;
    /// Whether a policy may stand in two parts (its results then join, as the field test's sim2sim modes do);
    /// otherwise it is refused: it would count as two seeds.
    const JOINS_A_POLICY: bool = false;
    /// Adds a later part's results.
    fn absorb(&mut self, part: Self) -> Result<()>;
    /// Puts the joined results in the report's order.
    fn finish(&mut self) {}
}

/// Joins `files` (one file reads back and renders again, e.g. to attach another report).
pub fn merge<R: Mergeable>(files: &[PathBuf]) -> Result<R> {
    ensure!(!files.is_empty(), "--merge takes one or more {} files", R::FILE);
    let mut out: Option<(&PathBuf, R)> = None;
    let mut weights: Vec<(PathBuf, u32, &PathBuf)> = Vec::new();
    let mut held: Vec<PathBuf> = Vec::new();
    for f in files {
        let part: R = read(f, "--merge")?;
        for (policy, crc) in part.measured() {
            ensure!(
                R::JOINS_A_POLICY || !held.contains(&policy),
                "--merge: policy {} is in more than one file ({} among them); it would count as two seeds",
                policy.display(),
                f.display()
            );
            held.push(policy.clone());
            let Some(crc) = crc else { continue };
            still_current::<R>(f, &policy, crc)?;
            if let Some((_, other, g)) = weights.iter().find(|(p, ..)| *p == policy) {
                ensure!(
                    *other == crc,
                    "--merge: {} was measured with other weights in {} than in {} (retrained in between?); run \
                     `{}` on the current policy again",
                    policy.display(),
                    f.display(),
                    g.display(),
                    R::COMMAND
                );
            }
            weights.push((policy, crc, f));
        }
        let Some((first, all)) = &mut out else {
            out = Some((f, part));
            continue;
        };
        let ((ours, ours_text), (theirs, theirs_text)) = (part.protocol(), all.protocol());
        ensure!(
            ours == theirs,
            "--merge: {} was run with another protocol ({ours_text}) than {} ({theirs_text}); re-run one of them \
             with the other's flags",
            f.display(),
            first.display()
        );
        if let (Some(a), Some(b)) = (part.settings(), all.settings()) {
            ensure!(
                a.same_results_as(b)?,
                "--merge: {} was run with other evaluation settings (timestep, sim2sim, integrator, settle time or \
                 seed) than {}; merge only runs made with the same flags",
                f.display(),
                first.display()
            );
        }
        all.absorb(part)?;
    }
    let (_, mut all) = out.expect("at least one file");
    all.finish();
    Ok(all)
}

/// Reads a report of kind `R` that the flag `flag` named: one error naming the file and what to give instead.
pub fn read<R: Mergeable>(file: &Path, flag: &str) -> Result<R> {
    let text =
        std::fs::read_to_string(file).map_err(|e| Error::file(format!("{flag}: cannot read {}", file.display()), e))?;
    serde_json::from_str(&text).map_err(|e| {
        let article = if R::FILE.starts_with(['a', 'e', 'i', 'o', 'u']) { "an" } else { "a" };
        let m = format!(
            "{flag}: {} is not {article} {} written by `{}` (give that file)",
            file.display(),
            R::FILE,
            R::COMMAND
        );
        Error::file(m, e)
    })
}

/// Refuses a result whose policy file, still at its path, now holds other weights than the ones measured; a file
/// not on this machine is let through.
fn still_current<R: Mergeable>(file: &Path, policy: &Path, measured: u32) -> Result<()> {
    if !policy.exists() {
        return Ok(());
    }
    let now = trainer::policy_file::Policy::load(policy)?.meta.weights_crc32;
    ensure!(
        now == measured,
        "--merge: {} measured {} with weights of CRC-32 {measured:08x}, but that policy now holds {now:08x} \
         (retrained or replaced): run `{}` on it again",
        file.display(),
        policy.display(),
        R::COMMAND
    );
    Ok(())
}

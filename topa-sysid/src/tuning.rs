//! `topa sysid estimator` as a job: the realistic sim2sim recorded twice (or two recordings given), the state
//! estimator tuned on one and checked on the other, the policy walked again on the tuned estimate (closed loop),
//! and the tuned sim2sim written so that `--sim2sim` reads it back to the same values.

use std::path::Path;

use crate::error::{Error, Result};
use topa_eval::settings::{EvalSettings, Sim2SimMode};

use crate::estimator;

/// Tunes the estimator into `out` (estimator.toml, .md, .json; the recordings as CSV); returns the report.
pub fn run(
    policy: &Path,
    seconds: f64,
    recording: Option<&Path>,
    held_out: Option<&Path>,
    seed: u64,
    out: &Path,
) -> Result<String> {
    let base = EvalSettings { seed, threads: 1, ..EvalSettings::default() }.with_sim2sim(&Sim2SimMode::Realistic)?;
    let default = base.sim2sim.estimator.filter.clone();
    let (fit, held, mut runner) = match (recording, held_out) {
        (Some(r), Some(h)) => (estimator::read_csv(r)?, estimator::read_csv(h)?, None),
        _ => {
            let mut runner = topa_env::policy_runner::PolicyRunner::load(policy, "policy")?;
            eprintln!("recording {seconds} s of the realistic sim2sim twice (seeds {seed} and {})", seed + 1);
            let fit = estimator::record(&mut runner, &base, seconds)?;
            let held = estimator::record(&mut runner, &EvalSettings { seed: seed + 1, ..base.clone() }, seconds)?;
            topa_eval::report::write_text(out, "recording.csv", &estimator::to_csv(&fit))?;
            topa_eval::report::write_text(out, "held_out.csv", &estimator::to_csv(&held))?;
            (fit, held, Some(runner))
        }
    };
    let t = estimator::tune(&default, &fit, &held)?;
    let mut tuned = base.sim2sim.clone();
    tuned.estimator.filter = t.tuned.clone();
    // Closed loop: the policy walking on the tuned filter's estimate, against the default's, on the held-out seed.
    let closed = match &mut runner {
        None => None,
        Some(r) => {
            let s = EvalSettings { seed: seed + 1, sim2sim: tuned.clone(), ..base.clone() };
            let rec = estimator::record(r, &s, seconds)?;
            let online = |v: &[topa_env::sim2sim::FilterSample]| {
                estimator::rmse(&v.iter().map(|x| x.estimate).collect::<Vec<_>>(), v)
            };
            Some([online(&held), online(&rec)])
        }
    };
    let toml = format!(
        "# The realistic sim2sim with the state estimator tuned by `topa sysid estimator` (use: --sim2sim <this file>).\n{}",
        toml::to_string(&tuned)?
    );
    topa_eval::report::write_text(out, "estimator.toml", &toml)?;
    // The file is what `--sim2sim` will read: it must load back to these values.
    let back = EvalSettings::default().with_sim2sim(&Sim2SimMode::File(out.join("estimator.toml")))?;
    if back.sim2sim != tuned {
        return Err(Error::bad_file("estimator.toml does not load back to the tuned values (a bug)"));
    }
    topa_eval::report::write_json(out, "estimator.json", &(&t, closed))?;
    let md = estimator::markdown(&t, closed);
    topa_eval::report::write_text(out, "estimator.md", &md)?;
    Ok(md)
}

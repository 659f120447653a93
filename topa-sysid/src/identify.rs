//! `topa sysid fit` end to end: the log split into fitted and held-out parts, the fit, the check against hidden
//! true values when they are known (synthetic logs), and what it writes — identified.{json,md}, the plot of measured
//! against simulated positions, and the bench MJCF with the identified values (a new file).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::error::{ensure, Result};
use plotters::prelude::*;
use serde::{Deserialize, Serialize};

use super::bench::{windows, Bench, Params, Window};
use super::fit::{self, FitOptions, FitResult, Kind};
use super::log::MotorLog;
use topa_train::plots::{err, register_font};

/// A fitted value against the hidden true one.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TruthError {
    pub kind: Kind,
    pub motor: usize,
    pub truth: f64,
    /// (fitted − true) / true; for the delay, in physics steps.
    pub error: f64,
    pub in_ci: bool,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TruthCheck {
    pub params: Params,
    /// The true parameters' own held-out RMSE: the floor that noise and initial states put under any fit, rad.
    pub held_out_floor: f64,
    pub errors: Vec<TruthError>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Identification {
    pub bench: PathBuf,
    pub log: PathBuf,
    pub motors: Vec<String>,
    pub timestep: f64,
    /// Seconds of log fitted and held out, and the window length.
    pub fitted_s: f64,
    pub held_out_s: f64,
    pub window_s: f64,
    pub burn_in_s: f64,
    pub fit: FitResult,
    /// Position RMSE on the held-out part, rad: start values, fitted values.
    pub held_out_rmse_start: f64,
    pub held_out_rmse: f64,
    pub truth: Option<TruthCheck>,
    pub wall_s: f64,
    pub threads: usize,
}

/// What to fit and how to hold out.
pub struct Plan<'a> {
    pub bench: &'a Bench,
    pub log: &'a MotorLog,
    pub log_path: &'a Path,
    /// A separate held-out log, or the last `held_out_fraction` of `log`.
    pub held_out: Option<&'a MotorLog>,
    pub held_out_fraction: f64,
    pub window_s: f64,
    pub options: FitOptions,
    pub start: Params,
    pub truth: Option<Params>,
}

pub fn identify(plan: &Plan) -> Result<Identification> {
    let t0 = std::time::Instant::now();
    let (log, n) = (plan.log, plan.log.time.len());
    let burn_in_s = plan.bench.burn_in as f64 * log.step();
    ensure!(plan.window_s > burn_in_s, "--window {} s must be longer than the burn-in {burn_in_s} s", plan.window_s);
    let step = log.step();
    let per_window = ((plan.window_s / step).round() as usize).max(3);
    ensure!((0.0..0.9).contains(&plan.held_out_fraction), "--held-out {} must be in [0, 0.9)", plan.held_out_fraction);
    let split = if plan.held_out.is_some() { n } else { ((1.0 - plan.held_out_fraction) * n as f64) as usize };
    let fitted = windows(0, split, per_window);
    let held_log = plan.held_out.unwrap_or(log);
    let held: Vec<Window> = match plan.held_out {
        Some(h) => windows(0, h.time.len(), per_window),
        None => windows(split, n, per_window),
    };
    ensure!(!fitted.is_empty(), "the log is too short to fit (a window is {} s)", plan.window_s);
    let options = FitOptions { window: per_window, ..plan.options.clone() };
    let result = fit::fit(plan.bench, log, &fitted, &plan.start, &options)?;
    let held_out_rmse = fit::rmse(plan.bench, held_log, &held, &result.params)?;
    let held_out_rmse_start = fit::rmse(plan.bench, held_log, &held, &plan.start)?;
    let truth = match &plan.truth {
        None => None,
        Some(t) => Some(TruthCheck {
            params: t.clone(),
            held_out_floor: fit::rmse(plan.bench, held_log, &held, t)?,
            errors: result
                .estimates
                .iter()
                .map(|e| {
                    let truth = e.kind.get(t, e.motor);
                    TruthError {
                        kind: e.kind,
                        motor: e.motor,
                        truth,
                        error: if e.kind == Kind::Delay {
                            (e.value - truth) / plan.bench.timestep()
                        } else {
                            (e.value - truth) / truth
                        },
                        in_ci: e.ci95[0] <= truth && truth <= e.ci95[1],
                    }
                })
                .collect(),
        }),
    };
    Ok(Identification {
        bench: plan.bench.path.clone(),
        log: plan.log_path.to_path_buf(),
        motors: plan.bench.motors.iter().map(|m| m.name.clone()).collect(),
        timestep: plan.bench.timestep(),
        fitted_s: split as f64 * step,
        held_out_s: held.iter().map(|(a, b)| b - a).sum::<usize>() as f64 * step,
        window_s: per_window as f64 * step,
        burn_in_s,
        fit: result,
        held_out_rmse_start,
        held_out_rmse,
        truth,
        wall_s: t0.elapsed().as_secs_f64(),
        threads: rayon::current_num_threads(),
    })
}

/// The report: per motor each fitted value with its 95 % interval (and the true value when known), the delay,
/// the residuals.
pub fn markdown(id: &Identification) -> String {
    let f = &id.fit;
    let mut s = format!(
        "# Actuator identification\n\nBench `{}`, log `{}`: {} motors, {:.1} s fitted in windows of {:.2} s (the \
         first {} s of each left out of the comparison), {:.1} s held out; MuJoCo timestep {} s. {} after {} evaluations ({}), {:.1} s wall on {} threads.\n\n",
        id.bench.display(),
        id.log.display(),
        id.motors.len(),
        id.fitted_s,
        id.window_s,
        id.burn_in_s,
        id.held_out_s,
        id.timestep,
        if f.converged { "Converged" } else { "**Did not converge**: the values below are the best found" },
        f.evaluations,
        f.termination,
        id.wall_s,
        id.threads
    );
    let kinds: Vec<Kind> =
        Kind::ALL.into_iter().filter(|k| *k != Kind::Delay && f.estimates.iter().any(|e| e.kind == *k)).collect();
    s.push_str("| motor |");
    for k in &kinds {
        let _ = write!(s, " {} ({}) |", k.name(), k.unit());
    }
    s.push_str("\n|---|");
    s.push_str(&"---:|".repeat(kinds.len()));
    s.push('\n');
    let cell = |e: &fit::Estimate| {
        let mut c = format!("{:.4} [{:.4}, {:.4}]", e.value, e.ci95[0], e.ci95[1]);
        if e.at_bound {
            c.push_str(" (at its bound)");
        }
        if let Some(t) =
            id.truth.as_ref().and_then(|t| t.errors.iter().find(|x| x.kind == e.kind && x.motor == e.motor))
        {
            let unit = if e.kind == Kind::Delay { " steps".to_string() } else { " %".to_string() };
            let err = if e.kind == Kind::Delay { t.error } else { 100.0 * t.error };
            let _ = write!(c, "; true {:.4}, {err:+.1}{unit}{}", t.truth, if t.in_ci { "" } else { ", outside" });
        }
        c
    };
    for (m, name) in id.motors.iter().enumerate() {
        let _ = write!(s, "| {name} |");
        for k in &kinds {
            match f.estimates.iter().find(|e| e.kind == *k && e.motor == m) {
                Some(e) => {
                    let _ = write!(s, " {} |", cell(e));
                }
                None => s.push_str(" – |"),
            }
        }
        s.push('\n');
    }
    if let Some(e) = f.estimates.iter().find(|e| e.kind == Kind::Delay) {
        let _ = writeln!(s, "\nCommand-to-torque delay (all drives), s: {}", cell(e));
    }
    let _ = writeln!(
        s,
        "\nPosition RMSE, rad: fitted part {:.2e} at the start values → {:.2e}; held out {:.2e} → {:.2e}{}. Residual \
         lag-1 autocorrelation {:.2} (the intervals are widened by (1 + ρ)/(1 − ρ) for it).",
        f.rmse_start,
        f.rmse,
        id.held_out_rmse_start,
        id.held_out_rmse,
        id.truth
            .as_ref()
            .map(|t| format!(
                " (the true values' own: {:.2e}, ratio {:.2})",
                t.held_out_floor,
                id.held_out_rmse / t.held_out_floor
            ))
            .unwrap_or_default(),
        f.residual_autocorrelation
    );
    s
}

/// Measured against simulated positions (start and fitted values) of one motor over the first held-out seconds.
pub fn plot(bench: &Bench, log: &MotorLog, span: Window, start: &Params, fitted: &Params, png: &Path) -> Result<()> {
    register_font();
    let win = [span];
    let (a, b) = span;
    let t: Vec<f64> = log.time[(a + 1 + bench.burn_in).min(b)..b].to_vec();
    let k = bench.motors.len();
    let series = |v: Vec<f64>| -> Vec<(f64, f64)> { t.iter().zip(v.chunks(k)).map(|(t, q)| (*t, q[0])).collect() };
    let measured = series(bench.measured(log, &win));
    let before = series(bench.simulate(start, log, &win)?);
    let after = series(bench.simulate(fitted, log, &win)?);
    let (lo, hi) = measured
        .iter()
        .chain(&before)
        .chain(&after)
        .fold((f64::MAX, f64::MIN), |(l, h), (_, q)| (l.min(*q), h.max(*q)));
    let pad = 0.05 * (hi - lo).max(1e-6);
    let root = BitMapBackend::new(png, (900, 420)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("{}: measured and simulated position (held out)", bench.motors[0].name), ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(t[0]..t[t.len() - 1], lo - pad..hi + pad)
        .map_err(err)?;
    chart.configure_mesh().x_desc("time (s)").y_desc("position (rad)").draw().map_err(err)?;
    for (data, color, label) in
        [(measured, BLACK, "measured"), (before, RGBColor(200, 120, 40), "start values"), (after, BLUE, "fitted")]
    {
        chart
            .draw_series(LineSeries::new(data, color))
            .map_err(err)?
            .label(label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color));
    }
    chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw().map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

/// The bench MJCF with the identified joint values and the torque constant folded into the actuator gains, as a new
/// file (MuJoCo writes it flattened).
pub fn write_patched_mjcf(bench: &Path, params: &Params, motors: &[String], out: &Path) -> Result<()> {
    let mut m = mujoco::Model::from_xml_path(bench)?;
    let mut pairs = Vec::new();
    for name in motors {
        let a = m.id(mujoco::ObjType::Actuator, name)?;
        pairs.push((m.jnt_dofadr_of(m.actuator_trnid()[a][0] as usize), a));
    }
    params.actuators(&(0..pairs.len()).collect::<Vec<_>>()).put(&mut m, &pairs);
    m.save_last_xml(out)?;
    Ok(())
}

/// When the fitted motors are the robot's (`assets/robots/topa_closed.toml`'s, by name), the realistic sim2sim with
/// the identified values on the evaluation model (`identified_sim2sim.toml`, for `--sim2sim`); the name written, or
/// an empty string.
pub fn write_sim2sim(id: &Identification, out: &Path) -> Result<String> {
    use topa_eval::settings::{EvalSettings, Sim2SimMode};
    let spec = topa_env::assets::resolve_path("assets/robots/topa_closed.toml");
    let Ok((spec, _)) = topa_env::spec::RobotSpec::load(&spec) else { return Ok(String::new()) };
    let order: Option<Vec<usize>> =
        spec.motors.iter().map(|m| id.motors.iter().position(|n| *n == m.actuator)).collect();
    let Some(order) = order else { return Ok(String::new()) };
    let mut cfg = EvalSettings::default().with_sim2sim(&Sim2SimMode::Realistic)?.sim2sim;
    cfg.actuators = topa_env::sim2sim::actuators::ActuatorConfig { enabled: true, ..id.fit.params.actuators(&order) };
    let text = format!(
        "# The realistic sim2sim with the motors identified by `topa sysid fit` on the evaluation model \
         (use: --sim2sim <this file>).\n# Identified command delay: {:.4} s (the sim2sim's own latency stays as it is).\n{}",
        id.fit.params.delay_s,
        toml::to_string(&cfg)?
    );
    topa_eval::report::write_text(out, "identified_sim2sim.toml", &text)?;
    Ok(", identified_sim2sim.toml".into())
}

/// Writes an identification's report into `out`: identified.json and .md, the plot of the first 2 s held out
/// (fit.png), the bench's MJCF with the identified values, and the realistic sim2sim's motor section; returns the
/// report, the MJCF written and the sim2sim file's note.
pub fn write(
    id: &Identification,
    b: &Bench,
    log: &MotorLog,
    held: Option<&MotorLog>,
    start: &Params,
    bench: &Path,
    out: &Path,
) -> Result<(String, PathBuf, String)> {
    let md = markdown(id);
    topa_eval::report::write_json(out, "identified.json", id)?;
    topa_eval::report::write_text(out, "identified.md", &md)?;
    // The plot: the first 2 s held out.
    let (plot_log, from) = match held {
        Some(h) => (h, 0),
        None => (log, (id.fitted_s / log.step()).round() as usize),
    };
    let to = (from + (2.0 / log.step()) as usize).min(plot_log.time.len());
    if let Some(&span) = windows(from, to, usize::MAX / 2).first().filter(|(s, e)| e - s > b.burn_in + 2) {
        plot(b, plot_log, span, start, &id.fit.params, &out.join("fit.png"))?;
    }
    let stem = bench.file_stem().map_or("bench".into(), |s| s.to_string_lossy().into_owned());
    let xml = out.join(format!("{stem}_identified.xml"));
    write_patched_mjcf(bench, &id.fit.params, &id.motors, &xml)?;
    let sim2sim = write_sim2sim(id, out)?;
    Ok((md, xml, sim2sim))
}

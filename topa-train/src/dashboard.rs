//! The training dashboard: one or several runs' `metrics.csv` as small multiples — return and episode length,
//! each reward term, the PPO losses, KL against its target, learning rate, entropy, samples/s and the adversary's
//! perturbation sizes — raw values faint under TensorBoard's exponential moving average, adversary phases shaded.
//! Several runs of a group are drawn as their mean with a min–max band, aligned by samples. Every line is clipped
//! to its axes and every axis gets distinct, readable tick labels, whatever the scale.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::error::{run_error, Error, Result};

/// TensorBoard's default smoothing weight.
pub const SMOOTHING: f64 = 0.6;
const COLS: usize = 4;
const PANEL: (u32, u32) = (440, 270);
const HEADER: u32 = 50;
/// Group colours; runs of one group share its colour (lines are drawn only inside plotting areas).
const PALETTE: [RGBColor; 4] =
    [RGBColor(31, 119, 180), RGBColor(214, 39, 40), RGBColor(44, 160, 44), RGBColor(148, 103, 189)];
const SHADE: RGBColor = RGBColor(228, 228, 228);

/// One run's metrics, by column.
#[derive(Debug, Clone)]
pub struct Run {
    pub name: String,
    pub columns: BTreeMap<String, Vec<f64>>,
    /// `ppo.desired_kl` of the run's config.toml, when there is one beside the metrics.
    pub desired_kl: Option<f64>,
}

impl Run {
    /// A run folder (or its `metrics.csv`).
    pub fn load(path: &Path) -> Result<Run> {
        if !path.exists() {
            run_error!("{}: no such run (give a run folder holding metrics.csv, or the file)", path.display());
        }
        let csv = if path.is_dir() { path.join("metrics.csv") } else { path.to_path_buf() };
        let (header, rows) = trainer::metrics::read_csv(&csv)?;
        for need in ["iteration", "samples", "phase", "episodes", "mean_return"] {
            if !header.iter().any(|h| h == need) {
                run_error!("{} has no column {need}: is it a metrics.csv written by `topa train`?", csv.display());
            }
        }
        if rows.is_empty() {
            run_error!("{} has no iterations yet", csv.display());
        }
        let columns =
            header.iter().enumerate().map(|(i, h)| (h.clone(), rows.iter().map(|r| r[i]).collect())).collect();
        let dir = csv.parent().unwrap_or(Path::new("."));
        let desired_kl = std::fs::read_to_string(dir.join("config.toml"))
            .ok()
            .and_then(|t| t.parse::<toml::Table>().ok())
            .and_then(|t| t.get("ppo")?.get("desired_kl")?.as_float());
        let name = dir.file_name().map_or("run".into(), |n| n.to_string_lossy().into_owned());
        Ok(Run { name, columns, desired_kl })
    }
    fn col(&self, name: &str) -> Option<&Vec<f64>> {
        self.columns.get(name)
    }
    /// A column's values, NaN where the iteration ended no episode (for episode statistics).
    fn values(&self, name: &str) -> Vec<f64> {
        let Some(v) = self.col(name) else { return Vec::new() };
        let episodic = trainer::metrics::is_episode_column(name);
        let episodes = &self.columns["episodes"];
        v.iter().zip(episodes).map(|(&x, &e)| if episodic && e <= 0.0 { f64::NAN } else { x }).collect()
    }
}

/// Runs drawn together (the seeds of one configuration).
#[derive(Debug, Clone)]
pub struct Group {
    pub name: String,
    pub runs: Vec<Run>,
}

/// One small multiple: a column, its title, and a reference line.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    pub title: String,
    pub column: String,
    pub reference: Option<f64>,
}

/// The panels for these runs, in reading order: what every run has, then each reward term, then the adversary's.
pub fn panels(groups: &[Group]) -> Vec<Panel> {
    let runs: Vec<&Run> = groups.iter().flat_map(|g| &g.runs).collect();
    let has = |c: &str| runs.iter().any(|r| r.col(c).is_some_and(|v| v.iter().any(|x| x.is_finite())));
    let nonzero = |c: &str| runs.iter().any(|r| r.col(c).is_some_and(|v| v.iter().any(|x| x.is_finite() && *x != 0.0)));
    let kl = runs.iter().find_map(|r| r.desired_kl);
    let mut out = Vec::new();
    let mut add = |title: &str, column: &str, reference: Option<f64>| {
        out.push(Panel { title: title.into(), column: column.into(), reference });
    };
    // Reading order; the KL panel carries the run's target as a line.
    for (title, column, reference) in [
        ("mean episode return", "mean_return", None),
        ("mean episode length (policy steps)", "mean_length", None),
        ("curriculum level (mean terrain row)", "curriculum_level", None),
        ("value loss", "policy_value_loss", None),
        ("surrogate loss", "policy_surrogate", None),
        ("symmetry loss", "policy_symmetry_loss", None),
        ("KL (line: target)", "policy_kl", kl),
        ("learning rate", "policy_lr", None),
        ("entropy", "policy_entropy", None),
        ("action std", "action_std", None),
        ("samples/s", "fps", None),
    ] {
        if has(column) {
            add(title, column, reference);
        }
    }
    let mut names: Vec<String> = runs.iter().flat_map(|r| r.columns.keys().cloned()).collect();
    names.sort();
    names.dedup();
    for c in names.iter().filter(|c| c.starts_with("rew_")) {
        add(&format!("reward: {}", &c[4..]), c, None);
    }
    for c in names.iter().filter(|c| c.starts_with("perturb_") && nonzero(c)) {
        add(&format!("adversary: {} (mean |offset|)", &c[8..]), c, None);
    }
    if nonzero("adversary_value_loss") {
        add("adversary value loss", "adversary_value_loss", None);
    }
    out
}

/// TensorBoard's smoothing: an exponential moving average, debiased at the start, skipping missing values.
pub fn ema(ys: &[f64], weight: f64) -> Vec<f64> {
    let (mut last, mut n) = (0.0, 0);
    ys.iter()
        .map(|&y| {
            if !y.is_finite() {
                return f64::NAN;
            }
            last = last * weight + (1.0 - weight) * y;
            n += 1;
            last / (1.0 - weight.powi(n))
        })
        .collect()
}

/// The y range that shows the data: every value within twenty spreads of the median (the spread being the middle
/// 90 % of the values, or a tenth of the median's size where they barely move), so that one spike — a diverged
/// iteration, 10⁶ — does not flatten the curve while a real step (a learning rate set at the first iteration) still
/// shows; what lies beyond is clipped at the edge. `always` (a target line) is always inside.
pub fn robust_range(values: &[f64], always: Option<f64>) -> Range<f64> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return always.map_or(0.0..1.0, |a| (a - 0.5 * a.abs().max(1e-3))..(a + 0.5 * a.abs().max(1e-3)));
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    let median = q(0.5);
    let fence = 20.0 * (q(0.95) - q(0.05)).max(0.1 * median.abs());
    let mut inside: Vec<f64> = v.iter().copied().filter(|x| (x - median).abs() <= fence).collect();
    inside.extend(always);
    let lo = inside.iter().copied().fold(f64::MAX, f64::min);
    let hi = inside.iter().copied().fold(f64::MIN, f64::max);
    let pad = if hi > lo { 0.06 * (hi - lo) } else { 0.5 * lo.abs().max(1e-3) };
    (lo - pad)..(hi + pad)
}

/// Tick labels per axis: plotters picks at most this many nice values, so consecutive ticks lie at least
/// span / LABELS apart, and `label` prints the decimals that step needs.
const LABELS: usize = 6;

/// The smallest step plotters' ticks can have on `r`: the power of ten at or below span / LABELS.
fn min_step(r: &Range<f64>) -> f64 {
    10f64.powf(((r.end - r.start).max(1e-12) / LABELS as f64).log10().floor())
}

/// The tick labels plotters will draw on `r`, as our formatter writes them.
pub fn tick_labels(r: &Range<f64>) -> Vec<String> {
    use plotters::coord::ranged1d::Ranged;
    let coord: plotters::coord::types::RangedCoordf64 = r.clone().into();
    let step = min_step(r);
    coord.key_points(LABELS).into_iter().map(|v| label(v, step)).collect()
}

/// A tick label with just the decimals its step needs; k / M / G suffixes for large numbers.
fn label(x: f64, step: f64) -> String {
    let (scale, suffix) = match step.abs().max(x.abs()) {
        m if m >= 1e9 => (1e9, "G"),
        m if m >= 1e6 => (1e6, "M"),
        m if m >= 1e4 => (1e3, "k"),
        _ => (1.0, ""),
    };
    let decimals = (-(step / scale).log10().floor()).max(0.0) as usize;
    let v = x / scale;
    let v = if v.abs() < 0.5 * 10f64.powi(-(decimals as i32)) { 0.0 } else { v };
    format!("{v:.decimals$}{suffix}")
}

/// Cohen–Sutherland: the part of segment a–b inside the box, if any.
fn clip(mut a: (f64, f64), mut b: (f64, f64), x: &Range<f64>, y: &Range<f64>) -> Option<((f64, f64), (f64, f64))> {
    let code = |p: (f64, f64)| {
        (p.0 < x.start) as u8 | ((p.0 > x.end) as u8) << 1 | ((p.1 < y.start) as u8) << 2 | ((p.1 > y.end) as u8) << 3
    };
    let (mut ca, mut cb) = (code(a), code(b));
    for _ in 0..8 {
        if ca | cb == 0 {
            return Some((a, b));
        }
        if ca & cb != 0 {
            return None;
        }
        let c = if ca != 0 { ca } else { cb };
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let p = if c & 8 != 0 {
            (a.0 + dx * (y.end - a.1) / dy, y.end)
        } else if c & 4 != 0 {
            (a.0 + dx * (y.start - a.1) / dy, y.start)
        } else if c & 2 != 0 {
            (x.end, a.1 + dy * (x.end - a.0) / dx)
        } else {
            (x.start, a.1 + dy * (x.start - a.0) / dx)
        };
        if c == ca {
            a = p;
            ca = code(a);
        } else {
            b = p;
            cb = code(b);
        }
    }
    None
}

/// A curve as polylines inside the box: gaps at missing values, cuts where it leaves the box.
pub fn clipped_paths(pts: &[(f64, f64)], x: &Range<f64>, y: &Range<f64>) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut open = false;
    for w in pts.windows(2) {
        let (a, b) = (w[0], w[1]);
        if !(a.1.is_finite() && b.1.is_finite()) {
            open = false;
            continue;
        }
        match clip(a, b, x, y) {
            Some((p, q)) => {
                let joined = open && out.last().and_then(|l| l.last()) == Some(&p);
                if !joined {
                    out.push(vec![p]);
                }
                out.last_mut().unwrap().push(q);
                open = q == b;
            }
            None => open = false,
        }
    }
    // A lone finite point between gaps still shows, as a dot-length path.
    out
}

/// Linear interpolation of (xs, ys) at x (NaN outside xs or next to a missing value).
fn interp(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let i = xs.partition_point(|v| *v < x);
    if i < xs.len() && xs[i] == x {
        return ys[i];
    }
    if i == 0 || i >= xs.len() {
        return f64::NAN;
    }
    let t = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
    ys[i - 1] + t * (ys[i] - ys[i - 1])
}

/// Where each panel's data go on screen, for the pixel checks in tests: (panel, plotting area) in pixels.
pub type Layout = Vec<(String, [i32; 4])>;

/// Draws the dashboard of `groups` to `png` and an SVG beside it; returns the PNG's plotting areas.
pub fn render(groups: &[Group], png: &Path) -> Result<Layout> {
    if !groups.iter().any(|g| !g.runs.is_empty()) {
        run_error!("no runs to plot");
    }
    crate::plots::register_font();
    let panels = panels(groups);
    let rows = panels.len().div_ceil(COLS) as u32;
    let size = (PANEL.0 * COLS as u32, HEADER + PANEL.1 * rows);
    let layout = {
        let root = BitMapBackend::new(png, size).into_drawing_area();
        let l = draw(&root, groups, &panels)?;
        root.present().map_err(crate::plots::err)?;
        l
    };
    let svg: PathBuf = png.with_extension("svg");
    let root = SVGBackend::new(&svg, size).into_drawing_area();
    draw(&root, groups, &panels)?;
    root.present().map_err(crate::plots::err)?;
    Ok(layout)
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, groups: &[Group], panels: &[Panel]) -> Result<Layout>
where
    DB::ErrorType: 'static,
{
    use crate::plots::err;
    root.fill(&WHITE).map_err(err)?;
    let (header, body) = root.split_vertically(HEADER);
    let single = groups.len() == 1 && groups[0].runs.len() == 1;
    let legend = if single {
        format!(
            "faint: raw; bold: exponential moving average (weight {SMOOTHING}); grey: adversary learning (policy \
             frozen); x: iterations below, samples above"
        )
    } else {
        let names: Vec<String> = groups.iter().map(|g| format!("{} ({} runs)", g.name, g.runs.len())).collect();
        format!(
            "{}: mean of the runs' moving averages (weight {SMOOTHING}), band min–max, runs faint",
            names.join(", ")
        )
    };
    header.draw(&Text::new(legend, (12, 16), ("sans-serif", 17).into_font())).map_err(err)?;
    for (gi, g) in groups.iter().enumerate() {
        let c = PALETTE[gi % PALETTE.len()];
        header
            .draw(&Rectangle::new([(12 + 150 * gi as i32, 38), (42 + 150 * gi as i32, 44)], c.filled()))
            .map_err(err)?;
        header
            .draw(&Text::new(g.name.clone(), (48 + 150 * gi as i32, 33), ("sans-serif", 14).into_font()))
            .map_err(err)?;
    }
    let cells = body.split_evenly(((panels.len().div_ceil(COLS)), COLS));
    let mut layout = Vec::new();
    for (area, panel) in cells.iter().zip(panels) {
        layout.push((panel.title.clone(), draw_panel(area, groups, panel, single)?));
    }
    Ok(layout)
}

/// x of each iteration: iterations for one run, millions of samples for several (runs align by samples).
fn xs(run: &Run, single: bool) -> Vec<f64> {
    if single {
        run.columns["iteration"].clone()
    } else {
        run.columns["samples"].iter().map(|s| s / 1e6).collect()
    }
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    groups: &[Group],
    panel: &Panel,
    single: bool,
) -> Result<[i32; 4]>
where
    DB::ErrorType: 'static,
{
    use crate::plots::err;
    // Every curve of the panel: (group index, x, raw, smoothed).
    let mut curves = Vec::new();
    for (gi, g) in groups.iter().enumerate() {
        for r in &g.runs {
            let raw = r.values(&panel.column);
            if !raw.is_empty() {
                curves.push((gi, xs(r, single), ema(&raw, SMOOTHING), raw));
            }
        }
    }
    // The scale comes from the raw values: a spike's moving average decays over many iterations and would
    // otherwise widen the scale it is meant to be clipped by.
    let all: Vec<f64> = curves.iter().flat_map(|c| c.3.iter().copied()).collect();
    let yr = robust_range(&all, panel.reference);
    let x_max = curves.iter().flat_map(|c| c.1.iter().copied()).fold(f64::MIN, f64::max);
    let x_min =
        if single { 0.0 } else { 0.0f64.min(curves.iter().flat_map(|c| c.1.iter().copied()).fold(f64::MAX, f64::min)) };
    let xr = x_min..x_max.max(x_min + 1e-9);
    let (xs_step, ys_step) = (min_step(&xr), min_step(&yr));
    // One run: iterations below, samples above (its samples per iteration are constant).
    let samples_max = groups[0].runs[0].columns["samples"].iter().copied().fold(0.0, f64::max);
    let top = if single { 26 } else { 0 };
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 16))
        .margin(8)
        .x_label_area_size(34)
        .top_x_label_area_size(top)
        .y_label_area_size(58)
        .build_cartesian_2d(xr.clone(), yr.clone())
        .map_err(err)?
        .set_secondary_coord(0.0..samples_max * (xr.end - xr.start) / x_max.max(1e-9), yr.clone());
    let xf = |v: &f64| label(*v, xs_step);
    let yf = |v: &f64| label(*v, ys_step);
    chart
        .configure_mesh()
        .x_labels(LABELS)
        .y_labels(LABELS)
        .x_desc(if single { "iteration" } else { "samples (M)" })
        .x_label_formatter(&xf)
        .y_label_formatter(&yf)
        .light_line_style(WHITE.mix(0.0))
        .label_style(("sans-serif", 12))
        .draw()
        .map_err(err)?;
    if single {
        let sr = 0.0..samples_max.max(1.0);
        let step = min_step(&sr);
        let sf = |v: &f64| label(*v, step);
        chart
            .configure_secondary_axes()
            .x_labels(LABELS)
            .y_labels(0)
            .x_label_formatter(&sf)
            .label_style(("sans-serif", 11).into_font().color(&BLACK.mix(0.6)))
            .draw()
            .map_err(err)?;
    }
    // Adversary learning (phase 2): the policy is frozen.
    if let Some(r) = groups.first().and_then(|g| g.runs.first()) {
        let x = xs(r, single);
        let phase = &r.columns["phase"];
        let step = if x.len() > 1 { x[1] - x[0] } else { 1.0 };
        let shade = x.iter().zip(phase).filter(|(_, p)| **p == 2.0).map(|(&x, _)| {
            Rectangle::new([((x - step).max(xr.start), yr.start), (x.min(xr.end), yr.end)], SHADE.filled())
        });
        chart.draw_series(shade).map_err(err)?;
    }
    // Iterations without a value (no episode ended) are skipped, as TensorBoard does: the line joins across them.
    let path = |pts: &[(f64, f64)], style: ShapeStyle| -> Vec<PathElement<(f64, f64)>> {
        let known: Vec<(f64, f64)> = pts.iter().copied().filter(|p| p.0.is_finite() && p.1.is_finite()).collect();
        clipped_paths(&known, &xr, &yr).into_iter().map(|p| PathElement::new(p, style)).collect()
    };
    if let Some(k) = panel.reference {
        chart.draw_series(path(&[(xr.start, k), (xr.end, k)], BLACK.mix(0.6).stroke_width(1))).map_err(err)?;
    }
    for gi in 0..groups.len() {
        let color = PALETTE[gi % PALETTE.len()];
        let mine: Vec<_> = curves.iter().filter(|c| c.0 == gi).collect();
        if mine.is_empty() {
            continue;
        }
        if single {
            let (x, smooth, raw) = (&mine[0].1, &mine[0].2, &mine[0].3);
            let zip = |ys: &[f64]| x.iter().copied().zip(ys.iter().copied()).collect::<Vec<_>>();
            chart.draw_series(path(&zip(raw), color.mix(0.3).stroke_width(1))).map_err(err)?;
            chart.draw_series(path(&zip(smooth), color.stroke_width(2))).map_err(err)?;
            continue;
        }
        // The group on the first run's x: each run's smoothed curve interpolated there.
        let x0 = &mine[0].1;
        let at: Vec<Vec<f64>> = x0
            .iter()
            .map(|&x| mine.iter().map(|c| interp(&c.1, &c.2, x)).filter(|v| v.is_finite()).collect())
            .collect();
        let stat = |f: fn(&[f64]) -> f64| -> Vec<(f64, f64)> {
            x0.iter().zip(&at).map(|(&x, v)| (x, if v.is_empty() { f64::NAN } else { f(v) })).collect()
        };
        let (lo, hi) = (
            stat(|v| v.iter().copied().fold(f64::MAX, f64::min)),
            stat(|v| v.iter().copied().fold(f64::MIN, f64::max)),
        );
        let band: Vec<(f64, f64)> = lo
            .iter()
            .zip(&hi)
            .filter(|(a, b)| a.1.is_finite() && b.1.is_finite())
            .map(|(a, _)| (a.0, a.1.clamp(yr.start, yr.end)))
            .chain(hi.iter().rev().filter(|b| b.1.is_finite()).map(|b| (b.0, b.1.clamp(yr.start, yr.end))))
            .collect();
        if band.len() > 2 {
            chart.draw_series(std::iter::once(Polygon::new(band, color.mix(0.15).filled()))).map_err(err)?;
        }
        for c in &mine {
            let pts: Vec<(f64, f64)> = c.1.iter().copied().zip(c.2.iter().copied()).collect();
            chart.draw_series(path(&pts, color.mix(0.35).stroke_width(1))).map_err(err)?;
        }
        chart
            .draw_series(path(&stat(|v| v.iter().sum::<f64>() / v.len() as f64), color.stroke_width(2)))
            .map_err(err)?;
    }
    let (px, py) = chart.plotting_area().get_pixel_range();
    Ok([px.start, py.start, px.end, py.end])
}

/// A run's own dashboard from its `metrics.csv`: `learning_curve.png` and `.svg` in the run folder.
pub fn learning_curve(csv: &Path, png: &Path) -> Result<()> {
    let run = Run::load(csv)?;
    render(&[Group { name: run.name.clone(), runs: vec![run] }], png).map(|_| ())
}

/// `topa plot`: runs given alone are one group each; `--group NAME=RUN,RUN…` puts seeds together.
pub fn plot(runs: &[PathBuf], groups: &[String], out: &Path) -> Result<Layout> {
    let mut all: Vec<Group> = Vec::new();
    for r in runs {
        let run = Run::load(r)?;
        all.push(Group { name: run.name.clone(), runs: vec![run] });
    }
    for spec in groups {
        let (name, list) = spec.split_once('=').ok_or_else(|| {
            Error::Invalid(format!("--group takes NAME=RUN,RUN…, got '{spec}' (e.g. C=runs/C-s1,runs/C-s2)"))
        })?;
        let runs =
            list.split(',').filter(|s| !s.is_empty()).map(|r| Run::load(Path::new(r))).collect::<Result<Vec<_>>>()?;
        if runs.is_empty() {
            return Err(Error::Invalid(format!("--group {name} names no run")));
        }
        all.push(Group { name: name.to_string(), runs });
    }
    if all.is_empty() {
        return Err(Error::Invalid("give runs (folders holding metrics.csv) or --group NAME=RUN,RUN…".into()));
    }
    render(&all, out)
}

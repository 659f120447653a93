//! The iterations-to-the-bars figure: per run, the worst component MAE and the share of tracking runs that fell or
//! stood still, against the iteration; a filled marker where a checkpoint meets every bar.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::claims::{worst_component, MAX_COMPONENT_MAE};
use super::progress::{RunProgress, Snapshot};
use super::results::RunCounts;
use crate::error::{ensure, Result};
use topa_train::plots::{err, register_font, whole_number};

/// Worst component MAE of a snapshot, the value its MAE bar was judged on (an infinite one plots at the top).
fn worst_mae(s: &Snapshot) -> f64 {
    let w = worst_component(&s.tracking).1;
    if w.is_finite() {
        w
    } else {
        1.0
    }
}

/// Runs that fell or stood still, as a share of the snapshot's tracking runs.
fn failed_share(s: &Snapshot) -> f64 {
    let c = RunCounts::of(&s.tracking);
    (c.falls + c.stood_still.unwrap_or(0)) as f64 / c.runs.max(1) as f64
}

/// A panel: its title, the value of a snapshot, and the bar drawn as a dashed line.
type Measure = (&'static str, fn(&Snapshot) -> f64, Option<f64>);

/// The figure as PNG and SVG.
pub fn figure(runs: &[RunProgress], png: &Path, svg: &Path) -> Result<()> {
    register_font();
    ensure!(runs.iter().any(|r| !r.snapshots.is_empty()), "no checkpoints to plot");
    let size = (1100, 420);
    {
        let root = BitMapBackend::new(png, size).into_drawing_area();
        draw(&root, runs)?;
        root.present().map_err(err)?;
    }
    let root = SVGBackend::new(svg, size).into_drawing_area();
    draw(&root, runs)?;
    root.present().map_err(err)?;
    Ok(())
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, runs: &[RunProgress]) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(err)?;
    let last = runs.iter().flat_map(|r| r.snapshots.iter().map(|s| s.iteration)).max().unwrap_or(1) as f64;
    let panels = root.split_evenly((1, 2));
    let measures: [Measure; 2] = [
        ("worst component MAE (bar: dashed)", worst_mae, Some(MAX_COMPONENT_MAE)),
        ("tracking runs that fell or stood still", failed_share, None),
    ];
    for (area, (title, value, bar)) in panels.iter().zip(measures) {
        let mut chart = ChartBuilder::on(area)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..last * 1.02, 0.0..1.05)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("iteration")
            .x_label_formatter(&whole_number)
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(err)?;
        if let Some(b) = bar {
            let dashes = (0..40).map(|i| {
                let x = last * 1.02 * i as f64 / 40.0;
                PathElement::new(vec![(x, b), (x + last * 0.012, b)], BLACK)
            });
            chart.draw_series(dashes).map_err(err)?;
        }
        for (i, r) in runs.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            let pts: Vec<(f64, f64)> = r.snapshots.iter().map(|s| (s.iteration as f64, value(s))).collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .map_err(err)?
                .label(format!("{} (seed {})", r.run, r.seed))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
            let marks = r.snapshots.iter().zip(&pts).map(|(s, &p)| {
                let style = if s.meets_all() { color.filled() } else { color.stroke_width(1) };
                Circle::new(p, 4, style)
            });
            chart.draw_series(marks).map_err(err)?;
        }
        chart
            .configure_series_labels()
            .border_style(BLACK.mix(0.3))
            .background_style(WHITE.mix(0.9))
            .label_font(("sans-serif", 13))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(err)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_a_png_and_an_svg_and_refuses_an_empty_study() {
        let dir = std::env::temp_dir().join(format!("topa-progress-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (png, svg) = (dir.join("p.png"), dir.join("p.svg"));
        let empty = RunProgress { run: "C-s1".into(), seed: 1, planned_iterations: 10, snapshots: vec![] };
        let e = figure(std::slice::from_ref(&empty), &png, &svg).unwrap_err();
        assert!(e.to_string().contains("no checkpoints"), "{e}");
        let snap = |it| Snapshot {
            iteration: it,
            samples: 0,
            wall_time_s: 0.0,
            tracking: vec![],
            push_t_fall_s: None,
            bars: vec![],
        };
        let run = RunProgress { snapshots: vec![snap(5), snap(10)], ..empty };
        figure(&[run], &png, &svg).unwrap();
        assert_eq!(&std::fs::read(&png).unwrap()[1..4], b"PNG");
        assert!(std::fs::read_to_string(&svg).unwrap().contains("C-s1 (seed 1)"));
        std::fs::remove_dir_all(dir).ok();
    }
}

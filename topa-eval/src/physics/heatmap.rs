//! The perturbation report's figure: one row per case, one column per policy; green where the policy survived
//! (darker as its worst tracking component nears the bar), red where it did not, the worst MAE written in.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::report::{labels, PhysicsReport};
use crate::claims::MAX_COMPONENT_MAE;
use crate::error::Result;
use topa_train::plots::{err, register_font};

/// The heatmap of `r` as PNG and SVG.
pub fn draw(r: &PhysicsReport, png: &Path, svg: &Path) -> Result<()> {
    register_font();
    let rows = r.entries.first().map_or(0, |e| e.result.cases.len());
    let size = (340 + 70 * r.entries.len() as u32, 110 + 20 * rows as u32);
    {
        let root = BitMapBackend::new(png, size).into_drawing_area();
        paint(&root, r)?;
        root.present().map_err(err)?;
    }
    let root = SVGBackend::new(svg, size).into_drawing_area();
    paint(&root, r)?;
    root.present().map_err(err)?;
    Ok(())
}

fn paint<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, r: &PhysicsReport) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(err)?;
    let names: Vec<String> =
        r.entries.first().map_or(Vec::new(), |e| e.result.cases.iter().map(|c| c.case.clone()).collect());
    let cols = labels(r);
    let (nx, ny) = (cols.len().max(1), names.len().max(1));
    let mut chart = ChartBuilder::on(root)
        .caption("Perturbations survived (worst component MAE)", ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(300)
        .build_cartesian_2d(0.0..nx as f64, 0.0..ny as f64)
        .map_err(err)?;
    // Row 0 (nominal) at the top.
    let name_at = |y: f64| names.get(ny - 1 - (y.floor() as usize).min(ny - 1)).cloned().unwrap_or_default();
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels(nx * 2 + 1)
        .y_labels(ny * 2 + 1)
        .x_label_formatter(&|x| {
            let i = x.floor() as usize;
            if (x - i as f64 - 0.5).abs() < 0.01 && i < cols.len() {
                cols[i].clone()
            } else {
                String::new()
            }
        })
        .y_label_formatter(&|y| if (y.fract() - 0.5).abs() < 0.01 { name_at(*y) } else { String::new() })
        .label_style(("sans-serif", 12))
        .draw()
        .map_err(err)?;
    for (x, e) in r.entries.iter().enumerate() {
        for (i, c) in e.result.cases.iter().enumerate() {
            let (x, y) = (x as f64, (ny - 1 - i) as f64);
            let colour = if c.survived() {
                let t = (c.worst_component_mae / MAX_COMPONENT_MAE).clamp(0.0, 1.0);
                RGBColor((200.0 - 140.0 * t) as u8, (235.0 - 95.0 * t) as u8, (200.0 - 140.0 * t) as u8)
            } else {
                RGBColor(215, 60, 50)
            };
            chart.draw_series([Rectangle::new([(x, y), (x + 1.0, y + 1.0)], colour.filled())]).map_err(err)?;
            let text = if c.failure.is_some() { "div".to_string() } else { format!("{:.3}", c.worst_component_mae) };
            let ink = if c.survived() && c.worst_component_mae < 0.5 * MAX_COMPONENT_MAE { BLACK } else { WHITE };
            chart
                .draw_series([Text::new(text, (x + 0.25, y + 0.75), ("sans-serif", 11).into_font().color(&ink))])
                .map_err(err)?;
        }
    }
    Ok(())
}

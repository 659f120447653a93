//! The terrain evaluation's figure: success (both commands, every run) by terrain type × difficulty.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::terrain::TerrainResult;
use crate::error::Result;
use topa_train::plots::{err, register_font};

/// The success heatmap of `r` as PNG and SVG.
pub fn success_map(r: &TerrainResult, title: &str, png: &Path, svg: &Path) -> Result<()> {
    register_font();
    let size = (140 + 110 * r.terrain.types.len() as u32, 520);
    {
        let root = BitMapBackend::new(png, size).into_drawing_area();
        draw(&root, r, title)?;
        root.present().map_err(err)?;
    }
    let root = SVGBackend::new(svg, size).into_drawing_area();
    draw(&root, r, title)?;
    root.present().map_err(err)?;
    Ok(())
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, r: &TerrainResult, title: &str) -> Result<()>
where
    DB::ErrorType: 'static,
{
    use plotters::style::colors::colormaps::{ColorMap, ViridisRGB};
    root.fill(&WHITE).map_err(err)?;
    let types = &r.terrain.types;
    let levels = r.terrain.levels;
    let mut chart = ChartBuilder::on(root)
        .caption(format!("{title}: success by terrain (mean {:.0} %)", 100.0 * r.mean_success()), ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(60)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..types.len() as f64, 0.0..levels as f64)
        .map_err(err)?;
    let names: Vec<&str> = types.iter().map(|t| t.name()).collect();
    let diff = |l: f64| r.terrain.difficulty((l.floor() as usize).min(levels - 1));
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels(types.len() * 2 + 1)
        .y_labels(levels * 2 + 1)
        .x_label_formatter(&|x| {
            let i = x.floor() as usize;
            if (x - i as f64 - 0.5).abs() < 0.01 && i < names.len() {
                names[i].to_string()
            } else {
                String::new()
            }
        })
        .y_label_formatter(&|y| if (y.fract() - 0.5).abs() < 0.01 { format!("{:.2}", diff(*y)) } else { String::new() })
        .x_desc("terrain")
        .y_desc("difficulty")
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(err)?;
    for (kind, d, success) in r.success_grid() {
        let x = types.iter().position(|&k| k == kind).unwrap_or(0) as f64;
        let y = (0..levels).position(|l| r.terrain.difficulty(l) == d).unwrap_or(0) as f64;
        let colour = ViridisRGB.get_color_normalized(success, 0.0, 1.0);
        chart.draw_series([Rectangle::new([(x, y), (x + 1.0, y + 1.0)], colour.filled())]).map_err(err)?;
        let ink = if success > 0.6 { BLACK } else { WHITE };
        chart
            .draw_series([Text::new(
                format!("{:.0}%", 100.0 * success),
                (x + 0.3, y + 0.6),
                ("sans-serif", 14).into_font().color(&ink),
            )])
            .map_err(err)?;
    }
    Ok(())
}

//! The push experiment's figure: one heatmap of time to fall per policy, side by side, with a shared colour bar.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::results::PushGrid;
use crate::error::{ensure, Result};
use topa_train::plots::{err, register_font, whole_number};

/// One push-grid heatmap per policy, side by side, with a shared colour bar (time to fall, s), as PNG and SVG.
pub fn push_heatmaps(grids: &[(String, &PushGrid)], png: &Path, svg: &Path) -> Result<()> {
    register_font();
    ensure!(!grids.is_empty(), "no push grids to plot");
    let (w, h) = (520 * grids.len() as u32 + 140, 560);
    {
        let root = BitMapBackend::new(png, (w, h)).into_drawing_area();
        draw_heatmaps(&root, grids)?;
        root.present().map_err(err)?;
    }
    let root = SVGBackend::new(svg, (w, h)).into_drawing_area();
    draw_heatmaps(&root, grids)?;
    root.present().map_err(err)?;
    Ok(())
}

/// Viridis colour of `t` in [0, window].
fn color_of(t: f64, window: f64) -> RGBColor {
    use plotters::style::colors::colormaps::{ColorMap, ViridisRGB};
    ViridisRGB.get_color_normalized(t.clamp(0.0, window), 0.0, window)
}

fn draw_heatmaps<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, grids: &[(String, &PushGrid)]) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(err)?;
    let (w, _) = root.dim_in_pixel();
    let (maps, bar) = root.split_horizontally(w - 140);
    let window = grids[0].1.window_s;
    for (area, (title, g)) in maps.split_evenly((1, grids.len())).iter().zip(grids) {
        let n = g.axis.len();
        let step = if n > 1 { g.axis[1] - g.axis[0] } else { 1.0 };
        let (lo, hi) = (g.axis[0] - step / 2.0, g.axis[n - 1] + step / 2.0);
        let mut chart = ChartBuilder::on(area)
            .caption(format!("{title}: mean t_fall = {:.2} s", g.mean_t_fall()), ("sans-serif", 20))
            .margin(10)
            .x_label_area_size(45)
            .y_label_area_size(55)
            .build_cartesian_2d(lo..hi, lo..hi)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("F_x (N), torso frame")
            .y_desc("F_y (N)")
            .x_label_formatter(&whole_number)
            .y_label_formatter(&whole_number)
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(err)?;
        chart
            .draw_series((0..g.cells()).map(|c| {
                let [fx, fy] = g.force(c);
                Rectangle::new(
                    [(fx - step / 2.0, fy - step / 2.0), (fx + step / 2.0, fy + step / 2.0)],
                    color_of(g.t_fall[c], window).filled(),
                )
            }))
            .map_err(err)?;
        if n <= 13 {
            chart
                .draw_series((0..g.cells()).map(|c| {
                    let [fx, fy] = g.force(c);
                    let t = g.t_fall[c];
                    let ink = if t > 0.6 * window { BLACK } else { WHITE };
                    Text::new(
                        format!("{t:.1}"),
                        (fx - step * 0.3, fy + step * 0.15),
                        ("sans-serif", 11).into_font().color(&ink),
                    )
                }))
                .map_err(err)?;
        }
    }
    // Colour bar.
    let mut cb = ChartBuilder::on(&bar)
        .margin_top(40)
        .margin_bottom(55)
        .margin_right(50)
        .y_label_area_size(40)
        .build_cartesian_2d(0.0..1.0, 0.0..window)
        .map_err(err)?;
    cb.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc("time to fall (s)")
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(err)?;
    let k = 100;
    cb.draw_series((0..k).map(|i| {
        let (a, b) = (window * i as f64 / k as f64, window * (i + 1) as f64 / k as f64);
        Rectangle::new([(0.0, a), (1.0, b)], color_of((a + b) / 2.0, window).filled())
    }))
    .map_err(err)?;
    Ok(())
}

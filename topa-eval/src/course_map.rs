//! The course from above: floor patches in their materials' colours, walls and door posts, the path, and each
//! run's trajectory with its interventions marked.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use topa_env::course::Course;

use super::course::CourseResult;
use crate::error::Result;
use topa_train::plots::{err, register_font};

/// The map with the runs of `result`, as PNG.
pub fn course_map(course: &Course, result: &CourseResult, title: &str, png: &Path) -> Result<()> {
    register_font();
    let (lo, hi) = course.bounds();
    let scale = 900.0 / (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let (w, h) = (((hi[0] - lo[0]) * scale) as u32 + 90, ((hi[1] - lo[1]) * scale) as u32 + 90);
    let root = BitMapBackend::new(png, (w.max(400), h.max(300))).into_drawing_area();
    draw(&root, course, result, title)?;
    root.present().map_err(err)?;
    Ok(())
}

const RUN_COLOURS: [RGBColor; 5] =
    [RGBColor(31, 119, 180), RGBColor(214, 39, 40), RGBColor(44, 160, 44), RGBColor(148, 103, 189), BLACK];

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, course: &Course, r: &CourseResult, title: &str) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(err)?;
    let (lo, hi) = course.bounds();
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(40)
        .build_cartesian_2d(lo[0]..hi[0], lo[1]..hi[1])
        .map_err(err)?;
    chart.configure_mesh().disable_mesh().x_desc("x (m)").y_desc("y (m)").draw().map_err(err)?;
    for f in &course.floor {
        let [r_, g, b, _] = course.materials[&f.material].rgba.map(|c| (c * 255.0) as u8);
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(f.min[0], f.min[1]), (f.max[0], f.max[1])],
                RGBColor(r_, g, b).filled(),
            )))
            .map_err(err)?;
    }
    for wall in &course.walls {
        let (dx, dy) = (wall.to[0] - wall.from[0], wall.to[1] - wall.from[1]);
        let l = dx.hypot(dy);
        let (nx, ny) = (-dy / l * wall.thickness / 2.0, dx / l * wall.thickness / 2.0);
        let poly = vec![
            (wall.from[0] + nx, wall.from[1] + ny),
            (wall.to[0] + nx, wall.to[1] + ny),
            (wall.to[0] - nx, wall.to[1] - ny),
            (wall.from[0] - nx, wall.from[1] - ny),
        ];
        chart.draw_series(std::iter::once(Polygon::new(poly, RGBColor(60, 60, 70).filled()))).map_err(err)?;
    }
    for t in &course.thresholds {
        let p = course.path.at(t.at_m);
        chart
            .draw_series(std::iter::once(Circle::new((p.xy[0], p.xy[1]), 4, RGBColor(120, 80, 40).filled())))
            .map_err(err)?;
    }
    let path: Vec<(f64, f64)> = course.path.points().iter().map(|p| (p[0], p[1])).collect();
    chart.draw_series(LineSeries::new(path, RGBColor(230, 190, 20).stroke_width(1))).map_err(err)?;
    for (run, colour) in r.runs.iter().zip(RUN_COLOURS.iter().cycle()) {
        let label = format!(
            "{:.2} m/s: {} in {:.0} s, {} interventions",
            run.top_speed,
            if run.finished { "goal" } else { "no goal" },
            run.time_s,
            run.interventions()
        );
        chart
            .draw_series(LineSeries::new(run.trajectory.iter().map(|p| (p[0], p[1])), colour.stroke_width(2)))
            .map_err(err)?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(3)));
        chart
            .draw_series(run.intervention_at.iter().map(|p| Cross::new((p[0], p[1]), 6, colour.stroke_width(2))))
            .map_err(err)?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(err)?;
    Ok(())
}

//! The excitation's amplitude spectrum (first motor), log–log, with the band marked.

use std::path::Path;

use crate::error::Result;
use plotters::prelude::*;

use super::excite::{spectrum, Design};
use topa_train::plots::{err, register_font};

pub fn plot(d: &Design, signal: &[f64], png: &Path) -> Result<()> {
    register_font();
    let s: Vec<(f64, f64)> = spectrum(signal, d.rate_hz).into_iter().filter(|(_, a)| *a > 0.0).collect();
    let top = s.iter().fold(1e-12f64, |m, (_, a)| m.max(*a)) * 2.0;
    let root = BitMapBackend::new(png, (800, 420)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let f_max = d.rate_hz / 2.0;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("{:?}, {}–{} Hz, {} s: amplitude spectrum", d.shape, d.band[0], d.band[1], d.duration_s),
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((d.band[0] / 10.0..f_max).log_scale(), (top * 1e-5..top).log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("frequency (Hz)")
        .y_desc("amplitude")
        .y_label_formatter(&|y| format!("{y:.0e}"))
        .x_label_formatter(&|x| format!("{x}"))
        .draw()
        .map_err(err)?;
    let band = RGBColor(230, 240, 255);
    chart
        .draw_series(std::iter::once(Rectangle::new([(d.band[0], top * 1e-5), (d.band[1], top)], band.filled())))
        .map_err(err)?;
    chart.draw_series(LineSeries::new(s.into_iter().filter(|(f, _)| *f >= d.band[0] / 10.0), BLUE)).map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

//! What every figure shares: the bundled font and the error and axis-label helpers. Text is drawn with the
//! bundled DejaVu Sans (assets/fonts), so plots render the same on any machine, without system fonts.

use std::sync::Once;

use plotters::prelude::*;

static FONT: Once = Once::new();

pub fn register_font() {
    FONT.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
        if plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_err() {
            log::warn!("could not register the bundled font; plot text may be missing");
        }
    });
}

/// Axis labels for iterations, returns, steps and newtons: plotters' default prints "1500.0".
pub fn whole_number(v: &f64) -> String {
    format!("{v:.0}")
}

pub fn err<E: std::fmt::Debug>(e: E) -> crate::error::Error {
    crate::error::Error::Plot(format!("{e:?}"))
}

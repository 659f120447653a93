//! System identification, the paper's data-fitting steps: excitation signals for the motors (`excite`).

pub mod excite;
pub mod spectrum_plot;

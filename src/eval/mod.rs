//! Sim2sim evaluation (paper, "Ablation study" and "Robustness evaluation"): every experiment runs on the
//! **closed** model with settings that differ from training on purpose — finer physics timestep, the MJCF's
//! exact integrator, no domain randomisation, no observation noise, no pushes — so that a policy's score is a
//! transfer, not a replay. A policy trained on the open model is run through the paper's map M.

pub mod ablate;
pub mod claims;
pub mod course;
pub mod course_map;
pub mod driver;
pub mod endurance;
pub mod field;
pub mod gait;
pub mod groups;
pub mod heatmaps;
pub mod intervals;
mod nan_json;
pub mod noise;
pub mod progress;
pub mod progress_plot;
pub mod push;
pub mod report;
pub mod results;
pub mod runner;
pub mod settings;
pub mod terrain;
pub mod terrain_map;
pub mod terrain_report;
pub mod tracking;

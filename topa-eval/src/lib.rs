//! The paper's sim2sim experiments and their reports. Every experiment runs on the **closed** model with settings
//! that differ from training on purpose — finer physics timestep, the MJCF's exact integrator, no domain
//! randomisation, no observation noise, no pushes (paper, "Ablation study" and "Robustness evaluation") — so that a
//! policy's score is a transfer, not a replay; a policy trained on the open model is run through the paper's map
//! M. The realistic mode adds what the robot's computer sees: the state estimator, sensor noise, latency.
//!
//! The experiments (`tracking`, `push`, `noise`, `course`, `endurance`, `terrain`) each take a policy file and
//! [`settings::EvalSettings`]; the groups of seeds are summarised with bootstrap intervals (`intervals`, after
//! rliable) and the paper's claims checked (`claims`) in the reports (`ablate`, `field`, `terrain_report`).
//!
//! ```
//! use topa_eval::intervals::{compare, Resampling, Scores};
//!
//! // Mean time to fall of five seeds of two groups: is the first group better, with 95 % confidence?
//! let c = Scores::per_run(&[8.1, 8.9, 9.3, 8.6, 9.1]);
//! let ca = Scores::per_run(&[9.9, 10.0, 9.8, 10.0, 9.9]);
//! let (diff, _p_improvement) = compare(&ca, &c, Resampling { tasks: false }).unwrap();
//! assert!((diff.point - 1.12).abs() < 1e-9);
//! assert!(diff.lo > 0.0 && diff.lo < diff.point && diff.point < diff.hi);
//! ```

pub mod ablate;
pub mod claims;
pub mod clips;
pub mod compare;
pub mod course;
pub mod course_map;
pub mod doc_blocks;
pub mod driver;
pub mod endurance;
pub mod error;
pub mod field;
pub mod gait;
pub mod groups;
pub mod heatmaps;
pub mod intervals;
pub mod merge;
mod nan_json;
pub mod noise;
pub mod physics;
pub mod play;
pub mod progress;
pub mod progress_plot;
pub mod push;
pub mod recording;
pub mod report;
pub mod results;
pub mod runner;
pub mod select;
pub mod settings;
pub mod terrain;
pub mod terrain_map;
pub mod terrain_report;
pub mod tracking;
pub mod velocity;
pub mod video;

pub use error::{Error, Result};

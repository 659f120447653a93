//! System identification, the paper's data-fitting steps: excitation signals for the motors (`excite`), motor logs
//! (`log`), the bench they are replayed on (`bench`), the robot hung in the air as a bench (`robot`), the
//! least-squares fit (`fit`, through the optimiser's adapter `lm`), the report (`identify`), a synthetic bench
//! with hidden values to prove it (`synthetic`), and the state estimator's tuning against ground truth
//! (`estimator`).
//!
//! ```
//! use topa_sysid::excite::{energy_in_band, Design, Shape};
//!
//! // A 4-second multisine from 0.5 to 15 Hz, sampled at 500 Hz, faded in and out over 0.5 s.
//! let d = Design { shape: Shape::Multisine, amplitude: 0.2, band: [0.5, 15.0], duration_s: 4.0, rate_hz: 500.0, fade_s: 0.5, seed: 1 };
//! d.check().unwrap();
//! let x = d.signal(0);
//! assert_eq!(x.len(), 2001);
//! assert!(x.iter().all(|v| v.abs() <= 0.2 + 1e-12));
//! assert!(energy_in_band(&x, 500.0, [0.4, 16.0]) > 0.9);
//! ```

pub mod bench;
pub mod error;
pub mod estimator;
pub mod excite;
pub mod fit;
pub mod identify;
pub mod lm;
pub mod log;
pub mod robot;
pub mod spectrum_plot;
pub mod synthetic;
pub mod tuning;

pub use error::{Error, Result};

//! System identification, the paper's data-fitting steps: excitation signals for the motors (`excite`), motor logs
//! (`log`), the bench they are replayed on (`bench`), the robot hung in the air as a bench (`robot`), the
//! least-squares fit (`fit`, through the optimiser's adapter `lm`), the report (`identify`), a synthetic bench
//! with hidden values to prove it (`synthetic`), and the state estimator's tuning against ground truth
//! (`estimator`).

pub mod bench;
pub mod estimator;
pub mod excite;
pub mod fit;
pub mod identify;
pub mod lm;
pub mod log;
pub mod robot;
pub mod spectrum_plot;
pub mod synthetic;

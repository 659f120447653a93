//! The tools around the stack: a policy exported to ONNX (and checked against its source), what a model or a
//! robot spec holds (`topa info`), the config reference generated from the config types, and the benchmarks
//! behind `topa bench`, each printing ratios measured in one run.
//!
//! ```
//! // A shipped C+A policy to ONNX, then checked: the graph's metadata names the policy's weights (their CRC).
//! let policy = topa_env::assets::repo_dir().join("assets/policies/CA/seed1.json");
//! let onnx = std::env::temp_dir().join(format!("topa-doc-{}.onnx", std::process::id()));
//! let (obs, actions) = topa_tools::export::export(&policy, &onnx, false)?;
//! assert_eq!((obs, actions), (42, 10)); // the paper's observation of a 10-motor robot
//! topa_tools::export::check(&onnx, &policy)?;
//! std::fs::remove_file(&onnx).map_err(topa_tools::Error::io("removing", &onnx))?;
//! # Ok::<(), topa_tools::Error>(())
//! ```

pub mod bench;
pub mod config_reference;
pub mod control_log;
pub mod controller_export;
pub mod error;
pub mod export;
pub mod info;
pub mod operator_keys;
pub mod operator_pad;
pub mod robot_info;

pub use error::{Error, Result};

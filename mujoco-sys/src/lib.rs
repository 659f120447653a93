//! MuJoCo 2.2 for Rust: the generated FFI (`ffi`) and a safe layer (`Model`, `Data`) in which a fatal MuJoCo
//! error becomes `Err` instead of ending the process, and warnings go to the `log` crate instead of stdout and
//! `MUJOCO_LOG.TXT`.
//!
//! ```
//! use std::sync::Arc;
//! use mujoco_sys::{Data, Model};
//!
//! // A ball dropped from 1 m: after 0.2 s of free fall it is 0.2 m lower (½ g t²), and MuJoCo's errors are `Err`.
//! let xml = r#"<mujoco><worldbody><body pos="0 0 1"><freejoint/><geom size="0.1"/></body></worldbody></mujoco>"#;
//! let model = Arc::new(Model::from_xml_string(xml, ".")?);
//! let mut data = Data::new(model.clone())?;
//! while data.time() < 0.2 - 1e-9 {
//!     data.step()?;
//! }
//! assert!((data.qpos()[2] - (1.0 - 0.5 * 9.81 * 0.04)).abs() < 0.01);
//! assert!(Model::from_xml_string("<mujoco><worldbody><geom/></worldbody>", ".").is_err());
//! # Ok::<(), mujoco_sys::MujocoError>(())
//! ```

pub mod ffi;

mod data;
mod error;
mod guard;
pub mod hfield_box;
mod model;
mod model_arrays;
mod names;
mod obj_type;
pub mod render;

pub use data::{Data, Warning};
pub use error::{MujocoError, Result};
pub use ffi::mjContact as Contact;
pub use guard::version_string;
pub use model::{Integrator, Model};
pub use obj_type::ObjType;

/// MuJoCo's equality-constraint kinds, by name.
pub fn equality_type_name(raw: i32) -> &'static str {
    match raw as u32 {
        ffi::mjEQ_CONNECT => "connect",
        ffi::mjEQ_WELD => "weld",
        ffi::mjEQ_JOINT => "joint",
        ffi::mjEQ_TENDON => "tendon",
        ffi::mjEQ_DISTANCE => "distance",
        _ => "unknown",
    }
}

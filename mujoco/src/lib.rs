//! MuJoCo 2.2 for Rust, safely: `Model`, `Data` and offscreen rendering over the raw API of `mujoco-sys`, in
//! which a fatal MuJoCo error becomes `Err` instead of ending the process, warnings go to the `log` crate instead
//! of stdout and `MUJOCO_LOG.TXT`, and MuJoCo's type codes are enums (`JointType`, `GeomType`, …).
//!
//! ```
//! use std::sync::Arc;
//! use mujoco::{Data, Model};
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
//! # Ok::<(), mujoco::MujocoError>(())
//! ```

mod data;
mod error;
pub mod gl;
mod guard;
pub mod hfield_box;
pub mod interact;
mod kinds;
mod model;
mod model_arrays;
mod names;
mod obj_type;
pub mod render;
mod sampling;

pub use data::{Data, Warning};
pub use error::{MujocoError, Result};
pub use guard::version_string;
pub use kinds::{Cone, ConstraintType, EqualityType, GeomType, JointType, Solver, Transmission};
pub use model::{Integrator, Model};
pub use mujoco_sys::ffi::mjContact as Contact;
pub use obj_type::ObjType;
pub use sampling::halton;

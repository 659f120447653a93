//! MuJoCo 2.2 for Rust: the generated FFI (`ffi`) and a safe layer (`Model`, `Data`) in which a fatal MuJoCo
//! error becomes `Err` instead of ending the process, and warnings go to the `log` crate instead of stdout and
//! `MUJOCO_LOG.TXT`.

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

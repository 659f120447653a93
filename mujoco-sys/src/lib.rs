//! MuJoCo 2.2's raw C API for Rust: the bindgen output (`ffi`, generated from Debian's libmujoco-dev 2.2.2
//! headers) and the entry points of a small C shim (`shim`) that runs the calls able to raise a fatal error under
//! `setjmp`, so that the error returns instead of ending the process. Everything here is `unsafe`; the safe layer
//! is the `mujoco` crate.
//!
//! ```
//! // The library this crate links, through its raw API.
//! // SAFETY: mj_version reads a constant; it has no preconditions.
//! let v = unsafe { mujoco_sys::ffi::mj_version() };
//! assert!((220..230).contains(&v), "MuJoCo 2.2.x, got {v}");
//! ```

pub mod ffi;
pub mod shim;

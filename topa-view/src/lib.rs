//! `topa view`: a policy walking live in a window, MuJoCo's own renderer in a GLFW window. Velocity commands
//! from the keyboard, bodies pulled with the mouse (MuJoCo's perturbation spring), shoves of the push
//! experiment's size, pause, slow motion, reset, a following camera, and an overlay with the command, the measured
//! velocity, the state estimator's estimate (realistic sim2sim) and the falls. Any robot, sim2sim mode and
//! terrain the evaluation commands take.

pub mod controls;
mod error;
pub mod session;
pub mod window;

pub use error::{Error, Result};
/// The window library, for callers that send the viewer events (tests, scripts).
pub use glfw;
pub use session::Session;
pub use window::Viewer;

/// Whether this process can open a window (an X11 or Wayland display is named).
pub fn has_display() -> bool {
    ["DISPLAY", "WAYLAND_DISPLAY"].iter().any(|v| std::env::var_os(v).is_some_and(|s| !s.is_empty()))
}

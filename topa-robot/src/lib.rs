//! A published robot model made a robot of this stack. `import` takes an MJCF as it is published (torque motors
//! with gears or PD actuators; keyframes, sensors, a floor and meshes or not) and writes a derived MJCF beside it
//! and a drafted spec: the loops with their passive joints and springs, motors and their limits, mirror pairs
//! checked against the geometry, feet, reward groups, PD gains from the load and the inertia. `stand` solves a
//! spec's stand keyframe (loops closed, on the floor) and the gravity feed-forward that holds it.

pub mod derive;
pub mod draft;
pub mod error;
pub mod gains;
mod geometry;
pub mod import;
pub mod stand;
mod xml;

pub use error::{Error, Result};
pub use import::{import, ImportOptions, ImportReport};
pub use stand::{stand, StandReport};

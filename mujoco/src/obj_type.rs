//! The kinds of named MuJoCo objects (bodies, joints, …), as the safe layer names them.

use std::fmt;

use mujoco_sys::ffi;

/// The kinds of named objects the safe layer looks up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ObjType {
    Body,
    Joint,
    Geom,
    Site,
    Actuator,
    Sensor,
    Equality,
    Key,
    Hfield,
}

impl ObjType {
    pub const ALL: [ObjType; 9] = [
        ObjType::Body,
        ObjType::Joint,
        ObjType::Geom,
        ObjType::Site,
        ObjType::Actuator,
        ObjType::Sensor,
        ObjType::Equality,
        ObjType::Key,
        ObjType::Hfield,
    ];

    pub(crate) fn raw(self) -> i32 {
        (match self {
            ObjType::Body => ffi::mjOBJ_BODY,
            ObjType::Joint => ffi::mjOBJ_JOINT,
            ObjType::Geom => ffi::mjOBJ_GEOM,
            ObjType::Site => ffi::mjOBJ_SITE,
            ObjType::Actuator => ffi::mjOBJ_ACTUATOR,
            ObjType::Sensor => ffi::mjOBJ_SENSOR,
            ObjType::Equality => ffi::mjOBJ_EQUALITY,
            ObjType::Key => ffi::mjOBJ_KEY,
            ObjType::Hfield => ffi::mjOBJ_HFIELD,
        }) as i32
    }

    /// Converts MuJoCo's `mjtObj` code (as stored in e.g. `eq_obj1id`'s companion type) back.
    pub fn from_raw(raw: i32) -> Option<ObjType> {
        ObjType::ALL.into_iter().find(|t| t.raw() == raw)
    }

    pub(crate) fn count(self, m: &ffi::mjModel) -> i32 {
        match self {
            ObjType::Body => m.nbody,
            ObjType::Joint => m.njnt,
            ObjType::Geom => m.ngeom,
            ObjType::Site => m.nsite,
            ObjType::Actuator => m.nu,
            ObjType::Sensor => m.nsensor,
            ObjType::Equality => m.neq,
            ObjType::Key => m.nkey,
            ObjType::Hfield => m.nhfield,
        }
    }
}

impl fmt::Display for ObjType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ObjType::Body => "body",
            ObjType::Joint => "joint",
            ObjType::Geom => "geom",
            ObjType::Site => "site",
            ObjType::Actuator => "actuator",
            ObjType::Sensor => "sensor",
            ObjType::Equality => "equality",
            ObjType::Key => "keyframe",
            ObjType::Hfield => "hfield",
        })
    }
}

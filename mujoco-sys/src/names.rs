//! Object kinds and name ↔ id lookups.

use std::ffi::{CStr, CString};
use std::fmt;

use crate::error::{MujocoError, Result};
use crate::ffi;
use crate::Model;

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
}

impl ObjType {
    pub const ALL: [ObjType; 8] = [
        ObjType::Body,
        ObjType::Joint,
        ObjType::Geom,
        ObjType::Site,
        ObjType::Actuator,
        ObjType::Sensor,
        ObjType::Equality,
        ObjType::Key,
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
        }) as i32
    }

    /// Converts MuJoCo's `mjtObj` code (as stored in e.g. `eq_obj1id`'s companion type) back.
    pub fn from_raw(raw: i32) -> Option<ObjType> {
        ObjType::ALL.into_iter().find(|t| t.raw() == raw)
    }

    fn count(self, m: &ffi::mjModel) -> i32 {
        match self {
            ObjType::Body => m.nbody,
            ObjType::Joint => m.njnt,
            ObjType::Geom => m.ngeom,
            ObjType::Site => m.nsite,
            ObjType::Actuator => m.nu,
            ObjType::Sensor => m.nsensor,
            ObjType::Equality => m.neq,
            ObjType::Key => m.nkey,
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
        })
    }
}

impl Model {
    /// The id of the named object, or an error that names the object, the model and the names it does have.
    pub fn id(&self, kind: ObjType, name: &str) -> Result<usize> {
        let c = CString::new(name).map_err(|_| MujocoError::Invalid(format!("name {name:?} contains NUL")))?;
        // SAFETY: valid model pointer and NUL-terminated name.
        let id = unsafe { ffi::mj_name2id(self.raw(), kind.raw(), c.as_ptr()) };
        if id >= 0 {
            return Ok(id as usize);
        }
        let known = self.names(kind);
        let hint = if known.is_empty() {
            format!(" (it has no named {kind}s)")
        } else {
            let shown: Vec<&str> = known.iter().take(12).map(String::as_str).collect();
            let more = if known.len() > 12 { format!(", … {} more", known.len() - 12) } else { String::new() };
            format!(" (its {kind}s: {}{more})", shown.join(", "))
        };
        Err(MujocoError::NotFound { model: self.name().to_string(), kind, name: name.to_string(), hint })
    }

    /// The name of object `id`, if it has one.
    pub fn name_of(&self, kind: ObjType, id: usize) -> Option<&str> {
        if id >= kind.count(self.raw()) as usize {
            return None;
        }
        // SAFETY: id is in range; MuJoCo returns NULL for unnamed objects.
        let p = unsafe { ffi::mj_id2name(self.raw(), kind.raw(), id as i32) };
        if p.is_null() {
            return None;
        }
        // SAFETY: names live as long as the model.
        unsafe { CStr::from_ptr(p) }.to_str().ok().filter(|s| !s.is_empty())
    }

    /// All names of one kind, in id order (unnamed objects skipped).
    pub fn names(&self, kind: ObjType) -> Vec<String> {
        (0..kind.count(self.raw()) as usize).filter_map(|i| self.name_of(kind, i).map(str::to_string)).collect()
    }

    /// The number of objects of one kind.
    pub fn count(&self, kind: ObjType) -> usize {
        kind.count(self.raw()) as usize
    }
}

//! Name ↔ id lookups of a model's objects.

use std::ffi::{CStr, CString};

use crate::error::{MujocoError, Result};
use crate::model::Model;
use crate::obj_type::ObjType;
use mujoco_sys::ffi;

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

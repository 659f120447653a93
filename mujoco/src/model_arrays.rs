//! Typed views of mjModel's arrays: read-only for structure, mutable for the parameters that domain randomisation
//! and system identification change (masses, inertias, friction, motor armature/damping/frictionloss, gains).

use crate::kinds::{EqualityType, GeomType, JointType, Transmission};
use crate::model::Model;
use mujoco_sys::ffi::{mjNBIAS, mjNEQDATA, mjNGAIN, mjNIMP, mjNREF};

/// A slice over a MuJoCo array of `count` items of type `T` (`T` may be `[f64; N]` for row-major groups).
///
/// # Safety
/// `ptr` must point to `count` valid items that live as long as `'a`.
pub(crate) unsafe fn view<'a, T, S>(ptr: *const S, count: usize) -> &'a [T] {
    if count == 0 || ptr.is_null() {
        &[]
    } else {
        std::slice::from_raw_parts(ptr as *const T, count)
    }
}

/// Mutable counterpart of [`view`]; same contract, and no other reference may alias the array.
///
/// # Safety
/// `ptr` must point to `count` valid, initialised values of `T`'s layout that outlive `'a`, with no other live
/// reference to them.
pub(crate) unsafe fn view_mut<'a, T, S>(ptr: *mut S, count: usize) -> &'a mut [T] {
    if count == 0 || ptr.is_null() {
        &mut []
    } else {
        std::slice::from_raw_parts_mut(ptr as *mut T, count)
    }
}

macro_rules! read_arrays {
    ($($(#[$doc:meta])* $name:ident: $ty:ty, $count:ident;)*) => {
        impl Model {
            $(
                $(#[$doc])*
                pub fn $name(&self) -> &[$ty] {
                    let m = self.raw();
                    // SAFETY: MuJoCo sizes this array by the model's count field.
                    unsafe { view(m.$name, m.$count as usize) }
                }
            )*
        }
    };
}

macro_rules! write_arrays {
    ($($(#[$doc:meta])* $name:ident / $name_mut:ident: $ty:ty, $count:ident;)*) => {
        impl Model {
            $(
                $(#[$doc])*
                pub fn $name(&self) -> &[$ty] {
                    let m = self.raw();
                    // SAFETY: as in read_arrays.
                    unsafe { view(m.$name, m.$count as usize) }
                }
                /// Mutable view (a parameter value; call `Data::set_const` after changing masses or inertias).
                pub fn $name_mut(&mut self) -> &mut [$ty] {
                    let (ptr, n) = { let m = self.raw(); (m.$name, m.$count as usize) };
                    // SAFETY: `&mut self` gives exclusive access.
                    unsafe { view_mut(ptr, n) }
                }
            )*
        }
    };
}

/// MuJoCo's type codes, read one at a time as the safe layer's enums.
macro_rules! typed_arrays {
    ($($(#[$doc:meta])* $name:ident: $kind:ident, $count:ident;)*) => {
        impl Model {
            $(
                $(#[$doc])*
                pub fn $name(&self, i: usize) -> $kind {
                    let m = self.raw();
                    // SAFETY: as in read_arrays.
                    let codes: &[i32] = unsafe { view(m.$name, m.$count as usize) };
                    $kind::of(codes[i])
                }
            )*
        }
    };
}

typed_arrays! {
    /// Joint `i`'s type.
    jnt_type: JointType, njnt;
    /// Geom `i`'s shape.
    geom_type: GeomType, ngeom;
    /// What actuator `i` drives.
    actuator_trntype: Transmission, nu;
    /// Equality constraint `i`'s type.
    eq_type: EqualityType, neq;
}

read_arrays! {
    body_parentid: i32, nbody;
    body_rootid: i32, nbody;
    body_weldid: i32, nbody;
    body_jntnum: i32, nbody;
    body_jntadr: i32, nbody;
    body_geomnum: i32, nbody;
    body_geomadr: i32, nbody;
    body_pos: [f64; 3], nbody;
    body_quat: [f64; 4], nbody;
    body_iquat: [f64; 4], nbody;
    body_subtreemass: f64, nbody;
    jnt_qposadr: i32, njnt;
    jnt_dofadr: i32, njnt;
    jnt_bodyid: i32, njnt;
    jnt_limited: u8, njnt;
    jnt_pos: [f64; 3], njnt;
    jnt_axis: [f64; 3], njnt;
    jnt_range: [f64; 2], njnt;
    /// Spring stiffness of each joint (0: none) and the qpos the springs pull towards.
    jnt_stiffness: f64, njnt;
    qpos_spring: f64, nq;
    dof_bodyid: i32, nv;
    dof_jntid: i32, nv;
    geom_bodyid: i32, ngeom;
    geom_pos: [f64; 3], ngeom;
    site_bodyid: i32, nsite;
    site_pos: [f64; 3], nsite;
    actuator_trnid: [i32; 2], nu;
    actuator_ctrllimited: u8, nu;
    actuator_forcelimited: u8, nu;
    actuator_ctrlrange: [f64; 2], nu;
    actuator_gear: [f64; 6], nu;
    actuator_gaintype: i32, nu;
    actuator_biastype: i32, nu;
    sensor_objid: i32, nsensor;
    sensor_dim: i32, nsensor;
    sensor_adr: i32, nsensor;
    eq_obj1id: i32, neq;
    eq_obj2id: i32, neq;
    eq_active: u8, neq;
    eq_data: [f64; mjNEQDATA as usize], neq;
    key_time: f64, nkey;
    /// Height fields: half-extents x, y, elevation z and base depth (m); samples per row and column; first sample.
    hfield_size: [f64; 4], nhfield;
    hfield_nrow: i32, nhfield;
    hfield_ncol: i32, nhfield;
    hfield_adr: i32, nhfield;
}

write_arrays! {
    /// Body masses (kg).
    body_mass / body_mass_mut: f64, nbody;
    /// Principal moments of inertia (kg·m²) in the body's inertial frame.
    body_inertia / body_inertia_mut: [f64; 3], nbody;
    /// Contact filter bits: a pair collides when (contype_a & conaffinity_b) | (contype_b & conaffinity_a) ≠ 0.
    geom_contype / geom_contype_mut: i32, ngeom;
    geom_conaffinity / geom_conaffinity_mut: i32, ngeom;
    /// Colour (alpha 0 hides a geom).
    geom_rgba / geom_rgba_mut: [f32; 4], ngeom;
    /// Centre of mass of each body in its frame (m).
    body_ipos / body_ipos_mut: [f64; 3], nbody;
    /// Geom sizes (meaning by type: box half-sizes; capsule radius and half-length).
    geom_size / geom_size_mut: [f64; 3], ngeom;
    /// Geom orientation in its body's frame.
    geom_quat / geom_quat_mut: [f64; 4], ngeom;
    /// Radius of each geom's bounding sphere (the broad phase reads it: keep it in step with the size).
    geom_rbound / geom_rbound_mut: f64, ngeom;
    /// Contact stiffness and damping (`solref`) per geom; a contact mixes its two geoms'.
    geom_solref / geom_solref_mut: [f64; mjNREF as usize], ngeom;
    /// Contact impedance (`solimp`) per geom.
    geom_solimp / geom_solimp_mut: [f64; mjNIMP as usize], ngeom;
    /// Sliding, torsional, rolling friction per geom.
    geom_friction / geom_friction_mut: [f64; 3], ngeom;
    /// Rotor inertia reflected to the joint (kg·m²). MuJoCo 2.2 reads it into the mass matrix through a value that
    /// `Data::set_const` computes: call it after a change, or the change has no effect.
    dof_armature / dof_armature_mut: f64, nv;
    /// Viscous friction (N·m·s/rad).
    dof_damping / dof_damping_mut: f64, nv;
    /// Dry friction (N·m).
    dof_frictionloss / dof_frictionloss_mut: f64, nv;
    /// Actuator gain parameters (`gainprm`, 10 per actuator).
    actuator_gainprm / actuator_gainprm_mut: [f64; mjNGAIN as usize], nu;
    /// Actuator bias parameters (`biasprm`, 10 per actuator).
    actuator_biasprm / actuator_biasprm_mut: [f64; mjNBIAS as usize], nu;
    /// Actuator force limits [low, high] (N·m for these joints), applied where `actuator_forcelimited`.
    actuator_forcerange / actuator_forcerange_mut: [f64; 2], nu;
    /// Height-field samples, normalised to [0, 1] of the field's elevation (row-major, row 0 at −y); collisions
    /// read them live, so a field can be written after compiling.
    hfield_data / hfield_data_mut: f32, nhfielddata;
}

impl Model {
    /// Gives geom `g` another shape; its size must then be given in that shape's terms (and its bounding radius).
    pub fn set_geom_type(&mut self, g: usize, kind: GeomType) {
        let (ptr, n) = {
            let m = self.raw();
            (m.geom_type, m.ngeom as usize)
        };
        // SAFETY: `&mut self` gives exclusive access; the array holds ngeom codes.
        let codes: &mut [i32] = unsafe { view_mut(ptr, n) };
        codes[g] = kind.raw();
    }

    /// qpos of keyframe `key` (nq values).
    pub fn key_qpos(&self, key: usize) -> &[f64] {
        let m = self.raw();
        let nq = m.nq as usize;
        // SAFETY: key_qpos holds nkey × nq values.
        let all: &[f64] = unsafe { view(m.key_qpos, m.nkey as usize * nq) };
        &all[key * nq..(key + 1) * nq]
    }

    /// ctrl of keyframe `key` (nu values).
    pub fn key_ctrl(&self, key: usize) -> &[f64] {
        let m = self.raw();
        let nu = m.nu as usize;
        // SAFETY: key_ctrl holds nkey × nu values.
        let all: &[f64] = unsafe { view(m.key_ctrl, m.nkey as usize * nu) };
        &all[key * nu..(key + 1) * nu]
    }

    /// The default joint configuration (`qpos0`, nq values).
    pub fn qpos0(&self) -> &[f64] {
        let m = self.raw();
        // SAFETY: qpos0 has nq values.
        unsafe { view(m.qpos0, m.nq as usize) }
    }

    /// Gravity vector (m/s²).
    pub fn gravity(&self) -> [f64; 3] {
        self.raw().opt.gravity
    }
}

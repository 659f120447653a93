//! `Data`: one simulation state for a model, owned by one thread at a time. Every call that can raise a MuJoCo
//! error goes through the shim and returns `Err` instead of exiting the process.

use mujoco_sys::shim;
use std::sync::Arc;

use crate::error::{MujocoError, Result};
use crate::guard::{self, guarded};
use crate::kinds::ConstraintType;
use crate::model::Model;
use crate::model_arrays::{view, view_mut};
use mujoco_sys::ffi::{self, mjContact, mjData};

/// MuJoCo's warning kinds (`mjtWarning`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Warning {
    Inertia = ffi::mjWARN_INERTIA as isize,
    ContactFull = ffi::mjWARN_CONTACTFULL as isize,
    ConstraintFull = ffi::mjWARN_CNSTRFULL as isize,
    VGeomFull = ffi::mjWARN_VGEOMFULL as isize,
    BadQpos = ffi::mjWARN_BADQPOS as isize,
    BadQvel = ffi::mjWARN_BADQVEL as isize,
    BadQacc = ffi::mjWARN_BADQACC as isize,
    BadCtrl = ffi::mjWARN_BADCTRL as isize,
}

impl Warning {
    pub const ALL: [Warning; 8] = [
        Warning::Inertia,
        Warning::ContactFull,
        Warning::ConstraintFull,
        Warning::VGeomFull,
        Warning::BadQpos,
        Warning::BadQvel,
        Warning::BadQacc,
        Warning::BadCtrl,
    ];
}

/// A simulation state. It keeps its model alive; several `Data` may share one `Arc<Model>`.
pub struct Data {
    ptr: std::ptr::NonNull<mjData>,
    model: Arc<Model>,
}

// SAFETY: an mjData is owned exclusively by this value; MuJoCo keeps no thread affinity.
unsafe impl Send for Data {}

impl Drop for Data {
    fn drop(&mut self) {
        // SAFETY: we own the pointer.
        unsafe { ffi::mj_deleteData(self.ptr.as_ptr()) }
    }
}

impl Clone for Data {
    /// A deep copy sharing the same model. Panics only if MuJoCo cannot allocate; see `try_clone`.
    fn clone(&self) -> Self {
        self.try_clone().expect("mj_copyData failed")
    }
}

macro_rules! data_arrays {
    ($($(#[$doc:meta])* $name:ident / $name_mut:ident: $ty:ty, |$m:ident| $count:expr;)*) => {
        impl Data {
            $(
                $(#[$doc])*
                pub fn $name(&self) -> &[$ty] {
                    let $m = self.model.raw();
                    // SAFETY: MuJoCo sizes this array by the model dimensions.
                    unsafe { view(self.raw().$name, ($count) as usize) }
                }
                pub fn $name_mut(&mut self) -> &mut [$ty] {
                    let n = { let $m = self.model.raw(); ($count) as usize };
                    // SAFETY: `&mut self` gives exclusive access to the array.
                    unsafe { view_mut(self.raw().$name, n) }
                }
            )*
        }
    };
}

data_arrays! {
    qpos / qpos_mut: f64, |m| m.nq;
    qvel / qvel_mut: f64, |m| m.nv;
    qacc / qacc_mut: f64, |m| m.nv;
    /// The solver's warm start; part of the state needed to continue a simulation bit for bit.
    qacc_warmstart / qacc_warmstart_mut: f64, |m| m.nv;
    act / act_mut: f64, |m| m.na;
    ctrl / ctrl_mut: f64, |m| m.nu;
    /// Generalised forces applied by the user (nv).
    qfrc_applied / qfrc_applied_mut: f64, |m| m.nv;
    /// Cartesian [force(3), torque(3)] applied at each body's centre of mass, world frame.
    xfrc_applied / xfrc_applied_mut: [f64; 6], |m| m.nbody;
    actuator_force / actuator_force_mut: f64, |m| m.nu;
    actuator_length / actuator_length_mut: f64, |m| m.nu;
    actuator_velocity / actuator_velocity_mut: f64, |m| m.nu;
    qfrc_actuator / qfrc_actuator_mut: f64, |m| m.nv;
    qfrc_constraint / qfrc_constraint_mut: f64, |m| m.nv;
    qfrc_bias / qfrc_bias_mut: f64, |m| m.nv;
    /// What `Data::inverse` computes: the generalised forces that produce `qacc` (nv).
    qfrc_inverse / qfrc_inverse_mut: f64, |m| m.nv;
    sensordata / sensordata_mut: f64, |m| m.nsensordata;
    xpos / xpos_mut: [f64; 3], |m| m.nbody;
    xquat / xquat_mut: [f64; 4], |m| m.nbody;
    xmat / xmat_mut: [f64; 9], |m| m.nbody;
    xipos / xipos_mut: [f64; 3], |m| m.nbody;
    /// Com-based spatial velocity per body: [angular(3), linear(3)].
    cvel / cvel_mut: [f64; 6], |m| m.nbody;
    cfrc_ext / cfrc_ext_mut: [f64; 6], |m| m.nbody;
    subtree_com / subtree_com_mut: [f64; 3], |m| m.nbody;
    geom_xpos / geom_xpos_mut: [f64; 3], |m| m.ngeom;
    geom_xmat / geom_xmat_mut: [f64; 9], |m| m.ngeom;
    site_xpos / site_xpos_mut: [f64; 3], |m| m.nsite;
    site_xmat / site_xmat_mut: [f64; 9], |m| m.nsite;
    /// Each joint's anchor and axis in the world frame (after kinematics).
    xanchor / xanchor_mut: [f64; 3], |m| m.njnt;
    xaxis / xaxis_mut: [f64; 3], |m| m.njnt;
}

impl Data {
    /// A fresh state at the model's `qpos0`.
    pub fn new(model: Arc<Model>) -> Result<Data> {
        guard::init()?;
        let mut out: *mut mjData = std::ptr::null_mut();
        // SAFETY: valid model; the shim writes the new pointer on success.
        guarded("mj_makeData", |e, n| unsafe { shim::mjs_make_data(model.raw(), &mut out, e, n) })?;
        let ptr = std::ptr::NonNull::new(out)
            .ok_or_else(|| MujocoError::Fatal { call: "mj_makeData", message: "allocation failed".into() })?;
        Ok(Data { ptr, model })
    }

    /// A deep copy sharing the same model.
    pub fn try_clone(&self) -> Result<Data> {
        let mut out: *mut mjData = std::ptr::null_mut();
        // SAFETY: self was made for self.model.
        guarded("mj_copyData", |e, n| unsafe { shim::mjs_copy_data(&mut out, self.model.raw(), self.raw(), e, n) })?;
        let ptr = std::ptr::NonNull::new(out)
            .ok_or_else(|| MujocoError::Fatal { call: "mj_copyData", message: "allocation failed".into() })?;
        Ok(Data { ptr, model: self.model.clone() })
    }

    pub fn model(&self) -> &Model {
        &self.model
    }

    pub fn model_arc(&self) -> &Arc<Model> {
        &self.model
    }

    /// The model, mutable. If other `Data` share it, this `Data` first gets its own copy (copy-on-write), so the
    /// change never leaks into other simulations.
    pub fn model_mut(&mut self) -> &mut Model {
        Arc::make_mut(&mut self.model)
    }

    /// The raw struct, for reading anything the safe layer does not wrap.
    pub fn raw(&self) -> &mjData {
        // SAFETY: valid for our lifetime.
        unsafe { self.ptr.as_ref() }
    }

    /// The raw struct, mutable.
    ///
    /// # Safety
    /// Do not change sizes, pointers or the stack bookkeeping.
    pub unsafe fn raw_mut(&mut self) -> &mut mjData {
        self.ptr.as_mut()
    }

    fn parts(&mut self) -> (*const ffi::mjModel, *mut mjData) {
        (self.model.raw() as *const _, self.ptr.as_ptr())
    }

    /// One physics step (`mj_step`). On `Err` the state is undefined: call `reset` before using it again.
    pub fn step(&mut self) -> Result<()> {
        let (m, d) = self.parts();
        // SAFETY: d was made for m.
        let r = guarded("mj_step", |e, n| unsafe { shim::mjs_step(m, d, e, n) });
        self.check_capacity("mj_step", r)
    }

    /// First half of a step (positions and velocities), so controls can depend on them.
    pub fn step1(&mut self) -> Result<()> {
        let (m, d) = self.parts();
        // SAFETY: d was made for m; the call is guarded.
        guarded("mj_step1", |e, n| unsafe { shim::mjs_step1(m, d, e, n) })
    }

    /// Second half of a step (forces, acceleration, integration).
    pub fn step2(&mut self) -> Result<()> {
        let (m, d) = self.parts();
        // SAFETY: d was made for m; the call is guarded.
        let r = guarded("mj_step2", |e, n| unsafe { shim::mjs_step2(m, d, e, n) });
        self.check_capacity("mj_step2", r)
    }

    /// Computes everything derived from the state without integrating (`mj_forward`).
    pub fn forward(&mut self) -> Result<()> {
        let (m, d) = self.parts();
        // SAFETY: d was made for m; the call is guarded.
        let r = guarded("mj_forward", |e, n| unsafe { shim::mjs_forward(m, d, e, n) });
        self.check_capacity("mj_forward", r)
    }

    /// Turns MuJoCo's silent truncations (contacts or constraint rows beyond the model's `<size>`, raised only as
    /// warnings) and its stack-overflow error into `MujocoError::Capacity`, which names the `<size>` attribute.
    fn check_capacity(&self, call: &'static str, r: Result<()>) -> Result<()> {
        let m = self.model.raw();
        let err = |what, limit: i32, attribute, needed: i32| MujocoError::Capacity {
            model: self.model.name().to_string(),
            call,
            what,
            limit: limit as usize,
            attribute,
            suggested: (needed.max(limit) as usize * 3).div_ceil(2),
        };
        match r {
            Err(MujocoError::Fatal { message, .. }) if message.contains("Stack overflow") => {
                Err(err("the solver's stack", m.nstack, "nstack", self.raw().maxuse_stack.max(m.nstack)))
            }
            Err(e) => Err(e),
            Ok(()) if self.warning_count(Warning::ContactFull) > 0 => {
                Err(err("the number of contacts", m.nconmax, "nconmax", self.raw().ncon))
            }
            Ok(()) if self.warning_count(Warning::ConstraintFull) > 0 => {
                Err(err("the number of constraint rows", m.njmax, "njmax", self.raw().nefc))
            }
            Ok(()) => Ok(()),
        }
    }

    /// Bytes this `Data` holds: its buffer and its stack (the model's are `Model::memory_bytes`).
    pub fn memory_bytes(&self) -> usize {
        let d = self.raw();
        std::mem::size_of::<mjData>() + d.nbuffer as usize + d.nstack as usize * std::mem::size_of::<f64>()
    }

    /// The most stack (in mjtNum), contacts and constraint rows used since the last reset.
    pub fn max_use(&self) -> (usize, usize, usize) {
        let d = self.raw();
        (d.maxuse_stack as usize, d.maxuse_con as usize, d.maxuse_efc as usize)
    }

    /// Positions and velocities of every body, geom and site from `qpos` and `qvel` alone (`mj_kinematics`,
    /// `mj_comPos`, `mj_comVel`): no forces, contacts or sensors.
    pub fn kinematics(&mut self) -> Result<()> {
        let (m, d) = self.parts();
        // SAFETY: d was made for m.
        guarded("mj_kinematics", |e, n| unsafe { shim::mjs_kinematics(m, d, e, n) })
    }

    /// Positions and the constraint set (rows, violations, Jacobian) for the current `qpos` (`mj_fwdPosition`):
    /// what loop-closure solving needs, without velocities, forces or integration.
    pub fn fwd_position(&mut self) -> Result<()> {
        let (m, d) = self.parts();
        // SAFETY: d was made for m; the call is guarded (a MuJoCo error returns instead of exiting).
        let r = guarded("mj_fwdPosition", |e, n| unsafe { shim::mjs_fwd_position(m, d, e, n) });
        self.check_capacity("mj_fwdPosition", r)
    }

    /// Inverse dynamics (`mj_inverse`): the generalised forces, into `qfrc_inverse`, that give the current `qacc`
    /// at the current position and velocity, constraint forces included.
    pub fn inverse(&mut self) -> Result<()> {
        let (m, d) = self.parts();
        // SAFETY: d was made for m; the call is guarded.
        let r = guarded("mj_inverse", |e, n| unsafe { shim::mjs_inverse(m, d, e, n) });
        self.check_capacity("mj_inverse", r)
    }

    /// The joint-space inertia matrix (nv × nv, row-major) at the last computed position.
    pub fn full_mass_matrix(&self) -> Vec<f64> {
        let nv = self.model.nv();
        let mut out = vec![0.0; nv * nv];
        // SAFETY: out holds nv × nv values; qM is d's, made for this model.
        unsafe { ffi::mj_fullM(self.model.raw(), out.as_mut_ptr(), self.raw().qM) };
        out
    }

    /// The constraint Jacobian as a dense nefc × nv row-major matrix, or `None` when the model stores it sparse
    /// (`Model::set_dense_jacobian` makes a model store it dense).
    pub fn efc_jacobian(&self) -> Option<&[f64]> {
        let (m, d) = (self.model().raw(), self.raw());
        let sparse =
            m.opt.jacobian == ffi::mjJAC_SPARSE as i32 || (m.opt.jacobian == ffi::mjJAC_AUTO as i32 && m.nv >= 60);
        if sparse {
            return None;
        }
        // SAFETY: in dense mode efc_J holds nefc × nv doubles, valid until the next call that changes the data
        // (which needs &mut self).
        Some(unsafe { view(d.efc_J, d.nefc as usize * m.nv as usize) })
    }

    /// Values in a state snapshot: qpos, qvel, act, ctrl, the solver's warm start (qacc_warmstart), time, and the
    /// applied forces (qfrc_applied, xfrc_applied) — what fixes the simulation's future for a given model (MuJoCo
    /// 3's "integration state" less mocap and user data, which we do not use). The applied forces belong here: a
    /// forward pass after restoring (for derived quantities) reads them and rewrites the warm start from them.
    pub fn state_len(&self) -> usize {
        let m = self.model();
        self.state_len_without_forces() + m.nv() + 6 * m.nbody()
    }

    /// The snapshot length of builds before the applied forces were part of it (`load_state` pads such a
    /// snapshot with zero forces).
    pub fn state_len_without_forces(&self) -> usize {
        let m = self.model();
        m.nq() + 2 * m.nv() + m.na() + m.nu() + 1
    }

    /// Appends the state snapshot (see `state_len`) to `out`: `load_state` continues the simulation bit for bit.
    pub fn save_state(&self, out: &mut Vec<f64>) {
        for arr in [self.qpos(), self.qvel(), self.act(), self.ctrl(), self.qacc_warmstart()] {
            out.extend_from_slice(arr);
        }
        out.push(self.time());
        out.extend_from_slice(self.qfrc_applied());
        out.extend(self.xfrc_applied().iter().flatten());
    }

    /// Restores a snapshot from the front of `src`; returns how many values it read.
    pub fn load_state(&mut self, src: &[f64]) -> Result<usize> {
        let need = self.state_len();
        if src.len() < need {
            return Err(MujocoError::Invalid(format!(
                "state snapshot of model '{}' needs {need} values, got {}",
                self.model().name(),
                src.len()
            )));
        }
        let m = self.model();
        let (nq, nv, na, nu) = (m.nq(), m.nv(), m.na(), m.nu());
        let mut at = 0;
        let mut take = |n: usize| {
            let s = &src[at..at + n];
            at += n;
            s
        };
        self.qpos_mut().copy_from_slice(take(nq));
        self.qvel_mut().copy_from_slice(take(nv));
        self.act_mut().copy_from_slice(take(na));
        self.ctrl_mut().copy_from_slice(take(nu));
        self.qacc_warmstart_mut().copy_from_slice(take(nv));
        self.set_time(take(1)[0]);
        self.qfrc_applied_mut().copy_from_slice(take(nv));
        let x = take(6 * self.model().nbody());
        for (w, c) in self.xfrc_applied_mut().iter_mut().zip(x.chunks_exact(6)) {
            w.copy_from_slice(c);
        }
        Ok(need)
    }

    /// Back to `qpos0`, zero velocity, zero controls, warnings cleared.
    pub fn reset(&mut self) -> Result<()> {
        let (m, d) = self.parts();
        // SAFETY: d was made for m; the call is guarded.
        guarded("mj_resetData", |e, n| unsafe { shim::mjs_reset_data(m, d, e, n) })
    }

    /// Back to keyframe `key` (its qpos, qvel, act, ctrl, time).
    pub fn reset_keyframe(&mut self, key: usize) -> Result<()> {
        if key >= self.model.nkey() {
            return Err(MujocoError::Invalid(format!(
                "keyframe {key} out of range: model '{}' has {} keyframes",
                self.model.name(),
                self.model.nkey()
            )));
        }
        let (m, d) = self.parts();
        // SAFETY: d was made for m and `key` was checked against nkey above; the call is guarded.
        guarded("mj_resetDataKeyframe", |e, n| unsafe { shim::mjs_reset_data_keyframe(m, d, key as i32, e, n) })
    }

    /// Recomputes the model constants that depend on masses and inertias (`mj_setConst`), after changing them.
    /// Uses (and leaves at `qpos0`) this `Data`.
    pub fn set_const(&mut self) -> Result<()> {
        let d = self.ptr.as_ptr();
        let m = self.model_mut().as_ptr();
        // SAFETY: d was made for m (copy-on-write keeps the sizes).
        guarded("mj_setConst", |e, n| unsafe { shim::mjs_set_const(m, d, e, n) })
    }

    /// Recomputes the constants of `model` (`mj_setConst`) on a scratch `Data`, after its masses, inertias or
    /// armature changed: MuJoCo 2.2 reads the armature into the mass matrix only through them.
    pub fn set_const_of(model: &mut Arc<Model>) -> Result<()> {
        let mut d = Data::new(model.clone())?;
        d.set_const()?;
        *model = d.model_arc().clone();
        Ok(())
    }

    /// Simulation time (s).
    pub fn time(&self) -> f64 {
        self.raw().time
    }

    pub fn set_time(&mut self, t: f64) {
        // SAFETY: a state value.
        unsafe { self.raw_mut().time = t };
    }

    /// How many times each warning fired since the last reset or `clear_warnings`.
    pub fn warning_count(&self, w: Warning) -> i32 {
        self.raw().warning[w as usize].number
    }

    pub fn clear_warnings(&mut self) {
        // SAFETY: plain counters.
        unsafe {
            for w in self.raw_mut().warning.iter_mut() {
                w.number = 0;
                w.lastinfo = 0;
            }
        }
    }

    /// True if the simulation blew up: MuJoCo flagged a bad qpos/qvel/qacc (it then silently resets the state),
    /// or the state holds a non-finite number.
    pub fn is_unstable(&self) -> bool {
        [Warning::BadQpos, Warning::BadQvel, Warning::BadQacc].iter().any(|&w| self.warning_count(w) > 0)
            || !self.qpos().iter().chain(self.qvel()).all(|x| x.is_finite())
    }

    /// Active contacts (valid after `forward` or `step`).
    pub fn contacts(&self) -> &[mjContact] {
        let d = self.raw();
        // SAFETY: `contact` holds at least ncon entries.
        unsafe { view(d.contact, d.ncon as usize) }
    }

    /// Contact `i`'s force and torque in its contact frame (normal first), via `mj_contactForce`.
    pub fn contact_force(&self, i: usize) -> Result<[f64; 6]> {
        if i >= self.raw().ncon as usize {
            return Err(MujocoError::Invalid(format!("contact {i} out of range ({} contacts)", self.raw().ncon)));
        }
        let mut out = [0.0; 6];
        // SAFETY: index checked; writes 6 values.
        unsafe { ffi::mj_contactForce(self.model.raw(), self.raw(), i as i32, out.as_mut_ptr()) };
        Ok(out)
    }

    /// 6-D velocity [angular(3), linear(3)] of a body's frame origin (`mj_objectVelocity`), in world
    /// orientation, or in the body's own frame if `local`. Valid after `forward`/`step`.
    pub fn body_velocity(&self, body: usize, local: bool) -> [f64; 6] {
        self.object_velocity(crate::obj_type::ObjType::Body, body, local)
    }

    /// 6-D velocity [angular(3), linear(3)] of an object's frame (body, geom, site, camera), in world orientation
    /// or in the object's own frame if `local`. Panics on an index the model does not have.
    pub fn object_velocity(&self, kind: crate::obj_type::ObjType, id: usize, local: bool) -> [f64; 6] {
        let n = self.model.count(kind);
        assert!(id < n, "{kind} {id} out of range ({n})");
        let mut out = [0.0; 6];
        // SAFETY: index checked; writes 6 values.
        unsafe {
            ffi::mj_objectVelocity(self.model.raw(), self.raw(), kind.raw(), id as i32, out.as_mut_ptr(), local as i32)
        };
        out
    }

    /// Rows of the current constraint set (after the last forward/step).
    pub fn nefc(&self) -> usize {
        self.raw().nefc as usize
    }

    /// Constraint row `i`'s type.
    pub fn efc_type(&self, i: usize) -> ConstraintType {
        ConstraintType::of(self.efc_codes()[i])
    }

    fn efc_codes(&self) -> &[i32] {
        let d = self.raw();
        // SAFETY: efc_type holds nefc entries after the last forward/step; the view lives as long as &self.
        unsafe { view(d.efc_type, d.nefc as usize) }
    }
    /// Object id of each constraint row (equality id for equality rows).
    pub fn efc_id(&self) -> &[i32] {
        let d = self.raw();
        // SAFETY: as for efc_type.
        unsafe { view(d.efc_id, d.nefc as usize) }
    }
    /// Constraint violation of each row.
    pub fn efc_pos(&self) -> &[f64] {
        let d = self.raw();
        // SAFETY: as for efc_type.
        unsafe { view(d.efc_pos, d.nefc as usize) }
    }
    /// Constraint force of each row.
    pub fn efc_force(&self) -> &[f64] {
        let d = self.raw();
        // SAFETY: as for efc_type.
        unsafe { view(d.efc_force, d.nefc as usize) }
    }

    /// Euclidean norm of equality constraint `eq`'s violation (metres for a connect), from the constraint rows of
    /// the last `forward`/`step`. Zero when the constraint is inactive.
    pub fn equality_residual(&self, eq: usize) -> f64 {
        let equality = ffi::mjCNSTR_EQUALITY as i32;
        let rows = self.efc_codes().iter().zip(self.efc_id()).zip(self.efc_pos());
        rows.filter(|((&t, &id), _)| t == equality && id as usize == eq).map(|(_, p)| p * p).sum::<f64>().sqrt()
    }
}

//! The C shim's entry points (shim/shim.c): each MuJoCo call that can raise a fatal error, run under `setjmp`
//! so that the error returns as a non-zero code and a message in `err` instead of ending the process; and the
//! one-time installation of the error and warning handlers.

use std::ffi::{c_char, c_int};

use crate::ffi::{mjData, mjModel, mjVFS, mjrContext, mjrRect, mjvScene};

extern "C" {
    pub fn mjs_install_handlers(warning_cb: extern "C" fn(*const c_char));
    pub fn mjs_step(m: *const mjModel, d: *mut mjData, err: *mut c_char, len: c_int) -> c_int;
    pub fn mjs_step1(m: *const mjModel, d: *mut mjData, err: *mut c_char, len: c_int) -> c_int;
    pub fn mjs_step2(m: *const mjModel, d: *mut mjData, err: *mut c_char, len: c_int) -> c_int;
    pub fn mjs_forward(m: *const mjModel, d: *mut mjData, err: *mut c_char, len: c_int) -> c_int;
    pub fn mjs_make_scene(m: *const mjModel, scn: *mut mjvScene, maxgeom: c_int, err: *mut c_char, len: c_int)
        -> c_int;
    pub fn mjs_make_context(
        m: *const mjModel,
        con: *mut mjrContext,
        fontscale: c_int,
        err: *mut c_char,
        len: c_int,
    ) -> c_int;
    pub fn mjs_render(
        viewport: mjrRect,
        scn: *mut mjvScene,
        con: *const mjrContext,
        err: *mut c_char,
        len: c_int,
    ) -> c_int;
    pub fn mjs_kinematics(m: *const mjModel, d: *mut mjData, err: *mut c_char, len: c_int) -> c_int;
    pub fn mjs_fwd_position(m: *const mjModel, d: *mut mjData, err: *mut c_char, len: c_int) -> c_int;
    pub fn mjs_inverse(m: *const mjModel, d: *mut mjData, err: *mut c_char, len: c_int) -> c_int;
    pub fn mjs_reset_data(m: *const mjModel, d: *mut mjData, err: *mut c_char, len: c_int) -> c_int;
    pub fn mjs_reset_data_keyframe(
        m: *const mjModel,
        d: *mut mjData,
        key: c_int,
        err: *mut c_char,
        len: c_int,
    ) -> c_int;
    pub fn mjs_set_const(m: *mut mjModel, d: *mut mjData, err: *mut c_char, len: c_int) -> c_int;
    pub fn mjs_make_data(m: *const mjModel, out: *mut *mut mjData, err: *mut c_char, len: c_int) -> c_int;
    pub fn mjs_copy_data(
        out: *mut *mut mjData,
        m: *const mjModel,
        src: *const mjData,
        err: *mut c_char,
        len: c_int,
    ) -> c_int;
    pub fn mjs_copy_model(out: *mut *mut mjModel, src: *const mjModel, err: *mut c_char, len: c_int) -> c_int;
    pub fn mjs_save_last_xml(
        filename: *const c_char,
        m: *const mjModel,
        ok: *mut c_int,
        err: *mut c_char,
        len: c_int,
    ) -> c_int;
    pub fn mjs_load_xml(
        filename: *const c_char,
        vfs: *const mjVFS,
        out: *mut *mut mjModel,
        err: *mut c_char,
        len: c_int,
    ) -> c_int;
}

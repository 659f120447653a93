//! The C shim's entry points, the one-time library set-up (version check, error and warning handlers), and the
//! helper that turns a shim return code into `Result`.

use std::ffi::{c_char, c_int, CStr};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

use crate::error::{MujocoError, Result};
use mujoco_sys::shim::mjs_install_handlers;

pub(crate) const ERR_LEN: usize = 1024;

/// Warnings logged so far; after the first few only every 1000th is logged, so that a batch of diverging
/// environments cannot flood the log (callers see every warning through `Data::warnings`).
static WARNINGS_SEEN: AtomicU64 = AtomicU64::new(0);

extern "C" fn log_warning(msg: *const c_char) {
    let n = WARNINGS_SEEN.fetch_add(1, Ordering::Relaxed);
    if n < 20 || n.is_multiple_of(1000) {
        // SAFETY: the shim always passes a NUL-terminated string.
        let text = unsafe { CStr::from_ptr(msg) }.to_string_lossy();
        log::warn!(target: "mujoco", "{text} (MuJoCo warning #{})", n + 1);
    }
}

/// Checks the library version and installs our handlers, once per process. Every constructor calls it.
pub(crate) fn init() -> Result<()> {
    static INIT: OnceLock<Result<()>> = OnceLock::new();
    INIT.get_or_init(|| {
        // SAFETY: plain getters with no preconditions.
        let version = unsafe { mujoco_sys::ffi::mj_version() };
        if !(220..230).contains(&version) {
            return Err(MujocoError::Version {
                found: format!("{}.{}.{}", version / 100, version / 10 % 10, version % 10),
            });
        }
        // SAFETY: sets two process-global function pointers to handlers that never return into MuJoCo
        // wrongly (the error one long-jumps or aborts).
        unsafe { mjs_install_handlers(log_warning) };
        Ok(())
    })
    .clone()
}

/// The library version string, e.g. "2.2.2".
pub fn version_string() -> String {
    // SAFETY: mj_version reads a constant; it has no preconditions.
    let v = unsafe { mujoco_sys::ffi::mj_version() };
    format!("{}.{}.{}", v / 100, v / 10 % 10, v % 10)
}

/// Runs one shim call with an error buffer and maps a non-zero return to `MujocoError::Fatal`.
pub(crate) fn guarded(call: &'static str, f: impl FnOnce(*mut c_char, c_int) -> c_int) -> Result<()> {
    let mut buf = [0 as c_char; ERR_LEN];
    if f(buf.as_mut_ptr(), ERR_LEN as c_int) == 0 {
        Ok(())
    } else {
        Err(MujocoError::Fatal { call, message: c_buf_to_string(&buf) })
    }
}

pub(crate) fn c_buf_to_string(buf: &[c_char]) -> String {
    // SAFETY: the shim and MuJoCo NUL-terminate within the buffer; the last byte is never written otherwise.
    let bytes: Vec<u8> = buf.iter().take_while(|&&c| c != 0).map(|&c| c as u8).collect();
    // MuJoCo wraps its messages (the XML parser's over two lines); an error is one line on our side.
    String::from_utf8_lossy(&bytes).lines().map(str::trim).filter(|l| !l.is_empty()).collect::<Vec<_>>().join(" ")
}

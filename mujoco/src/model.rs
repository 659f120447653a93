//! `Model`: a compiled mjModel, loaded from a file or from an XML string (through MuJoCo's virtual file system).

use mujoco_sys::shim;
use std::ffi::{c_char, CStr, CString};
use std::mem::MaybeUninit;
use std::path::Path;
use std::ptr::NonNull;

use crate::error::{MujocoError, Result};
use crate::guard::{self, c_buf_to_string, guarded, ERR_LEN};
use crate::kinds::{Cone, Solver};
use mujoco_sys::ffi::{self, mjModel};

/// A compiled MuJoCo model. Immutable while shared (`Arc<Model>`); the parameters that domain randomisation and
/// system identification change are reachable through `&mut Model`.
pub struct Model {
    ptr: NonNull<mjModel>,
}

// SAFETY: an mjModel is a plain heap block that MuJoCo only reads during simulation; mutation needs `&mut`.
unsafe impl Send for Model {}
unsafe impl Sync for Model {}

impl Drop for Model {
    fn drop(&mut self) {
        // SAFETY: we own the pointer, allocated by MuJoCo.
        unsafe { ffi::mj_deleteModel(self.ptr.as_ptr()) }
    }
}

impl Clone for Model {
    /// A deep copy (`mj_copyModel`). Panics only if MuJoCo cannot allocate the copy; use `try_clone` to handle that.
    fn clone(&self) -> Self {
        self.try_clone().expect("mj_copyModel failed")
    }
}

/// The name MuJoCo gets for a model loaded from a string; includes resolve against its directory.
const INLINE_NAME: &str = "mujoco_sys_inline_model.xml";

impl Model {
    /// Loads and compiles an MJCF (or MJB) file.
    pub fn from_xml_path(path: impl AsRef<Path>) -> Result<Self> {
        guard::init()?;
        let path = path.as_ref();
        if let Err(e) = std::fs::metadata(path) {
            return Err(MujocoError::MissingFile { path: path.to_path_buf(), reason: e.to_string() });
        }
        let c = path_cstring(path)?;
        load(&c, None, &path.display().to_string())
    }

    /// Compiles an MJCF document held in memory. `base_dir` is where `<include>`d files and meshes are looked up.
    pub fn from_xml_string(xml: &str, base_dir: impl AsRef<Path>) -> Result<Self> {
        guard::init()?;
        let vfs = Vfs::with_file(INLINE_NAME, xml.as_bytes())?;
        // MuJoCo finds the VFS file by its name without directory, and resolves includes against the directory.
        let c = path_cstring(&base_dir.as_ref().join(INLINE_NAME))?;
        load(&c, Some(&vfs), "<xml string>")
    }

    /// Writes an MJCF of this model (MuJoCo's `mj_saveLastXML`): the document this process last loaded from an XML
    /// file, flattened, with this model's numeric values (joint armature, damping and frictionloss, actuator gains,
    /// masses, …) copied back. So `self` must be a copy of the model loaded last — load the file, change the values,
    /// save. Written to a temporary file beside `path`, then renamed.
    pub fn save_last_xml(&self, path: &Path) -> Result<()> {
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let name = path.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
        let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
        let c = path_cstring(&tmp)?;
        let mut ok: std::os::raw::c_int = 0;
        let mut message = String::new();
        guarded("mj_saveLastXML", |e, n| {
            // SAFETY: valid model and NUL-terminated name; MuJoCo writes at most `n` bytes of error into `e`.
            let r = unsafe { shim::mjs_save_last_xml(c.as_ptr(), self.raw(), &mut ok, e, n) };
            if r == 0 && ok == 0 {
                // SAFETY: MuJoCo NUL-terminated its message within the buffer.
                message = guard::c_buf_to_string(unsafe { std::slice::from_raw_parts(e, n as usize) });
            }
            r
        })?;
        if ok == 0 {
            let _ = std::fs::remove_file(&tmp);
            return Err(MujocoError::Fatal { call: "mj_saveLastXML", message });
        }
        std::fs::rename(&tmp, path)
            .map_err(|e| MujocoError::Fatal { call: "rename", message: format!("{}: {e}", path.display()) })
    }

    /// A deep copy, or an error if MuJoCo cannot make one.
    pub fn try_clone(&self) -> Result<Self> {
        let mut out: *mut mjModel = std::ptr::null_mut();
        // SAFETY: valid source model; the shim writes the new pointer on success.
        guarded("mj_copyModel", |e, n| unsafe { shim::mjs_copy_model(&mut out, self.raw(), e, n) })?;
        NonNull::new(out)
            .map(|ptr| Model { ptr })
            .ok_or_else(|| MujocoError::Fatal { call: "mj_copyModel", message: "allocation failed".into() })
    }

    /// Bytes this model holds (its struct and its buffer).
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of::<mjModel>() + self.raw().nbuffer as usize
    }

    /// The raw struct, for FFI-level code (the bare-`mj_step` bench); everything else reads the accessors.
    pub fn raw(&self) -> &mjModel {
        // SAFETY: the pointer is valid for the model's lifetime.
        unsafe { self.ptr.as_ref() }
    }

    /// The raw struct, mutable.
    ///
    /// # Safety
    /// Changing sizes (`nq`, `nv`, …) or array pointers breaks every `Data` made for this model; only change
    /// parameter values.
    pub unsafe fn raw_mut(&mut self) -> &mut mjModel {
        self.ptr.as_mut()
    }

    pub(crate) fn as_ptr(&self) -> *mut mjModel {
        self.ptr.as_ptr()
    }

    /// The model's name (`<mujoco model="…">`).
    pub fn name(&self) -> &str {
        let m = self.raw();
        if m.nnames == 0 || m.names.is_null() {
            return "";
        }
        // SAFETY: the names buffer starts with the NUL-terminated model name.
        unsafe { CStr::from_ptr(m.names) }.to_str().unwrap_or("")
    }

    pub fn nq(&self) -> usize {
        self.raw().nq as usize
    }
    pub fn nv(&self) -> usize {
        self.raw().nv as usize
    }
    pub fn nu(&self) -> usize {
        self.raw().nu as usize
    }
    pub fn na(&self) -> usize {
        self.raw().na as usize
    }
    pub fn nbody(&self) -> usize {
        self.raw().nbody as usize
    }
    pub fn njnt(&self) -> usize {
        self.raw().njnt as usize
    }
    pub fn ngeom(&self) -> usize {
        self.raw().ngeom as usize
    }
    pub fn nsite(&self) -> usize {
        self.raw().nsite as usize
    }
    pub fn nsensor(&self) -> usize {
        self.raw().nsensor as usize
    }
    pub fn nsensordata(&self) -> usize {
        self.raw().nsensordata as usize
    }
    pub fn neq(&self) -> usize {
        self.raw().neq as usize
    }
    pub fn nkey(&self) -> usize {
        self.raw().nkey as usize
    }
    /// The preallocated sizes of the MJCF's `<size>`: contacts, constraint rows, and the stack in mjtNums.
    pub fn nconmax(&self) -> usize {
        self.raw().nconmax as usize
    }
    pub fn njmax(&self) -> usize {
        self.raw().njmax as usize
    }
    pub fn nstack(&self) -> usize {
        self.raw().nstack as usize
    }

    /// Physics timestep in seconds.
    pub fn timestep(&self) -> f64 {
        self.raw().opt.timestep
    }

    /// Sets the physics timestep; it must be positive and finite.
    pub fn set_timestep(&mut self, dt: f64) -> Result<()> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(MujocoError::Invalid(format!("timestep must be positive and finite, got {dt}")));
        }
        // SAFETY: a parameter value, not a size.
        unsafe { self.raw_mut().opt.timestep = dt };
        Ok(())
    }

    pub fn integrator(&self) -> Integrator {
        Integrator::from_raw(self.raw().opt.integrator)
    }

    pub fn set_integrator(&mut self, integrator: Integrator) {
        // SAFETY: a parameter value, not a size.
        unsafe { self.raw_mut().opt.integrator = integrator as i32 };
    }

    pub fn solver_iterations(&self) -> usize {
        self.raw().opt.iterations.max(0) as usize
    }

    pub fn solver_tolerance(&self) -> f64 {
        self.raw().opt.tolerance
    }

    /// The contacts' friction cone (`opt.cone`).
    pub fn cone(&self) -> Cone {
        Cone::of(self.raw().opt.cone)
    }

    /// Sets the friction cone. The cone changes the constraint rows per contact: the model's `njmax` must hold them.
    pub fn set_cone(&mut self, cone: Cone) {
        // SAFETY: a solver option; the constraint arrays are sized by njmax, checked at every step.
        unsafe { self.raw_mut().opt.cone = cone.raw() };
    }

    /// Ratio of frictional to normal constraint impedance (`opt.impratio`).
    pub fn impratio(&self) -> f64 {
        self.raw().opt.impratio
    }

    pub fn set_impratio(&mut self, ratio: f64) {
        // SAFETY: a parameter value, not a size.
        unsafe { self.raw_mut().opt.impratio = ratio };
    }

    /// The constraint solver (`opt.solver`).
    pub fn solver(&self) -> Solver {
        Solver::of(self.raw().opt.solver)
    }

    pub fn set_solver(&mut self, solver: Solver) {
        // SAFETY: a solver option, not a size.
        unsafe { self.raw_mut().opt.solver = solver.raw() };
    }

    /// The constraint solver's iteration limit (`opt.iterations`).
    pub fn set_solver_iterations(&mut self, iterations: usize) {
        // SAFETY: a solver option, not a size: nothing allocated depends on it.
        unsafe { self.raw_mut().opt.iterations = iterations.clamp(1, i32::MAX as usize) as i32 };
    }

    /// The constraint solver's tolerance (`opt.tolerance`): it stops once the cost improves by less.
    pub fn set_solver_tolerance(&mut self, tolerance: f64) {
        // SAFETY: a solver option, not a size.
        unsafe { self.raw_mut().opt.tolerance = tolerance };
    }

    /// Whether `mj_step`/`mj_forward` compute the sensors (`sensordata`).
    /// Store the constraint Jacobian dense (nefc × nv) whatever the model's size (`Data::efc_jacobian`).
    pub fn set_dense_jacobian(&mut self) {
        // SAFETY: a solver option, not a size: nothing allocated depends on it.
        unsafe { self.raw_mut().opt.jacobian = ffi::mjJAC_DENSE as i32 };
    }

    pub fn sensors_enabled(&self) -> bool {
        self.raw().opt.disableflags & ffi::mjDSBL_SENSOR as i32 == 0
    }

    /// Turns contacts on or off (off: a robot hung in the air, whose feet must touch nothing).
    pub fn set_contacts_enabled(&mut self, on: bool) {
        let bit = ffi::mjDSBL_CONTACT as i32;
        // SAFETY: a parameter value, not a size.
        let flags = unsafe { &mut self.raw_mut().opt.disableflags };
        *flags = if on { *flags & !bit } else { *flags | bit };
    }

    /// Turns sensor evaluation on or off. Off skips work the dynamics never reads (the accelerometer alone needs a
    /// second recursive Newton–Euler pass every step); `sensordata` then keeps stale values.
    pub fn set_sensors_enabled(&mut self, on: bool) {
        let bit = ffi::mjDSBL_SENSOR as i32;
        // SAFETY: a parameter value, not a size.
        let flags = unsafe { &mut self.raw_mut().opt.disableflags };
        *flags = if on { *flags & !bit } else { *flags | bit };
    }

    /// Total mass of all bodies (kg).
    pub fn total_mass(&self) -> f64 {
        self.body_mass().iter().sum()
    }

    /// qpos address of a joint.
    pub fn jnt_qposadr_of(&self, joint: usize) -> usize {
        self.jnt_qposadr()[joint] as usize
    }

    /// dof (qvel) address of a joint.
    pub fn jnt_dofadr_of(&self, joint: usize) -> usize {
        self.jnt_dofadr()[joint] as usize
    }
}

/// MuJoCo 2.2's integrators.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Integrator {
    Euler = ffi::mjINT_EULER as isize,
    Rk4 = ffi::mjINT_RK4 as isize,
    Implicit = ffi::mjINT_IMPLICIT as isize,
}

impl Integrator {
    fn from_raw(raw: i32) -> Self {
        match raw as u32 {
            ffi::mjINT_RK4 => Integrator::Rk4,
            ffi::mjINT_IMPLICIT => Integrator::Implicit,
            _ => Integrator::Euler,
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Euler => "Euler",
            Integrator::Rk4 => "RK4",
            Integrator::Implicit => "implicit",
        }
    }
}

fn path_cstring(path: &Path) -> Result<CString> {
    CString::new(path.as_os_str().as_encoded_bytes())
        .map_err(|_| MujocoError::Invalid(format!("path {} contains NUL", path.display())))
}

fn load(filename: &CStr, vfs: Option<&Vfs>, source_name: &str) -> Result<Model> {
    let mut err = [0 as c_char; ERR_LEN];
    let mut out: *mut mjModel = std::ptr::null_mut();
    let vfs_ptr = vfs.map_or(std::ptr::null(), |v| v.as_ptr());
    // SAFETY: valid C strings and buffers; the shim guards mju_error.
    let rc = unsafe { shim::mjs_load_xml(filename.as_ptr(), vfs_ptr, &mut out, err.as_mut_ptr(), ERR_LEN as i32) };
    let message = c_buf_to_string(&err);
    match NonNull::new(out) {
        Some(ptr) if rc == 0 => {
            if !message.is_empty() {
                log::warn!(target: "mujoco", "{source_name}: {message}");
            }
            Ok(Model { ptr })
        }
        Some(ptr) => {
            // An mju_error after the model was built: free it and report.
            drop(Model { ptr });
            Err(MujocoError::Load { source_name: source_name.to_string(), message })
        }
        None => Err(MujocoError::Load {
            source_name: source_name.to_string(),
            message: if message.is_empty() { "unknown error".into() } else { message },
        }),
    }
}

/// A heap-allocated mjVFS (about 2 MB, too big for the stack) that frees its files on drop.
struct Vfs {
    vfs: Box<MaybeUninit<ffi::mjVFS>>,
}

impl Vfs {
    fn with_file(name: &str, contents: &[u8]) -> Result<Vfs> {
        let mut vfs = Box::<ffi::mjVFS>::new_uninit();
        // SAFETY: mj_defaultVFS initialises the struct.
        unsafe { ffi::mj_defaultVFS(vfs.as_mut_ptr()) };
        let this = Vfs { vfs };
        let c_name = CString::new(name).expect("static name");
        let size = i32::try_from(contents.len())
            .map_err(|_| MujocoError::Invalid(format!("XML string too large ({} bytes)", contents.len())))?;
        // SAFETY: initialised VFS; MuJoCo allocates `size` bytes for the new file.
        let rc = unsafe { ffi::mj_makeEmptyFileVFS(this.as_ptr() as *mut _, c_name.as_ptr(), size) };
        if rc != 0 {
            return Err(MujocoError::Invalid(format!("mj_makeEmptyFileVFS failed with code {rc}")));
        }
        // SAFETY: the file was just added, so findFileVFS returns its index and its buffer holds `size` bytes.
        unsafe {
            let idx = ffi::mj_findFileVFS(this.as_ptr(), c_name.as_ptr());
            let v = &*this.as_ptr();
            if idx < 0 || v.filedata[idx as usize].is_null() {
                return Err(MujocoError::Invalid("virtual file system lost the XML string".into()));
            }
            std::ptr::copy_nonoverlapping(contents.as_ptr(), v.filedata[idx as usize] as *mut u8, contents.len());
        }
        Ok(this)
    }

    fn as_ptr(&self) -> *const ffi::mjVFS {
        self.vfs.as_ptr()
    }
}

impl Drop for Vfs {
    fn drop(&mut self) {
        // SAFETY: initialised in with_file before any early return could skip it.
        unsafe { ffi::mj_deleteVFS(self.vfs.as_mut_ptr()) }
    }
}

//! A headless OpenGL context through EGL (Mesa's software renderer on a machine without a GPU or an X server), for
//! MuJoCo's renderer; libEGL is loaded at run time so that a machine without it gets a message instead of a crash.

use khronos_egl as egl;

use crate::error::{MujocoError, Result};

/// `EGL_PLATFORM_SURFACELESS_MESA`: render without any window system.
const PLATFORM_SURFACELESS_MESA: egl::Enum = 0x31DD;

/// What to install when EGL is missing or cannot render.
pub const INSTALL_HINT: &str =
    "install EGL and Mesa's renderer: `apt-get install -y libegl1 libegl-mesa0 libgl1-mesa-dri` (scripts/setup.sh does)";

/// An OpenGL context, current on the thread that made it, with a pbuffer surface.
pub struct GlContext {
    egl: egl::DynamicInstance<egl::EGL1_5>,
    display: egl::Display,
    context: egl::Context,
    surface: egl::Surface,
}

impl GlContext {
    /// A context with a `width` × `height` pbuffer, current on this thread until dropped.
    pub fn headless(width: usize, height: usize) -> Result<GlContext> {
        let gl = |what: &str, e: &dyn std::fmt::Display| MujocoError::Gl(format!("{what} ({e}): {INSTALL_HINT}"));
        // SAFETY: loading the system's libEGL, which implements the EGL API the crate describes.
        let egl = unsafe { egl::DynamicInstance::<egl::EGL1_5>::load_required() }
            .map_err(|e| gl("cannot load libEGL", &e))?;
        // SAFETY: the surfaceless platform takes the default (null) native display.
        let display =
            unsafe { egl.get_platform_display(PLATFORM_SURFACELESS_MESA, egl::DEFAULT_DISPLAY, &[egl::ATTRIB_NONE]) }
                .map_err(|e| gl("no headless EGL display", &e))?;
        egl.initialize(display).map_err(|e| gl("eglInitialize failed", &e))?;
        egl.bind_api(egl::OPENGL_API).map_err(|e| gl("EGL has no desktop OpenGL", &e))?;
        let attributes = [
            egl::SURFACE_TYPE,
            egl::PBUFFER_BIT,
            egl::RENDERABLE_TYPE,
            egl::OPENGL_BIT,
            egl::RED_SIZE,
            8,
            egl::GREEN_SIZE,
            8,
            egl::BLUE_SIZE,
            8,
            egl::DEPTH_SIZE,
            24,
            egl::NONE,
        ];
        let config = egl
            .choose_first_config(display, &attributes)
            .map_err(|e| gl("eglChooseConfig", &e))?
            .ok_or_else(|| gl("EGL offers no OpenGL pbuffer configuration", &"none"))?;
        let context =
            egl.create_context(display, config, None, &[egl::NONE]).map_err(|e| gl("eglCreateContext", &e))?;
        let surface = egl
            .create_pbuffer_surface(display, config, &[egl::WIDTH, width as i32, egl::HEIGHT, height as i32, egl::NONE])
            .map_err(|e| gl("eglCreatePbufferSurface", &e))?;
        egl.make_current(display, Some(surface), Some(surface), Some(context)).map_err(|e| gl("eglMakeCurrent", &e))?;
        Ok(GlContext { egl, display, context, surface })
    }
}

impl Drop for GlContext {
    fn drop(&mut self) {
        let _ = self.egl.make_current(self.display, None, None, None);
        let _ = self.egl.destroy_surface(self.display, self.surface);
        let _ = self.egl.destroy_context(self.display, self.context);
        let _ = self.egl.terminate(self.display);
    }
}

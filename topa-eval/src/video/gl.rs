//! A headless OpenGL context through EGL (Mesa's software renderer on a machine without a GPU or an X server),
//! loaded at run time so that a machine without the libraries gets a message instead of a crash.

use anyhow::{anyhow, Context, Result};
use khronos_egl as egl;

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
    pub fn headless(width: usize, height: usize) -> Result<GlContext> {
        // SAFETY: loading the system's libEGL, which implements the EGL API the crate describes.
        let egl = unsafe { egl::DynamicInstance::<egl::EGL1_5>::load_required() }
            .map_err(|e| anyhow!("cannot load libEGL ({e}): {INSTALL_HINT}"))?;
        // SAFETY: the surfaceless platform takes the default (null) native display.
        let display =
            unsafe { egl.get_platform_display(PLATFORM_SURFACELESS_MESA, egl::DEFAULT_DISPLAY, &[egl::ATTRIB_NONE]) }
                .map_err(|e| anyhow!("no headless EGL display ({e}): {INSTALL_HINT}"))?;
        egl.initialize(display).map_err(|e| anyhow!("eglInitialize failed ({e}): {INSTALL_HINT}"))?;
        egl.bind_api(egl::OPENGL_API).context("EGL has no desktop OpenGL")?;
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
            .context("eglChooseConfig")?
            .ok_or_else(|| anyhow!("EGL offers no OpenGL pbuffer configuration: {INSTALL_HINT}"))?;
        let context = egl.create_context(display, config, None, &[egl::NONE]).context("eglCreateContext")?;
        let surface = egl
            .create_pbuffer_surface(display, config, &[egl::WIDTH, width as i32, egl::HEIGHT, height as i32, egl::NONE])
            .context("eglCreatePbufferSurface")?;
        egl.make_current(display, Some(surface), Some(surface), Some(context)).context("eglMakeCurrent")?;
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

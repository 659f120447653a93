//! Rendering with MuJoCo's own renderer (`mjv_*` scene, `mjr_*` OpenGL context): RGB frames of a `Data` from a
//! camera that follows a body, with MuJoCo's text overlay, offscreen (videos) or into a window (the viewer). The caller makes an OpenGL context
//! current on this thread first (EGL, OSMesa or GLX); MuJoCo finds its functions through whichever of those
//! libraries the process has loaded. Every call that can raise a MuJoCo error returns `Err`.

use mujoco_sys::shim;
use std::ffi::CString;
use std::sync::Arc;

use crate::data::Data;
use crate::error::{MujocoError, Result};
use crate::guard::guarded;
use crate::model::Model;
use mujoco_sys::ffi::{self, mjrContext, mjrRect, mjvCamera, mjvOption, mjvPerturb, mjvScene};

/// Most geoms a frame can hold.
const MAX_GEOM: i32 = 2000;

/// Rendering quality. On a software OpenGL (Mesa's llvmpipe, no GPU) `High` costs ~150 ms a 640×480 frame on
/// 2 cores and `Fast` ~15 ms (measured by the application's render benchmark).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quality {
    /// No multisampling, one quad per plane, no shadows, no reflections.
    Fast,
    /// The model's own visual settings (multisampling, shadows, floor reflections).
    High,
}

pub struct Renderer {
    model: Arc<Model>,
    scene: Box<mjvScene>,
    context: Box<mjrContext>,
    option: Box<mjvOption>,
    camera: mjvCamera,
    width: usize,
    height: usize,
    rgb: Vec<u8>,
    frame: Vec<u8>,
    /// The size of the last drawn viewport.
    viewport: (usize, usize),
    /// The OpenGL context was set up (only then may it be freed: freeing calls into OpenGL).
    context_made: bool,
}

/// A body picked with the mouse and the spring that drags it (its handling: `interact`).
pub struct Perturb {
    pub(crate) raw: Box<mjvPerturb>,
}

impl Default for Perturb {
    fn default() -> Self {
        // SAFETY: a plain C struct, initialised by MuJoCo's default function before use.
        let mut raw: Box<mjvPerturb> = Box::new(unsafe { std::mem::zeroed() });
        // SAFETY: a valid pointer to an owned struct.
        unsafe { ffi::mjv_defaultPerturb(&mut *raw) };
        Perturb { raw }
    }
}

/// A corner of the frame for a text overlay.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Corner {
    TopLeft,
    TopRight,
    BottomLeft,
    BottomRight,
}

impl Corner {
    fn grid(self) -> i32 {
        (match self {
            Corner::TopLeft => ffi::mjGRID_TOPLEFT,
            Corner::TopRight => ffi::mjGRID_TOPRIGHT,
            Corner::BottomLeft => ffi::mjGRID_BOTTOMLEFT,
            Corner::BottomRight => ffi::mjGRID_BOTTOMRIGHT,
        }) as i32
    }
}

impl Drop for Renderer {
    fn drop(&mut self) {
        // SAFETY: the scene was initialised by MuJoCo in `new`; the context only if `context_made`.
        unsafe {
            if self.context_made {
                ffi::mjr_freeContext(&mut *self.context);
            }
            ffi::mjv_freeScene(&mut *self.scene);
        }
    }
}

impl Renderer {
    /// A renderer of `width` × `height` pixels for `model`. Needs a current OpenGL context; the size must fit the
    /// model's offscreen buffer (`<visual><global offwidth offheight>`).
    pub fn new(model: Arc<Model>, width: usize, height: usize, quality: Quality) -> Result<Self> {
        let mut r = Self::make(model, width, height, quality)?;
        // SAFETY: the context was made by `make`.
        unsafe { ffi::mjr_setBuffer(ffi::mjFB_OFFSCREEN as i32, &mut *r.context) };
        let c = &r.context;
        if c.currentBuffer != ffi::mjFB_OFFSCREEN as i32 {
            return Err(MujocoError::Invalid("the OpenGL context has no offscreen framebuffer".into()));
        }
        if width > c.offWidth as usize || height > c.offHeight as usize || width == 0 || height == 0 {
            return Err(MujocoError::Invalid(format!(
                "frame {width}×{height} does not fit the model's offscreen buffer {}×{} (raise <visual><global \
                 offwidth offheight> in the MJCF)",
                c.offWidth, c.offHeight
            )));
        }
        r.rgb = vec![0; 3 * width * height];
        r.frame = vec![0; 3 * width * height];
        Ok(r)
    }

    /// A renderer drawing into the window whose OpenGL context is current on this thread (its default
    /// framebuffer); the viewport is given with each `draw`.
    pub fn on_window(model: Arc<Model>, quality: Quality) -> Result<Self> {
        let mut r = Self::make(model, 0, 0, quality)?;
        // SAFETY: the context was made by `make`.
        unsafe { ffi::mjr_setBuffer(ffi::mjFB_WINDOW as i32, &mut *r.context) };
        if r.context.currentBuffer != ffi::mjFB_WINDOW as i32 {
            return Err(MujocoError::Invalid("the OpenGL context has no window framebuffer".into()));
        }
        Ok(r)
    }

    fn make(model: Arc<Model>, width: usize, height: usize, quality: Quality) -> Result<Self> {
        let mut model = model;
        if quality == Quality::Fast {
            let m = Arc::make_mut(&mut model);
            // SAFETY: visual parameters, read when the context is made.
            unsafe {
                m.raw_mut().vis.quality.offsamples = 0;
                m.raw_mut().vis.quality.numquads = 1;
            }
        }
        // SAFETY: plain C structs, initialised by MuJoCo's default functions before any other use.
        let (mut scene, mut context, mut option): (Box<mjvScene>, Box<mjrContext>, Box<mjvOption>) =
            unsafe { (Box::new(std::mem::zeroed()), Box::new(std::mem::zeroed()), Box::new(std::mem::zeroed())) };
        let mut camera: mjvCamera = unsafe { std::mem::zeroed() };
        // SAFETY: valid pointers to owned structs.
        unsafe {
            ffi::mjv_defaultScene(&mut *scene);
            ffi::mjr_defaultContext(&mut *context);
            ffi::mjv_defaultOption(&mut *option);
            ffi::mjv_defaultCamera(&mut camera);
        }
        // Bodies with geoms only in the groups MuJoCo hides by default (3–5, collision geometry: a robot vendored
        // without its visual meshes) would draw as nothing: show those groups then.
        let raw = model.raw();
        // SAFETY: the model's geom arrays hold ngeom entries.
        let seen =
            (0..raw.ngeom as usize).any(|g| unsafe { *raw.geom_bodyid.add(g) > 0 && *raw.geom_group.add(g) < 3 });
        if !seen {
            option.geomgroup[3..6].fill(1);
        }
        let m = model.raw() as *const _;
        // The structs are boxed: their addresses stay put if a guarded call long-jumps out.
        let (scn, con) = (&mut *scene as *mut mjvScene, &mut *context as *mut mjrContext);
        // SAFETY: valid model and owned structs.
        guarded("mjv_makeScene", |e, n| unsafe { shim::mjs_make_scene(m, scn, MAX_GEOM, e, n) })?;
        // Text about 1/25 of the frame height: MuJoCo's font scales are fixed steps.
        let font = match height {
            1..=300 => ffi::mjFONTSCALE_50,
            0 | 301..=600 => ffi::mjFONTSCALE_100,
            _ => ffi::mjFONTSCALE_150,
        };
        // SAFETY: a GL context is current (made above) and `con` is a default-initialised mjrContext; the call is
        // guarded (no usable OpenGL raises mju_error, which returns here as an error).
        let made = guarded("mjr_makeContext", |e, n| unsafe { shim::mjs_make_context(m, con, font as i32, e, n) });
        let mut r = Renderer {
            model,
            scene,
            context,
            option,
            camera,
            width,
            height,
            rgb: Vec::new(),
            frame: Vec::new(),
            viewport: (width, height),
            context_made: made.is_ok(),
        };
        made.map_err(|e| {
            MujocoError::Invalid(format!("MuJoCo could not set up rendering (is an OpenGL context current?): {e}"))
        })?;
        if quality == Quality::Fast {
            r.set_effects(false, false);
        }
        Ok(r)
    }

    /// Shadows and floor reflections (each an extra rendering pass; on a software renderer they cost most of a
    /// frame).
    pub fn set_effects(&mut self, shadows: bool, reflections: bool) {
        self.scene.flags[ffi::mjRND_SHADOW as usize] = shadows as u8;
        self.scene.flags[ffi::mjRND_REFLECTION as usize] = reflections as u8;
    }

    /// The model, scene and camera, for the mouse's functions.
    pub(crate) fn parts(&mut self) -> (*const ffi::mjModel, *const mjvScene, *mut mjvCamera) {
        (self.model.raw(), &*self.scene, &mut self.camera)
    }

    pub(crate) fn option_and_scene(&self) -> (*const mjvOption, *const mjvScene) {
        (&*self.option, &*self.scene)
    }

    /// The camera's distance to what it looks at, m.
    pub fn camera_distance(&self) -> Option<f64> {
        (self.camera.distance > 0.0).then_some(self.camera.distance)
    }

    /// A free camera (the mouse moves it) looking at `lookat` from `distance` m.
    pub fn free(&mut self, lookat: [f64; 3], distance: f64) {
        self.camera.type_ = ffi::mjCAMERA_FREE as i32;
        self.camera.lookat = lookat;
        self.camera.distance = distance;
    }

    /// A camera that follows `body` at `distance` m, looking from `azimuth`° and `elevation`°.
    pub fn track(&mut self, body: usize, distance: f64, azimuth: f64, elevation: f64) {
        self.camera.type_ = ffi::mjCAMERA_TRACKING as i32;
        self.camera.trackbodyid = body as i32;
        self.camera.distance = distance;
        self.camera.azimuth = azimuth;
        self.camera.elevation = elevation;
    }

    /// The size of the frame (offscreen) or of the last drawn viewport (window).
    pub fn size(&self) -> (usize, usize) {
        self.viewport
    }

    /// Where a world point appears in the last rendered frame, in pixels from the top-left corner (None behind
    /// the camera). The pinhole model of MuJoCo's own camera: position, forward and up vectors, and the frustum
    /// at the near plane.
    pub fn project(&self, p: [f64; 3]) -> Option<(f64, f64)> {
        let c = &self.scene.camera[0];
        let f = c.forward.map(|v| v as f64);
        let u = c.up.map(|v| v as f64);
        let r = [f[1] * u[2] - f[2] * u[1], f[2] * u[0] - f[0] * u[2], f[0] * u[1] - f[1] * u[0]];
        let v = [p[0] - c.pos[0] as f64, p[1] - c.pos[1] as f64, p[2] - c.pos[2] as f64];
        let dot = |a: [f64; 3]| a[0] * v[0] + a[1] * v[1] + a[2] * v[2];
        let z = dot(f);
        if z <= 0.0 {
            return None;
        }
        let near = c.frustum_near as f64;
        let (bottom, top, centre) = (c.frustum_bottom as f64, c.frustum_top as f64, c.frustum_center as f64);
        let half_h = (top - bottom) / 2.0;
        let (width, height) = (self.viewport.0 as f64, self.viewport.1 as f64);
        let half_w = half_h * width / height;
        let (x, y) = (dot(r) * near / z, dot(u) * near / z);
        let px = width / 2.0 * (1.0 + (x - centre) / half_w);
        let py = height / 2.0 * (1.0 - (y - (top + bottom) / 2.0) / half_h);
        Some((px, py))
    }

    /// The model geom seen at pixel (`x`, `y`) (top-left origin) in a segmentation rendering of `d`, or None for
    /// the background or a decoration.
    pub fn geom_at(&mut self, d: &mut Data, x: usize, y: usize) -> Result<Option<usize>> {
        let (seg, id) = (ffi::mjRND_SEGMENT as usize, ffi::mjRND_IDCOLOR as usize);
        self.scene.flags[seg] = 1;
        self.scene.flags[id] = 1;
        let size = self.viewport;
        let drawn = self.draw(d, size, &[], None);
        self.scene.flags[seg] = 0;
        self.scene.flags[id] = 0;
        drawn?;
        let frame = self.read_pixels();
        let (width, height) = size;
        if x >= width || y >= height {
            return Err(MujocoError::Invalid(format!("pixel ({x}, {y}) outside the {width}×{height} frame")));
        }
        let p = &frame[3 * (y * width + x)..];
        let code = p[0] as usize | (p[1] as usize) << 8 | (p[2] as usize) << 16;
        if code == 0 || code > self.scene.ngeom as usize {
            return Ok(None);
        }
        // SAFETY: the scene holds `ngeom` geoms; the colour encodes an index below it.
        let g = unsafe { &*self.scene.geoms.add(code - 1) };
        Ok((g.objtype == ffi::mjOBJ_GEOM as i32).then_some(g.objid as usize))
    }

    /// Renders `d` and returns the frame as RGB rows, top row first. `overlay` is written in the top-left
    /// corner (two columns: labels, values; lines separated by '\n').
    pub fn render(&mut self, d: &mut Data, overlay: Option<(&str, &str)>) -> Result<&[u8]> {
        let texts: Vec<_> = overlay.map(|(a, b)| (Corner::TopLeft, a, b)).into_iter().collect();
        let (w, h) = (self.width, self.height);
        self.draw(d, (w, h), &texts, None)?;
        let mut rgb = std::mem::take(&mut self.rgb);
        let mut frame = std::mem::take(&mut self.frame);
        self.read_into((w, h), &mut rgb, &mut frame);
        (self.rgb, self.frame) = (rgb, frame);
        Ok(&self.frame)
    }

    /// Draws `d` into the current framebuffer's `size` (width, height) viewport, with text overlays (labels,
    /// values; lines separated by '\n') and, where given, the mouse perturbation's marker.
    pub fn draw(
        &mut self,
        d: &mut Data,
        (width, height): (usize, usize),
        overlays: &[(Corner, &str, &str)],
        perturb: Option<&Perturb>,
    ) -> Result<()> {
        if d.model().raw().nbody != self.model.raw().nbody || d.model().raw().ngeom != self.model.raw().ngeom {
            return Err(MujocoError::Invalid("render: the Data belongs to another model".into()));
        }
        let viewport = mjrRect { left: 0, bottom: 0, width: width as i32, height: height as i32 };
        self.viewport = (width, height);
        let m = d.model().raw() as *const _;
        let pert = perturb.map_or(std::ptr::null(), |p| &*p.raw as *const mjvPerturb);
        // SAFETY: d was made for a model of this structure; owned structs; the scene holds MAX_GEOM geoms; `pert`
        // null or a valid perturbation.
        unsafe {
            ffi::mjv_updateScene(
                m,
                d.raw_mut(),
                &*self.option,
                pert,
                &mut self.camera,
                ffi::mjCAT_ALL as i32,
                &mut *self.scene,
            )
        };
        let (scn, con) = (&mut *self.scene as *mut mjvScene, &*self.context as *const mjrContext);
        // SAFETY: owned structs, context made in `new`.
        guarded("mjr_render", |e, n| unsafe { shim::mjs_render(viewport, scn, con, e, n) })?;
        for &(corner, left, right) in overlays {
            let (a, b) = (CString::new(left).unwrap_or_default(), CString::new(right).unwrap_or_default());
            // SAFETY: NUL-terminated strings, context made in `new`.
            unsafe {
                ffi::mjr_overlay(
                    ffi::mjFONT_NORMAL as i32,
                    corner.grid(),
                    viewport,
                    a.as_ptr(),
                    b.as_ptr(),
                    &*self.context,
                )
            };
        }
        Ok(())
    }

    /// The pixels of the last `draw` as RGB rows, top row first.
    pub fn read_pixels(&self) -> Vec<u8> {
        let (w, h) = self.viewport;
        let (mut rgb, mut frame) = (vec![0; 3 * w * h], vec![0; 3 * w * h]);
        self.read_into((w, h), &mut rgb, &mut frame);
        frame
    }

    fn read_into(&self, (w, h): (usize, usize), rgb: &mut [u8], frame: &mut [u8]) {
        let viewport = mjrRect { left: 0, bottom: 0, width: w as i32, height: h as i32 };
        // SAFETY: rgb holds w × h × 3 bytes.
        unsafe { ffi::mjr_readPixels(rgb.as_mut_ptr(), std::ptr::null_mut(), viewport, &*self.context) };
        // OpenGL's rows run bottom-up.
        let row = 3 * w;
        for (dst, src) in frame.chunks_exact_mut(row).zip(rgb.chunks_exact(row).rev()) {
            dst.copy_from_slice(src);
        }
    }
}

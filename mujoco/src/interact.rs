//! The mouse in MuJoCo's viewer conventions: camera moves, picking a body under the cursor, and the spring that
//! drags a picked body (`mjvPerturb`), whose force MuJoCo computes from the model's `<visual><map stiffness>`.

use mujoco_sys::ffi;

use crate::data::Data;
pub use crate::render::Perturb;
use crate::render::Renderer;

/// A mouse motion's meaning, MuJoCo's `mjtMouse`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MouseMove {
    /// Rotate about a horizontal axis (vertical drag) …
    RotateV,
    /// … or a vertical one.
    RotateH,
    /// Move in the vertical plane facing the camera …
    MoveV,
    /// … or in the horizontal plane.
    MoveH,
    Zoom,
}

impl MouseMove {
    fn code(self) -> i32 {
        (match self {
            MouseMove::RotateV => ffi::mjMOUSE_ROTATE_V,
            MouseMove::RotateH => ffi::mjMOUSE_ROTATE_H,
            MouseMove::MoveV => ffi::mjMOUSE_MOVE_V,
            MouseMove::MoveH => ffi::mjMOUSE_MOVE_H,
            MouseMove::Zoom => ffi::mjMOUSE_ZOOM,
        }) as i32
    }
}

impl Renderer {
    /// Moves the camera as a mouse drag of (`dx`, `dy`) in window heights would.
    pub fn move_camera(&mut self, how: MouseMove, dx: f64, dy: f64) {
        let (m, scn, cam) = self.parts();
        // SAFETY: the renderer's model, scene and camera, all initialised by MuJoCo.
        unsafe { ffi::mjv_moveCamera(m, how.code(), dx, dy, scn, cam) };
    }

    /// The body under the window point (`relx`, `rely`) (fractions of the width and height from the bottom-left
    /// corner) in the last drawn scene, with the picked point in world coordinates; None for the world or nothing.
    pub fn pick(&mut self, d: &Data, relx: f64, rely: f64) -> Option<(usize, [f64; 3])> {
        let (w, h) = self.size();
        let aspect = w as f64 / h.max(1) as f64;
        let (option, scene) = self.option_and_scene();
        let (mut point, mut geom, mut skin) = ([0.0; 3], [-1i32], [-1i32]);
        // SAFETY: valid model, data, option and scene; out-pointers to owned arrays of the sizes MuJoCo writes.
        let body = unsafe {
            ffi::mjv_select(
                d.model().raw(),
                d.raw(),
                option,
                aspect,
                relx,
                rely,
                scene,
                point.as_mut_ptr(),
                geom.as_mut_ptr(),
                skin.as_mut_ptr(),
            )
        };
        (body > 0).then_some((body as usize, point))
    }
}

impl Perturb {
    /// The picked body, if any.
    pub fn body(&self) -> Option<usize> {
        (self.raw.select > 0).then_some(self.raw.select as usize)
    }

    /// Whether a drag is under way.
    pub fn dragging(&self) -> bool {
        self.raw.active != 0
    }

    /// Picks `body` at the world point `point` (as `Renderer::pick` returns them), or nothing.
    pub fn select(&mut self, d: &Data, picked: Option<(usize, [f64; 3])>) {
        self.raw.active = 0;
        match picked {
            Some((body, p)) if body < d.model().raw().nbody as usize => {
                // The picked point in the body's frame, so that the spring pulls where the user clicked.
                let x = &d.xpos()[body];
                let r = &d.xmat()[body];
                let v = [p[0] - x[0], p[1] - x[1], p[2] - x[2]];
                for (i, l) in self.raw.localpos.iter_mut().enumerate() {
                    *l = r[i] * v[0] + r[3 + i] * v[1] + r[6 + i] * v[2];
                }
                self.raw.select = body as i32;
            }
            _ => self.raw.select = 0,
        }
    }

    /// Starts dragging the picked body (translation: a spring from the picked point to the mouse's point).
    pub fn begin(&mut self, r: &mut Renderer, d: &mut Data) {
        if self.body().is_none() {
            return;
        }
        self.raw.active = ffi::mjPERT_TRANSLATE as i32;
        let (_, scn, _) = r.parts();
        let m = d.model().raw() as *const _;
        // SAFETY: valid model, data, scene and perturbation.
        unsafe { ffi::mjv_initPerturb(m, d.raw_mut(), scn, &mut *self.raw) };
    }

    /// Moves the spring's anchor as a mouse drag of (`dx`, `dy`) in window heights.
    pub fn drag(&mut self, r: &mut Renderer, d: &Data, how: MouseMove, dx: f64, dy: f64) {
        if !self.dragging() {
            return;
        }
        let (_, scn, _) = r.parts();
        // SAFETY: valid model, data, scene and perturbation.
        unsafe { ffi::mjv_movePerturb(d.model().raw(), d.raw(), how.code(), dx, dy, scn, &mut *self.raw) };
    }

    pub fn end(&mut self) {
        self.raw.active = 0;
    }

    /// The spring's wrench on the picked body now, world frame (force, torque about the body's centre of mass),
    /// as MuJoCo's viewer applies it; None when nothing is dragged. `d`'s applied forces are left as they were.
    pub fn wrench(&self, d: &mut Data) -> Option<(usize, [f64; 6])> {
        let body = self.body().filter(|_| self.dragging())?;
        let saved = d.xfrc_applied()[body];
        d.xfrc_applied_mut()[body] = [0.0; 6];
        let m = d.model().raw() as *const _;
        // SAFETY: valid model, data and perturbation; MuJoCo adds the spring's wrench to xfrc_applied[body].
        unsafe { ffi::mjv_applyPerturbForce(m, d.raw_mut(), &*self.raw) };
        let w = d.xfrc_applied()[body];
        d.xfrc_applied_mut()[body] = saved;
        Some((body, w))
    }
}

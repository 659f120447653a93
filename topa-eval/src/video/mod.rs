//! Video of a run, rendered by MuJoCo itself without a display: an EGL context, MuJoCo's offscreen renderer with a
//! camera that follows the torso, the command and the measured velocity written on every frame, and a GIF or MP4.

mod encode;

use std::path::{Path, PathBuf};

use crate::error::Result;
use mujoco::render::{Quality, Renderer};
use topa_env::RobotEnv;

pub use encode::VideoWriter;
pub use mujoco::gl::{GlContext, INSTALL_HINT};

/// Camera distances are given for a robot whose torso stands this high (TopA's stand pose); another robot's are
/// scaled by its own stand height (its spec's `base_height_target`), so that a taller one stays in the frame.
const FRAMED_STAND_HEIGHT_M: f64 = 0.5607;

/// The factor on camera distances that frames `env`'s robot as TopA is framed.
pub fn camera_scale(env: &RobotEnv) -> f64 {
    env.indices().spec.base_height_target / FRAMED_STAND_HEIGHT_M
}

/// Frames of a run at a fixed rate.
pub struct VideoRecorder {
    // Field order is drop order: the renderer frees OpenGL objects while the context still exists.
    renderer: Renderer,
    _gl: GlContext,
    writer: VideoWriter,
    fps: u32,
    /// The robot's size relative to the one the camera distances are given for.
    scale: f64,
}

impl VideoRecorder {
    pub fn create(
        path: &Path,
        env: &RobotEnv,
        (width, height): (usize, usize),
        fps: u32,
        quality: Quality,
    ) -> Result<VideoRecorder> {
        let gl = GlContext::headless(width, height)?;
        let mut renderer = Renderer::new(env.data().model_arc().clone(), width, height, quality)?;
        let scale = camera_scale(env);
        renderer.track(env.indices().torso_body, 1.6 * scale, 150.0, -12.0);
        let writer = VideoWriter::create(path, width, height, fps)?;
        Ok(VideoRecorder { renderer, _gl: gl, writer, fps, scale })
    }

    /// Adds the frames due up to time `t` (s since the start): frame k shows the state at the first step at or
    /// after k / fps, so a run of T seconds has T × fps frames.
    pub fn advance(&mut self, t: f64, env: &mut RobotEnv, text: &(String, String)) -> Result<()> {
        let due = (t * self.fps as f64 + 1e-9).floor() as usize;
        while self.writer.frames() < due {
            let frame = self.renderer.render(env.data_mut(), Some((&text.0, &text.1)))?;
            let frame = frame.to_vec();
            self.writer.write(&frame)?;
        }
        Ok(())
    }

    /// Points the camera: it follows `body` at `distance` m (for a robot of TopA's size; scaled by this one's stand
    /// height) from `azimuth`° (0 looks along +x) and `elevation`°.
    pub fn follow(&mut self, body: usize, distance: f64, azimuth: f64, elevation: f64) {
        self.renderer.track(body, distance * self.scale, azimuth, elevation);
    }

    pub fn frames(&self) -> usize {
        self.writer.frames()
    }

    pub fn finish(self) -> Result<PathBuf> {
        self.writer.finish()
    }
}

/// The overlay: commanded and measured (v_x, v_y, w_z), and the time.
pub fn overlay(env: &RobotEnv, t: f64) -> (String, String) {
    let c = env.command();
    let s = env.robot_state();
    (
        "time\ncommand (vx vy wz)\nmeasured".into(),
        format!(
            "{t:.2} s\n{:+.2} {:+.2} {:+.2}\n{:+.2} {:+.2} {:+.2}",
            c[0], c[1], c[2], s.lin_vel[0], s.lin_vel[1], s.ang_vel[2]
        ),
    )
}

/// A frame size: `WIDTHxHEIGHT` on the command line (e.g. 640x480).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameSize {
    pub width: usize,
    pub height: usize,
}

impl std::str::FromStr for FrameSize {
    type Err = crate::error::Error;
    fn from_str(s: &str) -> std::result::Result<Self, crate::error::Error> {
        let bad = || crate::error::Error::Invalid(format!("a frame size is WIDTHxHEIGHT, e.g. 640x480, not '{s}'"));
        let (w, h) = s.split_once('x').ok_or_else(bad)?;
        let (width, height) = (w.parse().map_err(|_| bad())?, h.parse().map_err(|_| bad())?);
        if width == 0 || height == 0 {
            return Err(bad());
        }
        Ok(FrameSize { width, height })
    }
}

#[cfg(test)]
mod tests {
    use super::FrameSize;

    #[test]
    fn frame_sizes_parse_and_bad_ones_name_the_form() {
        assert_eq!("640x480".parse::<FrameSize>().unwrap(), FrameSize { width: 640, height: 480 });
        for bad in ["640", "640x", "x480", "0x480", "640×480"] {
            let e = bad.parse::<FrameSize>().unwrap_err().to_string();
            assert!(e.contains("WIDTHxHEIGHT") && e.contains(bad), "{e}");
        }
    }
}

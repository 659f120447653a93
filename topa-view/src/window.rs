//! The window: GLFW's, with MuJoCo's renderer drawing into it; keys and mouse in MuJoCo's viewer conventions
//! (left drag rotates, right drag moves, wheel zooms, Ctrl+drag pulls a body on a spring).

use std::path::Path;
use std::time::Instant;

use glfw::{Context, MouseButton, WindowEvent};
use mujoco::interact::{MouseMove, Perturb};
use mujoco::render::{Corner, Quality, Renderer};

use crate::controls::{action_of, Action, HELP};
use crate::error::{Error, Result};
use crate::session::Session;

/// Simulated time a frame covers in lockstep mode (`frames`), s: a 30 fps video's.
pub const LOCKSTEP_FRAME_S: f64 = 1.0 / 30.0;
/// Most simulated time one frame catches up when the machine falls behind real time, s (beyond it the viewer
/// runs slower than real time instead of stalling).
const MAX_CATCH_UP_S: f64 = 0.1;

/// The viewer: a window, its renderer, and the session it shows.
pub struct Viewer {
    // Field order is drop order: the renderer frees OpenGL objects while the window's context still exists.
    renderer: Renderer,
    perturb: Perturb,
    pub session: Session,
    window: glfw::PWindow,
    events: glfw::GlfwReceiver<(f64, WindowEvent)>,
    glfw: glfw::Glfw,
    /// Camera distance for this robot's size, m.
    camera_distance: f64,
    cursor: (f64, f64),
    buttons: [bool; 3],
    /// Wall-clock time of the last frame, and the simulated time owed to the clock.
    last: Option<Instant>,
    owed_s: f64,
    /// Simulated per wall-clock seconds over the last frames.
    real_time: f64,
    quit: bool,
    /// The gamepad's messages, where one can be read (gilrs).
    pad: Option<std::sync::mpsc::Receiver<topa_control::operator::OperatorMessage>>,
}

impl Viewer {
    /// Opens a `size` window showing `session`.
    pub fn open(session: Session, (width, height): (usize, usize), quality: Quality, title: &str) -> Result<Viewer> {
        let mut glfw = glfw::init(glfw::log_errors).map_err(|e| Error::Window(format!("GLFW: {e:?}")))?;
        let (mut window, events) = glfw
            .create_window(width as u32, height as u32, title, glfw::WindowMode::Windowed)
            .ok_or_else(|| Error::Window("GLFW could not create an OpenGL window".into()))?;
        window.make_current();
        window.set_key_polling(true);
        window.set_mouse_button_polling(true);
        window.set_cursor_pos_polling(true);
        window.set_scroll_polling(true);
        glfw.set_swap_interval(glfw::SwapInterval::Sync(1));
        let env = session.env();
        let mut renderer = Renderer::on_window(env.data().model_arc().clone(), quality)?;
        let camera_distance = 1.6 * topa_eval::video::camera_scale(env);
        renderer.track(env.indices().torso_body, camera_distance, 150.0, -12.0);
        let pad = topa_tools::operator_pad::spawn(session.controls.ranges);
        Ok(Viewer {
            renderer,
            perturb: Perturb::default(),
            session,
            window,
            events,
            glfw,
            camera_distance,
            cursor: (0.0, 0.0),
            buttons: [false; 3],
            last: None,
            owed_s: 0.0,
            real_time: 1.0,
            quit: false,
            pad,
        })
    }

    /// Runs until the window closes or Esc; with `frames`, draws that many frames in lockstep (each advancing
    /// `LOCKSTEP_FRAME_S` of simulated time, however long it takes) and stops.
    pub fn run(&mut self, frames: Option<usize>) -> Result<usize> {
        let mut n = 0;
        while !self.quit && !self.window.should_close() && frames.is_none_or(|f| n < f) {
            self.frame(frames.is_some())?;
            n += 1;
        }
        Ok(n)
    }

    /// One frame: events, simulation up to the clock (or one lockstep period), drawing.
    pub fn frame(&mut self, lockstep: bool) -> Result<()> {
        self.glfw.poll_events();
        let events: Vec<_> = glfw::flush_messages(&self.events).map(|(_, e)| e).collect();
        for e in events {
            self.handle(e)?;
        }
        let pad: Vec<_> = self.pad.as_ref().map_or(Vec::new(), |rx| rx.try_iter().collect());
        for m in pad {
            // The sticks set the command (they send only when they move, so the keys keep theirs between).
            self.session.controls.set_command(m.command);
            if m.reset {
                self.session.apply(Action::Reset)?;
            }
        }
        let now = Instant::now();
        let wall = self.last.map_or(0.0, |l| now.duration_since(l).as_secs_f64());
        self.last = Some(now);
        let c = &self.session.controls;
        if !c.paused {
            self.owed_s = if lockstep {
                self.owed_s + LOCKSTEP_FRAME_S
            } else {
                (self.owed_s + wall * c.speed()).min(MAX_CATCH_UP_S)
            };
        }
        let dt = self.session.dt();
        let mut simulated = 0.0;
        while self.owed_s >= dt && !self.session.controls.paused {
            let wrench = self.perturb.wrench(self.session.env_mut().data_mut());
            self.session.step(wrench)?;
            self.owed_s -= dt;
            simulated += dt;
        }
        if wall > 0.0 && !lockstep {
            self.real_time += 0.1 * (simulated / wall - self.real_time);
        }
        self.draw(lockstep)?;
        self.window.swap_buffers();
        Ok(())
    }

    fn draw(&mut self, lockstep: bool) -> Result<()> {
        let (w, h) = self.window.get_framebuffer_size();
        let env = self.session.env();
        if self.session.controls.follow {
            let (torso, yaw) = (env.indices().torso_body, env.robot_state().yaw.to_degrees());
            // Behind and to the side of the robot, turning with it; the mouse's zoom is kept.
            let d = self.renderer.camera_distance().unwrap_or(self.camera_distance);
            self.renderer.track(torso, d, yaw + 150.0, -12.0);
        }
        let (labels, values) = self.session.overlay((!lockstep).then_some(self.real_time));
        let mut texts = vec![(Corner::TopLeft, labels.as_str(), values.as_str())];
        if self.session.controls.help {
            texts.push((Corner::BottomLeft, HELP.0, HELP.1));
        }
        let perturb = self.perturb.dragging().then_some(&self.perturb);
        let d = self.session.env_mut().data_mut();
        self.renderer.draw(d, (w.max(1) as usize, h.max(1) as usize), &texts, perturb)?;
        Ok(())
    }

    /// Handles one window event, as a user's input would be (tests send synthetic ones).
    pub fn handle(&mut self, e: WindowEvent) -> Result<()> {
        match e {
            WindowEvent::Key(key, _, glfw::Action::Press | glfw::Action::Repeat, _) => {
                if let Some(a) = action_of(key) {
                    self.quit |= !self.session.apply(a)?;
                }
            }
            WindowEvent::MouseButton(b, action, mods) => {
                let i = match b {
                    MouseButton::Button1 => 0,
                    MouseButton::Button2 => 1,
                    MouseButton::Button3 => 2,
                    _ => return Ok(()),
                };
                self.buttons[i] = action == glfw::Action::Press;
                if action == glfw::Action::Press && mods.contains(glfw::Modifiers::Control) && i < 2 {
                    let (w, h) = self.window.get_size();
                    let (relx, rely) = (self.cursor.0 / w as f64, 1.0 - self.cursor.1 / h as f64);
                    let d = self.session.env().data();
                    let picked = self.renderer.pick(d, relx, rely);
                    self.perturb.select(d, picked);
                    self.perturb.begin(&mut self.renderer, self.session.env_mut().data_mut());
                } else if action == glfw::Action::Release && !self.buttons.iter().any(|&b| b) {
                    self.perturb.end();
                }
            }
            WindowEvent::CursorPos(x, y) => {
                let (_, h) = self.window.get_size();
                let (dx, dy) = ((x - self.cursor.0) / h as f64, (y - self.cursor.1) / h as f64);
                self.cursor = (x, y);
                let shift = self.window.get_key(glfw::Key::LeftShift) == glfw::Action::Press;
                let how = match self.buttons {
                    [_, true, _] if shift => MouseMove::MoveH,
                    [_, true, _] => MouseMove::MoveV,
                    [true, _, _] if shift => MouseMove::RotateH,
                    [true, _, _] => MouseMove::RotateV,
                    [_, _, true] => MouseMove::Zoom,
                    _ => return Ok(()),
                };
                if self.perturb.dragging() {
                    let how = if shift { MouseMove::MoveH } else { MouseMove::MoveV };
                    self.perturb.drag(&mut self.renderer, self.session.env().data(), how, dx, dy);
                } else {
                    self.renderer.move_camera(how, dx, dy);
                }
            }
            WindowEvent::Scroll(_, y) => self.renderer.move_camera(MouseMove::Zoom, 0.0, -0.05 * y),
            _ => {}
        }
        Ok(())
    }

    /// The body the mouse is pulling, if any.
    pub fn dragged(&self) -> Option<usize> {
        self.perturb.body().filter(|_| self.perturb.dragging())
    }

    /// The window's pixels as last drawn (RGB rows, top row first) and their size.
    pub fn pixels(&self) -> (Vec<u8>, (usize, usize)) {
        (self.renderer.read_pixels(), self.renderer.size())
    }

    /// The model geom drawn at window pixel (`x`, `y`) (top-left origin), None for the background.
    pub fn geom_at(&mut self, x: usize, y: usize) -> Result<Option<usize>> {
        let d = self.session.env_mut().data_mut();
        Ok(self.renderer.geom_at(d, x, y)?)
    }

    /// Where a world point is drawn, in window pixels from the top-left corner.
    pub fn project(&self, p: [f64; 3]) -> Option<(f64, f64)> {
        self.renderer.project(p)
    }

    /// Writes the last drawn frame as a PNG.
    pub fn screenshot(&self, path: &Path) -> Result<()> {
        let (rgb, (w, h)) = self.pixels();
        let io = |source| Error::Screenshot { path: path.to_path_buf(), source };
        let tmp = path.with_extension("png.tmp");
        let file = std::fs::File::create(&tmp).map_err(io)?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w as u32, h as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let other = |e: png::EncodingError| io(std::io::Error::other(e));
        let mut writer = enc.write_header().map_err(other)?;
        writer.write_image_data(&rgb).map_err(other)?;
        writer.finish().map_err(other)?;
        std::fs::rename(&tmp, path).map_err(io)
    }
}

//! The viewer's keys: what each does, and the state they change (the velocity command, pause, speed, camera).

use glfw::Key;

/// Step of one key press on (v_x m/s, v_y m/s, w_z rad/s).
pub const COMMAND_STEP: [f64; 3] = [0.1, 0.1, 0.2];

/// Slow-motion factors `,` and `.` step through (simulated seconds per wall-clock second).
pub const SPEEDS: [f64; 5] = [0.125, 0.25, 0.5, 1.0, 2.0];

/// What a key does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Action {
    /// Add `sign` × the step to command component `axis` (0 v_x, 1 v_y, 2 w_z).
    Command {
        axis: usize,
        sign: f64,
    },
    /// Zero command.
    Stop,
    Pause,
    Slower,
    Faster,
    /// Put the robot back at the start (counted as an intervention).
    Reset,
    /// A push-grid-sized constant force on the torso for a second, in the torso frame's direction (x, y).
    Shove([f64; 2]),
    /// Camera: follow the torso, or stay where the mouse put it.
    Follow,
    /// On a course: the course's operator drives, or the keys do.
    Autopilot,
    Help,
    Quit,
}

/// The action of `key` (US layout names, as GLFW reports keys by position).
pub fn action_of(key: Key) -> Option<Action> {
    use Action::*;
    Some(match key {
        Key::W => Command { axis: 0, sign: 1.0 },
        Key::S => Command { axis: 0, sign: -1.0 },
        Key::A => Command { axis: 1, sign: 1.0 },
        Key::D => Command { axis: 1, sign: -1.0 },
        Key::Q => Command { axis: 2, sign: 1.0 },
        Key::E => Command { axis: 2, sign: -1.0 },
        Key::Space => Stop,
        Key::P => Pause,
        Key::Comma => Slower,
        Key::Period => Faster,
        Key::R | Key::Backspace => Reset,
        Key::Up => Shove([1.0, 0.0]),
        Key::Down => Shove([-1.0, 0.0]),
        Key::Left => Shove([0.0, 1.0]),
        Key::Right => Shove([0.0, -1.0]),
        Key::C => Follow,
        Key::G => Autopilot,
        Key::H | Key::F1 => Help,
        Key::Escape => Quit,
        _ => return None,
    })
}

/// The help overlay: keys, then what they do.
pub const HELP: (&str, &str) = (
    "W / S\nA / D\nQ / E\nSpace\narrows\nCtrl+drag\nP\n, / .\nR\nC\nG\nmouse\ngamepad\nH\nEsc",
    "forward / back\nleft / right\nturn left / right\nstop\nshove the torso\ndrag a body\npause\nslower / faster\n\
     reset\nfollow the robot\ncourse: operator / you\nrotate, move, zoom\nsticks drive, Y resets\nthis help\nquit",
);

/// What the keys have set.
#[derive(Debug, Clone, PartialEq)]
pub struct Controls {
    /// The velocity command (v_x, v_y, w_z), inside `ranges`.
    pub command: [f64; 3],
    /// The policy's command ranges (its training config's), [min, max] per component.
    pub ranges: [[f64; 2]; 3],
    pub paused: bool,
    /// Index into `SPEEDS`.
    speed: usize,
    pub follow: bool,
    pub help: bool,
}

impl Controls {
    pub fn new(command: [f64; 3], ranges: [[f64; 2]; 3]) -> Controls {
        let mut c = Controls { command, ranges, paused: false, speed: 3, follow: true, help: true };
        c.clamp();
        c
    }

    /// Sets the command (a gamepad's sticks), clamped to the ranges.
    pub fn set_command(&mut self, c: [f64; 3]) {
        self.command = c;
        self.clamp();
    }

    /// Simulated seconds per wall-clock second.
    pub fn speed(&self) -> f64 {
        SPEEDS[self.speed]
    }

    /// Applies the actions that change only this state; the others (reset, shove, quit) are the session's.
    pub fn apply(&mut self, a: Action) {
        match a {
            Action::Command { axis, sign } => {
                // Rounded to the step, so that presses back and forth return to exactly zero.
                let step = COMMAND_STEP[axis];
                self.command[axis] = ((self.command[axis] + sign * step) / step).round() * step;
            }
            Action::Stop => self.command = [0.0; 3],
            Action::Pause => self.paused = !self.paused,
            Action::Slower => self.speed = self.speed.saturating_sub(1),
            Action::Faster => self.speed = (self.speed + 1).min(SPEEDS.len() - 1),
            Action::Follow => self.follow = !self.follow,
            Action::Help => self.help = !self.help,
            Action::Reset | Action::Shove(_) | Action::Autopilot | Action::Quit => {}
        }
        self.clamp();
    }

    fn clamp(&mut self) {
        for (c, r) in self.command.iter_mut().zip(self.ranges) {
            *c = c.clamp(r[0], r[1]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RANGES: [[f64; 2]; 3] = [[-0.5, 0.7], [-0.3, 0.3], [-1.0, 1.0]];

    #[test]
    fn presses_step_the_command_inside_the_policy_range() {
        let mut c = Controls::new([0.0; 3], RANGES);
        for _ in 0..10 {
            c.apply(action_of(Key::W).unwrap());
        }
        assert_eq!(c.command[0], 0.7, "v_x stops at the range's end");
        for _ in 0..3 {
            c.apply(action_of(Key::D).unwrap());
        }
        assert!((c.command[1] + 0.3).abs() < 1e-12);
        c.apply(action_of(Key::Q).unwrap());
        assert!((c.command[2] - 0.2).abs() < 1e-12);
        c.apply(action_of(Key::E).unwrap());
        assert_eq!(c.command[2], 0.0, "back and forth returns to exactly zero");
        c.apply(action_of(Key::Space).unwrap());
        assert_eq!(c.command, [0.0; 3]);
    }

    #[test]
    fn an_initial_command_outside_the_range_is_clamped() {
        assert_eq!(Controls::new([2.0, 0.0, -3.0], RANGES).command, [0.7, 0.0, -1.0]);
    }

    #[test]
    fn speed_pause_and_camera_toggle() {
        let mut c = Controls::new([0.0; 3], RANGES);
        assert_eq!(c.speed(), 1.0);
        for _ in 0..9 {
            c.apply(Action::Slower);
        }
        assert_eq!(c.speed(), SPEEDS[0]);
        for _ in 0..9 {
            c.apply(Action::Faster);
        }
        assert_eq!(c.speed(), 2.0);
        c.apply(Action::Pause);
        c.apply(Action::Follow);
        assert!(c.paused && !c.follow);
        c.apply(Action::Pause);
        assert!(!c.paused);
        assert_eq!(action_of(Key::Z), None);
    }
}

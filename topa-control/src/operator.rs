//! What an operator asks of the controller — a velocity command, and stop, reset and start — whether it comes from
//! a keyboard, a gamepad or a program on the wire (an evaluation driving the simulated robot).

use crate::controller::Controller;

/// One operator message. The flags act in the order stop, reset, start: all three together restart the policy
/// from a soft start (what an evaluation does between its runs).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OperatorMessage {
    /// v_x, v_y (m/s), w_z (rad/s); clamped to the policy's ranges by the controller.
    pub command: [f64; 3],
    pub stop: bool,
    pub reset: bool,
    pub start: bool,
}

impl OperatorMessage {
    pub fn apply(&self, c: &mut Controller) {
        if self.stop {
            c.stop();
        }
        if self.reset {
            c.reset();
        }
        if self.start {
            c.start();
        }
        c.set_command(self.command);
    }
}

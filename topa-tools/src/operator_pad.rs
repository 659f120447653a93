//! The operator with a gamepad: the sticks to velocity commands (full deflection = the end of the policy's range),
//! buttons to start, stop and reset; read on a thread of its own, as the keys are, so the control loop only looks
//! at a queue. A gamepad that disconnects sends a zero command first: a lost pad never leaves the robot walking.

use std::sync::mpsc::{channel, Receiver, Sender};
use std::time::Duration;

use gilrs::{Axis, Button, EventType, Gilrs};
use topa_control::operator::OperatorMessage;

/// What the gamepad does (shown at start).
pub const HELP: &str = "gamepad: left stick v_x / v_y, right stick w_z (full deflection = the policy's range), \
                        A (south) start, B (east) STOP (damping), Y (north) reset";

/// Stick deflection below this is zero (a stick at rest reads a few percent off centre).
pub const DEADZONE: f64 = 0.1;
/// A command change smaller than this is not sent again.
const RESEND_STEP: f64 = 1e-3;
/// How often the sticks are read, s (the controller's period).
const PERIOD: Duration = Duration::from_millis(20);

/// The command the sticks ask for. `sticks` = (forward, left, counter-clockwise) deflections in [−1, 1]; each is
/// rescaled past the deadzone and mapped onto its side of the range (`ranges` = (v_x, v_y, w_z) as [min, max]).
pub fn command(sticks: [f64; 3], ranges: &[[f64; 2]; 3]) -> [f64; 3] {
    std::array::from_fn(|i| {
        let d = sticks[i].clamp(-1.0, 1.0);
        let past = ((d.abs() - DEADZONE) / (1.0 - DEADZONE)).max(0.0);
        if d > 0.0 {
            past * ranges[i][1].max(0.0)
        } else {
            past * ranges[i][0].min(0.0)
        }
    })
}

/// The message a button sends (None: a button that does nothing).
pub fn button(b: Button, command: [f64; 3]) -> Option<OperatorMessage> {
    let mut m = OperatorMessage { command, ..Default::default() };
    match b {
        Button::South => m.start = true,
        Button::East => {
            m.stop = true;
            m.command = [0.0; 3];
        }
        Button::North => m.reset = true,
        _ => return None,
    }
    Some(m)
}

/// Reads the first connected gamepad on a thread; its messages arrive on the returned queue. None where the system
/// offers no gamepad interface (the reason is logged); a system without a pad attached gets a queue that stays
/// quiet until one is plugged in.
pub fn spawn(ranges: [[f64; 2]; 3]) -> Option<Receiver<OperatorMessage>> {
    let (tx, rx) = channel();
    let (ready_tx, ready_rx) = channel();
    std::thread::spawn(move || {
        // Gilrs is not Sync; it lives on this thread only.
        let gilrs = match Gilrs::new() {
            Ok(g) => g,
            Err(e) => {
                log::warn!("gamepad: {e}; the gamepad is not read");
                let _ = ready_tx.send(false);
                return;
            }
        };
        let _ = ready_tx.send(true);
        read(gilrs, ranges, &tx);
    });
    ready_rx.recv().ok()?.then_some(rx)
}

fn read(mut gilrs: Gilrs, ranges: [[f64; 2]; 3], tx: &Sender<OperatorMessage>) {
    let mut sent = [0.0; 3];
    loop {
        while let Some(ev) = gilrs.next_event() {
            let m = match ev.event {
                EventType::ButtonPressed(b, _) => button(b, sent),
                EventType::Connected => {
                    log::info!("gamepad {} connected: {}", ev.id, gilrs.gamepad(ev.id).name());
                    None
                }
                EventType::Disconnected => {
                    log::warn!("gamepad {} disconnected: zero command", ev.id);
                    sent = [0.0; 3];
                    Some(OperatorMessage::default())
                }
                _ => None,
            };
            if let Some(m) = m {
                if tx.send(m).is_err() {
                    return;
                }
            }
        }
        if let Some((_, pad)) = gilrs.gamepads().next() {
            let v = |a| f64::from(pad.value(a));
            // Stick up is +1 (gilrs), right is +1: forward, and left / counter-clockwise are the negative of right.
            let c = command([v(Axis::LeftStickY), -v(Axis::LeftStickX), -v(Axis::RightStickX)], &ranges);
            if c.iter().zip(&sent).any(|(a, b)| (a - b).abs() > RESEND_STEP) {
                sent = c;
                if tx.send(OperatorMessage { command: c, ..Default::default() }).is_err() {
                    return;
                }
            }
        }
        std::thread::sleep(PERIOD);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RANGES: [[f64; 2]; 3] = [[-0.5, 1.0], [-0.3, 0.3], [-1.0, 1.0]];

    #[test]
    fn sticks_map_onto_each_side_of_the_range_past_the_deadzone() {
        assert_eq!(command([0.05, -0.08, 0.1], &RANGES), [0.0; 3]);
        assert_eq!(command([1.0, -1.0, 1.0], &RANGES), [1.0, -0.3, 1.0]);
        // Full deflection backwards is the range's backward end, not the mirror of its forward end.
        assert_eq!(command([-1.0, 0.0, 0.0], &RANGES)[0], -0.5);
        let half = command([0.55, 0.0, 0.0], &RANGES)[0];
        assert!((half - 0.5).abs() < 1e-12, "{half}");
        // Beyond ±1 (a miscalibrated pad) is clamped.
        assert_eq!(command([3.0, 0.0, 0.0], &RANGES)[0], 1.0);
    }

    #[test]
    fn buttons_start_stop_and_reset() {
        let m = button(Button::East, [0.4, 0.0, 0.0]).unwrap();
        assert!(m.stop && m.command == [0.0; 3]);
        assert!(button(Button::South, [0.4, 0.0, 0.0]).unwrap().start);
        assert!(button(Button::North, [0.0; 3]).unwrap().reset);
        assert!(button(Button::LeftTrigger, [0.0; 3]).is_none());
    }
}

//! The operator at the terminal: keys to velocity commands, start, stop and reset, read on a thread of their own
//! so the control loop only ever looks at a queue (`try_recv`, never a lock it waits on).

use std::sync::mpsc::{channel, Receiver};

use console::{Key, Term};
use topa_control::operator::OperatorMessage;

/// The command step per key press: v_x, v_y (m/s), w_z (rad/s).
pub const STEP: [f64; 3] = [0.1, 0.1, 0.2];

/// What the keys do (shown at start).
pub const HELP: &str =
    "keys: w/s v_x ±0.1, a/d v_y ±0.1, q/e w_z ±0.2, 0 zero command, g start, space STOP (damping), \
                        r reset (damping → passive), Ctrl-C quit";

/// The operator's state: the command it asks for, and what a key changes.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Keyboard {
    pub command: [f64; 3],
}

impl Keyboard {
    /// The message a key sends (None: a key that does nothing).
    pub fn press(&mut self, key: &Key) -> Option<OperatorMessage> {
        let mut m = OperatorMessage::default();
        match key {
            Key::Char('w') => self.command[0] += STEP[0],
            Key::Char('s') => self.command[0] -= STEP[0],
            Key::Char('a') => self.command[1] += STEP[1],
            Key::Char('d') => self.command[1] -= STEP[1],
            Key::Char('q') => self.command[2] += STEP[2],
            Key::Char('e') => self.command[2] -= STEP[2],
            Key::Char('0') => self.command = [0.0; 3],
            Key::Char('g') => m.start = true,
            Key::Char(' ') => {
                m.stop = true;
                self.command = [0.0; 3];
            }
            Key::Char('r') => m.reset = true,
            _ => return None,
        }
        m.command = self.command;
        Some(m)
    }
}

/// Reads the terminal's keys on a thread; their messages arrive on the returned queue, which closes on Ctrl-C
/// (the terminal is in raw mode while a key is read, so Ctrl-C is a key, not a signal). None without a terminal.
pub fn spawn() -> Option<Receiver<OperatorMessage>> {
    let term = Term::stderr();
    if !term.is_term() {
        return None;
    }
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        let mut k = Keyboard::default();
        while let Ok(key) = term.read_key() {
            if let Some(m) = k.press(&key) {
                if tx.send(m).is_err() {
                    return;
                }
            }
        }
    });
    Some(rx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_step_the_command_and_space_stops() {
        let mut k = Keyboard::default();
        for key in [Key::Char('w'), Key::Char('w'), Key::Char('q')] {
            k.press(&key);
        }
        let m = k.press(&Key::Char('a')).unwrap();
        assert!((m.command[0] - 0.2).abs() < 1e-12 && (m.command[1] - 0.1).abs() < 1e-12);
        assert!((m.command[2] - 0.2).abs() < 1e-12 && !m.stop);
        let stop = k.press(&Key::Char(' ')).unwrap();
        assert!(stop.stop && stop.command == [0.0; 3]);
        assert!(k.press(&Key::Char('g')).unwrap().start);
        assert!(k.press(&Key::Char('z')).is_none());
    }
}

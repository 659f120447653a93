//! The wire format between a robot (or the simulator standing in for one) and the controller: one datagram per
//! sensor frame and per motor command, little-endian, fixed layout, checked end to end, so that a program in any
//! language can speak it.
//!
//! | offset | size | field |
//! |---:|---:|---|
//! | 0 | 4 | magic `TOPA` |
//! | 4 | 1 | version (1) |
//! | 5 | 1 | kind: 1 sensor frame, 2 motor command, 3 operator message |
//! | 6 | 1 | flags: sensor frame — bit 0 set when the base velocity is given; command — the mode (0 passive, 1 soft start, 2 policy, 3 damping); operator — bit 0 stop, bit 1 reset, bit 2 start (applied in that order) |
//! | 7 | 1 | reserved (0) |
//! | 8 | 2 | n, the number of motors (0 in an operator message) |
//! | 10 | 2 | reserved (0) |
//! | 12 | 4 | the sender's peer id |
//! | 16 | 4 | sequence number (each sender counts up from 0) |
//! | 20 | 4 | robot id: CRC-32 (IEEE) of the motors' actuator names, each followed by `\n` (0 in an operator message) |
//! | 24 | 8 | timestamp, s (f64, the sender's monotonic clock) |
//! | 32 | 8·k | payload, f64: a sensor frame's orientation (w x y z), gyro (3), base velocity (3, zeros when not given), motor positions (n), motor velocities (n) — k = 10 + 2n; a command's targets (n), kp (n), kd (n) — k = 3n; an operator message's velocity command v_x, v_y, w_z — k = 3 |
//! | 32 + 8k | 4 | CRC-32 (IEEE) of every byte before it |
//!
//! Encoding writes into a buffer the caller keeps and decoding reads into one: neither allocates.

use crate::controller::{Fault, Mode, MotorCommand};
use crate::driver::Readings;
use crate::operator::OperatorMessage;

pub const MAGIC: &[u8; 4] = b"TOPA";
pub const VERSION: u8 = 1;
pub const HEADER: usize = 32;
pub const SENSORS: u8 = 1;
pub const COMMAND: u8 = 2;
pub const OPERATOR: u8 = 3;

/// Why a datagram was refused (each is counted by the receiver; none is acted on).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum WireError {
    #[error("{0} bytes: not a TOPA datagram")]
    NotOurs(usize),
    #[error("version {0}, this build speaks {VERSION}")]
    Version(u8),
    #[error("kind {got}, expected {expected}")]
    Kind { got: u8, expected: u8 },
    #[error("{got} motors, this robot has {expected}")]
    Motors { got: usize, expected: usize },
    #[error("{got} bytes for {n} motors, expected {expected}")]
    Length { got: usize, n: usize, expected: usize },
    #[error("checksum mismatch")]
    Checksum,
    #[error("from peer {0}, not the one this side talks to")]
    Peer(u32),
    #[error("robot id {got:#010x}, this robot is {expected:#010x}: a controller file for another robot (export one for this robot's policy)")]
    Robot { got: u32, expected: u32 },
    #[error("sequence {got} is not after {last}")]
    Stale { got: u32, last: u32 },
}

/// The header fields of a datagram.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header {
    pub kind: u8,
    pub flags: u8,
    pub n: usize,
    pub peer: u32,
    pub seq: u32,
    pub robot: u32,
}

/// A robot's id on the wire, from its motors' actuator names in order (a controller file's motor names): both
/// sides compute it from their own files, so a controller for another robot (even one with as many motors) is
/// refused.
pub fn robot_id<'a>(actuators: impl IntoIterator<Item = &'a str>) -> u32 {
    let mut h = crc32fast::Hasher::new();
    for a in actuators {
        h.update(a.as_bytes());
        h.update(b"\n");
    }
    h.finalize()
}

/// A datagram's size for `n` motors.
pub fn size(kind: u8, n: usize) -> usize {
    let values = match kind {
        SENSORS => 10 + 2 * n,
        COMMAND => 3 * n,
        _ => 3,
    };
    HEADER + 8 * values + 4
}

fn put_header(buf: &mut [u8], h: &Header, timestamp: f64) {
    buf[..4].copy_from_slice(MAGIC);
    buf[4] = VERSION;
    buf[5] = h.kind;
    buf[6] = h.flags;
    buf[7] = 0;
    buf[8..10].copy_from_slice(&(h.n as u16).to_le_bytes());
    buf[10..12].fill(0);
    buf[12..16].copy_from_slice(&h.peer.to_le_bytes());
    buf[16..20].copy_from_slice(&h.seq.to_le_bytes());
    buf[20..24].copy_from_slice(&h.robot.to_le_bytes());
    buf[24..32].copy_from_slice(&timestamp.to_le_bytes());
}

fn put_values<'a>(buf: &mut [u8], values: impl Iterator<Item = &'a f64>) -> usize {
    let mut at = HEADER;
    for v in values {
        buf[at..at + 8].copy_from_slice(&v.to_le_bytes());
        at += 8;
    }
    let crc = crc32fast::hash(&buf[..at]);
    buf[at..at + 4].copy_from_slice(&crc.to_le_bytes());
    at + 4
}

/// Encodes a sensor frame into `buf` (resized once to the frame's size); returns the datagram.
pub fn encode_sensors<'b>(r: &Readings, peer: u32, robot: u32, seq: u32, buf: &'b mut Vec<u8>) -> &'b [u8] {
    let n = r.motor_pos.len();
    buf.resize(size(SENSORS, n), 0);
    let flags = u8::from(r.base_velocity.is_some());
    put_header(buf, &Header { kind: SENSORS, flags, n, peer, seq, robot }, r.timestamp_s);
    let v = r.base_velocity.unwrap_or_default();
    let values = r.orientation.iter().chain(&r.gyro).chain(&v).chain(&r.motor_pos).chain(&r.motor_vel);
    let len = put_values(buf, values);
    &buf[..len]
}

/// Encodes a motor command into `buf`; returns the datagram.
pub fn encode_command<'b>(
    c: &MotorCommand,
    peer: u32,
    robot: u32,
    seq: u32,
    timestamp: f64,
    buf: &'b mut Vec<u8>,
) -> &'b [u8] {
    let n = c.target.len();
    buf.resize(size(COMMAND, n), 0);
    let flags = match c.mode {
        Mode::Passive => 0,
        Mode::SoftStart => 1,
        Mode::Policy => 2,
        Mode::Damping(_) => 3,
    };
    put_header(buf, &Header { kind: COMMAND, flags, n, peer, seq, robot }, timestamp);
    let len = put_values(buf, c.target.iter().chain(&c.kp).chain(&c.kd));
    &buf[..len]
}

/// Encodes an operator message into `buf`; returns the datagram.
pub fn encode_operator<'b>(o: &OperatorMessage, peer: u32, seq: u32, timestamp: f64, buf: &'b mut Vec<u8>) -> &'b [u8] {
    buf.resize(size(OPERATOR, 0), 0);
    let flags = u8::from(o.stop) | u8::from(o.reset) << 1 | u8::from(o.start) << 2;
    put_header(buf, &Header { kind: OPERATOR, flags, n: 0, peer, seq, robot: 0 }, timestamp);
    let len = put_values(buf, o.command.iter());
    &buf[..len]
}

/// Decodes a checked operator message.
pub fn decode_operator(d: &[u8]) -> Result<(Header, OperatorMessage), WireError> {
    let (h, _) = check(d, OPERATOR, 0)?;
    let bit = |b: u8| h.flags >> b & 1 == 1;
    let command = [value(d, 0), value(d, 1), value(d, 2)];
    Ok((h, OperatorMessage { command, stop: bit(0), reset: bit(1), start: bit(2) }))
}

/// Checks a datagram of `kind` for `n` motors: magic, version, kind, size, checksum. Returns its header and
/// timestamp.
pub fn check(d: &[u8], kind: u8, n: usize) -> Result<(Header, f64), WireError> {
    if d.len() < HEADER + 4 || &d[..4] != MAGIC {
        return Err(WireError::NotOurs(d.len()));
    }
    if d[4] != VERSION {
        return Err(WireError::Version(d[4]));
    }
    if d[5] != kind {
        return Err(WireError::Kind { got: d[5], expected: kind });
    }
    let got_n = u16::from_le_bytes([d[8], d[9]]) as usize;
    if got_n != n {
        return Err(WireError::Motors { got: got_n, expected: n });
    }
    if d.len() != size(kind, n) {
        return Err(WireError::Length { got: d.len(), n, expected: size(kind, n) });
    }
    let body = d.len() - 4;
    let crc = u32::from_le_bytes(d[body..].try_into().unwrap());
    if crc32fast::hash(&d[..body]) != crc {
        return Err(WireError::Checksum);
    }
    let word = |at: usize| u32::from_le_bytes(d[at..at + 4].try_into().unwrap());
    let header = Header { kind, flags: d[6], n, peer: word(12), seq: word(16), robot: word(20) };
    Ok((header, f64::from_le_bytes(d[24..32].try_into().unwrap())))
}

fn value(d: &[u8], k: usize) -> f64 {
    let at = HEADER + 8 * k;
    f64::from_le_bytes(d[at..at + 8].try_into().unwrap())
}

/// Decodes a checked sensor frame into `r` (sized for its motors).
pub fn decode_sensors(d: &[u8], r: &mut Readings) -> Result<Header, WireError> {
    let n = r.motor_pos.len();
    let (h, t) = check(d, SENSORS, n)?;
    r.timestamp_s = t;
    for i in 0..4 {
        r.orientation[i] = value(d, i);
    }
    for i in 0..3 {
        r.gyro[i] = value(d, 4 + i);
    }
    r.base_velocity = (h.flags & 1 == 1).then(|| [value(d, 7), value(d, 8), value(d, 9)]);
    for i in 0..n {
        r.motor_pos[i] = value(d, 10 + i);
        r.motor_vel[i] = value(d, 10 + n + i);
    }
    Ok(h)
}

/// Decodes a checked motor command into `c` (sized for its motors); its mode from the flags.
pub fn decode_command(d: &[u8], c: &mut MotorCommand) -> Result<Header, WireError> {
    let n = c.target.len();
    let (h, _) = check(d, COMMAND, n)?;
    for i in 0..n {
        c.target[i] = value(d, i);
        c.kp[i] = value(d, n + i);
        c.kd[i] = value(d, 2 * n + i);
    }
    c.mode = match h.flags {
        0 => Mode::Passive,
        1 => Mode::SoftStart,
        2 => Mode::Policy,
        _ => Mode::Damping(Fault::Stop),
    };
    Ok(h)
}

/// What a receiver accepts: datagrams from its one peer, each newer than the last (late, duplicated or replayed
/// ones are refused), with a count of each refusal.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Receiver {
    /// The peer to accept (None: the first valid sender becomes it).
    pub peer: Option<u32>,
    /// The robot id to accept (None: any).
    pub robot: Option<u32>,
    pub last_seq: Option<u32>,
    pub accepted: u64,
    pub refused: u64,
    pub last_error: Option<WireError>,
}

impl Receiver {
    /// Admits a decoded header, or refuses it.
    pub fn admit(&mut self, h: Result<Header, WireError>) -> Result<Header, WireError> {
        let r = h.and_then(|h| {
            if let Some(expected) = self.robot.filter(|&r| r != h.robot) {
                return Err(WireError::Robot { got: h.robot, expected });
            }
            if self.peer.is_some_and(|p| p != h.peer) {
                return Err(WireError::Peer(h.peer));
            }
            if let Some(last) = self.last_seq.filter(|&l| h.seq <= l) {
                return Err(WireError::Stale { got: h.seq, last });
            }
            Ok(h)
        });
        match r {
            Ok(h) => {
                self.peer.get_or_insert(h.peer);
                self.last_seq = Some(h.seq);
                self.accepted += 1;
            }
            Err(e) => {
                self.refused += 1;
                self.last_error = Some(e);
            }
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn readings() -> Readings {
        let mut r = Readings::new(3);
        r.timestamp_s = 1.25;
        r.orientation = [0.9, 0.1, -0.2, 0.3];
        r.gyro = [0.5, -0.5, 0.25];
        r.motor_pos = vec![0.1, 0.2, 0.3];
        r.motor_vel = vec![-1.0, 2.0, -3.0];
        r.base_velocity = Some([0.4, 0.0, -0.1]);
        r
    }

    #[test]
    fn frames_and_commands_round_trip() {
        let (r, mut buf) = (readings(), Vec::new());
        let d = encode_sensors(&r, 7, 11, 42, &mut buf).to_vec();
        assert_eq!(d.len(), 32 + 8 * 16 + 4);
        let mut back = Readings::new(3);
        let h = decode_sensors(&d, &mut back).unwrap();
        assert_eq!((h.peer, h.seq, h.robot, back), (7, 42, 11, r));
        let c = MotorCommand { mode: Mode::Policy, target: vec![0.1; 3], kp: vec![30.0; 3], kd: vec![1.0; 3] };
        let d = encode_command(&c, 9, 11, 3, 0.5, &mut buf).to_vec();
        let mut got = MotorCommand { mode: Mode::Passive, target: vec![0.0; 3], kp: vec![0.0; 3], kd: vec![0.0; 3] };
        decode_command(&d, &mut got).unwrap();
        assert_eq!(got, c);
    }

    #[test]
    fn every_corruption_is_refused_by_name() {
        let mut buf = Vec::new();
        let good = encode_sensors(&readings(), 7, 11, 1, &mut buf).to_vec();
        let mut r = Readings::new(3);
        let flip = |at: usize| {
            let mut d = good.clone();
            d[at] ^= 0x40;
            d
        };
        assert_eq!(decode_sensors(&good[..20], &mut r), Err(WireError::NotOurs(20)));
        assert_eq!(decode_sensors(&flip(0), &mut r), Err(WireError::NotOurs(good.len())));
        assert_eq!(decode_sensors(&flip(4), &mut r), Err(WireError::Version(VERSION ^ 0x40)));
        assert!(matches!(decode_sensors(&flip(5), &mut r), Err(WireError::Kind { .. })));
        assert_eq!(decode_sensors(&good, &mut Readings::new(4)), Err(WireError::Motors { got: 3, expected: 4 }));
        assert_eq!(decode_sensors(&flip(40), &mut r), Err(WireError::Checksum));
        let mut long = good.clone();
        long.push(0);
        assert!(matches!(decode_sensors(&long, &mut r), Err(WireError::Length { .. })));
    }

    #[test]
    fn a_receiver_takes_one_peer_and_newer_frames_only() {
        let mut rx = Receiver { robot: Some(11), ..Receiver::default() };
        let h = |peer, seq| Ok(Header { kind: SENSORS, flags: 0, n: 3, peer, seq, robot: 11 });
        let other = Ok(Header { kind: SENSORS, flags: 0, n: 3, peer: 7, seq: 9, robot: 12 });
        assert_eq!(rx.admit(other), Err(WireError::Robot { got: 12, expected: 11 }));
        assert!(rx.admit(h(7, 1)).is_ok());
        assert_eq!(rx.admit(h(8, 2)), Err(WireError::Peer(8)));
        assert_eq!(rx.admit(h(7, 1)), Err(WireError::Stale { got: 1, last: 1 }));
        assert!(rx.admit(h(7, 5)).is_ok());
        assert_eq!(rx.admit(Err(WireError::Checksum)), Err(WireError::Checksum));
        assert_eq!((rx.accepted, rx.refused), (2, 4));
        assert_ne!(robot_id(["l_hip", "r_hip"]), robot_id(["r_hip", "l_hip"]), "the order is the identity");
    }
}

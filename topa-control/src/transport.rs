//! UDP carriage of the wire format: one socket per side, bound to the loopback interface unless an address is
//! given. Receiving drains the socket and keeps the newest valid datagram of the expected kind — a flood costs
//! the receiver one pass, never a backlog of stale frames — and counts what it dropped and refused.

use std::io::ErrorKind;
use std::net::{SocketAddr, UdpSocket};

use crate::wire::{self, Receiver, WireError};

/// The largest datagram read (a sensor frame of 1 000 motors fits).
const MAX_DATAGRAM: usize = 32 * 1024;

/// One side's socket and its receiving state.
pub struct Link {
    socket: UdpSocket,
    peer_addr: SocketAddr,
    buf: Vec<u8>,
    newest: Vec<u8>,
    pub receiver: Receiver,
    /// Valid datagrams superseded by a newer one in the same drain.
    pub superseded: u64,
    /// Datagrams from another address than the peer's.
    pub strangers: u64,
}

impl Link {
    /// Binds `local` (e.g. `127.0.0.1:0`) and sends to `peer_addr`; non-blocking.
    pub fn bind(local: SocketAddr, peer_addr: SocketAddr) -> std::io::Result<Link> {
        let socket = UdpSocket::bind(local)?;
        socket.set_nonblocking(true)?;
        Ok(Link {
            socket,
            peer_addr,
            buf: vec![0; MAX_DATAGRAM],
            newest: Vec::with_capacity(MAX_DATAGRAM),
            receiver: Receiver::default(),
            superseded: 0,
            strangers: 0,
        })
    }

    /// Talks to `peer_addr` from now on (e.g. once the other side's port is known).
    pub fn set_peer(&mut self, peer_addr: SocketAddr) {
        self.peer_addr = peer_addr;
    }

    pub fn local_addr(&self) -> std::io::Result<SocketAddr> {
        self.socket.local_addr()
    }

    pub fn send(&self, datagram: &[u8]) -> std::io::Result<()> {
        self.socket.send_to(datagram, self.peer_addr).map(|_| ())
    }

    /// Drains the socket; the newest admitted datagram (checked with `check`: kind, size, checksum) is returned,
    /// or None when nothing valid came. Every refusal is counted by the receiver.
    pub fn poll(&mut self, check: impl Fn(&[u8]) -> Result<wire::Header, WireError>) -> std::io::Result<Option<&[u8]>> {
        Ok(self.drain(&check)?.then_some(self.newest.as_slice()))
    }

    fn drain(&mut self, check: &impl Fn(&[u8]) -> Result<wire::Header, WireError>) -> std::io::Result<bool> {
        let mut got = false;
        loop {
            match self.socket.recv_from(&mut self.buf) {
                Ok((len, from)) => {
                    if from != self.peer_addr {
                        self.strangers += 1;
                        continue;
                    }
                    let d = &self.buf[..len];
                    if self.receiver.admit(check(d)).is_ok() {
                        self.superseded += u64::from(got);
                        self.newest.clear();
                        self.newest.extend_from_slice(d);
                        got = true;
                    }
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(e) => return Err(e),
            }
        }
        Ok(got)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::driver::Readings;

    fn pair() -> (Link, Link) {
        let any: SocketAddr = "127.0.0.1:0".parse().unwrap();
        let mut a = Link::bind(any, any).unwrap();
        let b = Link::bind(any, a.local_addr().unwrap()).unwrap();
        a.set_peer(b.local_addr().unwrap());
        (a, b)
    }

    fn wait_poll(l: &mut Link, n: usize) -> Option<Vec<u8>> {
        for _ in 0..200 {
            let r = l.poll(|d| wire::check(d, wire::SENSORS, n).map(|h| h.0)).unwrap().map(<[u8]>::to_vec);
            if r.is_some() {
                return r;
            }
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        None
    }

    #[test]
    fn a_flood_leaves_the_newest_frame_and_garbage_is_refused() {
        let (robot, mut ctl) = pair();
        let mut r = Readings::new(2);
        let mut buf = Vec::new();
        for seq in 0..200u32 {
            r.timestamp_s = seq as f64;
            robot.send(wire::encode_sensors(&r, 5, 0, seq, &mut buf)).unwrap();
        }
        robot.send(b"not a frame").unwrap();
        std::thread::sleep(std::time::Duration::from_millis(50));
        let newest = wait_poll(&mut ctl, 2).expect("a frame");
        let mut got = Readings::new(2);
        let h = wire::decode_sensors(&newest, &mut got).unwrap();
        assert_eq!((h.seq, got.timestamp_s), (199, 199.0), "the newest of the flood");
        assert_eq!(ctl.receiver.refused, 1, "the garbage");
        assert_eq!((ctl.receiver.accepted, ctl.superseded), (200, 199), "every frame admitted in order, kept the last");
        // Replayed frames are refused: the stream only moves forward.
        robot.send(wire::encode_sensors(&r, 5, 0, 3, &mut buf)).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(20));
        assert!(wait_poll(&mut ctl, 2).is_none());
        assert!(matches!(ctl.receiver.last_error, Some(WireError::Stale { got: 3, last: 199 })));
    }
}

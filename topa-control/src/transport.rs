//! Carriage of the wire format: a UDP socket per side, bound to the loopback interface unless an address is given,
//! or (cargo feature `zenoh`) a Zenoh publisher and subscriber. Receiving drains what waits and keeps the newest
//! valid message of the expected kind — a flood costs the receiver one pass, never a backlog of stale frames — and
//! counts what it dropped and refused.

use std::io::ErrorKind;
use std::net::{SocketAddr, UdpSocket};

use crate::wire::{self, Receiver, WireError};

/// The largest datagram read (a sensor frame of 1 000 motors fits).
const MAX_DATAGRAM: usize = 32 * 1024;

/// What carries the datagrams.
enum Carrier {
    Udp {
        socket: UdpSocket,
        peer_addr: SocketAddr,
    },
    #[cfg(feature = "zenoh")]
    Zenoh(crate::zenoh_carrier::ZenohCarrier),
}

/// One side's carrier and its receiving state.
pub struct Link {
    carrier: Carrier,
    buf: Vec<u8>,
    newest: Vec<u8>,
    pub receiver: Receiver,
    /// Valid datagrams superseded by a newer one in the same drain.
    pub superseded: u64,
    /// Datagrams from another address than the peer's (UDP; Zenoh names no sender, the wire's peer id does).
    pub strangers: u64,
}

impl Link {
    /// Binds `local` (e.g. `127.0.0.1:0`) and sends to `peer_addr`; non-blocking.
    pub fn bind(local: SocketAddr, peer_addr: SocketAddr) -> std::io::Result<Link> {
        let socket = UdpSocket::bind(local)?;
        socket.set_nonblocking(true)?;
        Ok(Link::over(Carrier::Udp { socket, peer_addr }))
    }

    /// A link over Zenoh: publishing and subscribing as `carrier` does.
    #[cfg(feature = "zenoh")]
    pub fn zenoh(carrier: crate::zenoh_carrier::ZenohCarrier) -> Link {
        Link::over(Carrier::Zenoh(carrier))
    }

    fn over(carrier: Carrier) -> Link {
        Link {
            carrier,
            buf: vec![0; MAX_DATAGRAM],
            newest: Vec::with_capacity(MAX_DATAGRAM),
            receiver: Receiver::default(),
            superseded: 0,
            strangers: 0,
        }
    }

    /// Talks to `peer_addr` from now on (e.g. once the other side's port is known); UDP only.
    pub fn set_peer(&mut self, peer_addr: SocketAddr) {
        match &mut self.carrier {
            Carrier::Udp { peer_addr: p, .. } => *p = peer_addr,
            #[cfg(feature = "zenoh")]
            Carrier::Zenoh(_) => {}
        }
    }

    /// The UDP socket's address (an error over Zenoh, which has no address of its own per link).
    pub fn local_addr(&self) -> std::io::Result<SocketAddr> {
        match &self.carrier {
            Carrier::Udp { socket, .. } => socket.local_addr(),
            #[cfg(feature = "zenoh")]
            Carrier::Zenoh(_) => Err(std::io::Error::other("a Zenoh link has no socket address")),
        }
    }

    pub fn send(&self, datagram: &[u8]) -> std::io::Result<()> {
        match &self.carrier {
            Carrier::Udp { socket, peer_addr } => socket.send_to(datagram, peer_addr).map(|_| ()),
            #[cfg(feature = "zenoh")]
            Carrier::Zenoh(z) => z.send(datagram),
        }
    }

    /// Drains what waits; the newest admitted datagram (checked with `check`: kind, size, checksum) is returned,
    /// or None when nothing valid came. Every refusal is counted by the receiver.
    pub fn poll(&mut self, check: impl Fn(&[u8]) -> Result<wire::Header, WireError>) -> std::io::Result<Option<&[u8]>> {
        Ok(self.drain(&check)?.then_some(self.newest.as_slice()))
    }

    /// The next waiting datagram's length in `buf` (None: nothing waits).
    fn next(&mut self) -> std::io::Result<Option<usize>> {
        match &self.carrier {
            Carrier::Udp { socket, peer_addr } => loop {
                match socket.recv_from(&mut self.buf) {
                    Ok((_, from)) if from != *peer_addr => self.strangers += 1,
                    Ok((len, _)) => return Ok(Some(len)),
                    Err(e) if e.kind() == ErrorKind::WouldBlock => return Ok(None),
                    Err(e) => return Err(e),
                }
            },
            #[cfg(feature = "zenoh")]
            Carrier::Zenoh(z) => z.try_recv(&mut self.buf),
        }
    }

    fn drain(&mut self, check: &impl Fn(&[u8]) -> Result<wire::Header, WireError>) -> std::io::Result<bool> {
        let mut got = false;
        while let Some(len) = self.next()? {
            let d = &self.buf[..len];
            if self.receiver.admit(check(d)).is_ok() {
                self.superseded += u64::from(got);
                self.newest.clear();
                self.newest.extend_from_slice(d);
                got = true;
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

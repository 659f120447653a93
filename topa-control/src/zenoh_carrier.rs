//! Zenoh carriage of the wire format (cargo feature `zenoh`): the same datagrams, each the payload of a Zenoh
//! sample, on key expressions under a prefix — `{prefix}/sensors` (robot → controller), `{prefix}/command`
//! (controller → robot), `{prefix}/operator` (operator → controller). Peers are named (an endpoint to listen on,
//! endpoints to connect to; multicast scouting off), so a loop on one machine never depends on the network's
//! multicast. Each subscriber keeps only its newest few samples (a ring), as the UDP receiver keeps the newest
//! datagram; publishers drop rather than block when congested, at real-time priority, without batching.

use std::io;

use zenoh::handlers::{RingChannel, RingChannelHandler};
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::{CongestionControl, Priority};
use zenoh::sample::Sample;
use zenoh::{Session, Wait};

/// Samples a subscriber keeps before the oldest is overwritten.
const RING: usize = 8;

fn other(what: &str, e: impl std::fmt::Display) -> io::Error {
    io::Error::other(format!("zenoh: {what}: {e}"))
}

/// One process's Zenoh session (its carriers share it).
#[derive(Clone)]
pub struct ZenohSession(Session);

impl ZenohSession {
    /// A peer session listening on `listen` and connecting to `connect` (Zenoh endpoints such as
    /// `tcp/127.0.0.1:7700`); a peer not up yet is retried, so either side may start first.
    pub fn open(listen: &[String], connect: &[String]) -> io::Result<ZenohSession> {
        let mut config = zenoh::Config::default();
        let json = |v: &[String]| serde_json::to_string(v).expect("a list of strings serialises");
        for (key, value) in [
            ("mode", "\"peer\"".to_string()),
            ("scouting/multicast/enabled", "false".to_string()),
            ("listen/endpoints", json(listen)),
            ("connect/endpoints", json(connect)),
        ] {
            config.insert_json5(key, &value).map_err(|e| other(&format!("config {key} = {value}"), e))?;
        }
        let session = zenoh::open(config).wait().map_err(|e| other("opening the session", e))?;
        Ok(ZenohSession(session))
    }

    /// Publishes on `publish`, receives what comes on `subscribe` (None: receives nothing).
    pub fn carrier(&self, publish: String, subscribe: Option<String>) -> io::Result<ZenohCarrier> {
        let publisher = self
            .0
            .declare_publisher(publish.clone())
            .congestion_control(CongestionControl::Drop)
            .priority(Priority::RealTime)
            .express(true)
            .wait()
            .map_err(|e| other(&format!("publisher on {publish}"), e))?;
        let subscriber = match subscribe {
            Some(k) => Some(
                self.0
                    .declare_subscriber(k.clone())
                    .with(RingChannel::new(RING))
                    .wait()
                    .map_err(|e| other(&format!("subscriber on {k}"), e))?,
            ),
            None => None,
        };
        Ok(ZenohCarrier { publisher, subscriber })
    }
}

/// A publisher and (optionally) a subscriber: one side of a link.
pub struct ZenohCarrier {
    publisher: Publisher<'static>,
    subscriber: Option<Subscriber<RingChannelHandler<Sample>>>,
}

impl ZenohCarrier {
    pub fn send(&self, datagram: &[u8]) -> io::Result<()> {
        self.publisher.put(datagram.to_vec()).wait().map_err(|e| other("put", e))
    }

    /// The next sample's payload copied into `buf` (truncated to its length: a truncated message fails the wire
    /// check and is counted there); None when nothing is waiting.
    pub fn try_recv(&self, buf: &mut [u8]) -> io::Result<Option<usize>> {
        let Some(sub) = &self.subscriber else { return Ok(None) };
        match sub.try_recv() {
            Ok(Some(sample)) => {
                let bytes = sample.payload().to_bytes();
                let n = bytes.len().min(buf.len());
                buf[..n].copy_from_slice(&bytes[..n]);
                Ok(Some(n))
            }
            Ok(None) => Ok(None),
            Err(e) => Err(other("receive", e)),
        }
    }
}

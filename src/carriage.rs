//! The links of `topa sim-robot` and `topa control` from the flags: UDP sockets, or one Zenoh session per process
//! (feature `zenoh`) whose publishers and subscribers carry the same datagrams.

use std::net::SocketAddr;

use anyhow::{Context, Result};
use topa_control::transport::Link;

use crate::cli::wire::CarriageArgs;

/// The key names under the Zenoh prefix (the wire's message kinds; a controller answers its operator nothing,
/// but a link always has a publisher).
pub(crate) mod names {
    pub(crate) const SENSORS: &str = "sensors";
    pub(crate) const COMMAND: &str = "command";
    pub(crate) const OPERATOR: &str = "operator";
    pub(crate) const OPERATOR_REPLY: &str = "operator_reply";
}

/// One process's way onto the wire.
pub(crate) enum Carriage {
    Udp,
    #[cfg(feature = "zenoh")]
    Zenoh {
        session: topa_control::zenoh_carrier::ZenohSession,
        prefix: String,
    },
}

impl Carriage {
    /// UDP, or a Zenoh session listening on tcp/`listen` and connecting to tcp/`peer`.
    pub(crate) fn open(a: &CarriageArgs, listen: SocketAddr, peer: SocketAddr) -> Result<Carriage> {
        if !a.zenoh {
            return Ok(Carriage::Udp);
        }
        #[cfg(feature = "zenoh")]
        {
            let session =
                topa_control::zenoh_carrier::ZenohSession::open(&[format!("tcp/{listen}")], &[format!("tcp/{peer}")])?;
            Ok(Carriage::Zenoh { session, prefix: a.zenoh_prefix.clone() })
        }
        #[cfg(not(feature = "zenoh"))]
        {
            let _ = (listen, peer);
            anyhow::bail!("--zenoh: this build carries the wire over UDP only; build with `cargo install --path . --features zenoh`")
        }
    }

    /// A link that sends the messages named `publish` and receives those named `subscribe` (Zenoh), or a UDP
    /// socket on `local` sending to `peer`.
    pub(crate) fn link(
        &self,
        publish: &str,
        subscribe: Option<&str>,
        local: SocketAddr,
        peer: SocketAddr,
    ) -> Result<Link> {
        match self {
            Carriage::Udp => {
                let _ = (publish, subscribe);
                Link::bind(local, peer).with_context(|| format!("binding {local}"))
            }
            #[cfg(feature = "zenoh")]
            Carriage::Zenoh { session, prefix } => {
                let carrier =
                    session.carrier(format!("{prefix}/{publish}"), subscribe.map(|s| format!("{prefix}/{s}")))?;
                Ok(Link::zenoh(carrier))
            }
        }
    }
}

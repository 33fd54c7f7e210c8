//! What both sides of Lumen's IPC must agree on, in one place: the client library and the
//! daemon import it; neither imports the other.
//!
//! - [`names`]: the control channel, each session's channel names and liveliness keys (the
//!   same strings on both transports).
//! - [`shm`]: iceoryx2 on one machine: the service flavour, the shapes of a session's frame and
//!   contacts services and their QoS, event ids, node and configuration helpers, and the
//!   clean-up of a private prefix.
//! - [`net`]: zenoh across machines: the session configuration both sides start from.
//! - [`TransportError`]: what failed, keeping the transport library's own error as source.

pub mod names;
pub mod net;
pub mod shm;

use std::error::Error as StdError;

/// A transport operation that failed: which step, and the transport library's error.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    /// An iceoryx2 call failed (shared memory exhausted, permissions, incompatible service...).
    #[error("iceoryx2: {what}: {source}")]
    Iceoryx2 { what: String, source: Box<dyn StdError + Send + Sync> },
    /// A session's iceoryx2 channel admits no more processes or ports (`max_nodes`,
    /// subscribers, listeners: sized by the daemon's `limits.max_observers`).
    #[error("iceoryx2: {what}: the channel is full (it admits the session's client and limits.max_observers observers)")]
    Full { what: String },
    /// A zenoh call failed (endpoint unreachable, bad configuration...).
    #[error("zenoh: {what}: {source}")]
    Zenoh { what: String, source: Box<dyn StdError + Send + Sync> },
}

impl TransportError {
    /// An iceoryx2 failure at step `what`.
    pub fn iceoryx2(what: impl Into<String>, source: impl StdError + Send + Sync + 'static) -> Self {
        TransportError::Iceoryx2 { what: what.into(), source: Box::new(source) }
    }

    /// A zenoh failure at step `what` (zenoh's own errors are already boxed).
    pub fn zenoh(what: impl Into<String>, source: impl Into<Box<dyn StdError + Send + Sync>>) -> Self {
        TransportError::Zenoh { what: what.into(), source: source.into() }
    }
}

use lumen_proto::session::{ControlError, ErrorCode, Transport};
use lumen_transport::TransportError;
use std::time::Duration;

/// What went wrong, and what to do about it.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Nobody answers on the control channel.
    #[error(
        "no Lumen daemon answered on {transport} ({detail}): start one with `lumen serve` (the same iceoryx2 prefix / zenoh endpoint); if one runs, it may be too busy to answer in time: try again"
    )]
    NoDaemon { transport: Transport, detail: String },
    /// A plain zenoh endpoint beyond loopback: the daemon there cannot be authenticated.
    #[error("{endpoint} is not on this machine, and over a plain endpoint anyone there could answer in the daemon's place (an impostor feeding false contacts): connect over tls/ with the lab's CA (lumen certs; Client::zenoh_tls, --zenoh-ca), or accept that with Client::zenoh_insecure (--insecure, LUMEN_ZENOH_INSECURE=1)")]
    Unauthenticated { endpoint: String },
    /// The daemon answered with an error (invalid spec, limits, unknown session...).
    #[error("the daemon refused: {} ({:?})", .0.message, .0.code)]
    Refused(ControlError),
    /// No reply within the timeout; the session still works.
    #[error("{}", timeout_message(*.0))]
    Timeout(Duration),
    /// The daemon went away, or (zenoh) it no longer has this session, as after a dropped
    /// link. Frames are dropped; the session reopens by itself on the next `frame()` /
    /// `submit()` once a daemon answers again.
    #[error("the daemon went away; keep submitting: the session reopens by itself when a daemon is back")]
    Disconnected,
    /// `submit()` without a frame written since the last one.
    #[error("no frame to submit: call frame() and write it first")]
    NoFrame,
    /// An async wait was called outside a tokio runtime with I/O enabled.
    #[error("contacts_async needs a tokio runtime with I/O enabled")]
    NoRuntime,
    /// The session admits no more observers: its iceoryx2 channels hold its client and
    /// `max` observers (the daemon's `limits.max_observers`), and all are attached.
    #[error("session {session} already has {max} observers, as many as the daemon allows (limits.max_observers): detach one or raise the limit")]
    ObserversFull { session: u64, max: u32 },
    /// The observed session ended (its client left or the daemon stopped).
    #[error("session {0} ended")]
    SessionEnded(u64),
    /// The transport failed (iceoryx2: shared memory exhausted, permissions, incompatible
    /// service; zenoh: endpoint unreachable, bad configuration...).
    #[error(transparent)]
    Transport(#[from] TransportError),
    /// The daemon sent something this client does not understand (version mismatch?).
    #[error("protocol: {0}")]
    Protocol(String),
}

impl Error {
    /// The daemon's error code, for [`Error::Refused`] and [`Error::ObserversFull`]
    /// (`observers_full`, on either transport).
    pub fn code(&self) -> Option<ErrorCode> {
        match self {
            Error::Refused(e) => Some(e.code),
            Error::ObserversFull { .. } => Some(ErrorCode::ObserversFull),
            _ => None,
        }
    }

    pub(crate) fn iox(what: &str, e: impl std::error::Error + Send + Sync + 'static) -> Self {
        Error::Transport(TransportError::iceoryx2(what, e))
    }

    pub(crate) fn zenoh(what: &str, e: impl Into<Box<dyn std::error::Error + Send + Sync>>) -> Self {
        Error::Transport(TransportError::zenoh(what, e))
    }
}

/// What [`Error::Timeout`] says: a wait of zero is a look that found nothing yet.
fn timeout_message(waited: Duration) -> String {
    if waited.is_zero() {
        "no contacts yet (the call looked without waiting): look again or wait with a timeout".into()
    } else {
        format!("no contacts within {waited:?}; the daemon may be busy: wait again or submit the next frame")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_timeout_of_zero_says_it_did_not_wait() {
        assert_eq!(Error::Timeout(Duration::ZERO).to_string(), "no contacts yet (the call looked without waiting): look again or wait with a timeout");
        assert!(Error::Timeout(Duration::from_millis(5)).to_string().starts_with("no contacts within 5ms;"));
    }
}

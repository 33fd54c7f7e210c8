use lumen_proto::session::{ControlError, ErrorCode, Transport};
use std::time::Duration;

/// What went wrong, and what to do about it.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Nobody answers on the control channel.
    #[error("no Lumen daemon answers on {transport} ({detail}); start one with `lumen serve` (same iceoryx2 prefix / zenoh endpoint)")]
    NoDaemon { transport: Transport, detail: String },
    /// The daemon answered with an error (invalid spec, limits, unknown session...).
    #[error("the daemon refused: {} ({:?})", .0.message, .0.code)]
    Refused(ControlError),
    /// No reply within the timeout; the session still works.
    #[error("no contacts within {0:?}; the daemon may be busy: wait again or submit the next frame")]
    Timeout(Duration),
    /// The daemon went away, or (zenoh) it no longer has this session, as after a dropped
    /// link. Frames are dropped; the session reopens by itself on the next `frame()` /
    /// `submit()` once a daemon answers again.
    #[error("the daemon went away; keep submitting: the session reopens by itself when a daemon is back")]
    Disconnected,
    /// `submit()` without a frame written since the last one.
    #[error("no frame to submit: call frame() and write it first")]
    NoFrame,
    /// The observed session ended (its client left or the daemon stopped).
    #[error("session {0} ended")]
    SessionEnded(u64),
    /// iceoryx2 failed (shared memory exhausted, permissions, incompatible service...).
    #[error("iceoryx2: {0}")]
    Iceoryx2(String),
    /// zenoh failed (endpoint unreachable, bad configuration...).
    #[error("zenoh: {0}")]
    Zenoh(String),
    /// The daemon sent something this client does not understand (version mismatch?).
    #[error("protocol: {0}")]
    Protocol(String),
}

impl Error {
    /// The daemon's error code, for [`Error::Refused`].
    pub fn code(&self) -> Option<ErrorCode> {
        match self {
            Error::Refused(e) => Some(e.code),
            _ => None,
        }
    }

    pub(crate) fn iox(what: &str, e: impl std::fmt::Debug) -> Self {
        Error::Iceoryx2(format!("{what}: {e:?}"))
    }

    pub(crate) fn zenoh(what: &str, e: impl std::fmt::Display) -> Self {
        Error::Zenoh(format!("{what}: {e}"))
    }
}

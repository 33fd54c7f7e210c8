//! JSON control replies, shared by both transports.

use crate::Error;
use lumen_proto::auth::Secret;
use lumen_proto::session::{ControlReply, ControlRequest, ErrorCode, SessionInfo};
use std::time::Duration;

/// How long a session waits for the daemon's answer when it reopens or asks whether it still
/// exists: short, since the caller's frame waits on it.
pub(crate) const CONTROL_WAIT: Duration = Duration::from_millis(300);

/// Parses a control reply (errors are returned as replies; the caller decides).
pub(crate) fn parse_reply(bytes: &[u8]) -> Result<ControlReply, Error> {
    serde_json::from_slice(bytes).map_err(|e| Error::Protocol(format!("unreadable control reply ({e}): {:?}", String::from_utf8_lossy(&bytes[..bytes.len().min(200)]))))
}

/// The error for a reply of the wrong kind.
pub(crate) fn unexpected(reply: ControlReply) -> Error {
    match reply {
        ControlReply::Error(e) => Error::Refused(e),
        other => Error::Protocol(format!("unexpected control reply: {other:?}")),
    }
}

/// The outcome of a close: freed now, or already gone (a daemon restarted meanwhile, or the
/// session expired), which is what the caller wanted too.
pub(crate) fn closed(reply: Result<ControlReply, Error>, session: u64) -> Result<(), Error> {
    match reply? {
        ControlReply::Closed { session: s } if s == session => Ok(()),
        ControlReply::Error(e) if e.code == ErrorCode::UnknownSession => Ok(()),
        other => Err(unexpected(other)),
    }
}

/// The secret of an `opened` reply.
pub(crate) fn secret(info: &SessionInfo) -> Result<Secret, Error> {
    Secret::parse(&info.secret).map_err(|e| Error::Protocol(format!("the opened reply of session {}: {e}", info.session)))
}

/// The request that closes the session of `info`, with the proof of its secret (an empty proof,
/// which the daemon refuses, where `info` holds none: a described session is not ours).
pub(crate) fn close_request(info: &SessionInfo) -> ControlRequest {
    ControlRequest::Close { session: info.session, proof: Secret::parse(&info.secret).map(|s| s.close_proof(info.session)).unwrap_or_default() }
}

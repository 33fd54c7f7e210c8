//! The crate's one error: what went wrong in a call, as the status it returns and the text
//! `lumen_last_error` gives.

use crate::status::LumenStatus;
use lumen_proto::{InputError, SpecError};
use std::fmt;

/// Why a call failed.
#[derive(Debug)]
pub enum Error {
    /// This argument was NULL.
    NullArgument(&'static str),
    /// The scene spec's bytes are not UTF-8.
    BadUtf8(std::str::Utf8Error),
    /// The scene spec is not JSON of the scene format.
    BadJson(serde_json::Error),
    /// The scene spec does not validate.
    BadSpec(SpecError),
    /// A spec's length that counts its terminating NUL (`strlen + 1`, `sizeof` a literal).
    TrailingNul { len: usize },
    /// The frame's state cannot be used.
    BadState(InputError),
    /// The detector panicked in an earlier call; its buffers may be half-written.
    Poisoned,
    /// A detector called while another thread's call on it runs.
    DetectorBusy,
    /// A panic caught at the boundary, with its message.
    Panic(String),
    /// A handle that is not a live one of the right kind.
    BadHandle { name: &'static str, detail: String },
    /// A local (iceoryx2) object used from another thread than its own.
    WrongThread(&'static str),
    /// A text argument (endpoint, prefix, path, name) is not UTF-8.
    BadText { name: &'static str, error: std::str::Utf8Error },
    /// A certificate without its key, or a key without its certificate.
    HalfIdentity,
    /// The Rust client's error.
    Client(lumen_client::Error),
}

impl Error {
    /// The status a call failing with this error returns.
    pub fn status(&self) -> LumenStatus {
        match self {
            Error::NullArgument(_) => LumenStatus::NullArgument,
            Error::BadUtf8(_) => LumenStatus::BadUtf8,
            Error::BadJson(_) | Error::BadSpec(_) | Error::TrailingNul { .. } => LumenStatus::BadSpec,
            Error::BadState(_) => LumenStatus::BadState,
            Error::Poisoned | Error::Panic(_) => LumenStatus::Panic,
            Error::DetectorBusy => LumenStatus::WrongThread,
            Error::BadHandle { .. } => LumenStatus::BadHandle,
            Error::WrongThread(_) => LumenStatus::WrongThread,
            Error::BadText { .. } => LumenStatus::BadUtf8,
            Error::HalfIdentity => LumenStatus::NullArgument,
            Error::Client(e) => match e {
                lumen_client::Error::NoDaemon { .. } => LumenStatus::NoDaemon,
                lumen_client::Error::Unauthenticated { .. } => LumenStatus::Transport,
                // A limit of the daemon's, as a refused open is (the message names it).
                lumen_client::Error::Refused(_) | lumen_client::Error::ObserversFull { .. } => LumenStatus::Refused,
                lumen_client::Error::Timeout(_) => LumenStatus::Timeout,
                lumen_client::Error::Disconnected => LumenStatus::Disconnected,
                lumen_client::Error::NoFrame => LumenStatus::NoFrame,
                lumen_client::Error::SessionEnded(_) => LumenStatus::SessionEnded,
                lumen_client::Error::Transport(_) | lumen_client::Error::NoRuntime => LumenStatus::Transport,
                lumen_client::Error::Protocol(_) => LumenStatus::Protocol,
            },
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::NullArgument(name) => write!(f, "argument `{name}` is NULL"),
            Error::BadUtf8(e) => write!(f, "scene spec is not UTF-8: {e}"),
            Error::BadJson(e) => write!(f, "scene spec is not a valid scene JSON: {e}"),
            Error::BadSpec(e) => write!(f, "scene spec: {e}"),
            Error::TrailingNul { len } => write!(f, "scene spec: {len} bytes given, the last a NUL: give the JSON's length without its NUL (strlen, not strlen + 1 or sizeof)"),
            Error::BadState(e) => write!(f, "state: {e}"),
            Error::Poisoned => write!(f, "this detector panicked in an earlier call and cannot be used again: free it and make another"),
            Error::DetectorBusy => write!(f, "another thread is calling this detector right now: one thread at a time per detector (nothing was done; make one detector per thread)"),
            Error::Panic(message) => write!(f, "internal error (a caught panic; please report it): {message}"),
            Error::BadHandle { name, detail } => write!(f, "argument `{name}` is not a live handle: {detail}"),
            Error::WrongThread(name) => write!(f, "`{name}` is a local (iceoryx2) object of another thread: use it on the thread that made it (one client per thread)"),
            Error::BadText { name, error } => write!(f, "argument `{name}` is not UTF-8: {error}"),
            Error::HalfIdentity => write!(f, "TLS: `certificate` and `private_key` go together (both NULL, or both set)"),
            Error::Client(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for Error {}

impl From<lumen_client::Error> for Error {
    fn from(e: lumen_client::Error) -> Self {
        Error::Client(e)
    }
}

impl From<InputError> for Error {
    fn from(e: InputError) -> Self {
        Error::BadState(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statuses_are_the_ones_the_header_names() {
        // lumen_observer_open on a session with every observer place taken: REFUSED.
        let full = Error::from(lumen_client::Error::ObserversFull { session: 7, max: 4 });
        assert_eq!(full.status(), LumenStatus::Refused);
        // A zenoh endpoint nothing answers on: NO_DAEMON; a plain one beyond loopback: TRANSPORT.
        let none = Error::from(lumen_client::Error::NoDaemon { transport: lumen_client::Transport::Zenoh, detail: "cannot connect".into() });
        assert_eq!(none.status(), LumenStatus::NoDaemon);
        let plain = Error::from(lumen_client::Error::Unauthenticated { endpoint: "tcp/10.0.0.2:7447".into() });
        assert_eq!(plain.status(), LumenStatus::Transport);
        // A spec whose length counts its NUL: BAD_SPEC, saying so.
        let json = "{\"bodies\":[{\"name\":\"r\",\"shape\":{\"rod\":{\"points\":2,\"radius\":[1.0]}}}],\"pairs\":[]}\0";
        let e = unsafe { crate::text::spec(json.as_ptr().cast(), json.len()) }.unwrap_err();
        assert_eq!(e.status(), LumenStatus::BadSpec);
        assert!(e.to_string().contains("the last a NUL: give the JSON's length without its NUL"), "{e}");
        assert!(unsafe { crate::text::spec(json.as_ptr().cast(), json.len() - 1) }.is_ok());
    }
}

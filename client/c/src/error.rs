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
    /// The frame's state cannot be used.
    BadState(InputError),
    /// The detector panicked in an earlier call; its buffers may be half-written.
    Poisoned,
    /// A panic caught at the boundary, with its message.
    Panic(String),
}

impl Error {
    /// The status a call failing with this error returns.
    pub fn status(&self) -> LumenStatus {
        match self {
            Error::NullArgument(_) => LumenStatus::NullArgument,
            Error::BadUtf8(_) => LumenStatus::BadUtf8,
            Error::BadJson(_) | Error::BadSpec(_) => LumenStatus::BadSpec,
            Error::BadState(_) => LumenStatus::BadState,
            Error::Poisoned | Error::Panic(_) => LumenStatus::Panic,
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
            Error::BadState(e) => write!(f, "state: {e}"),
            Error::Poisoned => write!(f, "this detector panicked in an earlier call and cannot be used again: free it and make another"),
            Error::Panic(message) => write!(f, "internal error (a caught panic; please report it): {message}"),
        }
    }
}

impl std::error::Error for Error {}

impl From<InputError> for Error {
    fn from(e: InputError) -> Self {
        Error::BadState(e)
    }
}

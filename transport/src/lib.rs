//! What both sides of Lumen's IPC must agree on, in one place: the client library and the
//! daemon import it; neither imports the other.
//!
//! - [`names`]: the control channel, each session's channel names and liveliness keys (the
//!   same strings on both transports).
//! - [`shm`]: iceoryx2 on one machine: the service flavour, the shapes of a session's frame and
//!   contacts services and their QoS, event ids, node and configuration helpers, and the
//!   clean-up of a private prefix.
//! - [`delta`]: delta frames, the rows that changed since a base, coded and decoded.
//! - [`net`]: zenoh across machines: the session configuration both sides start from.
//! - [`TransportError`]: what failed, keeping the transport library's own error as source.

pub mod delta;
pub mod names;
pub mod net;
pub mod shm;

use std::error::Error as StdError;

/// A transport operation that failed: which step, and the transport library's error.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    /// An iceoryx2 call failed (shared memory exhausted, permissions, incompatible service...).
    #[error("iceoryx2: {what}: {}", without_source_paths(&source.to_string()))]
    Iceoryx2 { what: String, source: Box<dyn StdError + Send + Sync> },
    /// A session's iceoryx2 channel admits no more processes or ports (`max_nodes`,
    /// subscribers, listeners: sized by the daemon's `limits.max_observers`).
    #[error("iceoryx2: {what}: the channel is full (it admits the session's client and limits.max_observers observers)")]
    Full { what: String },
    /// A zenoh call failed (endpoint unreachable, bad configuration...).
    #[error("zenoh: {what}: {}", without_source_paths(&source.to_string()))]
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

/// `text` without the source locations a library puts in its messages (zenoh's errors end in
/// ` at /home/builder/.cargo/registry/.../orchestrator.rs:447.`): they name the machine the
/// library was built on, which tells a user nothing. What else the text says is kept.
pub fn without_source_paths(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(at) = rest.find(" at ") {
        let after = &rest[at + 4..];
        let word_end = after.find(char::is_whitespace).unwrap_or(after.len());
        let word = after[..word_end].trim_end_matches(['.', ',', ';', ')']);
        let is_location = word.rsplit_once(':').is_some_and(|(file, line)| file.ends_with(".rs") && !line.is_empty() && line.bytes().all(|b| b.is_ascii_digit()));
        if is_location {
            out.push_str(rest[..at].trim_end());
            // Keep the punctuation that ended the sentence the location was in.
            rest = &after[word.len()..];
        } else {
            out.push_str(&rest[..at + 4]);
            rest = after;
        }
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn source_locations_are_cut_and_the_rest_kept() {
        let zenoh = "Unable to connect to any of [tcp/127.0.0.1:1]!  at /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/zenoh-1.10.2/src/net/runtime/orchestrator.rs:447.";
        assert_eq!(without_source_paths(zenoh), "Unable to connect to any of [tcp/127.0.0.1:1]!.");
        let nested = "open failed at src/a.rs:1. - Caused by: timed out at /x/b.rs:22";
        assert_eq!(without_source_paths(nested), "open failed. - Caused by: timed out");
        let plain = "looked at noon at the door: src.rs:x stays";
        assert_eq!(without_source_paths(plain), plain);
        let e = TransportError::zenoh("opening a session", zenoh.to_owned());
        assert!(!e.to_string().contains(".rs:"), "{e}");
    }
}

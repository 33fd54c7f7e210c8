//! Control messages (JSON, on both transports).
//!
//! A client sends a [`ControlRequest`] to the daemon's control channel (iceoryx2
//! request-response service `lumen/control`, or zenoh queryable key `lumen/control`) and gets
//! one [`ControlReply`]. Opening a session returns a [`SessionInfo`] naming the frame and
//! contacts channels to use. See `proto/README.md` for the JSON and a worked example.

use crate::scene::SceneSpec;
use crate::state::StateLayout;
use serde::{Deserialize, Serialize};

/// Largest control request the daemon reads, in bytes (a spec with per-point radii of a long rod
/// fits easily).
pub const MAX_CONTROL_BYTES: usize = 4 * 1024 * 1024;

/// Which transport a session runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Transport {
    /// Shared memory on this machine.
    Iceoryx2,
    /// Network (TCP or TLS).
    Zenoh,
}

impl std::fmt::Display for Transport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Transport::Iceoryx2 => "iceoryx2",
            Transport::Zenoh => "zenoh",
        })
    }
}

/// Whether `s` may be an open request's `alive`: exactly 32 lowercase hex digits (128 bits
/// drawn at random: no one else can name the key).
pub fn is_alive_chunk(s: &str) -> bool {
    s.len() == 32 && s.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
}

/// A request on the control channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case", deny_unknown_fields)]
pub enum ControlRequest {
    /// Open a session for `spec`. The daemon replies [`ControlReply::Opened`] or an error.
    Open {
        /// [`crate::wire::PROTOCOL_VERSION`] of the client.
        version: u16,
        spec: SceneSpec,
        /// A free-form name shown by `lumen status`.
        #[serde(default)]
        client: String,
        /// Benchmarks only: answer every frame with an empty `Ok` reply without detecting,
        /// to measure the transport alone.
        #[serde(default)]
        echo: bool,
        /// Zenoh only, optional: the last chunk of the session's client liveliness key
        /// ([`is_alive_chunk`]), 32 lowercase hex digits the client drew at random and sends
        /// with every open. Empty: the daemon derives one from the session's secret. zenoh keeps
        /// every key it ever routed for as long as a connection lasts, so a fresh key per
        /// session grew both sides by a few KiB per session; ids and this chunk reused keep
        /// the keys one connection sees bounded.
        #[serde(default, skip_serializing_if = "String::is_empty")]
        alive: String,
    },
    /// Describe an open session (for observers): replies [`ControlReply::Described`].
    Describe { session: u64 },
    /// Over zenoh: take one of the session's observer places (at most `max_observers`); replies
    /// [`ControlReply::Observing`] with the token its asks carry, or [`ErrorCode::ObserversFull`].
    Observe { session: u64 },
    /// Close a session now (clients also close by disappearing). Only its owner can:
    /// `proof` is [`crate::auth::Secret::close_proof`] of the session, the hex BLAKE3 keyed hash of
    /// `lumen close <session>` under the secret of the `opened` reply.
    Close {
        session: u64,
        #[serde(default)]
        proof: String,
    },
    /// List the sessions: replies [`ControlReply::Status`].
    Status,
    /// Who serves here: replies [`ControlReply::Hello`] with the daemon's name and load. Over
    /// zenoh a client asks every daemon at once (query target all) and opens on the least loaded.
    Hello,
}

/// The reply to a [`ControlRequest`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "reply", rename_all = "snake_case", deny_unknown_fields)]
pub enum ControlReply {
    Opened(SessionInfo),
    Described(SessionInfo),
    Closed {
        session: u64,
    },
    /// An observer place over zenoh: `observer` (32 hex digits) goes in every ask
    /// (`proto/README.md`, section 4).
    Observing {
        session: u64,
        observer: String,
    },
    Status(StatusReport),
    Hello(DaemonInfo),
    Error(ControlError),
}

/// One daemon, as [`ControlRequest::Hello`] answers.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DaemonInfo {
    /// The daemon's name on the zenoh network (one key chunk): the `daemon` selector parameter
    /// of a control request picks it (`proto/README.md`, section 1).
    pub daemon: String,
    pub pid: u32,
    /// Sessions it serves now (both transports).
    pub sessions: u32,
    /// Sessions it serves at most (`limits.max_sessions`).
    pub max_sessions: u32,
}

/// Why a control request failed.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlError {
    pub code: ErrorCode,
    /// What was wrong and what to do, for people.
    pub message: String,
}

/// Machine-readable class of a [`ControlError`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorCode {
    /// The request is not valid JSON for [`ControlRequest`].
    BadRequest,
    /// The client speaks another protocol version.
    Version,
    /// The spec is invalid (the message names the body, pair or field).
    Spec,
    /// The spec is valid but beyond this daemon's configured limits (frame size, contacts).
    Limit,
    /// The daemon already serves its maximum number of sessions.
    Busy,
    /// No such session.
    UnknownSession,
    /// The request needs the session's ownership and did not prove it (a close without the
    /// right `proof`).
    NotOwner,
    /// The daemon's access policy does not let this client certificate do this (zenoh with
    /// client certificates), or the request came on the bare control key where the daemon
    /// requires the certificate's own (`lumen/control/<common name>`).
    NotAllowed,
    /// The session already has `max_observers` observers (the message names the limit).
    ObserversFull,
    /// An ask for a zenoh observer's frames carries no observer token the session knows (never
    /// taken, ended, or lapsed after 5 s without an ask): take a place again with `observe`.
    NotObserver,
    /// The daemon failed to create the session's channels.
    Internal,
}

/// Everything a client needs to use a session.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SessionInfo {
    /// Session id: goes in every frame header.
    pub session: u64,
    /// Name of the daemon that serves the session: control requests about it go to that daemon
    /// (over zenoh, the selector parameter `daemon=<name>`).
    #[serde(default)]
    pub daemon: String,
    pub transport: Transport,
    /// The scene this session detects.
    pub spec: SceneSpec,
    /// `f32` values per frame (the state size).
    pub floats: u32,
    /// Bodies per frame.
    pub bodies: u32,
    /// Most contacts one reply carries; more are cut and flagged `FLAG_TRUNCATED`.
    pub max_contacts: u32,
    /// Frame channel name (`lumen/session/<id>/frame`).
    pub frame: String,
    /// Contacts channel name (`lumen/session/<id>/contacts`).
    pub contacts: String,
    /// Zenoh: liveliness key the client must declare (`lumen/session/<id>/client/<32 hex>`,
    /// named by the secret), only in the `opened` reply; the session is freed when it goes
    /// away. iceoryx2, and `describe`: empty (over iceoryx2 the frame publisher is its life).
    pub alive: String,
    /// Most observers of the session at once: over iceoryx2 extra subscribers of its channels,
    /// over zenoh places taken with `observe`.
    pub max_observers: u32,
    /// The session's secret, 32 lowercase hex digits ([`crate::auth::Secret`]): only in the
    /// `opened` reply, to the client that opened it (`describe` leaves it out). It keys the
    /// tags that prove ownership: of a close, and over zenoh of every frame and reply.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub secret: String,
}

impl SessionInfo {
    /// The state layout of this session's frames.
    pub fn layout(&self) -> StateLayout {
        StateLayout::of(&self.spec)
    }
}

/// Latency percentiles in microseconds.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Percentiles {
    pub p50_us: f64,
    pub p99_us: f64,
    pub p999_us: f64,
}

/// One session as `lumen status` shows it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SessionStatus {
    pub session: u64,
    pub transport: Transport,
    pub client: String,
    /// Seconds since the session opened.
    pub age_s: f64,
    /// Frames answered (good and bad).
    pub frames: u64,
    /// Frames answered with an error status.
    pub bad_frames: u64,
    /// Frames skipped because a newer one had arrived.
    pub skipped: u64,
    /// Frames that did not come from the session's owner, dropped and never answered: over
    /// zenoh messages on its frame key without the owner's tag or with a frame number used
    /// before, over iceoryx2 frames of a publisher of another node than the opener's.
    #[serde(default)]
    pub forged: u64,
    /// Frames per second over the last few seconds.
    pub fps: f64,
    /// Detection time of recent frames.
    pub detect: Percentiles,
    /// Time from the daemon seeing a frame to its reply being sent, recent frames.
    pub service: Percentiles,
    /// Contacts in the last reply.
    pub contacts_last: u32,
    /// Mean contacts per good frame.
    pub contacts_mean: f64,
}

/// The daemon's answer to [`ControlRequest::Status`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StatusReport {
    /// The daemon's name ([`DaemonInfo::daemon`]).
    #[serde(default)]
    pub daemon: String,
    pub pid: u32,
    pub version: String,
    pub uptime_s: f64,
    pub sessions: Vec<SessionStatus>,
    /// Sessions the daemon serves but does not list to this client: over zenoh its status
    /// policy (`[zenoh] status`, `"counts"` by default) shows a client without a certificate
    /// granting `status` only how many sessions there are.
    #[serde(default)]
    pub hidden: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_are_plain_json() {
        let json = r#"{"op":"open","version":1,"client":"sim",
            "spec":{"bodies":[{"name":"scope","shape":{"rod":{"points":3,"radius":[1.0]}}}],"pairs":[]}}"#;
        let r: ControlRequest = serde_json::from_str(json).unwrap();
        let ControlRequest::Open { version, spec, client, echo: false, alive } = r else { panic!("not open: {r:?}") };
        assert!(alive.is_empty(), "alive is optional");
        assert!(is_alive_chunk("0123456789abcdef0123456789abcdef"));
        for bad in ["", "0123456789abcdef0123456789abcde", "0123456789ABCDEF0123456789abcdef", "0123456789abcdef0123456789abcdeg", "0123456789abcdef0123456789abcdef0"] {
            assert!(!is_alive_chunk(bad), "{bad:?}");
        }
        assert_eq!((version, spec.bodies.len(), client.as_str()), (1, 1, "sim"));
        assert_eq!(serde_json::to_string(&ControlRequest::Status).unwrap(), r#"{"op":"status"}"#);
        let close: ControlRequest = serde_json::from_str(r#"{"op":"close","session":5,"proof":"ab"}"#).unwrap();
        assert_eq!(close, ControlRequest::Close { session: 5, proof: "ab".into() });
        // A close without a proof still parses (and is refused as not_owner by the daemon).
        assert_eq!(serde_json::from_str::<ControlRequest>(r#"{"op":"close","session":5}"#).unwrap(), ControlRequest::Close { session: 5, proof: String::new() });
        let e = ControlReply::Error(ControlError { code: ErrorCode::Limit, message: "too big".into() });
        assert_eq!(serde_json::to_string(&e).unwrap(), r#"{"reply":"error","code":"limit","message":"too big"}"#);
    }
}

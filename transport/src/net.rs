//! zenoh across machines: the configuration both sides start from, the queue depths and
//! congestion control of a session's keys, and the tag gate in front of their queues.

use crate::TransportError;
use lumen_proto::auth::{Gate, Secret};
use std::sync::Mutex;
use zenoh::handlers::{Callback, IntoHandler, RingChannel, RingChannelHandler};
use zenoh::qos::CongestionControl;
use zenoh::sample::Sample;

/// Frames the daemon keeps per session before the newest replaces the oldest.
pub const FRAME_QUEUE: usize = 1;
/// Replies a client keeps before the newest replaces the oldest.
pub const CONTACTS_QUEUE: usize = 8;
/// Frames and replies are dropped rather than queued where a link is congested. Congestion
/// control travels with a message through the daemon (a router), so with *block* one slow
/// subscriber anywhere on a session's keys held up every put to its link and with it the
/// session (a stranger on `lumen/**` took colon-sized sessions from 400 to 7 frames a second);
/// with *drop* only that subscriber misses samples. A frame dropped on its own client's link is
/// counted by the next reply's `skipped`; the client's own links are not congested while it
/// reads its replies.
pub const CONGESTION: CongestionControl = CongestionControl::Drop;
/// The congestion control of the Rust client's observer asks (`names::observe_name`), and so of
/// the daemon's answers, which zenoh sends with the ask's: on a congested link an answer is
/// dropped, not queued, and the next ask gets a newer frame.
pub const OBSERVER_CONGESTION: CongestionControl = CongestionControl::Drop;
/// Longest the daemon holds an ask waiting for a frame newer than its `after`, then ends it
/// with no answer (the observer asks again).
pub const ASK_HOLD: std::time::Duration = std::time::Duration::from_secs(1);
/// An observer's place lapses after this long without an ask.
pub const OBSERVER_IDLE: std::time::Duration = std::time::Duration::from_secs(5);

/// A zenoh configuration: `mode` (`client`, `peer` or `router`), no multicast scouting or
/// gossip, the given endpoints to listen on and to connect to.
pub fn config(mode: &str, listen: &[String], connect: &[String]) -> Result<zenoh::Config, TransportError> {
    let mut c = zenoh::Config::default();
    let set = |c: &mut zenoh::Config, k: &str, v: String| c.insert_json5(k, &v).map_err(|e| TransportError::zenoh(format!("config {k} = {v}"), e));
    set(&mut c, "mode", format!("{mode:?}"))?;
    set(&mut c, "scouting/multicast/enabled", "false".into())?;
    set(&mut c, "scouting/gossip/enabled", "false".into())?;
    set(&mut c, "listen/endpoints", serde_json::to_string(listen).expect("strings serialise"))?;
    set(&mut c, "connect/endpoints", serde_json::to_string(connect).expect("strings serialise"))?;
    Ok(c)
}

/// Whether a zenoh endpoint (`PROTOCOL/HOST:PORT`, possibly followed by `#` or `?` options)
/// names this machine only: a loopback address or `localhost`. Beyond loopback the daemon wants
/// client certificates and a client wants to authenticate the daemon (TLS).
pub fn is_loopback(endpoint: &str) -> bool {
    let address = endpoint.split_once('/').map_or(endpoint, |(_, a)| a);
    let address = address.split(['#', '?']).next().unwrap_or(address);
    let host = address.rsplit_once(':').map_or(address, |(h, _port)| h);
    let host = host.trim_start_matches('[').trim_end_matches(']');
    host.eq_ignore_ascii_case("localhost") || host.parse::<std::net::IpAddr>().is_ok_and(|ip| ip.is_loopback())
}

/// How long a client's put waits for room on its own link before zenoh drops it, us: a frame
/// is dropped only after its link has stalled this long (zenoh waits 1 ms, 50 ms for a
/// fragmented message, by default; a colon-sized frame is fragmented). [`client_config`].
pub const CLIENT_WAIT_BEFORE_DROP_US: u64 = 1_000_000;

/// The configuration of a client in client mode connected to `connect`: [`config`], with its
/// puts (frames, under [`CONGESTION`] *drop*) waiting up to [`CLIENT_WAIT_BEFORE_DROP_US`] for
/// room on its link before they are dropped. Only the client's own link is concerned: the
/// daemon drops at once what a slow subscriber's link cannot take.
pub fn client_config(connect: &[String]) -> Result<zenoh::Config, TransportError> {
    let mut c = config("client", &[], connect)?;
    let wait = CLIENT_WAIT_BEFORE_DROP_US.to_string();
    set(&mut c, "transport/link/tx/queue/congestion_control/drop/wait_before_drop", &wait)?;
    set(&mut c, "transport/link/tx/queue/congestion_control/drop/max_wait_before_drop_fragments", &wait)?;
    Ok(c)
}

/// A zenoh router listening on `listen` and connected to the routers at `connect` (what
/// `lumen router` runs: daemons on several machines and their clients meet there). Closed when
/// dropped.
pub fn open_router(listen: &[String], connect: &[String]) -> Result<zenoh::Session, TransportError> {
    use zenoh::Wait;
    zenoh::open(config("router", listen, connect)?).wait().map_err(|e| TransportError::zenoh(format!("opening a router listening on {listen:?}"), e))
}

/// Sets one configuration key of `config` to the JSON5 `value`.
pub fn set(config: &mut zenoh::Config, key: &str, value: &str) -> Result<(), TransportError> {
    config.insert_json5(key, value).map_err(|e| TransportError::zenoh(format!("config {key} = {value}"), e))
}

/// The longest header a [`tagged_queue`] reads (a reply's).
const MAX_HEAD: usize = lumen_proto::wire::CONTACTS_HEADER_BYTES;

/// A newest-wins queue of `capacity` samples behind a [`Gate`] for messages with a `head`-byte
/// header (`proto/README.md`, section 6): a sample without its owner's tag, or whose frame
/// number was used before, is handed to `on_forged` and dropped. The gate runs before the
/// queue, so samples anyone may put on a session's key can never push a genuine one out.
pub fn tagged_queue(capacity: usize, secret: Secret, head: usize, on_forged: impl Fn() + Send + Sync + 'static) -> (Callback<Sample>, RingChannelHandler<Sample>) {
    assert!(head <= MAX_HEAD, "headers are at most {MAX_HEAD} bytes");
    let (queue, handler) = RingChannel::new(capacity).into_handler();
    let gate = Mutex::new(Gate::new(secret, head));
    let gate = Callback::from(move |sample: Sample| {
        if admit(&gate, &sample) {
            queue.call(sample);
        } else {
            on_forged();
        }
    });
    (gate, handler)
}

/// Whether `gate` admits `sample`.
fn admit(gate: &Mutex<Gate>, sample: &Sample) -> bool {
    let Some(tag) = sample.attachment() else { return false };
    admit_parts(gate, sample.payload().slices(), sample.payload().len(), &tag.to_bytes())
}

/// Whether `gate` admits a message of `len` bytes given in `parts` (zenoh's fragments; its
/// header is copied out of them, nothing else) carrying `tag`: what the gate of a
/// [`tagged_queue`] does for each sample (`lumen bench ipc` times it).
pub fn admit_parts<'a>(gate: &Mutex<Gate>, parts: impl IntoIterator<Item = &'a [u8]>, len: usize, tag: &[u8]) -> bool {
    let mut gate = gate.lock().unwrap_or_else(|p| p.into_inner());
    let mut head = [0u8; MAX_HEAD];
    let head = &mut head[..gate.head().min(MAX_HEAD)];
    let filled = fill_head(parts, head);
    gate.admit(&head[..filled], len, tag)
}

/// Copies the first `head.len()` bytes of a message given as `parts` (zenoh's fragments) into
/// `head`; returns how many it had (fewer for a shorter message).
pub fn fill_head<'a>(parts: impl IntoIterator<Item = &'a [u8]>, head: &mut [u8]) -> usize {
    let mut filled = 0;
    for s in parts {
        if filled == head.len() {
            break;
        }
        let n = s.len().min(head.len() - filled);
        head[filled..filled + n].copy_from_slice(&s[..n]);
        filled += n;
    }
    filled
}

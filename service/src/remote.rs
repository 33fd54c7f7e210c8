//! The daemon's zenoh side: a queryable for control requests, and one thread per session that
//! blocks on its frame subscriber (newest frame wins), detects, and publishes the reply (and
//! hands it to the session's observers, [`crate::observe`]). A session lives while its
//! client's liveliness token does.

use crate::access::{Policy, Requester};
use crate::config::StatusPolicy;
use crate::control::{self, Plan};
use crate::engine::Engine;
use crate::error::DaemonError;
use crate::observe::Observing;
use crate::registry::Registry;
use lumen_proto::session::{ControlReply, Transport};
use lumen_proto::wire::{encode_contacts, FrameError, FrameHeader, CONTACTS_HEADER_BYTES, CONTACT_BYTES, FRAME_HEADER_BYTES};
use lumen_proto::StateLayout;
use lumen_transport::names::session_live_name;
use lumen_transport::names::{daemon_alive_name, CONTROL, DAEMON_PARAMETER};
use lumen_transport::net::{config, set, tagged_queue, CONGESTION, FRAME_QUEUE};
use lumen_transport::TransportError;
use std::sync::mpsc;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Instant;
use zenoh::bytes::ZBytes;
use zenoh::sample::SampleKind;
use zenoh::Wait;

use crate::local::{CLOSE_CHECK, CONNECT_GRACE, TICK};

/// The zenoh transport of a running daemon.
pub struct Remote {
    pub mode: String,
    pub listen: Vec<String>,
    pub connect: Vec<String>,
    pub tls: Option<crate::config::TlsFiles>,
    /// Client certificates required: who may do what (`None`: anyone who reaches the daemon).
    pub policy: Option<Policy>,
    /// What `status` shows a client no certificate grant identifies.
    pub status: StatusPolicy,
    /// Connections in zenoh's handshake at once, and milliseconds each may take.
    pub accept: (usize, u64),
    pub registry: Arc<Registry>,
}

impl Remote {
    /// Opens the zenoh session and starts the control thread; returns once it serves.
    pub fn start(self) -> Result<JoinHandle<()>, DaemonError> {
        let mut cfg = config(&self.mode, &self.listen, &self.connect)?;
        // Bounded memory: zenoh reassembles a fragmented message before we see it, so cap that
        // at the largest frame a valid spec can have (instead of zenoh's default 1 GiB).
        let cap = 4 * lumen_proto::limits::MAX_STATE_FLOATS + FRAME_HEADER_BYTES + 1024;
        set(&mut cfg, "transport/link/rx/max_message_size", &cap.to_string())?;
        // Connections that never finish the handshake hold a pending slot until the timeout;
        // zenoh closes every new one while all slots are taken (`[zenoh] accept_pending`).
        set(&mut cfg, "transport/unicast/accept_pending", &self.accept.0.to_string())?;
        set(&mut cfg, "transport/unicast/accept_timeout", &self.accept.1.to_string())?;
        raise_open_files(self.accept.0);
        if let Some(tls) = &self.tls {
            for (key, path) in [("listen_certificate", &tls.certificate), ("listen_private_key", &tls.private_key)] {
                let value = serde_json::to_string(&path.display().to_string()).expect("a string");
                set(&mut cfg, &format!("transport/link/tls/{key}"), &value)?;
            }
            if let Some(ca) = &tls.client_ca {
                set(&mut cfg, "transport/link/tls/root_ca_certificate", &serde_json::to_string(&ca.display().to_string()).expect("a string"))?;
                set(&mut cfg, "transport/link/tls/enable_mtls", "true")?;
            }
        }
        if let Some(policy) = &self.policy {
            set(&mut cfg, "access_control", &policy.acl().to_string())?;
        }
        let z = zenoh::open(cfg).wait().map_err(|e| TransportError::zenoh(format!("opening a session listening on {:?}", self.listen), e))?;
        // One name, one daemon: a second daemon of the same name on this network would answer
        // the first one's named requests too.
        let alive = daemon_alive_name(&self.registry.name);
        let taken = z.liveliness().get(&alive).timeout(std::time::Duration::from_millis(500)).wait().map_err(|e| TransportError::zenoh(format!("looking for another daemon named {alive}"), e))?;
        if taken.recv().is_ok_and(|r| r.result().is_ok()) {
            let _ = z.close().wait();
            return Err(DaemonError::NameTaken(self.registry.name.clone()));
        }
        let token = z.liveliness().declare_token(&alive).wait().map_err(|e| TransportError::zenoh("declaring the daemon's liveliness token", e))?;
        // `lumen/control` and, for certified clients, `lumen/control/<common name>`. Complete: a
        // query with zenoh's default target (best matching) reaches exactly one daemon, so a
        // client that names none still opens one session, on the nearest daemon.
        let keys = format!("{CONTROL}/**");
        let queryable = z.declare_queryable(&keys).complete(true).wait().map_err(|e| TransportError::zenoh(format!("declaring the queryable {keys}"), e))?;
        std::thread::Builder::new()
            .name("zenoh-control".into())
            .spawn(move || {
                let mut sessions: Vec<JoinHandle<()>> = Vec::new();
                while !self.registry.stopping() {
                    // Every turn, busy or not: a thread that ended keeps its stack until its
                    // handle goes (a daemon that only ever got requests, sessions opened and
                    // closed back to back, grew by each one's).
                    sessions.retain(|h| !h.is_finished());
                    let query = match queryable.recv_timeout(TICK) {
                        Ok(Some(q)) => q,
                        Ok(None) => continue,
                        Err(e) => {
                            tracing::error!("zenoh control: {e}");
                            break;
                        }
                    };
                    // A request for another daemon (`?daemon=<name>`) is left unanswered: that
                    // daemon answers it (the client asks every daemon at once).
                    if query.parameters().get(DAEMON_PARAMETER).is_some_and(|n| n != self.registry.name) {
                        continue;
                    }
                    let bytes = query.payload().map(|p| p.to_bytes().into_owned()).unwrap_or_default();
                    let requester = self.policy.as_ref().map_or(Requester::Anyone, |p| p.requester(query.key_expr().as_str()));
                    let mut reply = match control::decode(&bytes) {
                        Ok(req) => control::handle(&self.registry, Transport::Zenoh, &requester, req, |plan| {
                            let (h, r) = start_session(z.clone(), plan, self.registry.clone())?;
                            sessions.push(h);
                            r
                        }),
                        Err(reply) => reply,
                    };
                    // Anyone on the network, unidentified: only as much as the policy shows.
                    if let (ControlReply::Status(report), Requester::Anyone, StatusPolicy::Counts) = (&mut reply, &requester, self.status) {
                        control::counts_only(report);
                    }
                    if let ControlReply::Error(e) = &reply {
                        tracing::info!("refused a zenoh control request: {}", e.message);
                    }
                    let json = serde_json::to_vec(&reply).expect("replies serialise");
                    if let Err(e) = query.reply(query.key_expr().clone(), json).wait() {
                        tracing::warn!("zenoh control reply: {e}");
                    }
                }
                for h in sessions {
                    let _ = h.join();
                }
                drop(token);
                drop(queryable);
                if let Err(e) = z.close().wait() {
                    tracing::warn!("closing zenoh: {e}");
                }
            })
            .map_err(|source| DaemonError::Spawn { thread: "zenoh control".into(), source })
    }
}

/// Raises this process's soft limit on open files to its hard limit when the soft one leaves
/// fewer than `pending` + 256 descriptors (each pending connection holds one): a daemon out of
/// descriptors could not accept a real client however the pending slots are set.
fn raise_open_files(pending: usize) {
    let mut lim = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
    // SAFETY: getrlimit/setrlimit only read and write the struct given.
    unsafe {
        if libc::getrlimit(libc::RLIMIT_NOFILE, &mut lim) != 0 || lim.rlim_cur >= (pending + 256) as libc::rlim_t {
            return;
        }
        let want = libc::rlimit { rlim_cur: lim.rlim_max, rlim_max: lim.rlim_max };
        if libc::setrlimit(libc::RLIMIT_NOFILE, &want) != 0 || lim.rlim_max < (pending + 256) as libc::rlim_t {
            tracing::warn!("open files limited to {}: fewer than [zenoh] accept_pending ({pending}) + 256; a connection flood may exhaust them", lim.rlim_max);
        }
    }
}

/// Starts a session's thread; the inner result says whether its channels were created.
fn start_session(z: zenoh::Session, plan: Plan, registry: Arc<Registry>) -> Result<(JoinHandle<()>, Result<(), DaemonError>), DaemonError> {
    let id = plan.entry.info.session;
    crate::registry::spawn_session("zenoh-s", id, registry, move |registry, tx| run_session(&z, plan, registry, tx))
}

fn run_session(z: &zenoh::Session, plan: Plan, registry: &Registry, ready: &mpsc::Sender<Result<(), DaemonError>>) -> Result<&'static str, DaemonError> {
    let info = plan.entry.info.clone();
    // Anyone may put on the frame key: only the owner's tag makes a sample a frame of this
    // session. The gate runs before the newest-wins queue, so a stranger's flood can never push
    // the owner's frames out; what it drops is counted and never answered.
    let gate_entry = plan.entry.clone();
    let (gate, handler) = tagged_queue(FRAME_QUEUE, plan.entry.secret.clone(), FRAME_HEADER_BYTES, move || {
        gate_entry.count_forged(1, "message(s) on its frame key without its owner's tag, or with a frame number used before")
    });
    let frames = z.declare_subscriber(info.frame.clone()).with((gate, handler)).wait().map_err(|e| TransportError::zenoh(format!("subscribing to {}", info.frame), e))?;
    let publisher = z.declare_publisher(info.contacts.clone()).congestion_control(CONGESTION).express(true).wait().map_err(|e| TransportError::zenoh(format!("publishing on {}", info.contacts), e))?;
    // The client's token is on a key only the owner can name (its last chunk comes from the
    // secret), and only a token on exactly that key counts: a stranger's token on a wildcard
    // that covers it cannot keep the session alive once its client is gone.
    let alive_key = plan.alive();
    let alive = z.liveliness().declare_subscriber(alive_key.clone()).history(true).wait().map_err(|e| TransportError::zenoh(format!("watching {alive_key}"), e))?;
    // Held while the session lives: observers watch it to learn that the session ended.
    let live_key = session_live_name(info.session);
    let _live = z.liveliness().declare_token(live_key.clone()).wait().map_err(|e| TransportError::zenoh(format!("declaring {live_key}"), e))?;
    // Registered observers ask for the newest frame and reply; another thread answers them.
    let observers = Observing::start(z, plan.entry.clone())?;
    let mut engine = Engine::new(plan.entry.clone(), plan.echo);
    let mut state: Vec<f32> = Vec::with_capacity(engine.layout().floats);
    let mut delta: Vec<u8> = Vec::new();
    let mut whole: Vec<u8> = Vec::new();
    let reply_capacity = CONTACTS_HEADER_BYTES + CONTACT_BYTES * info.max_contacts as usize;
    let _ = ready.send(Ok(()));
    let opened = Instant::now();
    let mut connected = false;
    let mut last_tick = Instant::now();
    loop {
        match frames.recv_timeout(CLOSE_CHECK) {
            Ok(Some(sample)) => {
                let received = Instant::now();
                // The owner may still send anything: decoding checks every length first.
                let decoded = decode_payload(sample.payload(), engine.id, engine.layout(), &mut state, &mut delta);
                let was_delta = matches!(decoded, Ok(Payload::Delta(_)));
                let (mut reply, contacts) = match decoded {
                    Ok(Payload::Full(h)) => engine.run(Ok((h, state.as_slice()))),
                    Ok(Payload::Delta(h)) => {
                        // Observers get every frame whole; one the daemon could not rebuild, not at all.
                        let watched = plan.entry.places.any(received);
                        engine.run_delta(h, &delta, watched.then_some(&mut whole))
                    }
                    Err(e) => engine.run(Err(e)),
                };
                // zenoh takes ownership of what it sends: one buffer per reply.
                let mut out = Vec::with_capacity(reply_capacity.min(CONTACTS_HEADER_BYTES + CONTACT_BYTES * contacts.len()));
                encode_contacts(&mut reply, contacts, &mut out);
                let tag = plan.entry.secret.message_tag(&out[..CONTACTS_HEADER_BYTES], out.len());
                let service = received.elapsed();
                let out = ZBytes::from(out);
                if let Err(e) = publisher.put(out.clone()).attachment(tag.to_vec()).wait() {
                    tracing::warn!("session {}: publishing contacts: {e}", engine.id);
                }
                engine.record(&reply, service);
                // For observers, after the client's reply (shared buffers, no copies; a delta
                // frame rebuilt whole).
                if !whole.is_empty() {
                    observers.publish(reply.frame, ZBytes::from(std::mem::take(&mut whole)), out);
                } else if !was_delta {
                    observers.publish(reply.frame, sample.payload().clone(), out);
                }
            }
            Ok(None) => {}
            Err(e) => return Err(TransportError::zenoh("receiving a frame", e).into()),
        }
        if plan.entry.close.load(std::sync::atomic::Ordering::SeqCst) {
            return Ok("closed on request");
        }
        if last_tick.elapsed() >= TICK {
            last_tick = Instant::now();
            engine.tick();
            while let Ok(Some(s)) = alive.try_recv() {
                if s.key_expr().as_str() != alive_key {
                    continue;
                }
                match s.kind() {
                    SampleKind::Put => connected = true,
                    SampleKind::Delete => return Ok("its client left"),
                }
            }
            if !connected && opened.elapsed() > CONNECT_GRACE {
                return Ok("no client attached in time");
            }
            if registry.stopping() {
                return Ok("daemon stopping");
            }
        }
    }
}

/// What a frame message carried: every float (decoded into the state) or a delta (its bytes
/// after the header, gathered into one buffer).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Payload {
    Full(FrameHeader),
    Delta(FrameHeader),
}

/// Decodes a frame straight from zenoh's fragments: a full frame's floats into `state` (resized
/// to the frame's floats), with the checks of [`lumen_proto::wire::decode_frame`] and no
/// intermediate contiguous copy; a delta frame's bytes after the header into `delta`.
pub fn decode_payload(payload: &zenoh::bytes::ZBytes, session: u64, layout: &StateLayout, state: &mut Vec<f32>, delta: &mut Vec<u8>) -> Result<Payload, (FrameHeader, FrameError)> {
    let len = payload.len();
    if len < FRAME_HEADER_BYTES {
        return Err((FrameHeader::default(), FrameError::TooShort { got: len }));
    }
    let mut head = [0u8; FRAME_HEADER_BYTES];
    let mut filled = 0;
    let mut slices = payload.slices();
    let mut rest: &[u8] = &[];
    while filled < FRAME_HEADER_BYTES {
        let Some(s) = slices.next() else { break };
        let n = s.len().min(FRAME_HEADER_BYTES - filled);
        head[filled..filled + n].copy_from_slice(&s[..n]);
        filled += n;
        rest = &s[n..];
    }
    let header = FrameHeader::read(&head).map_err(|e| (FrameHeader::default(), e))?;
    let body = len - FRAME_HEADER_BYTES;
    if header.is_delta() {
        // Checked and decoded by the engine, which holds the base.
        delta.clear();
        for s in std::iter::once(rest).chain(slices) {
            delta.extend_from_slice(s);
        }
        return Ok(Payload::Delta(header));
    }
    if !body.is_multiple_of(4) {
        return Err((header, FrameError::Ragged { bytes: body }));
    }
    header.check(session, layout, body / 4).map_err(|e| (header, e))?;
    // The floats travel little-endian, as this machine keeps them: each fragment is copied
    // byte for byte into the state, wherever it cuts a float. Every byte is overwritten, so the
    // state keeps its length from frame to frame instead of being cleared and zeroed.
    let floats = body / 4;
    if state.len() != floats {
        state.clear();
        state.resize(floats, 0.0);
    }
    let bytes: &mut [u8] = bytemuck::cast_slice_mut(state.as_mut_slice());
    let mut at = 0;
    for s in std::iter::once(rest).chain(slices) {
        bytes[at..at + s.len()].copy_from_slice(s);
        at += s.len();
    }
    debug_assert_eq!(at, body);
    if cfg!(target_endian = "big") {
        for v in state.iter_mut() {
            *v = f32::from_bits(u32::from_le(v.to_bits()));
        }
    }
    Ok(Payload::Full(header))
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumen_proto::wire::encode_frame;
    use lumen_proto::{BodySpec, SceneSpec, Shape};

    #[test]
    fn fragmented_payloads_decode_like_contiguous_ones() {
        let spec = SceneSpec::new(vec![BodySpec { name: "r".into(), shape: Shape::Rod { points: 50, radius: vec![1.0] } }], vec![]);
        let layout = StateLayout::of(&spec);
        let floats: Vec<f32> = (0..150).map(|i| i as f32 * 0.5).collect();
        let mut msg = Vec::new();
        encode_frame(&FrameHeader::new(9, 4, 0, 150, 1), &floats, &mut msg);
        // Cut into fragments at awkward places (inside the header, inside floats), decoded into
        // one state that starts full of stale values (as a session's is after a frame).
        let mut state = vec![f32::NAN; 150];
        let fragments = |msg: &[u8], cuts: &[usize]| {
            let mut w = zenoh::bytes::ZBytes::writer();
            let mut at = 0;
            for c in cuts.iter().copied().chain(std::iter::once(msg.len())) {
                w.append(zenoh::bytes::ZBytes::from(msg[at..c].to_vec()));
                at = c;
            }
            w.finish()
        };
        let mut flagged = msg.clone();
        flagged[6] = lumen_proto::wire::FLAG_DELTA as u8;
        for cuts in [vec![], vec![7], vec![40, 41, 43, 100], vec![3, 39, 45, 46, 47, 333, 600]] {
            let z = fragments(&msg, &cuts);
            assert_eq!(z.slices().count(), cuts.len() + 1);
            let Payload::Full(h) = decode_payload(&z, 9, &layout, &mut state, &mut Vec::new()).unwrap() else { panic!("a full frame") };
            assert_eq!((h.frame, state.as_slice()), (4, floats.as_slice()), "cuts {cuts:?}");
            // The same bytes flagged delta: everything after the header, gathered whole.
            let mut delta = vec![1, 2];
            assert!(matches!(decode_payload(&fragments(&flagged, &cuts), 9, &layout, &mut state, &mut delta), Ok(Payload::Delta(h)) if h.frame == 4));
            assert_eq!(delta, msg[FRAME_HEADER_BYTES..], "cuts {cuts:?}");
        }
        let short = zenoh::bytes::ZBytes::from(msg[..msg.len() - 2].to_vec());
        assert_eq!(decode_payload(&short, 9, &layout, &mut Vec::new(), &mut Vec::new()).unwrap_err().1, FrameError::Ragged { bytes: 598 });
        // A fresh, empty state is sized to the frame.
        let mut fresh = Vec::new();
        decode_payload(&zenoh::bytes::ZBytes::from(msg.clone()), 9, &layout, &mut fresh, &mut Vec::new()).unwrap();
        assert_eq!(fresh, floats);
        assert_eq!(decode_payload(&zenoh::bytes::ZBytes::from(vec![1u8; 5]), 9, &layout, &mut Vec::new(), &mut Vec::new()).unwrap_err().1, FrameError::TooShort { got: 5 });
    }
}

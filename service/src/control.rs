//! Control requests, the same on both transports: validate, size, register, describe, report.

use crate::access::Requester;
use crate::error::DaemonError;
use crate::registry::{Entry, Registry};
use lumen_proto::auth::{Secret, Token, SECRET_BYTES, TOKEN_BYTES};
use lumen_proto::session::{ControlError, ControlReply, ControlRequest, ErrorCode, SessionInfo, StatusReport, Transport, MAX_CONTROL_BYTES};
use lumen_proto::wire::{CONTACTS_HEADER_BYTES, CONTACT_BYTES, FRAME_HEADER_BYTES, PROTOCOL_VERSION};
use lumen_proto::SceneSpec;
use lumen_transport::names::{client_alive_name, contacts_name, frame_name, CONTROL};
use lumen_transport::shm::ChannelQos;
use std::sync::Arc;

/// How long a close waits for the session's slot to be free before answering (the session's
/// thread sees the request within one tick, 100 ms).
const CLOSE_WAIT: std::time::Duration = std::time::Duration::from_secs(2);

/// A session accepted by [`open`], to be started by its transport.
pub struct Plan {
    pub entry: Arc<Entry>,
    pub echo: bool,
}

impl Plan {
    /// Zenoh: the client liveliness key the session lives by (the opened reply's `alive`).
    pub fn alive(&self) -> String {
        client_alive_name(self.entry.info.session, &self.entry.chunk, &self.entry.secret)
    }
}

pub(crate) fn error(code: ErrorCode, message: impl Into<String>) -> ControlReply {
    ControlReply::Error(ControlError { code, message: message.into() })
}

/// The answer about a session this daemon does not have.
fn no_session(session: u64) -> ControlReply {
    error(ErrorCode::UnknownSession, format!("no session {session}: it was closed, its client died, or the daemon restarted"))
}

/// Bytes of shared memory an iceoryx2 session pins: the client's frame segment and the
/// daemon's contacts segment, each sized for every subscriber's buffers plus one loan.
pub fn session_bytes(floats: usize, max_contacts: usize, observers: usize) -> usize {
    let frames = ChannelQos::frames(observers).segment_samples();
    let replies = ChannelQos::contacts(observers).segment_samples();
    frames * (FRAME_HEADER_BYTES + 4 * floats) + replies * (CONTACTS_HEADER_BYTES + CONTACT_BYTES * max_contacts)
}

/// Decodes a request; a reply is returned for anything unreadable.
#[allow(clippy::result_large_err)] // the error is the reply itself, built once per request
pub fn decode(bytes: &[u8]) -> Result<ControlRequest, ControlReply> {
    if bytes.len() > MAX_CONTROL_BYTES {
        return Err(error(ErrorCode::BadRequest, format!("control request of {} bytes; at most {MAX_CONTROL_BYTES} are read", bytes.len())));
    }
    let mut value: serde_json::Value = serde_json::from_slice(bytes).map_err(|e| error(ErrorCode::BadRequest, format!("not JSON: {e}")))?;
    // An open's spec is read on its own, so a spec that does not parse is answered with code
    // `spec` naming its field, body or pair (the request around it stays a `bad_request`).
    let spec = match value.get("op").and_then(|op| op.as_str()) {
        Some("open") => value.get_mut("spec").map(|slot| std::mem::replace(slot, serde_json::json!({"bodies": [], "pairs": []}))),
        _ => None,
    };
    let mut request: ControlRequest = serde_json::from_value(value).map_err(|e| error(ErrorCode::BadRequest, format!("not a control request: {e}")))?;
    if let (ControlRequest::Open { spec: slot, .. }, Some(spec)) = (&mut request, spec) {
        *slot = crate::spec_json::parse(spec).map_err(|e| error(ErrorCode::Spec, format!("invalid scene spec: {e}")))?;
    }
    Ok(request)
}

/// Handles a request on `transport`; `start` launches an accepted session and says whether it
/// could (its channels exist when it returns `Ok`).
pub fn handle(registry: &Registry, transport: Transport, requester: &Requester, request: ControlRequest, start: impl FnOnce(Plan) -> Result<(), DaemonError>) -> ControlReply {
    if let Some(refusal) = refuse(registry, requester, &request) {
        return refusal;
    }
    let holder = match requester {
        Requester::Certified(g) => Some(g.name.clone()),
        _ => None,
    };
    match request {
        ControlRequest::Status => ControlReply::Status(registry.status()),
        ControlRequest::Hello => ControlReply::Hello(registry.hello()),
        ControlRequest::Describe { session } => match registry.get(session) {
            // The stored info holds no secret: what describe tells an observer.
            Some(e) => ControlReply::Described(e.info.clone()),
            None => no_session(session),
        },
        ControlRequest::Observe { session } => match registry.get(session) {
            Some(e) if e.info.transport != Transport::Zenoh => {
                error(ErrorCode::BadRequest, format!("session {session} runs on iceoryx2: observe it there, by subscribing to its frame and contacts services (proto/README.md, section 4)"))
            }
            Some(e) => observe(&e, registry.limits.max_observers),
            None => no_session(session),
        },
        ControlRequest::Close { session, proof } => match registry.get(session) {
            Some(e) if !e.secret.verify_close(session, &proof) => {
                tracing::warn!("refused a close of session {session} without its owner's proof");
                error(ErrorCode::NotOwner, format!("session {session} is not yours: a close carries the proof of the secret its opened reply gave (proto/README.md, ownership)"))
            }
            Some(e) => {
                // Answered once the slot is free (the session's thread ends at its next tick),
                // so an open right after the answer finds room.
                e.close.store(true, std::sync::atomic::Ordering::SeqCst);
                drop(e);
                if !registry.wait_gone(session, CLOSE_WAIT) {
                    tracing::warn!("session {session} still ending {CLOSE_WAIT:?} after its close");
                }
                ControlReply::Closed { session }
            }
            None => error(ErrorCode::UnknownSession, format!("no session {session}")),
        },
        ControlRequest::Open { version, spec, client, echo, alive } => open(registry, transport, Opening { version, spec, client, holder, echo, alive }, start),
    }
}

/// Leaves in `report` only how many sessions there are (`hidden`): what `status` tells a zenoh
/// client no certificate identifies, under the default policy (`[zenoh] status = "counts"`).
pub fn counts_only(report: &mut StatusReport) {
    report.hidden += report.sessions.len() as u32;
    report.sessions.clear();
}

/// What the access policy refuses of `request` from `requester` (`None`: allowed). Ours, not
/// zenoh's ACL: the operation is inside the payload and the session count needs the registry.
fn refuse(registry: &Registry, requester: &Requester, request: &ControlRequest) -> Option<ControlReply> {
    let g = match requester {
        Requester::Anyone => return None,
        Requester::Unnamed => {
            return Some(error(
                ErrorCode::NotAllowed,
                format!("this daemon requires client certificates: send control requests on {CONTROL}/<your certificate's common name> (proto/README.md, section 6)"),
            ))
        }
        Requester::Certified(g) => g,
    };
    let denied = |what: &str| Some(error(ErrorCode::NotAllowed, format!("certificate {:?} may not {what} ([[zenoh.access]] of the daemon's configuration)", g.name)));
    match request {
        ControlRequest::Status if !g.status => denied("query status"),
        ControlRequest::Describe { .. } if !g.observe => denied("observe (describe) sessions"),
        ControlRequest::Observe { .. } if !g.observe => denied("observe sessions"),
        ControlRequest::Open { .. } if g.open == 0 => denied("open sessions"),
        ControlRequest::Open { .. } if registry.held_by(&g.name) >= g.open => {
            Some(error(ErrorCode::Limit, format!("certificate {:?} already holds {} sessions, as many as its access allows (open = {}): close one first", g.name, g.open, g.open)))
        }
        _ => None,
    }
}

/// An open request's fields and who sent it.
struct Opening {
    version: u16,
    spec: SceneSpec,
    client: String,
    holder: Option<String>,
    echo: bool,
    alive: String,
}

fn open(registry: &Registry, transport: Transport, opening: Opening, start: impl FnOnce(Plan) -> Result<(), DaemonError>) -> ControlReply {
    let Opening { version, spec, client, holder, echo, alive: chunk } = opening;
    if version != PROTOCOL_VERSION {
        return error(ErrorCode::Version, format!("client speaks protocol version {version}; this daemon speaks {PROTOCOL_VERSION}: upgrade the older side"));
    }
    if client.len() > lumen_proto::limits::MAX_NAME_BYTES {
        return error(ErrorCode::BadRequest, format!("client name of {} bytes; at most {} are allowed", client.len(), lumen_proto::limits::MAX_NAME_BYTES));
    }
    if !chunk.is_empty() && !lumen_proto::session::is_alive_chunk(&chunk) {
        return error(ErrorCode::BadRequest, format!("alive {chunk:?}: 32 lowercase hex digits drawn at random are expected, or none"));
    }
    let scene = match spec.validate() {
        Ok(scene) => scene,
        Err(e) => return error(ErrorCode::Spec, format!("invalid scene spec: {e}")),
    };
    let limits = registry.limits;
    let layout = scene.layout().clone();
    let max_contacts = scene.max_contacts().min(limits.max_contacts);
    let observers = limits.max_observers;
    let bytes = match transport {
        Transport::Iceoryx2 => session_bytes(layout.floats, max_contacts, observers),
        Transport::Zenoh => FRAME_HEADER_BYTES + 4 * layout.floats,
    };
    let allowed = limits.max_session_mib << 20;
    if bytes > allowed {
        return error(
            ErrorCode::Limit,
            format!(
                "this scene needs {:.1} MiB per session ({} floats per frame); the daemon allows {} MiB (limits.max_session_mib): use fewer rings or spokes, or raise the limit",
                bytes as f64 / 1048576.0,
                layout.floats,
                limits.max_session_mib
            ),
        );
    }
    if !registry.has_room() {
        return error(ErrorCode::Busy, format!("the daemon already serves {} sessions (limits.max_sessions): close one or raise the limit", limits.max_sessions));
    }
    let id = registry.next_id(transport, &chunk);
    let Some(secret) = new_secret() else {
        return error(ErrorCode::Internal, "the operating system gave no random bytes for the session's secret");
    };
    let info = SessionInfo {
        session: id,
        daemon: registry.name.clone(),
        transport,
        spec,
        floats: layout.floats as u32,
        bodies: layout.bodies.len() as u32,
        max_contacts: max_contacts as u32,
        frame: frame_name(id),
        contacts: contacts_name(id),
        // Named by the secret: only in the opened reply (see `opened` below).
        alive: String::new(),
        max_observers: observers as u32,
        secret: String::new(),
    };
    let alive = if transport == Transport::Zenoh { client_alive_name(id, &chunk, &secret) } else { String::new() };
    let opened = SessionInfo { secret: secret.to_hex(), alive: alive.clone(), ..info.clone() };
    let Some(entry) = registry.insert(info, secret, scene, client, holder, chunk) else {
        return error(ErrorCode::Busy, format!("the daemon already serves {} sessions", limits.max_sessions));
    };
    match start(Plan { entry, echo }) {
        Ok(()) => ControlReply::Opened(opened),
        Err(e) => {
            registry.remove(id);
            error(ErrorCode::Internal, format!("could not create the session's channels: {e}"))
        }
    }
}

/// A zenoh observer place of session `e` with a fresh token, or why not.
fn observe(e: &Entry, max: usize) -> ControlReply {
    let session = e.info.session;
    let Some(token) = random::<TOKEN_BYTES>().map(Token::from_bytes) else {
        return error(ErrorCode::Internal, "the operating system gave no random bytes for the observer's token");
    };
    if !e.places.take(token, max, std::time::Instant::now()) {
        return error(ErrorCode::ObserversFull, format!("session {session} already has {max} observers, as many as the daemon allows (limits.max_observers): end one or raise the limit"));
    }
    ControlReply::Observing { session, observer: token.to_hex() }
}

/// A fresh secret of 256 bits from the operating system's generator (`None` if it fails).
fn new_secret() -> Option<Secret> {
    random::<SECRET_BYTES>().map(Secret::from_bytes)
}

/// `N` bytes from the operating system's generator (`None` if it fails).
fn random<const N: usize>() -> Option<[u8; N]> {
    use ring::rand::SecureRandom;
    let mut bytes = [0u8; N];
    ring::rand::SystemRandom::new().fill(&mut bytes).ok()?;
    Some(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Limits;
    use lumen_proto::{BodySpec, ContactKind, PairSpec, Shape};

    fn spec(rings: usize) -> SceneSpec {
        SceneSpec::new(
            vec![BodySpec { name: "colon".into(), shape: Shape::Tube { rings, spokes: 32 } }, BodySpec { name: "scope".into(), shape: Shape::Rod { points: 160, radius: vec![6.5] } }],
            vec![PairSpec { a: "scope".into(), b: "colon".into(), kind: ContactKind::Interior }],
        )
    }

    fn open_req(spec: SceneSpec) -> ControlRequest {
        ControlRequest::Open { version: PROTOCOL_VERSION, spec, client: "t".into(), echo: false, alive: String::new() }
    }

    #[test]
    fn open_sizes_checks_and_registers() {
        let reg = Registry::new(Limits { max_sessions: 1, max_session_mib: 64, ..Limits::default() });
        let others = 1 + lumen_proto::limits::MAX_OTHER_WALLS;
        assert_eq!(spec(1250).validate().unwrap().max_contacts(), (159 * 4 + 1) * others);
        let ControlReply::Opened(info) = handle(&reg, Transport::Iceoryx2, &Requester::Anyone, open_req(spec(1250)), |_| Ok(())) else { panic!() };
        assert_eq!((info.floats, info.max_contacts as usize), (1250 * 33 * 3 + 480, 637 * others));
        // Every interior sample may report up to MAX_OTHER_WALLS more walls, with `nearest` or
        // not: the reply is sized for them, not cut at one per sample.
        let mut nearest = spec(1250);
        nearest.nearest = true;
        let roomy = Registry::new(Limits::default());
        let ControlReply::Opened(wide) = handle(&roomy, Transport::Iceoryx2, &Requester::Anyone, open_req(nearest), |_| Ok(())) else { panic!() };
        assert_eq!(wide.max_contacts as usize, 637 * others);
        assert_eq!(info.frame, format!("lumen/session/{}/frame", info.session));
        // Full: the second is refused as busy, with the limit named.
        let ControlReply::Error(e) = handle(&reg, Transport::Iceoryx2, &Requester::Anyone, open_req(spec(10)), |_| Ok(())) else { panic!() };
        assert_eq!(e.code, ErrorCode::Busy);
        assert!(e.message.contains("max_sessions"), "{}", e.message);
        reg.remove(info.session);
        // Beyond the memory limit: 65536 rings of 32 spokes is ~26 MB per frame.
        let ControlReply::Error(e) = handle(&reg, Transport::Iceoryx2, &Requester::Anyone, open_req(spec(65_536)), |_| Ok(())) else { panic!() };
        assert_eq!(e.code, ErrorCode::Limit);
        // Invalid spec: the message names the body.
        let ControlReply::Error(e) = handle(&reg, Transport::Zenoh, &Requester::Anyone, open_req(spec(1)), |_| Ok(())) else { panic!() };
        assert_eq!(e.code, ErrorCode::Spec);
        assert!(e.message.contains("\"colon\""), "{}", e.message);
        // A failing transport leaves nothing registered.
        let ControlReply::Error(e) = handle(&reg, Transport::Iceoryx2, &Requester::Anyone, open_req(spec(10)), |_| Err(DaemonError::Stopped("no shm".into()))) else { panic!() };
        assert_eq!((e.code, reg.len()), (ErrorCode::Internal, 0));
        assert!(matches!(decode(b"{\"op\":\"explode\"}"), Err(ControlReply::Error(ControlError { code: ErrorCode::BadRequest, .. }))));
        // A client name beyond MAX_NAME_BYTES is refused, naming the limit.
        let named = |client: String| ControlRequest::Open { version: PROTOCOL_VERSION, spec: spec(10), client, echo: false, alive: String::new() };
        let ControlReply::Error(e) = handle(&reg, Transport::Zenoh, &Requester::Anyone, named("c".repeat(129)), |_| Ok(())) else { panic!() };
        assert_eq!(e.code, ErrorCode::BadRequest);
        assert!(e.message.contains("client name of 129 bytes; at most 128"), "{}", e.message);
        assert_eq!(reg.len(), 0);
    }

    #[test]
    fn only_the_opener_knows_the_secret_and_only_its_proof_closes() {
        let reg = Registry::new(Limits::default());
        let ControlReply::Opened(info) = handle(&reg, Transport::Zenoh, &Requester::Anyone, open_req(spec(10)), |_| Ok(())) else { panic!() };
        let secret = Secret::parse(&info.secret).expect("64 hex digits");
        let ControlReply::Opened(again) = handle(&reg, Transport::Zenoh, &Requester::Anyone, open_req(spec(10)), |_| Ok(())) else { panic!() };
        assert_ne!(again.secret, info.secret, "each session its own secret");
        let ControlReply::Described(d) = handle(&reg, Transport::Zenoh, &Requester::Anyone, ControlRequest::Describe { session: info.session }, |_| Ok(())) else { panic!() };
        assert_eq!((d.secret.as_str(), d.alive.as_str(), d.session), ("", "", info.session), "describe tells no secret, nor the key it names");
        assert_eq!(info.alive, format!("lumen/session/{}/client/{}", info.session, secret.alive_chunk(info.session)), "the opener's liveliness key");
        assert!(!serde_json::to_string(&ControlReply::Described(d)).unwrap().contains("secret"));
        let other = Secret::parse(&again.secret).unwrap();
        for proof in [String::new(), "00".repeat(32), other.close_proof(info.session), secret.close_proof(again.session)] {
            let ControlReply::Error(e) = handle(&reg, Transport::Zenoh, &Requester::Anyone, ControlRequest::Close { session: info.session, proof }, |_| Ok(())) else { panic!() };
            assert_eq!(e.code, ErrorCode::NotOwner);
            assert!(reg.get(info.session).is_some(), "a refused close leaves the session open");
        }
        // The owner's proof closes it (no session thread here: removed as its thread would).
        let entry = reg.get(info.session).unwrap();
        std::thread::scope(|s| {
            s.spawn(|| {
                while !entry.close.load(std::sync::atomic::Ordering::SeqCst) {
                    std::thread::sleep(std::time::Duration::from_millis(1));
                }
                reg.remove(info.session);
            });
            let r = handle(&reg, Transport::Zenoh, &Requester::Anyone, ControlRequest::Close { session: info.session, proof: secret.close_proof(info.session) }, |_| Ok(()));
            assert_eq!(r, ControlReply::Closed { session: info.session });
        });
    }

    #[test]
    fn an_open_may_name_its_liveliness_chunk() {
        let reg = Registry::new(Limits::default());
        let chunk = "0123456789abcdef0123456789abcdef";
        let with = |alive: &str| ControlRequest::Open { version: PROTOCOL_VERSION, spec: spec(10), client: "t".into(), echo: false, alive: alive.into() };
        let mut plans = Vec::new();
        let ControlReply::Opened(info) = handle(&reg, Transport::Zenoh, &Requester::Anyone, with(chunk), |p| {
            plans.push(p.alive());
            Ok(())
        }) else {
            panic!()
        };
        let key = format!("lumen/session/{}/client/{chunk}", info.session);
        assert_eq!((info.alive.as_str(), plans[0].as_str()), (key.as_str(), key.as_str()), "the reply and the session's thread name the same key");
        // Not 32 lowercase hex digits: refused, naming the field; nothing registered.
        for bad in ["0123456789ABCDEF0123456789abcdef", "abc", "0123456789abcdef0123456789abcdef/x"] {
            let ControlReply::Error(e) = handle(&reg, Transport::Zenoh, &Requester::Anyone, with(bad), |_| Ok(())) else { panic!("{bad}") };
            assert_eq!(e.code, ErrorCode::BadRequest);
            assert!(e.message.starts_with(&format!("alive {bad:?}: 32 lowercase hex digits")), "{}", e.message);
        }
        assert_eq!(reg.len(), 1);
    }

    #[test]
    fn a_zenoh_clients_ids_are_taken_again_by_it_after_they_rested_and_an_iceoryx2_ones_never() {
        let reg = Registry::new(Limits::default());
        let (c1, c2) = ("0123456789abcdef0123456789abcdef", "fedcba9876543210fedcba9876543210");
        let open = |transport, alive: &str| {
            let req = ControlRequest::Open { version: PROTOCOL_VERSION, spec: spec(10), client: "t".into(), echo: false, alive: alive.into() };
            match handle(&reg, transport, &Requester::Anyone, req, |_| Ok(())) {
                ControlReply::Opened(info) => info.session,
                other => panic!("{other:?}"),
            }
        };
        let (z, i, anon) = (open(Transport::Zenoh, c1), open(Transport::Iceoryx2, c1), open(Transport::Zenoh, ""));
        for id in [z, i, anon] {
            reg.remove(id);
        }
        let soon = open(Transport::Zenoh, c1);
        assert_ne!(soon, z, "an id that has not rested {:?} is not taken", crate::registry::ID_REST);
        reg.age_rested(crate::registry::ID_REST);
        let other = open(Transport::Zenoh, c2);
        assert!(![z, i, anon, soon].contains(&other), "another client's ids are not its: a fresh one ({other})");
        assert_eq!(open(Transport::Zenoh, c1), z, "the client's oldest rested id");
        assert_eq!(open(Transport::Zenoh, ""), anon, "clients that give no chunk share theirs");
        let next = open(Transport::Zenoh, c1);
        assert!(![z, i, anon, soon, other].contains(&next), "nothing else of its has rested: a fresh id ({next})");
        reg.remove(soon);
        reg.age_rested(crate::registry::ID_REST);
        assert_eq!(open(Transport::Zenoh, c1), soon);
        assert_ne!(open(Transport::Iceoryx2, c1), i, "iceoryx2 ids are never taken again");
        // A rested id no one took for ID_KEPT is forgotten.
        reg.remove(next);
        reg.age_rested(crate::registry::ID_KEPT + crate::registry::ID_REST);
        assert_ne!(open(Transport::Zenoh, c1), next);
    }

    /// The code a raw request is answered with, or "ok" for one that decodes.
    fn code_of(json: &str) -> String {
        match decode(json.as_bytes()) {
            Ok(_) => "ok".into(),
            Err(ControlReply::Error(e)) => format!("{:?}: {}", e.code, e.message),
            Err(other) => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_spec_that_does_not_parse_is_code_spec_and_the_request_around_it_bad_request() {
        let spec =
            r#"{"bodies":[{"name":"colon","shape":{"tube":{"rings":20,"spokes":8}}},{"name":"scope","shape":{"rod":{"points":5,"radius":[1.0]}}}],"pairs":[{"a":"scope","b":"colon","kind":"KIND"}]}"#;
        let open = |kind: &str, rest: &str| format!(r#"{{"op":"open","version":1{rest},"spec":{}}}"#, spec.replace("KIND", kind));
        assert_eq!(code_of(&open("interior", "")), "ok", "client may be left out");
        assert!(code_of(&open("inside", "")).starts_with("Spec: invalid scene spec: pair #0 (\"scope\", \"colon\"): unknown variant `inside`"), "{}", code_of(&open("inside", "")));
        assert!(code_of(&open("interior", r#","version":"1""#)).starts_with("BadRequest"), "a bad version is the request's, not the spec's");
        assert!(code_of(&open("interior", r#","colour":1"#)).starts_with("BadRequest: not a control request: unknown field `colour`"));
        assert!(code_of(r#"{"op":"open","version":1}"#).starts_with("BadRequest: not a control request: missing field `spec`"));
        assert!(code_of("{").starts_with("BadRequest: not JSON"));
        assert!(code_of(r#"{"op":"shout"}"#).starts_with("BadRequest: not a control request: unknown variant `shout`"));
    }
}

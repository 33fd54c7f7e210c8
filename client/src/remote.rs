//! The zenoh transport: the same frames and replies as bytes over TCP (or TLS), for clients on
//! other machines.

use crate::control::{parse_reply, unexpected, CONTROL_WAIT};
use crate::view::ContactsView;
use crate::{now_ns, Error, Observed};
use lumen_proto::auth::Secret;
use lumen_proto::session::{ControlReply, ControlRequest, DaemonInfo, ErrorCode, SessionInfo, StatusReport, Transport};
use lumen_proto::wire::{decode_contacts, ContactsHeader, FrameHeader, CONTACTS_HEADER_BYTES, FRAME_HEADER_BYTES};
use lumen_proto::{Contact, StateLayout};
use lumen_transport::names::{daemon_alive_name, observe_name, session_live_name, AFTER_PARAMETER, CONTROL, DAEMONS_ALIVE, DAEMON_PARAMETER, END_PARAMETER, OBSERVER_PARAMETER};
use lumen_transport::net::{tagged_queue, ASK_HOLD, CONGESTION, CONTACTS_QUEUE, OBSERVER_CONGESTION};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use zenoh::handlers::{FifoChannelHandler, RingChannelHandler};
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::query::{ConsolidationMode, QueryTarget, Reply};
use zenoh::sample::{Sample, SampleKind};
use zenoh::Wait;

/// A client of the daemons reachable over zenoh (one, or several through a router).
pub struct ZenohClient {
    session: zenoh::Session,
    route: Route,
    /// The daemon sessions open on, by name; `None`: the least loaded at each open.
    daemon: Option<String>,
    /// The last chunk of every session's liveliness key (the open request's `alive`), drawn
    /// once: zenoh keeps each key a connection has seen, so one chunk for all the sessions
    /// (and the daemon's reused ids) keeps this process and the daemon from growing per session.
    alive: String,
}

/// Where control requests go: the daemon's endpoint (for messages) and the control key
/// (`lumen/control`, or `lumen/control/<common name>` with a client certificate).
#[derive(Debug, Clone)]
pub(crate) struct Route {
    endpoint: String,
    control: String,
}

impl ZenohClient {
    /// Connects in client mode to `endpoint` (e.g. `tcp/127.0.0.1:7447`).
    pub fn connect(endpoint: &str) -> Result<Self, Error> {
        Self::with_config(lumen_transport::net::client_config(&[endpoint.to_owned()])?, endpoint)
    }

    /// Sends control requests on `lumen/control/<name>`, as a client whose certificate's common
    /// name is `name` must when the daemon requires client certificates.
    pub(crate) fn certified_as(mut self, name: &str) -> Self {
        self.route.control = lumen_transport::names::control_name_for(name);
        self
    }

    /// Connects with a full zenoh configuration (TLS, authentication...); `label` names the
    /// daemon in error messages.
    pub fn with_config(config: zenoh::Config, label: &str) -> Result<Self, Error> {
        let session = zenoh::open(config)
            .wait()
            .map_err(|e| Error::NoDaemon { transport: Transport::Zenoh, detail: format!("cannot connect to {label}: {}", lumen_transport::without_source_paths(&e.to_string())) })?;
        let mut chunk = [0u8; 16];
        getrandom::fill(&mut chunk).map_err(|e| Error::zenoh("drawing the liveliness key's chunk", e.to_string()))?;
        let alive = lumen_proto::auth::hex(&chunk);
        Ok(Self { session, route: Route { endpoint: label.to_owned(), control: CONTROL.to_owned() }, daemon: None, alive })
    }

    /// Opens sessions on the daemon named `name` only (see [`DaemonInfo::daemon`]), not on the
    /// least loaded one.
    pub(crate) fn on_daemon(mut self, name: &str) -> Self {
        self.daemon = Some(name.to_owned());
        self
    }

    /// Sends one control request and waits up to `timeout` for the reply: a `describe`, an
    /// `observe` or a `close` from the daemon that has the session, anything else from the
    /// nearest daemon.
    pub fn request(&self, request: &ControlRequest, timeout: Duration) -> Result<ControlReply, Error> {
        match request {
            ControlRequest::Describe { .. } | ControlRequest::Observe { .. } | ControlRequest::Close { .. } => about_a_session(&self.session, &self.route, request, timeout),
            _ => request_on(&self.session, &self.route, request, None, timeout),
        }
    }

    /// Every daemon's name and load (each daemon on the network answers).
    pub fn daemons(&self, timeout: Duration) -> Result<Vec<DaemonInfo>, Error> {
        daemons_on(&self.session, &self.route, timeout)
    }

    /// Every daemon's status report (each daemon on the network answers).
    pub fn status_all(&self, timeout: Duration) -> Result<Vec<StatusReport>, Error> {
        let mut reports = Vec::new();
        for reply in request_all(&self.session, &self.route, &ControlRequest::Status, timeout)? {
            match reply {
                ControlReply::Status(s) => reports.push(s),
                other => return Err(unexpected(other)),
            }
        }
        reports.sort_by(|a, b| a.daemon.cmp(&b.daemon));
        Ok(reports)
    }

    pub(crate) fn open(&self, mut request: ControlRequest) -> Result<ZenohSession, Error> {
        if let ControlRequest::Open { alive, .. } = &mut request {
            alive.clone_from(&self.alive);
        }
        let daemon = match &self.daemon {
            Some(name) => Some(name.clone()),
            None => least_loaded(&self.session, &self.route, crate::CONTROL_TIMEOUT)?,
        };
        match request_on(&self.session, &self.route, &request, daemon.as_deref(), crate::CONTROL_TIMEOUT)? {
            ControlReply::Opened(info) => ZenohSession::new(self.session.clone(), self.route.clone(), self.daemon.clone(), request, info),
            other => Err(unexpected(other)),
        }
    }

    pub(crate) fn observe(&self, info: SessionInfo) -> Result<ZenohObserver, Error> {
        let token = take_place(&self.session, &self.route, &info)?;
        // The session lives while the daemon's token for it and the daemon's own do.
        let watch = |key: &str| self.session.liveliness().declare_subscriber(key).wait().map_err(|e| Error::zenoh(&format!("watching {key}"), e));
        let ended = [watch(&session_live_name(info.session))?, watch(&daemon_key(&info))?];
        let key = observe_name(info.session);
        let (route, session) = (self.route.clone(), self.session.clone());
        Ok(ZenohObserver {
            session,
            route,
            key,
            token,
            ask: None,
            after: None,
            reply: None,
            ended,
            gone: false,
            info,
            frame_header: FrameHeader::default(),
            state: Vec::new(),
            header: ContactsHeader::default(),
            contacts: Vec::new(),
        })
    }
}

/// The liveliness key of the daemon that serves the session of `info` (any daemon's, for a
/// daemon that gives no name).
fn daemon_key(info: &SessionInfo) -> String {
    if info.daemon.is_empty() {
        DAEMONS_ALIVE.to_owned()
    } else {
        daemon_alive_name(&info.daemon)
    }
}

/// The selector and query target of a control request for `daemon`: named, every daemon gets
/// it and only that one answers; unnamed, zenoh routes it to the nearest daemon alone (the
/// daemons' control queryables are complete).
fn selector(route: &Route, daemon: Option<&str>) -> (String, QueryTarget) {
    match daemon {
        Some(name) => (format!("{}?{DAEMON_PARAMETER}={name}", route.control), QueryTarget::All),
        None => (route.control.clone(), QueryTarget::BestMatching),
    }
}

fn request_on(session: &zenoh::Session, route: &Route, request: &ControlRequest, daemon: Option<&str>, timeout: Duration) -> Result<ControlReply, Error> {
    let json = serde_json::to_vec(request).expect("control requests serialise");
    let (key, target) = selector(route, daemon);
    let replies = session.get(&key).target(target).payload(json).timeout(timeout).wait().map_err(|e| Error::zenoh("sending a control request", e))?;
    read_reply(replies.recv().ok(), route, timeout)
}

/// [`request_on`] for async code.
async fn request_on_async(session: &zenoh::Session, route: &Route, request: &ControlRequest, daemon: Option<&str>, timeout: Duration) -> Result<ControlReply, Error> {
    let json = serde_json::to_vec(request).expect("control requests serialise");
    let (key, target) = selector(route, daemon);
    let replies = session.get(&key).target(target).payload(json).timeout(timeout).await.map_err(|e| Error::zenoh("sending a control request", e))?;
    read_reply(replies.recv_async().await.ok(), route, timeout)
}

/// Sends `request` to every daemon and returns every reply that came within `timeout` (the
/// query ends as soon as each daemon has answered).
fn request_all(session: &zenoh::Session, route: &Route, request: &ControlRequest, timeout: Duration) -> Result<Vec<ControlReply>, Error> {
    let json = serde_json::to_vec(request).expect("control requests serialise");
    // No consolidation: every daemon replies on the same key, and zenoh's default keeps one.
    let replies =
        session.get(&route.control).target(QueryTarget::All).consolidation(ConsolidationMode::None).payload(json).timeout(timeout).wait().map_err(|e| Error::zenoh("sending a control request", e))?;
    let mut all = Vec::new();
    while let Ok(r) = replies.recv() {
        all.push(read_reply(Some(r), route, timeout)?);
    }
    if all.is_empty() {
        return Err(Error::NoDaemon { transport: Transport::Zenoh, detail: format!("no reply on {} at {} within {timeout:?}", route.control, route.endpoint) });
    }
    Ok(all)
}

/// Every daemon's answer to `hello`.
fn daemons_on(session: &zenoh::Session, route: &Route, timeout: Duration) -> Result<Vec<DaemonInfo>, Error> {
    Ok(request_all(session, route, &ControlRequest::Hello, timeout)?.into_iter().filter_map(|r| if let ControlReply::Hello(d) = r { Some(d) } else { None }).collect())
}

/// A request about one session asked of every daemon: the reply of the one that has the
/// session, else the first (an unknown session).
fn about_a_session(session: &zenoh::Session, route: &Route, request: &ControlRequest, timeout: Duration) -> Result<ControlReply, Error> {
    let mut all = request_all(session, route, request, timeout)?;
    let found = all.iter().position(|r| !matches!(r, ControlReply::Error(e) if e.code == ErrorCode::UnknownSession)).unwrap_or(0);
    Ok(all.swap_remove(found))
}

/// The name of the daemon with the most free session slots (then the fewest sessions, then
/// the first name), or `None` where no daemon gives its name (one that predates names: the
/// open then goes to the nearest daemon).
fn least_loaded(session: &zenoh::Session, route: &Route, timeout: Duration) -> Result<Option<String>, Error> {
    Ok(daemons_on(session, route, timeout)?.into_iter().min_by_key(|d| (std::cmp::Reverse(d.max_sessions.saturating_sub(d.sessions)), d.sessions, d.daemon.clone())).map(|d| d.daemon))
}

/// Whether a control reply says the session asked about does not exist.
fn unknown_session(reply: Result<ControlReply, Error>) -> bool {
    matches!(reply, Ok(ControlReply::Error(e)) if e.code == ErrorCode::UnknownSession)
}

fn read_reply(reply: Option<zenoh::query::Reply>, route: &Route, timeout: Duration) -> Result<ControlReply, Error> {
    let no_daemon = |detail: String| Error::NoDaemon { transport: Transport::Zenoh, detail };
    let reply = reply.ok_or_else(|| no_daemon(format!("no reply on {} at {} within {timeout:?}", route.control, route.endpoint)))?;
    match reply.result() {
        Ok(sample) => parse_reply(&sample.payload().to_bytes()),
        Err(e) => Err(no_daemon(format!("error reply: {}", String::from_utf8_lossy(&e.payload().to_bytes())))),
    }
}

/// Watches the liveliness of the daemon that serves the session of `info`.
fn watch_daemon(z: &zenoh::Session, info: &SessionInfo) -> Result<Subscriber<FifoChannelHandler<Sample>>, Error> {
    z.liveliness().declare_subscriber(daemon_key(info)).history(true).wait().map_err(|e| Error::zenoh("watching the daemon", e))
}

struct Channels {
    publisher: Publisher<'static>,
    replies: Subscriber<RingChannelHandler<Sample>>,
    _token: LivelinessToken,
}

impl Channels {
    /// Declares the session's keys; replies pass a gate (the daemon's tag under `secret`) before
    /// the newest-wins queue, so forged ones are counted in `forged` and can never push a
    /// genuine reply out: anyone can put on the contacts key.
    fn declare(z: &zenoh::Session, info: &SessionInfo, secret: Secret, forged: Arc<AtomicU64>) -> Result<Self, Error> {
        // The key the opened reply named (its last chunk comes from the secret).
        let token = z.liveliness().declare_token(info.alive.clone()).wait().map_err(|e| Error::zenoh("declaring the session's liveliness token", e))?;
        let (gate, handler) = tagged_queue(CONTACTS_QUEUE, secret, CONTACTS_HEADER_BYTES, move || {
            forged.fetch_add(1, Ordering::Relaxed);
        });
        let replies = z.declare_subscriber(info.contacts.clone()).with((gate, handler)).wait().map_err(|e| Error::zenoh("subscribing to contacts", e))?;
        let publisher = z.declare_publisher(info.frame.clone()).congestion_control(CONGESTION).express(true).wait().map_err(|e| Error::zenoh("declaring the frame publisher", e))?;
        Ok(Self { publisher, replies, _token: token })
    }
}

/// A session over zenoh (see [`crate::Session`]).
pub(crate) struct ZenohSession {
    z: zenoh::Session,
    route: Route,
    /// The daemon the user chose (`None`: the least loaded, chosen again at each reopen).
    pinned: Option<String>,
    request: ControlRequest,
    channels: Option<Channels>,
    daemon: Subscriber<FifoChannelHandler<Sample>>,
    state: Vec<f32>,
    written: bool,
    header: ContactsHeader,
    contacts: Vec<Contact>,
    pub(crate) info: SessionInfo,
    pub(crate) layout: StateLayout,
    pub(crate) frame_no: u64,
    pub(crate) reconnects: u64,
    /// The reply awaited: to the newest frame sent (older ones' are dropped, counted).
    pub(crate) awaited: crate::session::Awaited,
    /// The session's secret: tags frames, checks replies.
    secret: Secret,
    /// Messages on the contacts key without the daemon's tag, dropped (counted by the gate).
    pub(crate) forged: Arc<AtomicU64>,
    /// The daemon's base for delta frames, and how frames went out.
    pub(crate) deltas: crate::deltas::Deltas,
    /// An emulated link: its rate in bytes a second, and when it is free again.
    pub(crate) link: Option<(u64, Instant)>,
}

impl ZenohSession {
    fn new(z: zenoh::Session, route: Route, pinned: Option<String>, request: ControlRequest, info: SessionInfo) -> Result<Self, Error> {
        let daemon = watch_daemon(&z, &info)?;
        let secret = crate::control::secret(&info)?;
        let forged = Arc::new(AtomicU64::new(0));
        let channels = Channels::declare(&z, &info, secret.clone(), forged.clone())?;
        let layout = info.layout();
        Ok(Self {
            secret,
            forged,
            z,
            route,
            pinned,
            request,
            channels: Some(channels),
            daemon,
            state: vec![0.0; layout.floats],
            written: false,
            header: ContactsHeader::default(),
            contacts: Vec::with_capacity(info.max_contacts as usize),
            info,
            layout,
            frame_no: 0,
            reconnects: 0,
            awaited: Default::default(),
            deltas: crate::deltas::Deltas::new(true),
            link: None,
        })
    }

    /// Whether the daemon's liveliness token went away since the last look, even if it is back.
    ///
    /// Any `Delete` counts, not only the latest sample: when the link drops for a moment (seen
    /// with zenoh-link-tls 1.10.2, which can drop a fresh TLS link) zenoh reconnects by itself
    /// and the token comes back, but the daemon saw this client's token go too and ended the
    /// session. Reopening is then the only way to be answered again.
    fn daemon_left(&self) -> bool {
        let mut left = false;
        while let Ok(Some(s)) = self.daemon.try_recv() {
            left |= s.kind() == SampleKind::Delete;
        }
        left
    }

    /// Whether the daemon says it has no such session (asked only after a timeout).
    ///
    /// A link that drops and comes back at once, while the session is being set up, can end the
    /// session on the daemon before this client watches the daemon's token, so no `Delete` ever
    /// reaches it; its frames then go unanswered. Only a definite "unknown session" counts: a
    /// daemon that does not answer may just be busy, and its token says when it is gone.
    fn session_gone(&self) -> bool {
        unknown_session(request_on(&self.z, &self.route, &self.describe(), self.daemon_name(), CONTROL_WAIT))
    }

    /// The name of the daemon that serves the session (`None` for one that gives no name).
    fn daemon_name(&self) -> Option<&str> {
        Some(self.info.daemon.as_str()).filter(|n| !n.is_empty())
    }

    /// [`ZenohSession::session_gone`] for async code.
    async fn session_gone_async(&self) -> bool {
        unknown_session(request_on_async(&self.z, &self.route, &self.describe(), self.daemon_name(), CONTROL_WAIT).await)
    }

    /// Asks the daemon to free the session now (see [`crate::Session::close`]).
    pub(crate) fn close(mut self) -> Result<(), Error> {
        let session = self.info.session;
        if self.channels.take().is_none() {
            return Ok(());
        }
        crate::control::closed(request_on(&self.z, &self.route, &crate::control::close_request(&self.info), self.daemon_name(), crate::CONTROL_TIMEOUT), session)
    }

    fn describe(&self) -> ControlRequest {
        ControlRequest::Describe { session: self.info.session }
    }

    fn ensure_open(&mut self) -> Result<(), Error> {
        if self.channels.is_some() && self.daemon_left() {
            self.channels = None;
        }
        if self.channels.is_none() {
            // On the chosen daemon, or on the least loaded of those still there.
            let daemon = match &self.pinned {
                Some(name) => Some(name.clone()),
                None => least_loaded(&self.z, &self.route, CONTROL_WAIT).map_err(|_| Error::Disconnected)?,
            };
            let reply = request_on(&self.z, &self.route, &self.request, daemon.as_deref(), CONTROL_WAIT).map_err(|_| Error::Disconnected)?;
            let ControlReply::Opened(info) = reply else { return Err(Error::Disconnected) };
            if info.daemon != self.info.daemon {
                self.daemon = watch_daemon(&self.z, &info)?;
            }
            self.secret = crate::control::secret(&info)?;
            self.channels = Some(Channels::declare(&self.z, &info, self.secret.clone(), self.forged.clone())?);
            self.layout = info.layout();
            self.state.resize(self.layout.floats, 0.0);
            self.info = info;
            self.reconnects += 1;
            self.deltas.reset();
        }
        Ok(())
    }

    pub(crate) fn frame(&mut self) -> Result<&mut [f32], Error> {
        self.ensure_open()?;
        self.written = true;
        Ok(&mut self.state)
    }

    pub(crate) fn submit(&mut self, edit: impl FnOnce(&mut FrameHeader)) -> Result<u64, Error> {
        self.ensure_open()?;
        if !std::mem::take(&mut self.written) {
            return Err(Error::NoFrame);
        }
        let n = self.frame_no;
        let mut header = FrameHeader::new(self.info.session, n, now_ns(), self.layout.floats, self.layout.bodies.len());
        edit(&mut header);
        // zenoh owns what it sends: one buffer per frame, whole or a delta.
        let mut bytes = Vec::with_capacity(FRAME_HEADER_BYTES + 4 * self.state.len());
        self.deltas.write(&mut header, &self.state, &mut bytes).map_err(|e| Error::Protocol(format!("coding a delta frame: {e}")))?;
        // The tag proves the frame is the owner's (the daemon drops frames without it, and
        // frames whose number does not go up).
        let tag = self.secret.message_tag(&bytes[..FRAME_HEADER_BYTES], bytes.len());
        self.wait_for_link(bytes.len());
        self.channels.as_ref().expect("open").publisher.put(bytes).attachment(tag.to_vec()).wait().map_err(|e| Error::zenoh("sending the frame", e))?;
        self.awaited.sent(header.frame);
        self.frame_no += 1;
        Ok(n)
    }

    /// With an emulated link, waits until a message of `bytes` would have crossed it: a token
    /// bucket of one message, so back-to-back frames queue behind each other as on a real link.
    fn wait_for_link(&mut self, bytes: usize) {
        let Some((rate, free)) = &mut self.link else { return };
        let start = (*free).max(Instant::now());
        *free = start + Duration::from_secs_f64(bytes as f64 / *rate as f64);
        // Spun, not slept: a sleep would add the scheduler's wake-up to every frame.
        while Instant::now() < *free {
            std::hint::spin_loop();
        }
    }

    /// Notes a reply for the delta frames' base; whether it answers a frame older than the
    /// newest sent (dropped, counted).
    fn stale(deltas: &mut crate::deltas::Deltas, awaited: &mut crate::session::Awaited, sample: &Sample) -> bool {
        let (frame, status) = reply_frame(sample);
        deltas.answered(frame, status);
        awaited.stale(frame)
    }

    fn accept(&mut self, sample: Sample) -> Result<ContactsView<'_>, Error> {
        self.header = decode_contacts(&sample.payload().to_bytes(), &mut self.contacts).map_err(|e| Error::Protocol(e.to_string()))?;
        Ok(ContactsView { header: &self.header, contacts: &self.contacts })
    }

    pub(crate) fn try_contacts(&mut self) -> Result<Option<ContactsView<'_>>, Error> {
        let Some(ch) = self.channels.as_ref() else { return Err(Error::Disconnected) };
        loop {
            match ch.replies.try_recv() {
                Ok(Some(s)) if Self::stale(&mut self.deltas, &mut self.awaited, &s) => {}
                Ok(Some(s)) => return self.accept(s).map(Some),
                Ok(None) => return Ok(None),
                Err(e) => return Err(Error::zenoh("receiving contacts", e)),
            }
        }
    }

    pub(crate) fn contacts(&mut self, timeout: Duration) -> Result<ContactsView<'_>, Error> {
        let deadline = Instant::now() + timeout;
        loop {
            let Some(ch) = self.channels.as_ref() else { return Err(Error::Disconnected) };
            let left = deadline.saturating_duration_since(Instant::now());
            match ch.replies.recv_timeout(left.min(lumen_transport::shm::LIVENESS_PERIOD)) {
                Ok(Some(s)) if Self::stale(&mut self.deltas, &mut self.awaited, &s) => continue,
                Ok(Some(s)) => return self.accept(s),
                Ok(None) => {}
                Err(e) => return Err(Error::zenoh("receiving contacts", e)),
            }
            if self.daemon_left() {
                self.channels = None;
                return Err(Error::Disconnected);
            }
            if Instant::now() >= deadline {
                if self.session_gone() {
                    self.channels = None;
                    return Err(Error::Disconnected);
                }
                return Err(Error::Timeout(timeout));
            }
        }
    }

    pub(crate) async fn contacts_async(&mut self, timeout: Duration) -> Result<ContactsView<'_>, Error> {
        let deadline = tokio::time::Instant::now() + timeout;
        let Some(ch) = self.channels.as_ref() else { return Err(Error::Disconnected) };
        let next = loop {
            match tokio::time::timeout_at(deadline, ch.replies.recv_async()).await {
                Ok(Ok(s)) if Self::stale(&mut self.deltas, &mut self.awaited, &s) => {}
                other => break other,
            }
        };
        match next {
            Ok(Ok(s)) => self.accept(s),
            Ok(Err(e)) => Err(Error::zenoh("receiving contacts", e)),
            Err(_) => {
                // As `contacts`: a daemon that left, or no longer has the session, is `Disconnected`.
                if self.daemon_left() || self.session_gone_async().await {
                    self.channels = None;
                    return Err(Error::Disconnected);
                }
                Err(Error::Timeout(timeout))
            }
        }
    }
}

/// The frame number and status of a reply (bytes 16..24 and 6..8 of its header, read across
/// zenoh's fragments); `(u64::MAX, 0)` for a message too short to hold them (never stale:
/// decoding refuses it).
fn reply_frame(sample: &Sample) -> (u64, u16) {
    let mut head = [0u8; 24];
    if lumen_transport::net::fill_head(sample.payload().slices(), &mut head) < head.len() {
        return (u64::MAX, 0);
    }
    (u64::from_le_bytes(head[16..24].try_into().expect("8 bytes")), u16::from_le_bytes([head[6], head[7]]))
}

/// An observer over zenoh: a place taken with `observe`, and one ask at a time for the
/// session's newest frame and its reply (`proto/README.md`, section 4).
pub(crate) struct ZenohObserver {
    session: zenoh::Session,
    route: Route,
    /// `lumen/session/<id>/observe`.
    key: String,
    /// The place's token, 32 hex digits.
    token: String,
    /// The ask in flight and when it was sent: its answer (the frame and its reply, in one) comes
    /// on this channel.
    ask: Option<(FifoChannelHandler<Reply>, Instant)>,
    /// The newest frame number seen (asks want a newer one).
    after: Option<u64>,
    /// The daemon's reply that came with the last frame, not yet returned.
    reply: Option<Vec<u8>>,
    /// Liveliness of the daemon's token for the session and of the daemon: a `Delete` ends the
    /// session.
    ended: [Subscriber<FifoChannelHandler<Sample>>; 2],
    /// Whether one of them said so already.
    gone: bool,
    pub(crate) info: SessionInfo,
    frame_header: FrameHeader,
    state: Vec<f32>,
    header: ContactsHeader,
    contacts: Vec<Contact>,
}

/// How often a waiting observer looks whether its session ended.
const LIVENESS_PERIOD: Duration = Duration::from_millis(50);

impl ZenohObserver {
    pub(crate) fn next(&mut self, timeout: Duration) -> Result<Observed<'_>, Error> {
        // The reply that came with the frame returned last.
        if let Some(bytes) = self.reply.take() {
            self.header = decode_contacts(&bytes, &mut self.contacts).map_err(|e| Error::Protocol(e.to_string()))?;
            return Ok(Observed::Contacts(ContactsView { header: &self.header, contacts: &self.contacts }));
        }
        if self.gone {
            return Err(Error::SessionEnded(self.info.session));
        }
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if self.ask.is_none() {
                self.ask = Some((self.send_ask()?, Instant::now()));
            }
            let (ask, asked) = self.ask.as_ref().expect("an ask in flight");
            let reply = match ask.recv_timeout(left.min(LIVENESS_PERIOD)) {
                Ok(Some(reply)) => reply,
                waiting => {
                    // Nothing yet (`Ok(None)`), or the ask ended unanswered (`Err`: the daemon
                    // held it as long as it holds asks, or nothing serves the key): ask again,
                    // not at once if it ended at once, unless the session is gone or the time
                    // is up.
                    if waiting.is_err() {
                        let quick = asked.elapsed() < LIVENESS_PERIOD;
                        self.ask = None;
                        if quick {
                            std::thread::sleep(left.min(LIVENESS_PERIOD));
                        }
                    }
                    // Once ended, ended for good: every later call says so (as over iceoryx2).
                    self.gone |= self.ended.iter().any(|w| std::iter::from_fn(|| w.try_recv().ok().flatten()).any(|s| s.kind() == SampleKind::Delete));
                    if self.gone {
                        return Err(Error::SessionEnded(self.info.session));
                    }
                    if left <= LIVENESS_PERIOD {
                        return Err(Error::Timeout(timeout));
                    }
                    continue;
                }
            };
            let sample = match reply.result() {
                Ok(sample) => sample,
                Err(e) => match parse_reply(&e.payload().to_bytes())? {
                    // The place lapsed (no ask for a while): take one again.
                    ControlReply::Error(c) if c.code == ErrorCode::NotObserver => {
                        self.ask = None;
                        self.token = take_place(&self.session, &self.route, &self.info)?;
                        continue;
                    }
                    other => return Err(unexpected(other)),
                },
            };
            // The frame, then its reply, split where the attachment says.
            let bytes = sample.payload().to_bytes();
            let split = sample.attachment().map(|a| a.to_bytes()).and_then(|a| <[u8; 8]>::try_from(&a[..]).ok()).map(u64::from_le_bytes);
            let Some(split) = split.and_then(|n| usize::try_from(n).ok()).filter(|&n| n >= FRAME_HEADER_BYTES && n <= bytes.len()) else {
                return Err(Error::Protocol(format!("an observer's answer of {} bytes without the frame's length (8 bytes) as its attachment", bytes.len())));
            };
            let (frame, reply) = bytes.split_at(split);
            let h = FrameHeader::read(frame).map_err(|e| Error::Protocol(format!("the frame of an observer's answer: {e}")))?;
            self.state.clear();
            self.state.extend(frame[FRAME_HEADER_BYTES..].chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])));
            self.reply = Some(reply.to_vec());
            self.frame_header = h;
            self.after = Some(h.frame);
            // The ask is answered (one answer an ask). The next goes out now, while the caller
            // reads this frame: the daemon holds it until a newer frame exists and answers it
            // then, so the observer gets each newest frame within a round trip of its reply, at
            // up to the session's rate. (Asking only on the next call, after the answered ask
            // had ended, capped observers at about 20 frames a second.)
            self.ask = Some((self.send_ask()?, Instant::now()));
            return Ok(Observed::Frame { header: &self.frame_header, state: &self.state });
        }
    }

    /// Asks for a frame newer than the newest seen, with congestion control drop: on a
    /// congested link the answer is lost, not queued (the next ask gets a newer one).
    fn send_ask(&self) -> Result<FifoChannelHandler<Reply>, Error> {
        let mut selector = format!("{}?{OBSERVER_PARAMETER}={}", self.key, self.token);
        if let Some(a) = self.after {
            selector.push_str(&format!(";{AFTER_PARAMETER}={a}"));
        }
        self.session
            .get(selector)
            .congestion_control(OBSERVER_CONGESTION)
            .consolidation(ConsolidationMode::None)
            .timeout(ASK_HOLD + CONTROL_WAIT)
            .wait()
            .map_err(|e| Error::zenoh("asking for the newest frame", e))
    }
}

impl Drop for ZenohObserver {
    /// Gives the place back (if this ask is lost, the place lapses by itself).
    fn drop(&mut self) {
        let selector = format!("{}?{OBSERVER_PARAMETER}={};{END_PARAMETER}", self.key, self.token);
        let _ = self.session.get(selector).congestion_control(OBSERVER_CONGESTION).callback(|_| {}).wait();
    }
}

/// Takes an observer place of the session of `info` on the daemon that serves it; returns its
/// token.
fn take_place(session: &zenoh::Session, route: &Route, info: &SessionInfo) -> Result<String, Error> {
    match about_a_session(session, route, &ControlRequest::Observe { session: info.session }, crate::CONTROL_TIMEOUT)? {
        ControlReply::Observing { observer, .. } => Ok(observer),
        ControlReply::Error(e) if e.code == ErrorCode::ObserversFull => Err(Error::ObserversFull { session: info.session, max: info.max_observers }),
        other => Err(unexpected(other)),
    }
}

//! The daemon's iceoryx2 side: a control thread (request-response server woken by its event)
//! and one thread per session that sleeps in a WaitSet until the client's frame event, reads the
//! frame in place from shared memory, detects, and writes the reply into a loaned sample.

use crate::control::{self, Plan};
use crate::engine::Engine;
use crate::error::DaemonError;
use crate::registry::Registry;
use iceoryx2::identifiers::{UniqueClientId, UniqueNodeId, UniquePublisherId};
use iceoryx2::node::NodeView;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::request_response;
use lumen_proto::session::{ControlReply, Transport};
use lumen_proto::wire::{ContactsHeader, FrameHeader};
use lumen_proto::Contact;
use lumen_transport::names::CONTROL;
use lumen_transport::shm::{config, create_channel, node, service_name, ChannelQos, ContactsService, EventService, FrameService, Svc, DAEMON_FRAME_BUFFER, EVENT_PEER_DIED, EVENT_SENT};
use lumen_transport::TransportError;
use std::sync::mpsc;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How often threads look at the shutdown flag, clean up dead nodes and check their client.
pub const TICK: Duration = Duration::from_millis(100);
/// How often a session's thread looks whether it was asked to close: a close is answered once
/// the thread ended, so this bounds how long it takes (the tick's checks cost more).
pub const CLOSE_CHECK: Duration = Duration::from_millis(5);
/// How long a new session waits for its client's frame publisher before it is dropped.
pub const CONNECT_GRACE: Duration = Duration::from_secs(5);

/// The iceoryx2 transport of a running daemon.
pub struct Local {
    prefix: Option<String>,
    registry: Arc<Registry>,
}

fn iox(what: &str, e: impl std::error::Error + Send + Sync + 'static) -> DaemonError {
    TransportError::iceoryx2(what, e).into()
}

impl Local {
    pub fn new(prefix: Option<String>, registry: Arc<Registry>) -> Self {
        Self { prefix, registry }
    }

    /// Starts the control thread; returns once it serves (or why it cannot).
    pub fn start(self) -> Result<JoinHandle<()>, DaemonError> {
        let (tx, rx) = mpsc::channel();
        let handle = std::thread::Builder::new()
            .name("iox2-control".into())
            .spawn(move || {
                if let Err(e) = self.serve(&tx) {
                    tracing::error!("iceoryx2 control stopped: {e}");
                    let _ = tx.send(Err(e));
                }
            })
            .map_err(|source| DaemonError::Spawn { thread: "iceoryx2 control".into(), source })?;
        rx.recv().map_err(|_| DaemonError::Stopped("iceoryx2 control".into()))??;
        Ok(handle)
    }

    fn serve(self, ready: &mpsc::Sender<Result<(), DaemonError>>) -> Result<(), DaemonError> {
        let cfg = config(self.prefix.as_deref())?;
        let node = node(&cfg, "lumen-daemon")?;
        let cleaned = node.try_cleanup_dead_nodes();
        if cleaned.cleanups > 0 {
            tracing::info!("removed the shared memory of {} dead processes", cleaned.cleanups);
        }
        let name = service_name(CONTROL)?;
        let service =
            node.service_builder(&name).request_response::<[u8], [u8]>().max_clients(256).max_active_requests_per_client(1).open_or_create().map_err(|e| iox("creating the control service", e))?;
        // One daemon a prefix: a second would answer opens too, and each client would land on
        // whichever took its request. Dead daemons' servers went with the cleanup above.
        if service.dynamic_config().number_of_servers() > 0 {
            return Err(DaemonError::PrefixTaken(self.prefix.clone().unwrap_or_else(|| "iox2_".into())));
        }
        let server = service.server_builder().initial_max_slice_len(64 * 1024).allocation_strategy(AllocationStrategy::PowerOfTwo).create().map_err(|e| iox("creating the control server", e))?;
        let wake = node.service_builder(&name).event().max_notifiers(256).open_or_create().map_err(|e| iox("creating the control event", e))?;
        let listener = wake.listener_builder().create().map_err(|e| iox("creating the control listener", e))?;
        let waitset = WaitSetBuilder::new().signal_handling_mode(SignalHandlingMode::Disabled).create::<Svc>().map_err(|e| iox("creating a waitset", e))?;
        let on_request = waitset.attach_notification(&listener).map_err(|e| iox("attaching", e))?;
        let on_tick = waitset.attach_interval(TICK).map_err(|e| iox("attaching", e))?;
        let _ = ready.send(Ok(()));
        let mut sessions: Vec<JoinHandle<()>> = Vec::new();
        let result = waitset.wait_and_process(|id| {
            if id.has_event_from(&on_request) {
                let _ = listener.try_wait(|_| {});
            }
            // Requests are few: look at the server on every wake-up.
            loop {
                let request = match server.receive() {
                    Ok(Some(r)) => r,
                    Ok(None) => break,
                    Err(e) => {
                        tracing::warn!("control receive: {e:?}");
                        break;
                    }
                };
                let reply = match control::decode(request.payload()) {
                    Ok(req) => control::handle(&self.registry, Transport::Iceoryx2, &crate::access::Requester::Anyone, req, |plan| {
                        // Only a frame publisher of the opener's node is the session's client.
                        let opener = node_of_client(&service, request.origin());
                        let (h, r) = start_session(cfg.clone(), plan, opener, self.registry.clone())?;
                        sessions.push(h);
                        r
                    }),
                    Err(reply) => reply,
                };
                let bytes = serde_json::to_vec(&reply).expect("replies serialise");
                match request.loan_slice_uninit(bytes.len()) {
                    Ok(loan) => {
                        if let Err(e) = loan.write_from_slice(&bytes).send() {
                            tracing::warn!("control reply: {e:?}");
                        }
                    }
                    Err(e) => tracing::warn!("control reply loan: {e:?}"),
                }
                if let ControlReply::Error(e) = &reply {
                    tracing::info!("refused a control request: {}", e.message);
                }
            }
            if id.has_event_from(&on_tick) {
                // Frees the shared memory of clients that died; their sessions notice below.
                node.try_cleanup_dead_nodes();
                sessions.retain(|h| !h.is_finished());
            }
            if self.registry.stopping() {
                CallbackProgression::Stop
            } else {
                CallbackProgression::Continue
            }
        });
        for h in sessions {
            let _ = h.join();
        }
        result.map(|_| ()).map_err(|e| iox("control waitset", e))
    }
}

/// The node of the control client `client` (`None` if iceoryx2 no longer lists it).
fn node_of_client(service: &request_response::PortFactory<Svc, [u8], (), [u8], ()>, client: UniqueClientId) -> Option<UniqueNodeId> {
    let mut node = None;
    service.dynamic_config().list_clients(|d| {
        if d.client_id == client {
            node = Some(d.node_id);
            return CallbackProgression::Stop;
        }
        CallbackProgression::Continue
    });
    node
}

/// Starts a session's thread; the inner result says whether its channels were created.
/// `opener` is the node of the process that asked for the session (`None` if iceoryx2 no
/// longer lists its control client).
fn start_session(cfg: Config, plan: Plan, opener: Option<UniqueNodeId>, registry: Arc<Registry>) -> Result<(JoinHandle<()>, Result<(), DaemonError>), DaemonError> {
    let id = plan.entry.info.session;
    crate::registry::spawn_session("iox2-s", id, registry, move |registry, tx| run_session(&cfg, plan, opener, registry, tx))
}

/// A session's services and ports.
struct Channels {
    frames: FrameService,
    subscriber: iceoryx2::port::subscriber::Subscriber<Svc, [f32], FrameHeader>,
    listener: iceoryx2::port::listener::Listener<Svc>,
    publisher: iceoryx2::port::publisher::Publisher<Svc, [Contact], ContactsHeader>,
    notifier: iceoryx2::port::notifier::Notifier<Svc>,
    _events: (EventService, EventService, ContactsService),
    /// The node of the process that opened the session: its frame publisher is the client.
    /// Frames of any other publisher are dropped, counted and never answered. `None`: the
    /// opener could not be told (any publisher is the client, as before owners were checked).
    opener: Option<UniqueNodeId>,
    /// The publisher found to be the opener's, once seen.
    owner: std::cell::Cell<Option<UniquePublisherId>>,
}

impl Channels {
    fn create(node: &Node<Svc>, plan: &Plan, opener: Option<UniqueNodeId>, observers: usize) -> Result<Self, DaemonError> {
        let info = &plan.entry.info;
        let (frame_qos, contacts_qos) = (ChannelQos::frames(observers), ChannelQos::contacts(observers));
        let (frames, frame_events) = create_channel::<f32, FrameHeader>(node, &info.frame, "frame", frame_qos)?;
        let (contacts, contact_events) = create_channel::<Contact, ContactsHeader>(node, &info.contacts, "contacts", contacts_qos)?;
        let subscriber = frames.subscriber_builder().buffer_size(DAEMON_FRAME_BUFFER).create().map_err(|x| iox("subscribing to frames", x))?;
        let listener = frame_events.listener_builder().create().map_err(|x| iox("listening for frames", x))?;
        let publisher = contacts
            .publisher_builder()
            .initial_max_slice_len(info.max_contacts as usize)
            .allocation_strategy(AllocationStrategy::Static)
            .max_loaned_samples(1)
            .create()
            .map_err(|x| iox("creating the contacts publisher", x))?;
        let notifier = contact_events.notifier_builder().default_event_id(EVENT_SENT).create().map_err(|x| iox("creating the contacts notifier", x))?;
        Ok(Self { frames, subscriber, listener, publisher, notifier, _events: (frame_events, contact_events, contacts), opener, owner: std::cell::Cell::new(None) })
    }

    /// Whether `publisher` is the session's client: a publisher of the opener's node.
    fn is_owner(&self, publisher: UniquePublisherId) -> bool {
        let Some(opener) = self.opener else { return true };
        if self.owner.get() == Some(publisher) {
            return true;
        }
        let mut of_opener = false;
        self.frames.dynamic_config().list_publishers(|d| {
            if d.publisher_id == publisher {
                of_opener = d.node_id == opener;
                return CallbackProgression::Stop;
            }
            CallbackProgression::Continue
        });
        if of_opener {
            self.owner.set(Some(publisher));
        }
        of_opener
    }

    /// Answers the newest waiting frame, if any; returns whether there was one.
    fn serve(&self, engine: &mut Engine) -> bool {
        let received = Instant::now();
        let mut newest = None;
        let mut forged = 0;
        loop {
            match self.subscriber.receive() {
                // Each publisher has a queue of its own: another process's samples never push
                // the client's out, and are dropped here unanswered.
                Ok(Some(s)) if !self.is_owner(s.origin()) => forged += 1,
                Ok(Some(s)) => newest = Some(s),
                Ok(None) => break,
                Err(e) => {
                    tracing::warn!("session {}: receiving a frame: {e:?}", engine.id);
                    break;
                }
            }
        }
        if forged > 0 {
            engine.entry.count_forged(forged, "frame(s) published by a process other than its opener");
        }
        let Some(sample) = newest else { return false };
        // The frame is read where the client wrote it: no copy. A delta frame's bytes travel as
        // whole floats.
        let header = *sample.user_header();
        let (reply, contacts) = if header.is_delta() { engine.run_delta(header, bytemuck::cast_slice(sample.payload()), None) } else { engine.run(Ok((header, sample.payload()))) };
        let mut service = received.elapsed();
        match self.publisher.loan_slice_uninit(contacts.len()) {
            Ok(loan) => {
                let mut out = loan.write_from_slice(contacts);
                *out.user_header_mut() = reply;
                if let Err(e) = out.send() {
                    tracing::warn!("session {}: sending contacts: {e:?}", engine.id);
                }
                // Measured before the wake-up: the woken client may take this core at once.
                service = received.elapsed();
                if let Err(e) = self.notifier.notify() {
                    tracing::warn!("session {}: notifying: {e:?}", engine.id);
                }
            }
            Err(e) => tracing::warn!("session {}: no shared memory for the reply: {e:?}", engine.id),
        }
        drop(sample);
        engine.record(&reply, service);
        true
    }

    /// Where the session's client stands: its frame publisher and the state of its process.
    ///
    /// A client killed with `kill -9` leaves its publisher registered until someone removes its
    /// dead node. The control thread tries that every tick, but a removal can fail for a while
    /// (another process or thread may be cleaning at the same moment), so the session does not
    /// wait for it: it asks for the publisher's node state itself and, when the node is dead,
    /// removes its resources (best effort) and reports the client dead.
    fn client(&self) -> ClientState {
        let mut publisher_node = None;
        self.frames.dynamic_config().list_publishers(|d| {
            if self.opener.is_none_or(|o| o == d.node_id) {
                publisher_node = Some(d.node_id);
                return CallbackProgression::Stop;
            }
            CallbackProgression::Continue
        });
        let Some(client) = publisher_node else { return ClientState::Absent };
        let mut dead = None;
        let _ = self.frames.nodes(|state| match state {
            NodeState::Dead(view) if *view.id() == client => {
                dead = Some(view);
                CallbackProgression::Stop
            }
            _ => CallbackProgression::Continue,
        });
        match dead {
            Some(view) => {
                if let Err(e) = view.try_remove_stale_resources() {
                    tracing::debug!("the dead client's resources are left to the next cleanup: {e:?}");
                }
                ClientState::Dead
            }
            None => ClientState::Present,
        }
    }

    /// Whether the process that opened the session is gone: its node dead, or no longer listed
    /// (the control thread removes dead nodes every tick). A client killed right after it
    /// opened, before any tick saw its frame publisher, leaves nothing else behind: without
    /// this look its session waited out [`CONNECT_GRACE`]. An opener that could not be told, or
    /// a list that cannot be read: not gone.
    fn opener_gone(&self, cfg: &Config) -> bool {
        let Some(opener) = self.opener else { return false };
        let mut listed = false;
        let read = Node::<Svc>::list(cfg, |state| {
            let id = match &state {
                NodeState::Alive(view) => *view.id(),
                NodeState::Inaccessible(id) | NodeState::Undefined(id) => *id,
                NodeState::Dead(_) => return CallbackProgression::Continue,
            };
            listed |= id == opener;
            if listed {
                CallbackProgression::Stop
            } else {
                CallbackProgression::Continue
            }
        });
        read.is_ok() && !listed
    }
}

/// What a session's tick sees of its client.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ClientState {
    /// No frame publisher: not attached yet, or gone and already cleaned up.
    Absent,
    /// A frame publisher whose process is alive (or not known to be dead).
    Present,
    /// A frame publisher whose process died.
    Dead,
}

fn run_session(cfg: &Config, plan: Plan, opener: Option<UniqueNodeId>, registry: &Registry, ready: &mpsc::Sender<Result<(), DaemonError>>) -> Result<&'static str, DaemonError> {
    let id = plan.entry.info.session;
    let node = node(cfg, &format!("lumen-session-{id}"))?;
    let channels = Channels::create(&node, &plan, opener, registry.limits.max_observers)?;
    let mut engine = Engine::new(plan.entry.clone(), plan.echo);
    let waitset = WaitSetBuilder::new().signal_handling_mode(SignalHandlingMode::Disabled).create::<Svc>().map_err(|e| iox("creating a waitset", e))?;
    let on_frame = waitset.attach_notification(&channels.listener).map_err(|e| iox("attaching", e))?;
    let on_tick = waitset.attach_interval(TICK).map_err(|e| iox("attaching", e))?;
    let on_close_check = waitset.attach_interval(CLOSE_CHECK).map_err(|e| iox("attaching", e))?;
    let _ = ready.send(Ok(()));
    let opened = Instant::now();
    // Whether a client ever attached. Its frame publisher or a frame proves it, and so does
    // the peer-died event: a client can attach, send frames and be killed before the first
    // tick, and be cleaned up (by this daemon or by any other process of the prefix) before
    // the tick looks, so "no publisher" alone cannot tell "not yet" from "gone".
    let mut attached = false;
    let mut why = "daemon stopping";
    waitset
        .wait_and_process(|wake| {
            let mut peer_died = false;
            if wake.has_event_from(&on_frame) {
                let _ = channels.listener.try_wait(|e| peer_died |= e.id == EVENT_PEER_DIED);
                attached |= channels.serve(&mut engine);
            }
            if wake.has_event_from(&on_close_check) && plan.entry.close.load(std::sync::atomic::Ordering::SeqCst) {
                why = "closed on request";
                return CallbackProgression::Stop;
            }
            if peer_died || wake.has_event_from(&on_tick) {
                engine.tick();
                // Any process may notify the frame event, "a peer died" too: the client's own
                // publisher and process say whether it is gone.
                let client = channels.client();
                match client {
                    ClientState::Present => attached = true,
                    ClientState::Dead => {
                        why = "its client died";
                        return CallbackProgression::Stop;
                    }
                    ClientState::Absent if attached => {
                        why = "its client left";
                        return CallbackProgression::Stop;
                    }
                    ClientState::Absent if opened.elapsed() > CONNECT_GRACE => {
                        why = "no client attached in time";
                        return CallbackProgression::Stop;
                    }
                    ClientState::Absent if channels.opener_gone(cfg) => {
                        why = "its client died before it attached";
                        return CallbackProgression::Stop;
                    }
                    ClientState::Absent => {}
                }
                if plan.entry.close.load(std::sync::atomic::Ordering::SeqCst) {
                    why = "closed on request";
                    return CallbackProgression::Stop;
                }
                if registry.stopping() {
                    return CallbackProgression::Stop;
                }
            }
            CallbackProgression::Continue
        })
        .map_err(|e| iox("session waitset", e))?;
    Ok(why)
}

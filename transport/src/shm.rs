//! iceoryx2 on one machine: the service flavour, the shapes and QoS of a session's two
//! channels, the event ids, and node and configuration helpers.
//!
//! The daemon creates every session's services ([`create_channel`], sized from the spec);
//! clients and observers open them ([`open_frame`], [`open_contacts`]). Each publish-subscribe
//! service has an event service of the same name: [`EVENT_SENT`] after each sample, and
//! [`EVENT_PEER_DIED`] when iceoryx2 cleans up a dead process's notifier.

use crate::TransportError;
use iceoryx2::prelude::*;
use iceoryx2::service::builder::event::EventOpenError;
use iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenError;
use iceoryx2::service::port_factory::{event, publish_subscribe, request_response};
use lumen_proto::wire::{ContactsHeader, FrameHeader};
use lumen_proto::Contact;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The iceoryx2 service flavour used throughout (inter-process, ports bound to their thread).
pub type Svc = ipc::Service;
/// A session's frame service: user header [`FrameHeader`], payload `[f32]`.
pub type FrameService = publish_subscribe::PortFactory<Svc, [f32], FrameHeader>;
/// A session's contacts service: user header [`ContactsHeader`], payload `[Contact]`.
pub type ContactsService = publish_subscribe::PortFactory<Svc, [Contact], ContactsHeader>;
/// An event service (paired with each publish-subscribe service, same name).
pub type EventService = event::PortFactory<Svc>;
/// The control service: JSON bytes both ways.
pub type ControlService = request_response::PortFactory<Svc, [u8], (), [u8], ()>;
/// A publish-subscribe service of `[T]` slices with header `H`, and its event service.
pub type Channel<T, H> = (publish_subscribe::PortFactory<Svc, [T], H>, EventService);

/// Event sent after each frame / reply / control request.
pub const EVENT_SENT: EventId = EventId::new(0);
/// Event iceoryx2 raises when the notifier of a dead process is cleaned up.
pub const EVENT_PEER_DIED: EventId = EventId::new(1);
/// How often a blocked wait looks whether the other side died.
pub const LIVENESS_PERIOD: Duration = Duration::from_millis(200);

/// Frames kept per observer (the service's subscriber buffer): an observer that falls up to
/// this many frames behind (a recorder descheduled for a few milliseconds of a 1 kHz session)
/// still gets every frame; past it the oldest is dropped, never the client slowed. 16: with 8
/// the recorder of an unpaced `lumen demo` on two cores lost 1 or 2 frames in 3 runs of 20,
/// with 16 none in 40; a session's shared memory grows with it (`docs/measurements.md`).
pub const FRAME_BUFFER: usize = 16;
/// Frames the daemon's own subscriber keeps: one, so that it always answers the newest frame.
pub const DAEMON_FRAME_BUFFER: usize = 1;
/// Frames one subscriber may hold at once: the newest, and the next while draining to it.
pub const FRAME_BORROWED: usize = 2;
/// Replies kept per subscriber (the client and each observer), as deep as the frames.
pub const CONTACTS_BUFFER: usize = 16;
/// Replies one subscriber may hold at once.
pub const CONTACTS_BORROWED: usize = 2;

/// The QoS of one of a session's channels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ChannelQos {
    /// Publishers (and notifiers of the event service): the frame channel admits the client's
    /// and [`SPARE_PUBLISHERS`] more, so no other process can take the client's place by
    /// creating one first (the daemon answers only the opener's; `lumen-service`'s `local`).
    pub publishers: usize,
    /// Subscribers: the session's other side and every observer.
    pub subscribers: usize,
    /// Samples kept per subscriber, at most (the service's subscriber buffer).
    pub buffer: usize,
    /// Samples a subscriber may hold at once.
    pub borrowed: usize,
}

impl ChannelQos {
    /// The frame channel of a session with `observers` observers.
    pub fn frames(observers: usize) -> Self {
        Self { publishers: 1 + SPARE_PUBLISHERS, subscribers: 1 + observers, buffer: FRAME_BUFFER, borrowed: FRAME_BORROWED }
    }

    /// The contacts channel of a session with `observers` observers.
    pub fn contacts(observers: usize) -> Self {
        Self { publishers: 1, subscribers: 1 + observers, buffer: CONTACTS_BUFFER, borrowed: CONTACTS_BORROWED }
    }

    /// Samples the publisher's segment must hold: every subscriber's buffer and borrowed
    /// samples, plus the publisher's one loan.
    pub fn segment_samples(&self) -> usize {
        self.subscribers * (self.buffer + self.borrowed) + 1
    }
}

fn iox(what: impl Into<String>, e: impl std::error::Error + Send + Sync + 'static) -> TransportError {
    TransportError::iceoryx2(what, e)
}

/// An iceoryx2 configuration with `prefix` (default settings otherwise; no config file is read).
pub fn config(prefix: Option<&str>) -> Result<Config, TransportError> {
    let mut c = Config::default();
    if let Some(p) = prefix {
        c.global.prefix = FileName::new(p.as_bytes()).map_err(|e| iox(format!("prefix {p:?} is not a valid file name prefix"), e))?;
    }
    Ok(c)
}

/// A node that leaves signals alone (the daemon handles them itself; a library must not).
pub fn node(config: &Config, name: &str) -> Result<Node<Svc>, TransportError> {
    let name = NodeName::new(name).map_err(|e| iox(format!("node name {name:?}"), e))?;
    NodeBuilder::new().config(config).name(&name).signal_handling_mode(SignalHandlingMode::Disabled).create::<Svc>().map_err(|e| iox("creating the iceoryx2 node", e))
}

/// A service name, checked.
pub fn service_name(name: &str) -> Result<ServiceName, TransportError> {
    ServiceName::new(name).map_err(|e| iox(format!("service name {name:?}"), e))
}

/// A service that admits no more nodes is [`TransportError::Full`]; other failures keep their
/// source.
fn open_error(what: &str, e: PublishSubscribeOpenError) -> TransportError {
    match e {
        PublishSubscribeOpenError::ExceedsMaxNumberOfNodes => TransportError::Full { what: what.into() },
        e => iox(what, e),
    }
}

/// [`open_error`] for event services.
fn event_open_error(what: &str, e: EventOpenError) -> TransportError {
    match e {
        EventOpenError::ExceedsMaxNumberOfNodes => TransportError::Full { what: what.into() },
        e => iox(what, e),
    }
}

/// Processes beyond the client and its observers that may hold a session's services open
/// without a port (a process that only opens them, as a tool listing services does): iceoryx2
/// counts every opener against `max_nodes`, so without room for them five such processes once
/// locked the session's own client out.
pub const SPARE_NODES: usize = 32;

/// Frame publishers beyond the client's a session's frame channel admits (see
/// [`ChannelQos::publishers`]).
pub const SPARE_PUBLISHERS: usize = 8;

/// Opens a session's frame service and its event service.
pub fn open_frame(node: &Node<Svc>, name: &str) -> Result<(FrameService, EventService), TransportError> {
    let n = service_name(name)?;
    let ps = node.service_builder(&n).publish_subscribe::<[f32]>().user_header::<FrameHeader>().open().map_err(|e| open_error("opening the frame service", e))?;
    let ev = node.service_builder(&n).event().open().map_err(|e| event_open_error("opening the frame event", e))?;
    Ok((ps, ev))
}

/// Opens a session's contacts service and its event service.
pub fn open_contacts(node: &Node<Svc>, name: &str) -> Result<(ContactsService, EventService), TransportError> {
    let n = service_name(name)?;
    let ps = node.service_builder(&n).publish_subscribe::<[Contact]>().user_header::<ContactsHeader>().open().map_err(|e| open_error("opening the contacts service", e))?;
    let ev = node.service_builder(&n).event().open().map_err(|e| event_open_error("opening the contacts event", e))?;
    Ok((ps, ev))
}

/// Creates one of a session's two channels (the daemon's side): a publish-subscribe service of
/// `[T]` slices with header `H` (one publisher; the newest sample wins when a subscriber falls
/// behind) and its event service, which also tells when a peer dies. `what` names the channel
/// in errors.
pub fn create_channel<T, H>(node: &Node<Svc>, name: &str, what: &str, qos: ChannelQos) -> Result<Channel<T, H>, TransportError>
where
    T: std::fmt::Debug + ZeroCopySend,
    H: std::fmt::Debug + ZeroCopySend,
{
    let name = service_name(name)?;
    let data = node
        .service_builder(&name)
        .publish_subscribe::<[T]>()
        .user_header::<H>()
        .max_publishers(qos.publishers)
        .max_subscribers(qos.subscribers)
        .subscriber_max_buffer_size(qos.buffer)
        .subscriber_max_borrowed_samples(qos.borrowed)
        .history_size(0)
        .enable_safe_overflow(true)
        .max_nodes(qos.subscribers + 1 + SPARE_NODES)
        .create()
        .map_err(|e| iox(format!("creating the {what} service"), e))?;
    let events = node
        .service_builder(&name)
        .event()
        .max_notifiers(qos.publishers)
        .max_listeners(qos.subscribers)
        .max_nodes(qos.subscribers + 1 + SPARE_NODES)
        .notifier_dead_event(EVENT_PEER_DIED)
        .create()
        .map_err(|e| iox(format!("creating the {what} event"), e))?;
    Ok((data, events))
}

/// Files in `/dev/shm` of iceoryx2 prefix `prefix`.
pub fn shm_files(prefix: &str) -> Vec<String> {
    entries_starting(Path::new("/dev/shm"), prefix)
}

fn entries_starting(dir: &Path, prefix: &str) -> Vec<String> {
    std::fs::read_dir(dir).map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).filter(|n| n.starts_with(prefix)).collect()).unwrap_or_default()
}

/// Removes everything iceoryx2 prefix `prefix` left behind, once every process that used it
/// has exited: its files in `/dev/shm` (the per-prefix node counter, which iceoryx2 never
/// removes itself, and whatever a process killed without cleaning up left there) and its
/// service and node entries under iceoryx2's root directory. Only for a private prefix (one
/// run's, one benchmark's): processes still using it would lose their shared memory. Returns
/// what could not be removed.
pub fn remove_prefix(prefix: &str) -> Vec<String> {
    let mut failed = Vec::new();
    let mut remove = |path: PathBuf| {
        let r = if path.is_dir() { std::fs::remove_dir_all(&path) } else { std::fs::remove_file(&path) };
        if let Err(e) = r {
            if e.kind() != std::io::ErrorKind::NotFound {
                failed.push(format!("{}: {e}", path.display()));
            }
        }
    };
    let shm = Path::new("/dev/shm");
    for f in shm_files(prefix) {
        remove(shm.join(f));
    }
    if let Ok(cfg) = config(Some(prefix)) {
        let services = PathBuf::from(cfg.global.service_dir().to_string());
        for f in entries_starting(&services, prefix) {
            remove(services.join(f));
        }
        // Node entries are directories named by node id holding files named with the prefix.
        let nodes = PathBuf::from(cfg.global.node_dir().to_string());
        for f in entries_starting(&nodes, prefix) {
            remove(nodes.join(f));
        }
        if let Ok(dirs) = std::fs::read_dir(&nodes) {
            for d in dirs.filter_map(|e| e.ok()).map(|e| e.path()).filter(|p| p.is_dir()) {
                let mine = entries_starting(&d, prefix);
                if mine.is_empty() {
                    continue;
                }
                for f in &mine {
                    remove(d.join(f));
                }
                // The node's directory goes once it is empty (another prefix may share it).
                let _ = std::fs::remove_dir(&d);
            }
        }
    }
    failed
}

//! The iceoryx2 transport: shared memory on this machine, woken by events, never polled.
//!
//! The daemon creates every session's services (sized from the spec); clients and observers
//! open them with the shapes, event ids and helpers of [`lumen_transport::shm`].

use crate::control::{parse_reply, CONTROL_WAIT};
use crate::view::ContactsView;
use crate::{now_ns, Error};
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::sample::Sample;
use iceoryx2::sample_mut::SampleMut;
use lumen_proto::session::{ControlReply, ControlRequest, SessionInfo, Transport};
use lumen_proto::wire::{ContactsHeader, FrameHeader};
use lumen_proto::{Contact, StateLayout};
use lumen_transport::names::CONTROL;
use lumen_transport::shm::{config, node, open_contacts, open_frame, service_name, ContactsService, Svc, EVENT_PEER_DIED, EVENT_SENT, LIVENESS_PERIOD};
use std::rc::Rc;
use std::time::{Duration, Instant};

/// Waits until `listener` fires or `timeout` passes; returns whether a peer died.
fn wait(listener: &Listener<Svc>, timeout: Duration) -> Result<bool, Error> {
    let mut died = false;
    listener.timed_wait(|e| died |= e.id == EVENT_PEER_DIED, timeout).map_err(|e| Error::iox("waiting for an event", e))?;
    Ok(died)
}

/// The control channel seen from a client: one request, one reply.
#[derive(Clone)]
pub struct Control {
    node: Rc<Node<Svc>>,
}

impl Control {
    /// Sends `request` and waits up to `timeout` for the reply.
    pub fn request(&self, request: &ControlRequest, timeout: Duration) -> Result<ControlReply, Error> {
        let no_daemon = |detail: String| Error::NoDaemon { transport: Transport::Iceoryx2, detail };
        // Stale services of a daemon that died would swallow the request: clean them first.
        self.node.try_cleanup_dead_nodes();
        let name = service_name(CONTROL)?;
        let service = self.node.service_builder(&name).request_response::<[u8], [u8]>().open().map_err(|e| no_daemon(format!("service {CONTROL}: {e:?}")))?;
        let wake = self.node.service_builder(&name).event().open().map_err(|e| no_daemon(format!("event {CONTROL}: {e:?}")))?;
        let json = serde_json::to_vec(request).expect("control requests serialise");
        let client =
            service.client_builder().initial_max_slice_len(json.len()).allocation_strategy(AllocationStrategy::Static).create().map_err(|e| Error::iox("creating a control client port", e))?;
        let loan = client.loan_slice_uninit(json.len()).map_err(|e| Error::iox("loaning a control request", e))?;
        let pending = loan.write_from_slice(&json).send().map_err(|e| Error::iox("sending a control request", e))?;
        let notifier = wake.notifier_builder().default_event_id(EVENT_SENT).create().map_err(|e| Error::iox("creating a control notifier", e))?;
        notifier.notify().map_err(|e| Error::iox("waking the daemon", e))?;
        let start = Instant::now();
        loop {
            // Control traffic is rare and small: a short sleep between looks is enough.
            if let Some(response) = pending.receive().map_err(|e| Error::iox("receiving a control reply", e))? {
                return parse_reply(response.payload());
            }
            if start.elapsed() > timeout {
                return Err(no_daemon(format!("no reply on {CONTROL} within {timeout:?}")));
            }
            std::thread::sleep(Duration::from_micros(200));
        }
    }
}

/// A local client: one iceoryx2 node.
pub struct LocalClient {
    control: Control,
}

impl LocalClient {
    /// A client with iceoryx2 `prefix` (must match the daemon's).
    pub fn new(prefix: Option<&str>) -> Result<Self, Error> {
        let cfg = config(prefix)?;
        let node = node(&cfg, &format!("lumen-client-{}", std::process::id()))?;
        Ok(Self { control: Control { node: Rc::new(node) } })
    }

    /// The control channel.
    pub fn control(&self) -> &Control {
        &self.control
    }

    pub(crate) fn open(&self, request: ControlRequest) -> Result<LocalSession, Error> {
        let info = match self.control.request(&request, crate::CONTROL_TIMEOUT)? {
            ControlReply::Opened(info) => info,
            ControlReply::Error(e) => return Err(Error::Refused(e)),
            other => return Err(crate::control::unexpected(other)),
        };
        let ports = SessionPorts::attach(&self.control.node, &info)?;
        Ok(LocalSession::new(self.control.clone(), request, info, ports))
    }

    pub(crate) fn observe(&self, info: SessionInfo) -> Result<LocalObserver, Error> {
        LocalObserver::new(&self.control.node, info)
    }
}

struct SessionPorts {
    contacts: ContactsService,
    publisher: Publisher<Svc, [f32], FrameHeader>,
    notifier: Notifier<Svc>,
    subscriber: Subscriber<Svc, [Contact], ContactsHeader>,
    listener: Listener<Svc>,
}

impl SessionPorts {
    fn attach(node: &Node<Svc>, info: &SessionInfo) -> Result<Self, Error> {
        let (frame, frame_event) = open_frame(node, &info.frame)?;
        let (contacts, contacts_event) = open_contacts(node, &info.contacts)?;
        let publisher = frame
            .publisher_builder()
            .initial_max_slice_len(info.floats as usize)
            .allocation_strategy(AllocationStrategy::Static)
            .max_loaned_samples(1)
            .create()
            .map_err(|e| Error::iox("creating the frame publisher", e))?;
        let notifier = frame_event.notifier_builder().default_event_id(EVENT_SENT).create().map_err(|e| Error::iox("creating the frame notifier", e))?;
        let subscriber = contacts.subscriber_builder().create().map_err(|e| Error::iox("creating the contacts subscriber", e))?;
        let listener = contacts_event.listener_builder().create().map_err(|e| Error::iox("creating the contacts listener", e))?;
        Ok(Self { contacts, publisher, notifier, subscriber, listener })
    }
}

/// The ports of a session the daemon lost, with the frame that was being written: kept, not
/// dropped, until the session is, so memory lent out through [`crate::Session::frame`] (a
/// foreign binding may hold on to it, as Python's NumPy arrays do) stays mapped. One per
/// reconnection.
struct Retired {
    // The sample first: it is dropped before the publisher it came from.
    _loan: Option<SampleMut<Svc, [f32], FrameHeader>>,
    _ports: SessionPorts,
}

/// A session over iceoryx2 (see [`crate::Session`]).
pub(crate) struct LocalSession {
    // Samples first: they are dropped before the ports they came from.
    loan: Option<SampleMut<Svc, [f32], FrameHeader>>,
    last: Option<Sample<Svc, [Contact], ContactsHeader>>,
    ports: Option<SessionPorts>,
    retired: Vec<Retired>,
    control: Control,
    request: ControlRequest,
    pub(crate) info: SessionInfo,
    pub(crate) layout: StateLayout,
    pub(crate) frame_no: u64,
    pub(crate) reconnects: u64,
    pub(crate) awaited: crate::session::Awaited,
}

impl LocalSession {
    fn new(control: Control, request: ControlRequest, info: SessionInfo, ports: SessionPorts) -> Self {
        let layout = info.layout();
        Self { loan: None, last: None, ports: Some(ports), retired: Vec::new(), control, request, info, layout, frame_no: 0, reconnects: 0, awaited: Default::default() }
    }

    /// Reopens the session after the daemon went away, if one answers now.
    fn ensure_open(&mut self) -> Result<&SessionPorts, Error> {
        if self.ports.is_none() {
            let reply = self.control.request(&self.request, CONTROL_WAIT).map_err(|_| Error::Disconnected)?;
            let ControlReply::Opened(info) = reply else { return Err(Error::Disconnected) };
            let ports = SessionPorts::attach(&self.control.node, &info)?;
            self.layout = info.layout();
            self.info = info;
            self.ports = Some(ports);
            self.reconnects += 1;
        }
        Ok(self.ports.as_ref().expect("just opened"))
    }

    /// Asks the daemon to free the session now (see [`crate::Session::close`]).
    pub(crate) fn close(mut self) -> Result<(), Error> {
        let session = self.info.session;
        let request = crate::control::close_request(&self.info);
        let open = self.ports.is_some();
        // Ports first: the daemon may free the slot as soon as it answers.
        self.loan = None;
        self.last = None;
        self.ports = None;
        if !open {
            return Ok(());
        }
        crate::control::closed(self.control.request(&request, crate::CONTROL_TIMEOUT), session)
    }

    fn lose(&mut self) -> Error {
        self.last = None;
        if let Some(ports) = self.ports.take() {
            self.retired.push(Retired { _loan: self.loan.take(), _ports: ports });
        }
        self.loan = None;
        Error::Disconnected
    }

    /// Whether the daemon's side of the session is gone (daemon dead or session freed).
    fn daemon_gone(&self) -> bool {
        self.control.node.try_cleanup_dead_nodes();
        self.ports.as_ref().is_none_or(|p| p.contacts.dynamic_config().number_of_publishers() == 0)
    }

    pub(crate) fn frame(&mut self) -> Result<&mut [f32], Error> {
        self.ensure_open()?;
        if self.loan.is_none() {
            let ports = self.ports.as_ref().expect("open");
            let uninit = ports.publisher.loan_slice_uninit(self.info.floats as usize).map_err(|e| Error::iox("loaning a frame", e))?;
            // SAFETY: every bit pattern is a valid f32, and the publisher's shared-memory
            // segment is zero-filled when it is created and only ever holds f32 frames, so each
            // byte is initialised (with an earlier frame's data until the caller overwrites it).
            self.loan = Some(unsafe { uninit.assume_init() });
        }
        Ok(self.loan.as_mut().expect("loaned").payload_mut())
    }

    pub(crate) fn submit(&mut self, edit: impl FnOnce(&mut FrameHeader)) -> Result<u64, Error> {
        self.ensure_open()?;
        let mut sample = self.loan.take().ok_or(Error::NoFrame)?;
        let n = self.frame_no;
        let mut header = FrameHeader::new(self.info.session, n, now_ns(), self.layout.floats, self.layout.bodies.len());
        edit(&mut header);
        *sample.user_header_mut() = header;
        sample.send().map_err(|e| Error::iox("sending the frame", e))?;
        self.awaited.sent(header.frame);
        self.ports.as_ref().expect("open").notifier.notify().map_err(|e| Error::iox("notifying the daemon", e))?;
        self.frame_no += 1;
        Ok(n)
    }

    pub(crate) fn try_contacts(&mut self) -> Result<Option<ContactsView<'_>>, Error> {
        let Some(ports) = self.ports.as_ref() else { return Err(Error::Disconnected) };
        self.last = loop {
            match ports.subscriber.receive().map_err(|e| Error::iox("receiving contacts", e))? {
                Some(s) if self.awaited.stale(s.user_header().frame) => {}
                other => break other,
            }
        };
        Ok(self.last.as_ref().map(|s| ContactsView { header: s.user_header(), contacts: s.payload() }))
    }

    pub(crate) fn contacts(&mut self, timeout: Duration) -> Result<ContactsView<'_>, Error> {
        let start = Instant::now();
        let deadline = start + timeout;
        let mut last_check = start;
        self.last = None;
        loop {
            let Some(ports) = self.ports.as_ref() else { return Err(Error::Disconnected) };
            if let Some(s) = ports.subscriber.receive().map_err(|e| Error::iox("receiving contacts", e))? {
                if self.awaited.stale(s.user_header().frame) {
                    continue;
                }
                let s = self.last.insert(s);
                return Ok(ContactsView { header: s.user_header(), contacts: s.payload() });
            }
            let now = Instant::now();
            let left = deadline.saturating_duration_since(now);
            let died = !left.is_zero() && wait(&ports.listener, left.min(LIVENESS_PERIOD))?;
            if ports.subscriber.has_samples().unwrap_or(false) {
                continue;
            }
            // Nothing arrived: look whether the daemon is still there, at most every period.
            if died || left.is_zero() || last_check.elapsed() >= LIVENESS_PERIOD {
                last_check = Instant::now();
                if self.daemon_gone() {
                    return Err(self.lose());
                }
            }
            if left.is_zero() {
                return Err(Error::Timeout(timeout));
            }
        }
    }
}

impl LocalSession {
    /// [`LocalSession::contacts`] for async code: the contacts listener's file descriptor is
    /// awaited through tokio's reactor (no polling, no thread blocked).
    pub(crate) async fn contacts_async(&mut self, timeout: Duration) -> Result<ContactsView<'_>, Error> {
        let deadline = tokio::time::Instant::now() + timeout;
        self.last = None;
        let Some(ports) = self.ports.as_ref() else { return Err(Error::Disconnected) };
        if tokio::runtime::Handle::try_current().is_err() {
            return Err(Error::NoRuntime);
        }
        // SAFETY (both): the descriptor belongs to the session's listener, which stays open and
        // the same until `fd` is dropped (the ports are replaced only through `&mut self`, which
        // this call holds, and `fd` is dropped before `lose` closes them).
        let fd = ListenerFd(unsafe { ports.listener.file_descriptor().native_handle() });
        let fd = unsafe { tokio::io::unix::AsyncFd::register_with_interest(fd, tokio::io::Interest::READABLE) }.map_err(|e| Error::iox("watching the contacts event", e))?;
        loop {
            let Some(ports) = self.ports.as_ref() else { return Err(Error::Disconnected) };
            // Consume the wake-ups first: a reply sent after the look below brings a new one.
            let mut died = false;
            ports.listener.try_wait(|e| died |= e.id == EVENT_PEER_DIED).map_err(|e| Error::iox("consuming contacts events", e))?;
            if let Some(s) = ports.subscriber.receive().map_err(|e| Error::iox("receiving contacts", e))? {
                if self.awaited.stale(s.user_header().frame) {
                    continue;
                }
                let s = self.last.insert(s);
                return Ok(ContactsView { header: s.user_header(), contacts: s.payload() });
            }
            let left = deadline.saturating_duration_since(tokio::time::Instant::now());
            let woke = !left.is_zero() && !died && tokio::time::timeout(left.min(LIVENESS_PERIOD), fd.readable()).await.is_ok_and(|r| r.map(|mut g| g.clear_ready()).is_ok());
            if !woke {
                if self.daemon_gone() {
                    drop(fd); // deregistered before `lose` closes the descriptor
                    return Err(self.lose());
                }
                if deadline <= tokio::time::Instant::now() {
                    return Err(Error::Timeout(timeout));
                }
            }
        }
    }
}

/// A listener's descriptor, lent to tokio's reactor for the length of one wait.
#[derive(Debug)]
struct ListenerFd(std::os::fd::RawFd);

impl std::os::fd::AsRawFd for ListenerFd {
    fn as_raw_fd(&self) -> std::os::fd::RawFd {
        self.0
    }
}

/// An observer over iceoryx2.
pub(crate) struct LocalObserver {
    frame_sample: Option<Sample<Svc, [f32], FrameHeader>>,
    contacts_sample: Option<Sample<Svc, [Contact], ContactsHeader>>,
    contacts: ContactsService,
    frames: Subscriber<Svc, [f32], FrameHeader>,
    replies: Subscriber<Svc, [Contact], ContactsHeader>,
    frame_listener: Listener<Svc>,
    contacts_listener: Listener<Svc>,
    node: Rc<Node<Svc>>,
    pub(crate) info: SessionInfo,
    prefer_frame: bool,
    /// Frames in the order sent (up to the service's buffer behind) instead of the newest.
    pub(crate) every_frame: bool,
}

impl LocalObserver {
    fn new(node: &Rc<Node<Svc>>, info: SessionInfo) -> Result<Self, Error> {
        // Every way a session can be full (its services' nodes, subscribers, listeners) is one
        // error naming the limit, not iceoryx2's own.
        let full = || Error::ObserversFull { session: info.session, max: info.max_observers };
        let named = |e: lumen_transport::TransportError| if matches!(e, lumen_transport::TransportError::Full { .. }) { full() } else { e.into() };
        let (frame, frame_event) = open_frame(node, &info.frame).map_err(named)?;
        let (contacts, contacts_event) = open_contacts(node, &info.contacts).map_err(named)?;
        use iceoryx2::port::listener::ListenerCreateError::ExceedsMaxSupportedListeners;
        use iceoryx2::port::subscriber::SubscriberCreateError::ExceedsMaxSupportedSubscribers;
        let frames = frame.subscriber_builder().create().map_err(|e| if matches!(e, ExceedsMaxSupportedSubscribers) { full() } else { Error::iox("subscribing to frames", e) })?;
        let replies = contacts.subscriber_builder().create().map_err(|e| if matches!(e, ExceedsMaxSupportedSubscribers) { full() } else { Error::iox("subscribing to contacts", e) })?;
        let frame_listener = frame_event.listener_builder().create().map_err(|e| if matches!(e, ExceedsMaxSupportedListeners) { full() } else { Error::iox("listening for frames", e) })?;
        let contacts_listener = contacts_event.listener_builder().create().map_err(|e| if matches!(e, ExceedsMaxSupportedListeners) { full() } else { Error::iox("listening for contacts", e) })?;
        Ok(Self { frame_sample: None, contacts_sample: None, contacts, frames, replies, frame_listener, contacts_listener, node: node.clone(), info, prefer_frame: true, every_frame: false })
    }

    /// The next frame or reply: the newest frame, and replies in order.
    pub(crate) fn next(&mut self, timeout: Duration) -> Result<crate::Observed<'_>, Error> {
        let deadline = Instant::now() + timeout;
        loop {
            // Consume the wake-ups first: a sample sent after the look below brings a new one.
            self.frame_listener.try_wait(|_| {}).map_err(|e| Error::iox("consuming frame events", e))?;
            self.contacts_listener.try_wait(|_| {}).map_err(|e| Error::iox("consuming contacts events", e))?;
            // Frames and replies take turns while both wait; a frame is taken from the queue
            // only when it is returned.
            let reply_first = !self.prefer_frame;
            self.prefer_frame = true;
            if reply_first && self.take_reply()? {
                return Ok(self.reply());
            }
            // Drain the frame queue to its newest sample (releasing the one held since last time),
            // or take its oldest when every frame is wanted.
            self.frame_sample = None;
            let mut newest = None;
            while let Some(s) = self.frames.receive().map_err(|e| Error::iox("receiving a frame", e))? {
                newest = Some(s); // the previous one is released here, after the receive
                if self.every_frame {
                    break;
                }
            }
            if newest.is_none() && self.take_reply()? {
                return Ok(self.reply());
            }
            if let Some(f) = newest {
                self.prefer_frame = false;
                let f = self.frame_sample.insert(f);
                return Ok(crate::Observed::Frame { header: f.user_header(), state: f.payload() });
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(Error::Timeout(timeout));
            }
            if poll2(&self.frame_listener, &self.contacts_listener, left.min(LIVENESS_PERIOD)) == 0 {
                self.node.try_cleanup_dead_nodes();
                if self.contacts.dynamic_config().number_of_publishers() == 0 {
                    return Err(Error::SessionEnded(self.info.session));
                }
            }
        }
    }

    /// Takes the next reply from the queue, if any, holding it until the next call.
    fn take_reply(&mut self) -> Result<bool, Error> {
        self.contacts_sample = self.replies.receive().map_err(|e| Error::iox("receiving contacts", e))?;
        Ok(self.contacts_sample.is_some())
    }

    /// The reply [`LocalObserver::take_reply`] took.
    fn reply(&self) -> crate::Observed<'_> {
        let r = self.contacts_sample.as_ref().expect("a reply was taken");
        crate::Observed::Contacts(ContactsView { header: r.user_header(), contacts: r.payload() })
    }
}

/// Blocks until either listener's file descriptor is readable or `timeout` passes; returns the
/// number of ready descriptors.
fn poll2(a: &Listener<Svc>, b: &Listener<Svc>, timeout: Duration) -> i32 {
    // SAFETY: the descriptors belong to listeners that outlive the call; poll only reads them.
    let mut fds = [a, b].map(|l| libc::pollfd { fd: unsafe { l.file_descriptor().native_handle() }, events: libc::POLLIN, revents: 0 });
    unsafe { libc::poll(fds.as_mut_ptr(), 2, timeout.as_millis().clamp(1, i32::MAX as u128) as i32) }
}

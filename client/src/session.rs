use crate::local::LocalSession;
use crate::remote::ZenohSession;
use crate::view::ContactsView;
use crate::Error;
use lumen_proto::session::{ControlRequest, SessionInfo};
use lumen_proto::StateLayout;
use std::time::Duration;

/// One open scene: write a frame in place, submit it, read its contacts.
///
/// Frames are numbered from 0 in submission order; each reply names the frame it answers. If the
/// client outruns the daemon the newest frame wins (the reply's `skipped` counts the others).
/// If the daemon goes away, calls fail with [`Error::Disconnected`] and the session reopens by
/// itself (a new session: new secret, same spec; a new id, except that a daemon that stayed up
/// may give a zenoh client one of its own ended sessions' ids) on a later [`Session::frame`] /
/// [`Session::submit`].
pub struct Session {
    inner: Inner,
}

/// Which reply a session waits for: the one to the newest frame it submitted. A reply to an
/// older frame (one that came after its wait timed out) is stale: dropped and counted, so a
/// wait never returns another frame's contacts.
#[derive(Debug, Default)]
pub(crate) struct Awaited {
    /// The number of the newest frame submitted (as its header went out).
    sent: Option<u64>,
    /// Replies dropped as stale.
    pub(crate) stale: u64,
}

impl Awaited {
    /// Notes that frame `n` went out.
    pub(crate) fn sent(&mut self, n: u64) {
        self.sent = Some(n);
    }

    /// Whether a reply to frame `n` is stale (counted if so).
    pub(crate) fn stale(&mut self, n: u64) -> bool {
        let stale = self.sent.is_some_and(|s| n < s);
        self.stale += u64::from(stale);
        stale
    }
}

enum Inner {
    Local(Box<LocalSession>),
    Zenoh(Box<ZenohSession>),
}

impl Session {
    pub(crate) fn from_local(s: LocalSession) -> Self {
        Self { inner: Inner::Local(Box::new(s)) }
    }
    pub(crate) fn from_zenoh(s: ZenohSession) -> Self {
        Self { inner: Inner::Zenoh(Box::new(s)) }
    }

    /// The session id (changes when the session reopens after a daemon restart; over zenoh a
    /// session reopened on a daemon that stayed up may get its old id back).
    pub fn id(&self) -> u64 {
        self.info().session
    }

    /// The daemon's description of the session (id, channel names, sizes).
    pub fn info(&self) -> &SessionInfo {
        match &self.inner {
            Inner::Local(s) => &s.info,
            Inner::Zenoh(s) => &s.info,
        }
    }

    /// The request that closes this session, with the proof of its secret: what
    /// [`Session::close`] sends, for a tool that closes it from another connection.
    pub fn close_request(&self) -> ControlRequest {
        crate::control::close_request(self.info())
    }

    /// Zenoh: messages on the session's contacts key dropped because they lacked the daemon's
    /// tag (forged replies); 0 on iceoryx2.
    pub fn forged_replies(&self) -> u64 {
        match &self.inner {
            Inner::Local(_) => 0,
            Inner::Zenoh(s) => s.forged.load(std::sync::atomic::Ordering::Relaxed),
        }
    }

    /// Where each body's floats go in [`Session::frame`].
    pub fn layout(&self) -> &StateLayout {
        match &self.inner {
            Inner::Local(s) => &s.layout,
            Inner::Zenoh(s) => &s.layout,
        }
    }

    /// How many times the session reopened after losing the daemon.
    pub fn reconnects(&self) -> u64 {
        match &self.inner {
            Inner::Local(s) => s.reconnects,
            Inner::Zenoh(s) => s.reconnects,
        }
    }

    /// Replies dropped because they answered a frame older than the newest submitted (late
    /// ones, after a wait for them timed out).
    pub fn stale_replies(&self) -> u64 {
        match &self.inner {
            Inner::Local(s) => s.awaited.stale,
            Inner::Zenoh(s) => s.awaited.stale,
        }
    }

    /// Over zenoh, whether frames go as deltas where they can (on by default; the daemon then
    /// rebuilds each frame on the last one it answered, `proto/README.md` section 2). Turned
    /// off, every frame goes whole. iceoryx2 frames are shared memory and always go whole; there
    /// this does nothing.
    pub fn set_deltas(&mut self, on: bool) {
        if let Inner::Zenoh(s) = &mut self.inner {
            s.deltas.on = on;
        }
    }

    /// Over zenoh, emulates a link of `bytes_per_second` for benchmarks: each frame is held back
    /// for as long as its bytes take to cross such a link after the previous frame's
    /// (`None`: no emulation, the default). Replies are not held back. Nothing on iceoryx2.
    pub fn emulate_link(&mut self, bytes_per_second: Option<u64>) {
        if let Inner::Zenoh(s) = &mut self.inner {
            s.link = bytes_per_second.filter(|&r| r > 0).map(|r| (r, std::time::Instant::now()));
        }
    }

    /// Over zenoh, how many frames went whole and as deltas, and their bytes; zeros on
    /// iceoryx2 (no bytes travel).
    pub fn frame_counts(&self) -> crate::FrameCounts {
        match &self.inner {
            Inner::Local(_) => crate::FrameCounts::default(),
            Inner::Zenoh(s) => s.deltas.counts,
        }
    }

    /// The number the next submitted frame will carry.
    pub fn next_frame_number(&self) -> u64 {
        match &self.inner {
            Inner::Local(s) => s.frame_no,
            Inner::Zenoh(s) => s.frame_no,
        }
    }

    /// The frame to fill: `layout().floats` values in the spec's layout
    /// ([`lumen_proto::state`]). On iceoryx2 it is the shared memory the daemon will read
    /// (no copy anywhere); it holds stale data, so write every value. Calling it again before
    /// [`Session::submit`] returns the same frame.
    pub fn frame(&mut self) -> Result<&mut [f32], Error> {
        match &mut self.inner {
            Inner::Local(s) => s.frame(),
            Inner::Zenoh(s) => s.frame(),
        }
    }

    /// Sends the frame written through [`Session::frame`]; returns its frame number.
    pub fn submit(&mut self) -> Result<u64, Error> {
        self.submit_with(|_| {})
    }

    /// Like [`Session::submit`], letting `edit` change the header first (tools and tests that
    /// need a malformed frame; normal clients never need it). Over zenoh a frame whose number
    /// is not greater than the last one sent in this session is dropped by the daemon as a
    /// replay and never answered (`proto/README.md`, section 6).
    pub fn submit_with(&mut self, edit: impl FnOnce(&mut lumen_proto::wire::FrameHeader)) -> Result<u64, Error> {
        match &mut self.inner {
            Inner::Local(s) => s.submit(edit),
            Inner::Zenoh(s) => s.submit(edit),
        }
    }

    /// Copies `state` into a frame and submits it (convenience; costs one copy).
    pub fn submit_state(&mut self, state: &[f32]) -> Result<u64, Error> {
        let frame = self.frame()?;
        if frame.len() != state.len() {
            // Let the daemon name the problem: send what fits and report the length it had.
            let n = frame.len().min(state.len());
            frame[..n].copy_from_slice(&state[..n]);
        } else {
            frame.copy_from_slice(state);
        }
        self.submit()
    }

    /// Frees the session on the daemon now and waits for its answer (dropping a session frees
    /// it too, once the daemon notices the client's ports are gone). A session the daemon no
    /// longer has (it restarted, or the session expired) counts as closed.
    pub fn close(self) -> Result<(), Error> {
        match self.inner {
            Inner::Local(s) => s.close(),
            Inner::Zenoh(s) => s.close(),
        }
    }

    /// The reply to the newest frame submitted, waiting up to `timeout` (blocking; no busy
    /// polling). A reply to an older frame (one that came after an earlier wait timed out) is
    /// dropped, never returned for this one, and counted ([`Session::stale_replies`]).
    pub fn contacts(&mut self, timeout: Duration) -> Result<ContactsView<'_>, Error> {
        match &mut self.inner {
            Inner::Local(s) => s.contacts(timeout),
            Inner::Zenoh(s) => s.contacts(timeout),
        }
    }

    /// The reply to the newest frame submitted if it is there, without waiting (older frames'
    /// replies are dropped and counted, as by [`Session::contacts`]).
    pub fn try_contacts(&mut self) -> Result<Option<ContactsView<'_>>, Error> {
        match &mut self.inner {
            Inner::Local(s) => s.try_contacts(),
            Inner::Zenoh(s) => s.try_contacts(),
        }
    }

    /// The next reply, asynchronously (needs a tokio runtime with I/O enabled): zenoh awaits
    /// the subscriber, iceoryx2 the contacts event's file descriptor. Neither polls.
    pub async fn contacts_async(&mut self, timeout: Duration) -> Result<ContactsView<'_>, Error> {
        match &mut self.inner {
            Inner::Local(s) => s.contacts_async(timeout).await,
            Inner::Zenoh(s) => s.contacts_async(timeout).await,
        }
    }
}

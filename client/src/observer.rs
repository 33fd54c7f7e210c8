use crate::local::LocalObserver;
use crate::remote::ZenohObserver;
use crate::view::ContactsView;
use crate::Error;
use lumen_proto::session::SessionInfo;
use lumen_proto::wire::FrameHeader;
use std::time::Duration;

/// Something an [`Observer`] saw.
#[derive(Debug)]
pub enum Observed<'a> {
    /// The newest frame the client sent (older ones not yet seen are skipped), or the next one
    /// in order after [`Observer::every_frame`].
    Frame { header: &'a FrameHeader, state: &'a [f32] },
    /// A reply of the daemon.
    Contacts(ContactsView<'a>),
}

/// Watches a session's frames and replies (a VR front-end, a recorder). It never slows the
/// session: it sees the newest frame, and replies while it keeps up.
pub struct Observer {
    inner: Inner,
}

enum Inner {
    Local(Box<LocalObserver>),
    Zenoh(Box<ZenohObserver>),
}

impl Observer {
    pub(crate) fn from_local(o: LocalObserver) -> Self {
        Self { inner: Inner::Local(Box::new(o)) }
    }
    pub(crate) fn from_zenoh(o: ZenohObserver) -> Self {
        Self { inner: Inner::Zenoh(Box::new(o)) }
    }

    /// The observed session.
    pub fn info(&self) -> &SessionInfo {
        match &self.inner {
            Inner::Local(o) => &o.info,
            Inner::Zenoh(o) => &o.info,
        }
    }

    /// Asks for every frame, in the order sent, rather than the newest (a recorder). Over
    /// iceoryx2 the session keeps [`lumen_transport::shm::FRAME_BUFFER`] frames for each
    /// observer, so one that falls up to that many frames behind loses none; past it the oldest
    /// are dropped (frame numbers tell). Over zenoh an observer's ask is always answered with
    /// the newest frame, so this changes nothing there.
    pub fn every_frame(&mut self) {
        if let Inner::Local(o) = &mut self.inner {
            o.every_frame = true;
        }
    }

    /// The next frame or reply, waiting up to `timeout`. [`Error::SessionEnded`] once the
    /// session is gone.
    pub fn next(&mut self, timeout: Duration) -> Result<Observed<'_>, Error> {
        match &mut self.inner {
            Inner::Local(o) => o.next(timeout),
            Inner::Zenoh(o) => o.next(timeout),
        }
    }
}

//! `lumen_observer_*`: watching another session's frames and replies (a VR front-end, a
//! recorder) without slowing it.

use crate::boundary::call;
use crate::client::LumenClient;
use crate::error::Error;
use crate::handles::{self, Kind, Owner};
use crate::session::LumenReply;
use crate::status::LumenStatus;
use lumen_client::{Observed, Observer};
use lumen_proto::wire::FrameHeader;
use std::ptr;
use std::time::Duration;

/// A watcher of one session (opaque): made by `lumen_observer_open`, freed by
/// `lumen_observer_free`.
pub struct LumenObserver {
    observer: Observer,
    owner: Owner,
}

/// What `lumen_observer_next` saw.
#[repr(i32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LumenObservedKind {
    /// Nothing (the call failed).
    Nothing = 0,
    /// The newest frame the session's client sent: `frame`, `state`, `floats`.
    Frame = 1,
    /// A reply of the daemon: `reply`.
    Contacts = 2,
}

/// One thing an observer saw, borrowed from it: valid until the next call on the observer.
#[repr(C)]
pub struct LumenObserved {
    /// Which of the fields below are set.
    pub kind: LumenObservedKind,
    /// The frame's header (`kind == LUMEN_OBSERVED_KIND_FRAME`), else NULL.
    pub frame: *const FrameHeader,
    /// The frame's `floats` state values, else NULL.
    pub state: *const f32,
    /// The number of state values.
    pub floats: usize,
    /// The reply (`kind == LUMEN_OBSERVED_KIND_CONTACTS`), else empty.
    pub reply: LumenReply,
}

/// Starts watching session `session` (any client's, on the same transport as `client`).
/// Older frames not yet seen are skipped (the newest wins); replies come in order while the
/// observer keeps up. `LUMEN_STATUS_REFUSED` for an unknown session, and when the session has
/// all the observers it allows (the message says how many, code `observers_full`).
///
/// # Safety
/// `out` is NULL or writable; no call frees `client` meanwhile.
#[no_mangle]
pub unsafe extern "C" fn lumen_observer_open(client: *mut LumenClient, session: u64, out: *mut *mut LumenObserver) -> LumenStatus {
    call(|| {
        // SAFETY: the caller's contract, for each pointer.
        let out = unsafe { out.as_mut() }.ok_or(Error::NullArgument("out"))?;
        *out = ptr::null_mut();
        let client = unsafe { handles::get(client, Kind::Client, "client") }?;
        client.owner.check("client")?;
        let observer = client.client.observe(session)?;
        *out = handles::register(LumenObserver { observer, owner: client.owner }, Kind::Observer);
        Ok(())
    })
}

/// Waits up to `timeout_ms` milliseconds for the next frame or reply of the watched session
/// and describes it in `*seen`. `LUMEN_STATUS_SESSION_ENDED` once the session is gone,
/// `LUMEN_STATUS_TIMEOUT` when nothing came.
///
/// # Safety
/// `seen` is NULL or writable; no call frees `observer` meanwhile.
#[no_mangle]
pub unsafe extern "C" fn lumen_observer_next(observer: *mut LumenObserver, timeout_ms: u32, seen: *mut LumenObserved) -> LumenStatus {
    call(|| {
        // SAFETY: the caller's contract, for each pointer.
        let seen = unsafe { seen.as_mut() }.ok_or(Error::NullArgument("seen"))?;
        *seen = LumenObserved { kind: LumenObservedKind::Nothing, frame: ptr::null(), state: ptr::null(), floats: 0, reply: LumenReply::EMPTY };
        let o = unsafe { handles::get(observer, Kind::Observer, "observer") }?;
        o.owner.check("observer")?;
        match o.observer.next(Duration::from_millis(timeout_ms.into()))? {
            Observed::Frame { header, state } => {
                (seen.frame, seen.state, seen.floats) = (header, state.as_ptr(), state.len());
                seen.kind = LumenObservedKind::Frame;
            }
            Observed::Contacts(view) => {
                seen.reply = LumenReply::of(&view);
                seen.kind = LumenObservedKind::Contacts;
            }
        }
        Ok(())
    })
}

/// Stops watching and frees the observer. NULL is a no-op. Any thread may free it: a local
/// (iceoryx2) observer freed off its own thread is dropped by that thread at its next call into
/// Lumen, and keeps its place on the session until then.
///
/// # Safety
/// No call on `observer` runs meanwhile, and none follows.
#[no_mangle]
pub unsafe extern "C" fn lumen_observer_free(observer: *mut LumenObserver) -> LumenStatus {
    if observer.is_null() {
        return LumenStatus::Ok;
    }
    call(|| {
        // SAFETY: the caller's contract.
        unsafe { handles::free_anywhere(observer, Kind::Observer, "observer", |o| o.owner) }
    })
}

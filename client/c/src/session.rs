//! `lumen_session_*`: one scene on the daemon, frames in and contacts out, as an opaque handle.

use crate::boundary::call;
use crate::client::LumenClient;
use crate::error::Error;
use crate::handles::{self, Kind, Owner};
use crate::status::LumenStatus;
use crate::text;
use lumen_client::Session;
use lumen_proto::wire::ContactsHeader;
use lumen_proto::Contact;
use std::ffi::c_char;
use std::ptr;
use std::time::Duration;

/// One open scene (opaque): made by `lumen_session_open`, ended by `lumen_session_close`.
///
/// If the daemon goes away, calls return `LUMEN_STATUS_DISCONNECTED`; keep calling
/// `lumen_session_frame` and `lumen_session_submit` and the session reopens by itself (same
/// spec, new id) as soon as a daemon answers again.
pub struct LumenSession {
    session: Session,
    owner: Owner,
    /// Its client's iceoryx2 prefix ([`LumenClient::prefix`]).
    prefix: Option<String>,
}

/// One reply of the daemon, borrowed from the session or observer that received it: valid
/// until the next call on that handle.
#[repr(C)]
pub struct LumenReply {
    /// The reply's header: `frame` (the frame it answers), `status` (0: contacts computed;
    /// else `message`/`message_len` say why not, with `error_body`/`error_index`/
    /// `error_spoke`), `detect_ns`, `skipped`, the echoed `client_time_ns`, `flags`.
    pub header: *const ContactsHeader,
    /// `count` contacts, ordered by pair then rod sample (none unless `header->status` is 0).
    pub contacts: *const Contact,
    /// The number of contacts.
    pub count: usize,
}

impl LumenReply {
    pub(crate) const EMPTY: Self = Self { header: ptr::null(), contacts: ptr::null(), count: 0 };

    pub(crate) fn of(view: &lumen_client::ContactsView<'_>) -> Self {
        Self { header: view.header(), contacts: view.contacts().as_ptr(), count: view.contacts().len() }
    }
}

/// The session behind `session`, on its own thread.
///
/// # Safety
/// No other call uses or frees `session` meanwhile.
unsafe fn live<'a>(session: *mut LumenSession) -> Result<&'a mut Session, Error> {
    // SAFETY: forwarded.
    let s = unsafe { handles::get(session, Kind::Session, "session") }?;
    s.owner.check("session")?;
    Ok(&mut s.session)
}

/// Opens a session for the scene spec `spec_json` (`len` bytes of UTF-8 JSON, the format of
/// proto/README.md; `len` without a terminating NUL). Checked here first:
/// `LUMEN_STATUS_BAD_UTF8` for bytes that are not UTF-8, `LUMEN_STATUS_BAD_SPEC` for text that
/// is not JSON of the scene format (a `len` that counts the NUL says so). Then the daemon
/// validates it: `LUMEN_STATUS_REFUSED` names what is wrong. `LUMEN_STATUS_NO_DAEMON` when
/// none answers. Opening takes milliseconds (iceoryx2 creates shared memory for the session:
/// about 70 ms at the median for a colon-sized scene, more on a loaded machine): open once,
/// before the frame loop.
///
/// On `LUMEN_STATUS_OK`, `*out` is the new session, the caller's until `lumen_session_close`.
///
/// # Safety
/// `spec_json` points to `len` readable bytes; `out` is NULL or writable; no call frees
/// `client` meanwhile.
#[no_mangle]
pub unsafe extern "C" fn lumen_session_open(client: *mut LumenClient, spec_json: *const c_char, len: usize, out: *mut *mut LumenSession) -> LumenStatus {
    call(|| {
        // SAFETY: the caller's contract, for each pointer.
        let out = unsafe { out.as_mut() }.ok_or(Error::NullArgument("out"))?;
        *out = ptr::null_mut();
        let client = unsafe { handles::get(client, Kind::Client, "client") }?;
        client.owner.check("client")?;
        let spec = unsafe { text::spec(spec_json, len) }?;
        let session = client.client.open_session(&spec)?;
        *out = handles::register(LumenSession { session, owner: client.owner, prefix: client.prefix.clone() }, Kind::Session);
        Ok(())
    })
}

/// Writes the session's id to `*out` (it changes when the session reopens after a daemon
/// restart).
///
/// # Safety
/// `out` is NULL or writable; no call frees `session` meanwhile.
#[no_mangle]
pub unsafe extern "C" fn lumen_session_id(session: *mut LumenSession, out: *mut u64) -> LumenStatus {
    call(|| {
        // SAFETY: the caller's contract, for each pointer.
        let out = unsafe { out.as_mut() }.ok_or(Error::NullArgument("out"))?;
        *out = unsafe { live(session) }?.id();
        Ok(())
    })
}

/// Writes to `*out` how many times the session reopened after losing the daemon.
///
/// # Safety
/// `out` is NULL or writable; no call frees `session` meanwhile.
#[no_mangle]
pub unsafe extern "C" fn lumen_session_reconnects(session: *mut LumenSession, out: *mut u64) -> LumenStatus {
    call(|| {
        // SAFETY: the caller's contract, for each pointer.
        let out = unsafe { out.as_mut() }.ok_or(Error::NullArgument("out"))?;
        *out = unsafe { live(session) }?.reconnects();
        Ok(())
    })
}

/// Writes to `*out` how many replies `lumen_session_contacts` dropped because they answered a
/// frame older than the newest submitted (late ones, after a wait for them timed out):
/// `lumen_session_contacts` returns the newest frame's reply or none, never another frame's.
///
/// # Safety
/// `out` is NULL or writable; no call frees `session` meanwhile.
#[no_mangle]
pub unsafe extern "C" fn lumen_session_stale_replies(session: *mut LumenSession, out: *mut u64) -> LumenStatus {
    call(|| {
        // SAFETY: the caller's contract, for each pointer.
        let out = unsafe { out.as_mut() }.ok_or(Error::NullArgument("out"))?;
        *out = unsafe { live(session) }?.stale_replies();
        Ok(())
    })
}

/// The frame to fill: `*frame` points to `*floats` floats in the spec's layout (every body in
/// the spec's order; tube: per ring its control point then its radial vectors, relative to it;
/// rod: its points). Over iceoryx2 it is the shared memory the daemon will read, with no copy
/// anywhere; it holds an earlier frame's values, so write every float. It is valid until
/// `lumen_session_submit` or `lumen_session_close`; calling this again before submitting
/// returns the same frame.
///
/// `LUMEN_STATUS_DISCONNECTED`: the daemon is gone; call again (this is where the session
/// reopens).
///
/// # Safety
/// `frame` and `floats` are NULL or writable; no call frees `session` meanwhile.
#[no_mangle]
pub unsafe extern "C" fn lumen_session_frame(session: *mut LumenSession, frame: *mut *mut f32, floats: *mut usize) -> LumenStatus {
    call(|| {
        // SAFETY: the caller's contract, for each pointer.
        let (frame, floats) = unsafe { (frame.as_mut(), floats.as_mut()) };
        let frame = frame.ok_or(Error::NullArgument("frame"))?;
        *frame = ptr::null_mut();
        let floats = floats.ok_or(Error::NullArgument("floats"))?;
        *floats = 0;
        let state = unsafe { live(session) }?.frame()?;
        (*frame, *floats) = (state.as_mut_ptr(), state.len());
        Ok(())
    })
}

/// Sends the frame written through `lumen_session_frame`, stamped with the time (for the
/// round trip) and the next frame number, which goes to `*frame_number` (NULL: not wanted).
///
/// `LUMEN_STATUS_NO_FRAME` without a `lumen_session_frame` since the last submit;
/// `LUMEN_STATUS_DISCONNECTED` when the daemon is gone (get a frame again: the session
/// reopens there); `LUMEN_STATUS_TRANSPORT` when the transport failed.
///
/// # Safety
/// `frame_number` is NULL or writable; no call frees `session` meanwhile.
#[no_mangle]
pub unsafe extern "C" fn lumen_session_submit(session: *mut LumenSession, frame_number: *mut u64) -> LumenStatus {
    call(|| {
        // SAFETY: the caller's contract, for each pointer.
        let n = unsafe { live(session) }?.submit()?;
        if let Some(out) = unsafe { frame_number.as_mut() } {
            *out = n;
        }
        Ok(())
    })
}

/// Waits up to `timeout_ms` milliseconds for the reply to the newest frame submitted
/// (blocking, no busy polling) and puts it in `*reply`: header, contacts and count, valid until
/// the next call on `session`. A reply to an older frame (one that came after its wait timed
/// out) is dropped, never returned for this one (`lumen_session_stale_replies` counts them).
/// `LUMEN_STATUS_TIMEOUT` when none came in time (the session still works);
/// `LUMEN_STATUS_DISCONNECTED` when the daemon is gone or no longer has the session (keep
/// submitting: it reopens); `LUMEN_STATUS_PROTOCOL` for a reply this library cannot read.
/// A frame the daemon could not read is still a reply: check `reply->header->status`.
/// `LUMEN_STATUS_TIMEOUT` when none came (the session still works).
///
/// # Safety
/// `reply` is NULL or writable; no call frees `session` meanwhile.
#[no_mangle]
pub unsafe extern "C" fn lumen_session_contacts(session: *mut LumenSession, timeout_ms: u32, reply: *mut LumenReply) -> LumenStatus {
    call(|| {
        // SAFETY: the caller's contract, for each pointer.
        let reply = unsafe { reply.as_mut() }.ok_or(Error::NullArgument("reply"))?;
        *reply = LumenReply::EMPTY;
        let view = unsafe { live(session) }?.contacts(Duration::from_millis(timeout_ms.into()))?;
        *reply = LumenReply::of(&view);
        Ok(())
    })
}

/// Ends the session: asks the daemon to free it, waits for the answer, and frees the handle
/// (whatever the status; a session the daemon no longer has counts as closed). NULL is a
/// no-op. Any thread may close it: a local (iceoryx2) session closed off its own thread is
/// closed on the daemon through a client of the calling thread (its proof, from its open), and
/// its own thread drops what is left of it at its next call into Lumen.
///
/// # Safety
/// No call on `session` runs meanwhile, and none follows.
#[no_mangle]
pub unsafe extern "C" fn lumen_session_close(session: *mut LumenSession) -> LumenStatus {
    if session.is_null() {
        return LumenStatus::Ok;
    }
    call(|| {
        // SAFETY: the caller's contract.
        let s = unsafe { handles::get(session, Kind::Session, "session") }?;
        let Some(thread) = s.owner.elsewhere() else {
            let s = unsafe { handles::release(session, Kind::Session, "session") }?;
            return Ok(s.session.close()?);
        };
        // Plain data read off the owner's thread; nothing of iceoryx2's is touched here.
        let (request, id, prefix) = (s.session.close_request(), s.session.id(), s.prefix.clone());
        let s = unsafe { handles::release(session, Kind::Session, "session") }?;
        handles::adopt(thread, s);
        let here = lumen_client::Client::local_with(lumen_client::LocalOptions { prefix, name: Some("lumen-close".into()) })?;
        match here.request(&request) {
            Ok(lumen_proto::session::ControlReply::Closed { .. }) => Ok(()),
            Err(lumen_client::Error::Refused(e)) if e.code == lumen_proto::session::ErrorCode::UnknownSession => Ok(()),
            Ok(other) => Err(Error::Client(lumen_client::Error::Protocol(format!("closing session {id}: the daemon answered {other:?}")))),
            Err(e) => Err(e.into()),
        }
    })
}

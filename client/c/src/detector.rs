//! `lumen_detector_*`: a [`Detector`] behind an opaque handle, for one scene, fed one state per
//! frame.

use crate::boundary::call;
use crate::error::Error;
use crate::handles::{self, Kind};
use crate::status::LumenStatus;
use crate::text;
use lumen_detect::Detector;
use lumen_proto::Contact;
use std::cell::UnsafeCell;
use std::ffi::c_char;
use std::ptr;
use std::sync::atomic::{AtomicU8, Ordering};

/// A detector for one scene (opaque): made by `lumen_detector_new`, freed by
/// `lumen_detector_free`. It keeps each rod sample's place from frame to frame, so feed it the
/// frames of one simulation in order.
///
/// Threading: one thread at a time may call a detector (it may move between threads between
/// calls); a call while another thread's runs on the same detector is refused with
/// `LUMEN_STATUS_WRONG_THREAD` and changes nothing. Distinct detectors share nothing and may run
/// on distinct threads at once.
pub struct LumenDetector {
    /// Touched only by the call that set `state` from idle to busy.
    detector: UnsafeCell<Detector>,
    /// [`IDLE`], [`BUSY`] while a call runs, [`POISONED`] after a panic in one (the buffers may
    /// be half-written).
    state: AtomicU8,
    /// The number of floats of a frame's state (read without entering).
    floats: usize,
}

const IDLE: u8 = 0;
const BUSY: u8 = 1;
const POISONED: u8 = 2;

// SAFETY: the detector inside is reached only by the one call that moved `state` from IDLE to
// BUSY, so two threads never touch it at once; a second thread meanwhile is refused.
unsafe impl Sync for LumenDetector {}

// A handle may move between threads between calls (see the type's documentation).
const _: () = {
    const fn send<T: Send>() {}
    send::<LumenDetector>();
};

/// Leaves a detector's call: idle again, or poisoned if the call is unwinding.
struct Leave<'a>(&'a AtomicU8);

impl Drop for Leave<'_> {
    fn drop(&mut self) {
        self.0.store(if std::thread::panicking() { POISONED } else { IDLE }, Ordering::Release);
    }
}

impl LumenDetector {
    fn new(detector: Detector) -> Self {
        let floats = detector.layout().floats;
        Self { detector: UnsafeCell::new(detector), state: AtomicU8::new(IDLE), floats }
    }

    /// One frame's contacts, or why there are none: refused while another thread's call runs,
    /// and for good after a panic.
    fn detect(&self, state: &[f32]) -> Result<&[Contact], Error> {
        match self.state.compare_exchange(IDLE, BUSY, Ordering::Acquire, Ordering::Relaxed) {
            Ok(_) => {}
            Err(POISONED) => return Err(Error::Poisoned),
            Err(_) => return Err(Error::DetectorBusy),
        }
        let _leave = Leave(&self.state);
        // SAFETY: this call moved `state` from IDLE to BUSY: nothing else touches the detector
        // until `_leave` drops. The contacts returned live in it until the caller's next call
        // (the API's contract), after this one has left.
        let detector = unsafe { &mut *self.detector.get() };
        Ok(detector.detect(state)?)
    }
}

/// Makes a detector for the scene spec `spec_json` (`len` bytes of UTF-8 JSON, no NUL needed;
/// the format of proto/README.md: `bodies`, `pairs`, optional `precision`, `alpha`, `margin`,
/// `method`, `nearest`, `refine`), validated once here.
///
/// On `LUMEN_STATUS_OK`, `*out` is the new detector, owned by the caller until
/// `lumen_detector_free`. Otherwise `*out` is NULL and the status is `LUMEN_STATUS_BAD_UTF8`,
/// `LUMEN_STATUS_BAD_SPEC` (the message names the body or pair) or
/// `LUMEN_STATUS_NULL_ARGUMENT`. The spec's bytes are not kept.
///
/// # Safety
/// `spec_json` points to `len` readable bytes; `out` is NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn lumen_detector_new(spec_json: *const c_char, len: usize, out: *mut *mut LumenDetector) -> LumenStatus {
    call(|| {
        // SAFETY: `out` is NULL or writable (the caller's contract).
        let out = unsafe { out.as_mut() }.ok_or(Error::NullArgument("out"))?;
        *out = ptr::null_mut();
        // SAFETY: `spec_json` points to `len` readable bytes (the caller's contract).
        let scene = unsafe { text::spec(spec_json, len) }?.validate().map_err(Error::BadSpec)?;
        *out = handles::register(LumenDetector::new(Detector::new(&scene)), Kind::Detector);
        Ok(())
    })
}

/// Frees a detector and the contacts it returned last. NULL is a no-op (`LUMEN_STATUS_OK`); a
/// handle freed already is `LUMEN_STATUS_BAD_HANDLE`.
///
/// # Safety
/// No call on `detector` runs meanwhile.
#[no_mangle]
pub unsafe extern "C" fn lumen_detector_free(detector: *mut LumenDetector) -> LumenStatus {
    if detector.is_null() {
        return LumenStatus::Ok;
    }
    // SAFETY: no call on it runs meanwhile (the caller's contract).
    call(|| unsafe { handles::release(detector, Kind::Detector, "detector") }.map(drop))
}

/// Writes to `*out` the number of floats of one frame's state for this detector's scene (the
/// `len` `lumen_detector_detect` wants): per tube `rings * (spokes + 1) * 3`, per rod
/// `points * 3`, in the spec's order of bodies.
///
/// # Safety
/// `out` is NULL or writable; no call frees `detector` meanwhile.
#[no_mangle]
pub unsafe extern "C" fn lumen_detector_floats(detector: *const LumenDetector, out: *mut usize) -> LumenStatus {
    call(|| {
        // SAFETY: NULL or writable, NULL or live (the caller's contract).
        let out = unsafe { out.as_mut() }.ok_or(Error::NullArgument("out"))?;
        *out = 0;
        // SAFETY: no other call frees it meanwhile (the caller's contract).
        let detector = unsafe { handles::shared(detector, Kind::Detector, "detector") }?;
        *out = detector.floats;
        Ok(())
    })
}

/// Runs one frame: `state` is `len` floats laid out as proto/README.md says (every body in
/// the spec's order; tube: per ring its control point then its radial vectors, relative to
/// it; rod: its points), all finite.
///
/// On `LUMEN_STATUS_OK`, `*contacts` points to `*count` contacts (possibly none), ordered by
/// pair, then by rod sample. They live inside the detector: read them before the next call on
/// it or its free, which overwrite them; never free them. On any other status `*contacts` is
/// NULL and `*count` 0; `LUMEN_STATUS_BAD_STATE` (wrong length, non-finite value) leaves the
/// detector's history as it was, so the next good frame continues.
///
/// # Safety
/// No call frees `detector` meanwhile; `state` points to `len` readable floats; `contacts` and
/// `count` are NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn lumen_detector_detect(detector: *mut LumenDetector, state: *const f32, len: usize, contacts: *mut *const Contact, count: *mut usize) -> LumenStatus {
    call(|| {
        // SAFETY: NULL or writable (the caller's contract).
        let (contacts, count) = unsafe { (contacts.as_mut(), count.as_mut()) };
        let contacts = contacts.ok_or(Error::NullArgument("contacts"))?;
        *contacts = ptr::null();
        let count = count.ok_or(Error::NullArgument("count"))?;
        *count = 0;
        // SAFETY: no call frees it meanwhile (the caller's contract); another thread's call at
        // the same time is refused inside.
        let detector = unsafe { handles::shared(detector, Kind::Detector, "detector") }?;
        if state.is_null() {
            return Err(Error::NullArgument("state"));
        }
        // SAFETY: `state` points to `len` readable floats (the caller's contract).
        let state = unsafe { std::slice::from_raw_parts(state, len) };
        let found = detector.detect(state)?;
        (*contacts, *count) = (found.as_ptr(), found.len());
        Ok(())
    })
}

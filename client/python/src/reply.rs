//! What comes back: contacts as a NumPy structured array (one copy), a reply's header on a
//! small frozen object, an observed frame.

use crate::errors;
use lumen_proto::wire::{ContactsHeader, Status, FLAG_TRUNCATED};
use lumen_proto::Contact;
use numpy::{PyArray1, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;

/// The fields of [`Contact`] as NumPy sees them: name, format, byte offset (from the struct
/// itself, so the dtype cannot drift from the wire record).
pub fn contact_fields() -> Vec<(&'static str, &'static str, usize)> {
    use std::mem::offset_of;
    vec![
        ("pair", "<u2", offset_of!(Contact, pair)),
        ("kind", "u1", offset_of!(Contact, kind)),
        ("flags", "u1", offset_of!(Contact, flags)),
        ("body_a", "<u2", offset_of!(Contact, body_a)),
        ("body_b", "<u2", offset_of!(Contact, body_b)),
        ("sample", "<u4", offset_of!(Contact, sample)),
        ("segment_a", "<u4", offset_of!(Contact, segment_a)),
        ("param_a", "<f4", offset_of!(Contact, param_a)),
        ("index_b", "<u4", offset_of!(Contact, index_b)),
        ("spoke_b", "<u4", offset_of!(Contact, spoke_b)),
        ("param_b", "<f4", offset_of!(Contact, param_b)),
        ("weights_b", "(4,)<f4", offset_of!(Contact, weights_b)),
        ("point_a", "(3,)<f4", offset_of!(Contact, point_a)),
        ("point_b", "(3,)<f4", offset_of!(Contact, point_b)),
        ("normal", "(3,)<f4", offset_of!(Contact, normal)),
        ("depth", "<f4", offset_of!(Contact, depth)),
    ]
}

/// `lumen.CONTACT_DTYPE`, looked up once.
fn dtype(py: Python<'_>) -> PyResult<&Bound<'_, PyAny>> {
    static DTYPE: PyOnceLock<Py<PyAny>> = PyOnceLock::new();
    DTYPE.get_or_try_init(py, || py.import("lumen._dtype")?.getattr("CONTACT_DTYPE").map(Bound::unbind)).map(|d| d.bind(py))
}

/// A new structured array holding `contacts` (one `memcpy`).
pub fn contacts_array<'py>(py: Python<'py>, contacts: &[Contact]) -> PyResult<Bound<'py, PyAny>> {
    let array = py.import("numpy")?.getattr("empty")?.call1((contacts.len(), dtype(py)?))?;
    let untyped = array.cast::<PyUntypedArray>()?;
    debug_assert!(untyped.is_c_contiguous() && untyped.len() == contacts.len());
    if !contacts.is_empty() {
        // SAFETY: a fresh C-contiguous array of `len` records of 88 bytes (the dtype's itemsize,
        // checked when `lumen` is imported), which nothing else references yet.
        unsafe {
            let data = (*untyped.as_array_ptr()).fields.data.cast::<u8>();
            std::ptr::copy_nonoverlapping(contacts.as_ptr().cast::<u8>(), data, std::mem::size_of_val(contacts));
        }
    }
    Ok(array)
}

/// A status code's name: `"ok"`, `"non_finite"`, ... (`"unknown"` for a code this client does
/// not know).
pub fn status_name(code: u16) -> &'static str {
    match Status::from_u16(code) {
        Some(Status::Ok) => "ok",
        Some(Status::Malformed) => "malformed",
        Some(Status::BadVersion) => "bad_version",
        Some(Status::BadSession) => "bad_session",
        Some(Status::BadLength) => "bad_length",
        Some(Status::BadCounts) => "bad_counts",
        Some(Status::NonFinite) => "non_finite",
        Some(Status::NotStarShaped) => "not_star_shaped",
        Some(Status::Internal) => "internal",
        Some(Status::OutOfRange) => "out_of_range",
        Some(Status::NoBase) => "no_base",
        Some(Status::BadDelta) => "bad_delta",
        None => "unknown",
    }
}

/// One reply of the daemon to one frame: its header's fields and its contacts (copied out of
/// the reply buffer, so it stays valid after the next call).
///
/// A frame the daemon could not use (a NaN, a wrong length...) still gets a reply: `ok` is
/// False, `status`/`status_name` say why, `message` explains, `error_body`/`error_index`/
/// `error_spoke` point at a bad value, and `contacts` is empty. `raise_for_status()` turns that
/// into a `lumen.FrameError`.
#[pyclass(frozen, module = "lumen")]
pub struct Reply {
    /// The session this answers.
    #[pyo3(get)]
    session: u64,
    /// The frame number this answers (0 if the frame was too malformed to read it).
    #[pyo3(get)]
    frame: u64,
    /// Status code: 0 ok, else see `status_name`.
    #[pyo3(get)]
    status: u16,
    /// The daemon's explanation when the status is not ok ("" when ok).
    #[pyo3(get)]
    message: String,
    /// Detection time in nanoseconds (0 on error).
    #[pyo3(get)]
    detect_ns: u32,
    /// Frames of this session the daemon skipped (a newer one had arrived) since the previous reply.
    #[pyo3(get)]
    skipped: u32,
    /// Body index of a bad value, or None.
    #[pyo3(get)]
    error_body: Py<PyAny>,
    /// Control point / ring of a bad value, or None.
    #[pyo3(get)]
    error_index: Py<PyAny>,
    /// Radial vector of a bad value, or None (a control point).
    #[pyo3(get)]
    error_spoke: Py<PyAny>,
    /// The frame's `client_time_ns`, echoed (`lumen.now_ns()` at submit unless given).
    #[pyo3(get)]
    client_time_ns: u64,
    /// More contacts than the session's `max_contacts`: the first ones are here.
    #[pyo3(get)]
    truncated: bool,
    /// The contacts, a structured array of `lumen.CONTACT_DTYPE` (empty on error).
    #[pyo3(get)]
    contacts: Py<PyAny>,
}

impl Reply {
    pub fn new(py: Python<'_>, header: &ContactsHeader, contacts: &[Contact]) -> PyResult<Self> {
        Ok(Self {
            session: header.session,
            frame: header.frame,
            status: header.status,
            message: header.message().to_owned(),
            detect_ns: header.detect_ns,
            skipped: header.skipped,
            error_body: errors::index(py, header.error_body),
            error_index: errors::index(py, header.error_index),
            error_spoke: errors::index(py, header.error_spoke),
            client_time_ns: header.client_time_ns,
            truncated: header.flags & FLAG_TRUNCATED != 0,
            contacts: contacts_array(py, contacts)?.unbind(),
        })
    }
}

#[pymethods]
impl Reply {
    /// Whether the frame was processed (status 0).
    #[getter]
    fn ok(&self) -> bool {
        self.status == Status::Ok as u16
    }

    /// The status's name: "ok", "malformed", "bad_version", "bad_session", "bad_length",
    /// "bad_counts", "non_finite", "not_star_shaped", "internal" (or "unknown").
    #[getter]
    fn status_name(&self) -> &'static str {
        status_name(self.status)
    }

    /// Detection time in microseconds.
    #[getter]
    fn detect_us(&self) -> f64 {
        self.detect_ns as f64 / 1e3
    }

    /// Round trip in microseconds, for frames stamped with `lumen.now_ns()` (the default).
    #[getter]
    fn round_trip_us(&self) -> f64 {
        lumen_client::now_ns().saturating_sub(self.client_time_ns) as f64 / 1e3
    }

    /// Raises `lumen.FrameError` (with `status`, `status_name`, `frame` and the `error_*`
    /// fields) if the frame was refused; returns the reply itself otherwise.
    fn raise_for_status(slf: Bound<'_, Self>) -> PyResult<Bound<'_, Self>> {
        let me = slf.get();
        if me.ok() {
            return Ok(slf);
        }
        let py = slf.py();
        let message = format!("frame {} refused ({}): {}; the session goes on: fix the state and submit the next frame", me.frame, me.status_name(), me.message);
        let details = [
            ("status", me.status.into_pyobject(py)?.into_any().unbind()),
            ("status_name", me.status_name().into_pyobject(py)?.into_any().unbind()),
            ("frame", me.frame.into_pyobject(py)?.into_any().unbind()),
            ("reason", me.message.clone().into_pyobject(py)?.into_any().unbind()),
            ("error_body", me.error_body.clone_ref(py)),
            ("error_index", me.error_index.clone_ref(py)),
            ("error_spoke", me.error_spoke.clone_ref(py)),
        ];
        Err(errors::make(py, "FrameError", &message, &details))
    }

    /// Number of contacts.
    fn __len__(&self, py: Python<'_>) -> PyResult<usize> {
        self.contacts.bind(py).len()
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let n = self.contacts.bind(py).len()?;
        Ok(if self.ok() {
            format!("<lumen.Reply session={} frame={} ok contacts={} detect_us={:.1}>", self.session, self.frame, n, self.detect_us())
        } else {
            format!("<lumen.Reply session={} frame={} status={} message={:?}>", self.session, self.frame, self.status_name(), self.message)
        })
    }
}

/// A frame an observer saw: its header's fields and a copy of its state.
#[pyclass(frozen, module = "lumen")]
pub struct ObservedFrame {
    /// The observed session.
    #[pyo3(get)]
    session: u64,
    /// The frame number.
    #[pyo3(get)]
    frame: u64,
    /// The client's timestamp of the frame.
    #[pyo3(get)]
    client_time_ns: u64,
    /// The state, a read-only float32 array (a copy).
    #[pyo3(get)]
    state: Py<PyAny>,
}

impl ObservedFrame {
    pub fn new(py: Python<'_>, header: &lumen_proto::wire::FrameHeader, state: &[f32]) -> PyResult<Self> {
        let array = PyArray1::from_slice(py, state);
        array.getattr("flags")?.setattr("writeable", false)?;
        Ok(Self { session: header.session, frame: header.frame, client_time_ns: header.client_time_ns, state: array.into_any().unbind() })
    }
}

#[pymethods]
impl ObservedFrame {
    fn __repr__(&self) -> String {
        format!("<lumen.ObservedFrame session={} frame={}>", self.session, self.frame)
    }
}

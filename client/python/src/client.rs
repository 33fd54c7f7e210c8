//! `lumen.Client`, `lumen.Session`, `lumen.Observer`: the Rust client (`lumen_client`) with
//! NumPy arrays at the boundary.
//!
//! iceoryx2 ports belong to the thread that made them, so these classes are `unsendable`: use
//! each from the thread that created it (PyO3 raises `RuntimeError` otherwise).

use crate::errors;
use crate::reply::{ObservedFrame, Reply};
use lumen_client::{LocalOptions, Observed};
use numpy::ndarray::ArrayView1;
use numpy::{PyArray1, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use std::path::PathBuf;
use std::time::Duration;

/// Runs `f` without the GIL on this thread. `f` may hold `!Send` iceoryx2 state: `detach` runs
/// it on the calling thread and only lets other Python threads run meanwhile.
fn without_gil<T, F: FnOnce() -> T>(py: Python<'_>, f: F) -> T {
    struct OnThisThread<F>(F);
    // SAFETY: `Python::detach` calls the closure on the current thread before returning; the
    // value never crosses threads.
    unsafe impl<F> Send for OnThisThread<F> {}
    impl<F> OnThisThread<F> {
        fn into_inner(self) -> F {
            self.0
        }
    }
    let f = OnThisThread(f);
    let out = py.detach(move || OnThisThread(f.into_inner()()));
    out.into_inner()
}

fn seconds(timeout: f64) -> Duration {
    Duration::try_from_secs_f64(timeout.max(0.0)).unwrap_or(Duration::MAX)
}

/// A connection to the Lumen daemon (`lumen serve`): on this machine over iceoryx2 shared memory
/// (`Client.local`), or over the network with zenoh (`Client.zenoh`, `Client.zenoh_tls`).
///
/// A client, its sessions and its observers belong to the thread that made them.
#[pyclass(unsendable, module = "lumen")]
pub struct Client {
    inner: lumen_client::Client,
}

#[pymethods]
impl Client {
    /// A client of the daemon on this machine, over iceoryx2 shared memory. `prefix`: the
    /// daemon's `--prefix` (default: `LUMEN_IOX2_PREFIX`, else iceoryx2's default); `name`:
    /// shown by `lumen status`. Raises `NoDaemonError` when no daemon answers on that prefix.
    #[staticmethod]
    #[pyo3(signature = (prefix=None, name=None))]
    fn local(py: Python<'_>, prefix: Option<String>, name: Option<String>) -> PyResult<Self> {
        let name = Some(name.unwrap_or_else(|| "python".into()));
        let inner = lumen_client::Client::local_with(LocalOptions { prefix, name }).map_err(|e| errors::client(py, e))?;
        Ok(Self { inner })
    }

    /// A client of the daemon at a zenoh endpoint such as `"tcp/127.0.0.1:7447"`.
    #[staticmethod]
    #[pyo3(signature = (endpoint, name=None))]
    fn zenoh(py: Python<'_>, endpoint: &str, name: Option<String>) -> PyResult<Self> {
        let inner = without_gil(py, || lumen_client::Client::zenoh(endpoint)).map_err(|e| errors::client(py, e))?;
        Ok(Self { inner: inner.with_name(name.as_deref().unwrap_or("python")) })
    }

    /// A client of the daemon at a TLS endpoint such as `"tls/lab-server:7447"`, trusting the
    /// certificate authority in the PEM file `root_ca`.
    #[staticmethod]
    #[pyo3(signature = (endpoint, root_ca, name=None))]
    fn zenoh_tls(py: Python<'_>, endpoint: &str, root_ca: PathBuf, name: Option<String>) -> PyResult<Self> {
        let inner = without_gil(py, || lumen_client::Client::zenoh_tls(endpoint, &root_ca)).map_err(|e| errors::client(py, e))?;
        Ok(Self { inner: inner.with_name(name.as_deref().unwrap_or("python")) })
    }

    /// `"iceoryx2"` or `"zenoh"`.
    #[getter]
    fn transport(&self) -> String {
        self.inner.transport().to_string()
    }

    /// Opens a session for `spec` (JSON text or a dict). The daemon validates it: an invalid
    /// one raises `RefusedError` with `code == "spec"` and the daemon's reason.
    fn open_session(slf: Bound<'_, Self>, spec: &Bound<'_, PyAny>) -> PyResult<Session> {
        let py = slf.py();
        let spec = crate::spec_from(py, spec)?;
        let me = slf.borrow();
        let session = without_gil(py, || me.inner.open_session(&spec)).map_err(|e| errors::client(py, e))?;
        drop(me);
        Ok(Session { inner: Some(session), client: slf.unbind(), frame: None, handed_out: Vec::new(), closed: false })
    }

    /// Watches session `session` (of any client of this transport): its frames and replies.
    fn observe(&self, py: Python<'_>, session: u64) -> PyResult<Observer> {
        let observer = without_gil(py, || self.inner.observe(session)).map_err(|e| errors::client(py, e))?;
        Ok(Observer { inner: Some(observer) })
    }

    /// What the daemon knows of session `session`, as a dict (`session`, `transport`, `spec`,
    /// `floats`, `bodies`, `max_contacts`, channel names...).
    fn describe(&self, py: Python<'_>, session: u64) -> PyResult<Py<PyAny>> {
        let info = without_gil(py, || self.inner.describe(session)).map_err(|e| errors::client(py, e))?;
        crate::json_to_py(py, &serde_json::to_string(&info).expect("serialises"))
    }

    /// The daemon's status as a dict: `pid`, `version`, `uptime_s` and `sessions` (each with
    /// `session`, `client`, `frames`, `bad_frames`, `skipped`, `fps`, latencies, contacts).
    fn status(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let report = without_gil(py, || self.inner.status()).map_err(|e| errors::client(py, e))?;
        crate::json_to_py(py, &serde_json::to_string(&report).expect("serialises"))
    }

    fn __repr__(&self) -> String {
        format!("<lumen.Client transport={}>", self.inner.transport())
    }
}

/// One open scene on the daemon: fill a frame, submit it, read its contacts.
///
/// The zero-copy rule: `frame()` returns a writable float32 array over the frame itself (on
/// iceoryx2, the shared memory the daemon reads). It is valid only until `submit()`: then (or
/// on `close()`, or when the daemon is lost) it becomes read-only and its contents undefined, as
/// iceoryx2 lends a new buffer for each frame. Call `frame()` again for every frame; do not keep
/// frame arrays, and do not read one after its frame was submitted.
///
/// Frames are numbered from 0; each reply names the frame it answers. If the daemon goes away,
/// calls raise `DisconnectedError`: keep submitting, the session reopens by itself (new `id`,
/// same spec) once a daemon answers again. Use it as a context manager to close it.
#[pyclass(unsendable, module = "lumen")]
pub struct Session {
    /// Dropped on `close()` unless frame arrays (which point into its memory) are still alive.
    inner: Option<lumen_client::Session>,
    client: Py<Client>,
    /// The frame being written: a writable array over the frame, until `submit`.
    frame: Option<Py<PyAny>>,
    /// Weak references to the frame arrays handed out, to know whether any is still alive.
    handed_out: Vec<Py<PyAny>>,
    closed: bool,
}

impl Session {
    fn inner(&mut self, py: Python<'_>) -> PyResult<&mut lumen_client::Session> {
        match (&mut self.inner, self.closed) {
            (Some(s), false) => Ok(s),
            _ => Err(errors::closed(py, "session")),
        }
    }

    /// Makes the current frame array read-only and forgets it (its frame was sent, or lost).
    fn retire_frame(&mut self, py: Python<'_>) -> PyResult<()> {
        if let Some(a) = self.frame.take() {
            a.bind(py).getattr("flags")?.setattr("writeable", false)?;
        }
        Ok(())
    }

    /// A client error; a lost daemon also retires the frame array (its memory is gone).
    fn fail(&mut self, py: Python<'_>, e: lumen_client::Error) -> PyErr {
        if matches!(e, lumen_client::Error::Disconnected) {
            let _ = self.retire_frame(py);
        }
        errors::client(py, e)
    }

    /// Whether a frame array handed out is still referenced.
    fn arrays_alive(&mut self, py: Python<'_>) -> bool {
        self.handed_out.retain(|w| w.bind(py).call0().map(|o| !o.is_none()).unwrap_or(false));
        !self.handed_out.is_empty()
    }
}

#[pymethods]
impl Session {
    /// The session id (changes when the session reopens after a daemon restart).
    #[getter]
    fn id(&mut self, py: Python<'_>) -> PyResult<u64> {
        Ok(self.inner(py)?.id())
    }

    /// Floats per frame.
    #[getter]
    fn floats(&mut self, py: Python<'_>) -> PyResult<usize> {
        Ok(self.inner(py)?.layout().floats)
    }

    /// Where each body's floats start in a frame: one dict per body, in the spec's order, with
    /// `name`, `offset`, `points` and `spokes` (0 for a rod).
    #[getter]
    fn layout(&mut self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let s = self.inner(py)?;
        crate::layout_list(py, s.layout(), &s.info().spec.bodies)
    }

    /// Most contacts one reply carries.
    #[getter]
    fn max_contacts(&mut self, py: Python<'_>) -> PyResult<u32> {
        Ok(self.inner(py)?.info().max_contacts)
    }

    /// `"iceoryx2"` or `"zenoh"`.
    #[getter]
    fn transport(&mut self, py: Python<'_>) -> PyResult<String> {
        Ok(self.inner(py)?.info().transport.to_string())
    }

    /// How many times the session reopened after losing the daemon.
    #[getter]
    fn reconnects(&mut self, py: Python<'_>) -> PyResult<u64> {
        Ok(self.inner(py)?.reconnects())
    }

    /// Replies dropped because they answered a frame older than the newest submitted (late
    /// ones, after a wait for them timed out): `contacts` never returns another frame's reply.
    #[getter]
    fn stale_replies(&mut self, py: Python<'_>) -> PyResult<u64> {
        Ok(self.inner(py)?.stale_replies())
    }

    /// The number the next submitted frame will carry.
    #[getter]
    fn next_frame(&mut self, py: Python<'_>) -> PyResult<u64> {
        Ok(self.inner(py)?.next_frame_number())
    }

    /// Whether `close()` was called.
    #[getter]
    fn closed(&self) -> bool {
        self.closed
    }

    /// The frame to fill: a writable 1-D float32 array of `floats` values in the spec's layout,
    /// over the frame itself (iceoryx2: the shared memory the daemon reads; no copy). It holds
    /// stale data: write every value. Calling it again before `submit()` returns the same
    /// array. After `submit()` it is read-only and undefined: call `frame()` for the next one.
    fn frame(slf: Bound<'_, Self>) -> PyResult<Py<PyAny>> {
        let py = slf.py();
        let mut me = slf.borrow_mut();
        if let Some(a) = &me.frame {
            return Ok(a.clone_ref(py));
        }
        me.arrays_alive(py);
        let (ptr, len) = match me.inner(py)?.frame() {
            Ok(f) => (f.as_mut_ptr(), f.len()),
            Err(e) => return Err(me.fail(py, e)),
        };
        // SAFETY: `ptr` is the session's current frame of `len` floats, which stays mapped
        // while the `lumen_client::Session` lives; the array's base is this Session object, and
        // the Rust session is dropped only when no frame array is left (see `close`). The array
        // is made read-only when the frame is sent or lost, before the memory is reused.
        let view = unsafe { ArrayView1::from_shape_ptr(len, ptr as *const f32) };
        let array = unsafe { PyArray1::borrow_from_array(&view, slf.clone().into_any()) }.into_any();
        let weak = py.import("weakref")?.getattr("ref")?.call1((&array,))?;
        me.handed_out.push(weak.unbind());
        me.frame = Some(array.clone().unbind());
        Ok(array.unbind())
    }

    /// Sends the frame written through `frame()`; returns its frame number. The frame array
    /// becomes read-only. `client_time_ns` (default `lumen.now_ns()`) is echoed in the reply.
    #[pyo3(signature = (client_time_ns=None))]
    fn submit(&mut self, py: Python<'_>, client_time_ns: Option<u64>) -> PyResult<u64> {
        self.retire_frame(py)?;
        let result = self.inner(py)?.submit_with(|h| {
            if let Some(t) = client_time_ns {
                h.client_time_ns = t;
            }
        });
        result.map_err(|e| self.fail(py, e))
    }

    /// Copies `state` (float32, `floats` values, C-contiguous) into a frame and submits it
    /// (convenience: one copy); returns the frame number.
    #[pyo3(signature = (state, client_time_ns=None))]
    fn submit_state(slf: Bound<'_, Self>, state: PyReadonlyArrayDyn<'_, f32>, client_time_ns: Option<u64>) -> PyResult<u64> {
        let py = slf.py();
        let state = state.as_slice().map_err(|_| errors::make(py, "BadStateError", "the state must be a C-contiguous float32 array; pass numpy.ascontiguousarray(state, dtype=numpy.float32)", &[]))?;
        let floats = slf.borrow_mut().inner(py)?.layout().floats;
        if state.len() != floats {
            let message = format!("state has {} floats; the session's layout needs exactly {floats}", state.len());
            return Err(errors::make(py, "BadStateError", &message, &[]));
        }
        let mut me = slf.borrow_mut();
        me.retire_frame(py)?;
        let session = me.inner(py)?;
        let result = session.frame().map(|f| f.copy_from_slice(state)).and_then(|()| {
            session.submit_with(|h| {
                if let Some(t) = client_time_ns {
                    h.client_time_ns = t;
                }
            })
        });
        result.map_err(|e| me.fail(py, e))
    }

    /// The next reply, waiting up to `timeout` seconds (blocking, GIL released). Raises
    /// `lumen.TimeoutError` if none came (wait again or submit the next frame) and
    /// `DisconnectedError` if the daemon went away (keep submitting).
    #[pyo3(signature = (timeout=1.0))]
    fn contacts(&mut self, py: Python<'_>, timeout: f64) -> PyResult<Reply> {
        let session = self.inner(py)?;
        let got = without_gil(py, || session.contacts(seconds(timeout)).map(|v| (*v.header(), v.contacts().as_ptr() as usize, v.contacts().len())));
        match got {
            // SAFETY: the contacts stay in the session's reply buffer until its next call; we
            // hold `&mut self` and copy them now.
            Ok((header, ptr, len)) => Reply::new(py, &header, unsafe { std::slice::from_raw_parts(ptr as *const lumen_proto::Contact, len) }),
            Err(e) => Err(self.fail(py, e)),
        }
    }

    /// The next reply if one is there, else None (never waits).
    fn try_contacts(&mut self, py: Python<'_>) -> PyResult<Option<Reply>> {
        let got = match self.inner(py)?.try_contacts() {
            Ok(Some(v)) => Some(Reply::new(py, v.header(), v.contacts())?),
            Ok(None) => None,
            Err(e) => return Err(self.fail(py, e)),
        };
        Ok(got)
    }

    /// The daemon's description of the session, as a dict.
    fn info(&mut self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let info = serde_json::to_string(self.inner(py)?.info()).expect("serialises");
        crate::json_to_py(py, &info)
    }

    /// Ends the session: the daemon frees it now. The frame array becomes read-only; later calls
    /// raise `ClosedError`. Closing twice is a no-op.
    fn close(&mut self, py: Python<'_>) -> PyResult<()> {
        if self.closed {
            return Ok(());
        }
        self.retire_frame(py)?;
        self.closed = true;
        let Some(session) = self.inner.as_ref() else { return Ok(()) };
        // Tell the daemon (errors ignored: a daemon gone has nothing left to free).
        let _ = self.client.borrow(py).inner.request(&session.close_request());
        if !self.arrays_alive(py) {
            // No array points into its memory: drop the ports now (iceoryx2 publisher, zenoh
            // token). Otherwise they go when this object does (the arrays keep it alive).
            self.inner = None;
        }
        Ok(())
    }

    fn __enter__(slf: Bound<'_, Self>) -> Bound<'_, Self> {
        slf
    }

    #[pyo3(signature = (*_args))]
    fn __exit__(&mut self, py: Python<'_>, _args: &Bound<'_, pyo3::types::PyTuple>) -> PyResult<bool> {
        self.close(py)?;
        Ok(false)
    }

    fn __repr__(&self) -> String {
        match (&self.inner, self.closed) {
            (Some(s), false) => format!("<lumen.Session id={} transport={} floats={}>", s.id(), s.info().transport, s.layout().floats),
            _ => "<lumen.Session closed>".into(),
        }
    }
}

/// Watches a session's frames and replies (a viewer, a recorder) without slowing it: it sees
/// the newest frame, or every frame after `every_frame()`, and replies while it keeps up.
#[pyclass(unsendable, module = "lumen")]
pub struct Observer {
    inner: Option<lumen_client::Observer>,
}

#[pymethods]
impl Observer {
    /// The observed session's id.
    #[getter]
    fn session(&self, py: Python<'_>) -> PyResult<u64> {
        Ok(self.inner.as_ref().ok_or_else(|| errors::closed(py, "observer"))?.info().session)
    }

    /// Asks for every frame in the order sent rather than the newest (a recorder): over
    /// iceoryx2 the session keeps 16 frames for each observer, so one up to 16 frames behind
    /// loses none (frame numbers tell what it missed); over zenoh it changes nothing (an ask is
    /// answered with the newest frame).
    fn every_frame(&mut self, py: Python<'_>) -> PyResult<()> {
        self.inner.as_mut().ok_or_else(|| errors::closed(py, "observer"))?.every_frame();
        Ok(())
    }

    /// The next thing seen, waiting up to `timeout` seconds: an `ObservedFrame` (a copy of the
    /// frame) or a `Reply`. Raises `lumen.TimeoutError` if nothing came, and
    /// `SessionEndedError` once the session is gone.
    #[pyo3(signature = (timeout=1.0))]
    fn next(&mut self, py: Python<'_>, timeout: f64) -> PyResult<Py<PyAny>> {
        let observer = self.inner.as_mut().ok_or_else(|| errors::closed(py, "observer"))?;
        enum Seen {
            Frame(lumen_proto::wire::FrameHeader, usize, usize),
            Reply(Box<lumen_proto::wire::ContactsHeader>, usize, usize),
        }
        let seen = without_gil(py, || {
            observer.next(seconds(timeout)).map(|o| match o {
                Observed::Frame { header, state } => Seen::Frame(*header, state.as_ptr() as usize, state.len()),
                Observed::Contacts(v) => Seen::Reply(Box::new(*v.header()), v.contacts().as_ptr() as usize, v.contacts().len()),
            })
        });
        // SAFETY (both arms): what the observer saw stays in its buffers until its next call;
        // we hold `&mut self` and copy it now.
        match seen.map_err(|e| errors::client(py, e))? {
            Seen::Frame(h, ptr, len) => Ok(Py::new(py, ObservedFrame::new(py, &h, unsafe { std::slice::from_raw_parts(ptr as *const f32, len) })?)?.into_any()),
            Seen::Reply(h, ptr, len) => Ok(Py::new(py, Reply::new(py, &h, unsafe { std::slice::from_raw_parts(ptr as *const lumen_proto::Contact, len) })?)?.into_any()),
        }
    }

    /// Stops observing.
    fn close(&mut self) {
        self.inner = None;
    }

    fn __enter__(slf: Bound<'_, Self>) -> Bound<'_, Self> {
        slf
    }

    #[pyo3(signature = (*_args))]
    fn __exit__(&mut self, _args: &Bound<'_, pyo3::types::PyTuple>) -> bool {
        self.close();
        false
    }
}

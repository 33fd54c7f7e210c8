//! Rust errors as the typed exceptions of `lumen.errors` (defined in Python, so they can derive
//! from Python's own `TimeoutError`, `ConnectionError` and `ValueError` too).

use lumen_client::Error;
use lumen_proto::session::ErrorCode;
use lumen_proto::wire::NO_INDEX;
use lumen_proto::InputError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use pyo3::BoundObject;

/// An instance of `lumen.errors.<class>` with `message` and the keyword attributes `details`.
pub fn make(py: Python<'_>, class: &str, message: &str, details: &[(&str, Py<PyAny>)]) -> PyErr {
    let build = || -> PyResult<PyErr> {
        let cls = py.import("lumen.errors")?.getattr(class)?;
        let kwargs = PyDict::new(py);
        for (k, v) in details {
            kwargs.set_item(k, v)?;
        }
        Ok(PyErr::from_value(cls.call((message,), Some(&kwargs))?))
    };
    build().unwrap_or_else(|e| e)
}

fn obj<'py, T: IntoPyObject<'py>>(py: Python<'py>, v: T) -> Py<PyAny> {
    v.into_pyobject(py).map(|b| b.into_any().unbind()).unwrap_or_else(|_| py.None())
}

/// `None` for [`NO_INDEX`], else the index.
pub fn index(py: Python<'_>, v: u32) -> Py<PyAny> {
    if v == NO_INDEX {
        py.None()
    } else {
        obj(py, v)
    }
}

/// The daemon's error code as its JSON name (`"spec"`, `"limit"`, ...).
pub fn code_name(code: ErrorCode) -> String {
    serde_json::to_value(code).ok().and_then(|v| v.as_str().map(str::to_owned)).unwrap_or_else(|| format!("{code:?}"))
}

/// A client error as its exception.
pub fn client(py: Python<'_>, e: Error) -> PyErr {
    let message = e.to_string();
    match e {
        Error::NoDaemon { transport, .. } => make(py, "NoDaemonError", &message, &[("transport", obj(py, transport.to_string()))]),
        Error::Refused(c) => make(py, "RefusedError", &message, &[("code", obj(py, code_name(c.code))), ("reason", obj(py, c.message))]),
        Error::ObserversFull { .. } => make(py, "RefusedError", &message, &[("code", obj(py, code_name(ErrorCode::ObserversFull))), ("reason", obj(py, message.clone()))]),
        Error::Timeout(t) => make(py, "TimeoutError", &message, &[("timeout", obj(py, t.as_secs_f64()))]),
        Error::Disconnected => make(py, "DisconnectedError", &message, &[]),
        Error::NoFrame => make(py, "NoFrameError", &message, &[]),
        Error::SessionEnded(id) => make(py, "SessionEndedError", &message, &[("session", obj(py, id))]),
        Error::Transport(_) => make(py, "TransportError", &message, &[]),
        Error::Protocol(_) => make(py, "ProtocolError", &message, &[]),
        _ => make(py, "LumenError", &message, &[]),
    }
}

/// A refused state (embedded detection) as `BadStateError`, naming the body and where in it.
pub fn input(py: Python<'_>, e: &InputError, body_index: impl Fn(&str) -> Option<usize>) -> PyErr {
    let message = format!("{e}; the frame was not used (the detector's history is kept: fix the state and call detect again)");
    let (body, index, spoke): (Option<&str>, Option<usize>, Option<usize>) = match e {
        InputError::StateLength { .. } => (None, None, None),
        InputError::NonFinitePoint { body, point, .. } => (Some(body), Some(*point), None),
        InputError::NonFiniteSpoke { body, ring, spoke, .. } => (Some(body), Some(*ring), Some(*spoke)),
        InputError::NotStarShaped { body, ring, spoke, .. } => (Some(body), Some(*ring), Some(*spoke)),
        InputError::OutOfRangePoint { body, point, .. } => (Some(body), Some(*point), None),
        InputError::OutOfRangeSpoke { body, ring, spoke, .. } => (Some(body), Some(*ring), Some(*spoke)),
        InputError::NonFiniteResult { body, sample } => (Some(body), Some(*sample), None),
    };
    let details = [("body", obj(py, body)), ("body_index", obj(py, body.and_then(body_index))), ("index", obj(py, index)), ("spoke", obj(py, spoke))];
    make(py, "BadStateError", &message, &details)
}

/// A spec that cannot be used, as `SpecError`.
pub fn spec(py: Python<'_>, what: impl std::fmt::Display) -> PyErr {
    make(py, "SpecError", &format!("invalid scene spec: {what}; see proto/README.md for the format"), &[])
}

/// A call on a closed session or observer.
pub fn closed(py: Python<'_>, what: &str) -> PyErr {
    make(py, "ClosedError", &format!("this {what} is closed; open a new one"), &[])
}

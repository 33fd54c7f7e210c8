//! `lumen._lumen`, the native half of the `lumen` Python package (built by maturin from
//! `client/python/pyproject.toml`; the Python half is in `python/lumen/`).
//!
//! One implementation of the protocol: the classes wrap [`lumen_client`] (sessions, observers,
//! over iceoryx2 or zenoh) and [`lumen_detect::Detector`] (embedded detection), with NumPy
//! arrays at the boundary: a session's frame is a float32 array over the frame itself (zero
//! copy on iceoryx2), contacts come back as structured arrays of the 88-byte wire record
//! (one copy). Errors become the typed exceptions of `lumen.errors`.

use lumen_proto::{BodySpec, SceneSpec, StateLayout};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyString};

mod client;
mod detector;
mod errors;
mod reply;

/// A scene spec from JSON text or from a JSON-like object (dict), as `SpecError` if it does
/// not parse.
pub(crate) fn spec_from(py: Python<'_>, spec: &Bound<'_, PyAny>) -> PyResult<SceneSpec> {
    let text: String = match spec.cast::<PyString>() {
        Ok(s) => s.extract()?,
        Err(_) => py.import("json")?.getattr("dumps")?.call1((spec,)).map_err(|e| errors::spec(py, format!("not JSON-serialisable ({e})")))?.extract()?,
    };
    serde_json::from_str(&text).map_err(|e| errors::spec(py, e))
}

/// JSON text as Python objects (`json.loads`).
pub(crate) fn json_to_py(py: Python<'_>, text: &str) -> PyResult<Py<PyAny>> {
    Ok(py.import("json")?.getattr("loads")?.call1((text,))?.unbind())
}

/// A state layout as a list of dicts: `name`, `offset`, `points`, `spokes` per body.
pub(crate) fn layout_list(py: Python<'_>, layout: &StateLayout, bodies: &[BodySpec]) -> PyResult<Py<PyAny>> {
    let list = PyList::empty(py);
    for (b, spec) in layout.bodies.iter().zip(bodies) {
        let d = PyDict::new(py);
        d.set_item("name", &spec.name)?;
        d.set_item("offset", b.offset)?;
        d.set_item("points", b.points)?;
        d.set_item("spokes", b.spokes)?;
        list.append(d)?;
    }
    Ok(list.into_any().unbind())
}

/// The contact record's fields as `(name, numpy format, byte offset)`, from the Rust struct.
#[pyfunction]
fn contact_fields() -> Vec<(&'static str, &'static str, usize)> {
    reply::contact_fields()
}

/// Nanoseconds on this process's monotonic clock: what `submit()` stamps a frame with; a
/// reply echoes it, so `now_ns() - reply.client_time_ns` is the round trip.
#[pyfunction]
fn now_ns() -> u64 {
    lumen_client::now_ns()
}

#[pymodule]
#[pyo3(name = "_lumen")]
fn lumen_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<client::Client>()?;
    m.add_class::<client::Session>()?;
    m.add_class::<client::Observer>()?;
    m.add_class::<reply::Reply>()?;
    m.add_class::<reply::ObservedFrame>()?;
    m.add_class::<detector::Detector>()?;
    m.add_function(wrap_pyfunction!(contact_fields, m)?)?;
    m.add_function(wrap_pyfunction!(now_ns, m)?)?;
    m.add("CONTACT_BYTES", std::mem::size_of::<lumen_proto::Contact>())?;
    m.add("PROTOCOL_VERSION", lumen_proto::wire::PROTOCOL_VERSION)?;
    m.add("NO_INDEX", lumen_proto::wire::NO_INDEX)?;
    m.add("NO_SPOKE", lumen_proto::contact::NO_SPOKE)?;
    m.add("FLAG_NOT_STAR", lumen_proto::contact::FLAG_NOT_STAR)?;
    m.add("FLAG_OUTSIDE", lumen_proto::contact::FLAG_OUTSIDE)?;
    m.add("FLAG_OTHER_WALL", lumen_proto::contact::FLAG_OTHER_WALL)?;
    m.add("MAX_OTHER_WALLS", lumen_proto::limits::MAX_OTHER_WALLS)?;
    m.add("KIND_INTERIOR", lumen_proto::ContactKind::Interior as u8)?;
    m.add("KIND_EXTERIOR", lumen_proto::ContactKind::Exterior as u8)?;
    m.add("KIND_SELF", lumen_proto::ContactKind::SelfContact as u8)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

//! `lumen.Detector`: embedded detection, no daemon.

use crate::errors;
use crate::reply::contacts_array;
use lumen_proto::ValidScene;
use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;

/// Embedded detection for one scene, in this process (no daemon): feed it the frames of one
/// simulation in order (it keeps each rod sample's place from frame to frame).
///
/// `Detector(spec)`: `spec` is the scene spec as JSON text or as a dict (the format of
/// proto/README.md: `bodies`, `pairs`, optional `precision`, `alpha`, `margin`, `method`,
/// `nearest`, `refine`); an invalid one raises `lumen.SpecError`.
///
/// One thread at a time may use a detector; `detect` releases the GIL while it runs.
#[pyclass(module = "lumen")]
pub struct Detector {
    detector: lumen_detect::Detector,
    scene: ValidScene,
}

#[pymethods]
impl Detector {
    #[new]
    fn new(py: Python<'_>, spec: &Bound<'_, PyAny>) -> PyResult<Self> {
        let spec = crate::spec_from(py, spec)?;
        let scene = spec.validate().map_err(|e| errors::spec(py, e))?;
        Ok(Self { detector: lumen_detect::Detector::new(&scene), scene })
    }

    /// Floats of one frame's state (per tube `rings * (spokes + 1) * 3`, per rod `points * 3`,
    /// in the spec's order of bodies).
    #[getter]
    fn floats(&self) -> usize {
        self.detector.layout().floats
    }

    /// Where each body's floats start: one dict per body, in the spec's order, with `name`,
    /// `offset`, `points` and `spokes` (0 for a rod).
    #[getter]
    fn layout(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        crate::layout_list(py, self.detector.layout(), &self.scene.spec().bodies)
    }

    /// The spec as validated, as a dict (defaults filled in).
    #[getter]
    fn spec(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        crate::json_to_py(py, &serde_json::to_string(self.scene.spec()).expect("a spec serialises"))
    }

    /// One frame's contacts as a new structured array of `lumen.CONTACT_DTYPE` (ordered by
    /// pair, then rod sample). `state`: `floats` float32 values, C-contiguous (any shape); a
    /// wrong length or a non-finite value raises `lumen.BadStateError` (naming the body and
    /// where) and leaves the detector's history as it was.
    fn detect<'py>(&mut self, py: Python<'py>, state: PyReadonlyArrayDyn<'py, f32>) -> PyResult<Bound<'py, PyAny>> {
        let state = state.as_slice().map_err(|_| errors::make(py, "BadStateError", "the state must be a C-contiguous float32 array; pass numpy.ascontiguousarray(state, dtype=numpy.float32)", &[]))?;
        let detector = &mut self.detector;
        let found = py.detach(move || detector.detect(state).map(|c| (c.as_ptr() as usize, c.len())));
        match found {
            Ok((ptr, len)) => {
                // SAFETY: the contacts live in `self.detector`, which nothing has touched since
                // `detect` returned them (we hold `&mut self`).
                let contacts = unsafe { std::slice::from_raw_parts(ptr as *const lumen_proto::Contact, len) };
                contacts_array(py, contacts)
            }
            Err(e) => Err(errors::input(py, &e, |name| self.scene.spec().bodies.iter().position(|b| b.name == name))),
        }
    }

    fn __repr__(&self) -> String {
        format!("<lumen.Detector bodies={} floats={}>", self.scene.spec().bodies.len(), self.floats())
    }
}

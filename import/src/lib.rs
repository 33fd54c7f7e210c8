//! Real colons: a tube model from a triangle surface and a midline.
//!
//! 1. [`load_mesh`] reads the surface (OBJ; STL binary or ASCII; PLY ASCII or binary; legacy
//!    VTK polydata, ASCII or BINARY; VTK XML polydata `.vtp`) and [`load_centerline`] the
//!    midline (CSV, or JSON: point arrays, objects with `x`, `y`, `z`, 3D Slicer markups).
//! 2. [`build_tube`] resamples the midline every `ring_spacing` along its arc (after a light
//!    Gaussian smoothing of its points), smooths its tangents (CT midlines are noisy and ring
//!    planes follow the tangent), and carries a rotation-minimising frame `(n, b)` along it. At
//!    each ring it casts `spokes` rays in the ring's plane, from the midline point, with parry3d
//!    against the surface's `TriMesh`, and keeps the first wall hit as the radial vector. It
//!    does so at each width of tangent smoothing of a ladder and keeps the slicing whose wall is
//!    truest to the surface with the fewest spokes reaching into another ring's section, which
//!    it clips ([`slice`]): every tube it builds passes the fold check.
//! 3. Rays that do not give the ring's own wall are **repaired, and counted by kind** in the
//!    [`ImportReport`] (never silently): rays that miss; rays whose first hit is a wall seen from
//!    outside; rays that reach a *neighbouring loop* where the colon touches itself and the
//!    surface has a gap (the hit point is much nearer a part of the midline far along the arc
//!    than its own ring's point, and in that part's sight: no wall between them); and outliers
//!    (a jump against the same spoke of both neighbouring rings, or a run of spokes stepping up
//!    from its ring's neighbouring spokes and back down). A hit far from the ring's point but
//!    continuous with its neighbours is the ring's own wall (a midline off the lumen's centre, a
//!    pocket): it is kept. A repaired spoke is interpolated from the
//!    nearest kept spokes of its ring when the gap is at most a quarter turn, else set to the
//!    ring's median (rings with too few kept rays borrow the median of the nearest good rings).
//! 4. `inflate` scales every radial vector: the GCA scan was not insufflated, and `inflate = 2`
//!    turns its collapsed lumen (median radius about 9.4 mm) into a colonoscopy lumen.
//! 5. The surface's orientation is read from the midline (the side most first hits see is the
//!    inside; a surface whose normals face its lumen is read flipped), doubled walls are
//!    counted, and the wall (before inflation) is measured against the surface
//!    ([`fidelity`]). [`quality::assess`] turns the report into named problems with the rings
//!    they touch; `lumen import` refuses a model with any, and [`import`] (the one way in for
//!    the scenes, benchmarks and simulation) returns them as [`ImportError::Refused`].
//!
//! Radial vectors run counter-clockwise about the midline's tangent, spoke 0 along the frame's
//! normal, as in [`crate::colon`].
//!
//! ## Modules
//! - [`mesh`] and [`centerline`]: the file formats.
//! - [`units`]: mm, cm, m, um or voxel coordinates to mm.
//! - [`build`]: rings, ray casts and repairs.
//! - [`fidelity`]: the imported wall's distance to the surface.
//! - [`quality`]: thresholds on the report, and the problems they find.
//! - [`fit`]: where the lumen is narrower than a scope.
//! - [`slice`]: the ring planes' widths tried, and which slicing is kept.
//! - [`geom`]: arc length, smoothing along the arc, rotation-minimising frames (f64).
//! - [`probe`]: tube coordinates for checks (where a point is along a tube, its distance to
//!   the midline and to the wall), and [`probe::clearance`] (wall overlap, bend tightness).

pub mod axis;
pub mod build;
pub mod centerline;
pub mod fidelity;
pub mod fit;
pub mod geom;
pub mod mesh;
pub mod probe;
pub mod quality;
pub mod slice;
pub mod units;

pub use build::{build_tube, ImportParams, ImportReport, Retraced, RingTally, GCA_INFLATE, MAX_AUTO_SPOKES, RETRACE_GAIN, SPOKES_STEP};
pub use centerline::{load_centerline, load_centerline_csv, parse_centerline_csv, parse_centerline_json, write_centerline_csv, Centerline};
pub use mesh::{load_mesh, parse_obj, parse_ply, parse_stl, parse_vtk, parse_vtp, write_obj, Mesh, SURFACE_FORMATS};
pub use quality::{assess, Cause, Problem, Thresholds};
pub use units::Unit;

use thiserror::Error;

/// A file that cannot be read or a model that cannot be built.
#[derive(Debug, Error)]
pub enum ImportError {
    #[error("{0}: {1}")]
    Io(String, #[source] std::io::Error),
    #[error("{file}: line {line}: {message}")]
    Parse { file: String, line: usize, message: String },
    /// A file that is wrong as a whole or at a place that is not a text line (an item of binary
    /// data, a JSON point): the message names the place.
    #[error("{file}: {message}")]
    Format { file: String, message: String },
    #[error("{0}")]
    Invalid(String),
    /// An [`ImportParams`] field out of range: which one (as `ImportParams` names it, less the
    /// unit), its value, and what it must be.
    #[error("{name} {value}: expected {expected}")]
    Param { name: &'static str, value: String, expected: String },
    /// The model was built but fails the quality gate ([`quality::assess`] or
    /// [`quality::check_tube`]): every problem, with its cause and rings.
    #[error("the model is refused: {}", .problems.iter().map(ToString::to_string).collect::<Vec<_>>().join("; "))]
    Refused { problems: Vec<Problem> },
}

/// [`build_tube`] behind the quality gate: the tube and its report when [`assess`] finds no
/// problem under the default [`Thresholds`], else [`ImportError::Refused`] with every problem.
/// Every colon that enters Lumen from a surface (the `gca` scene, the benchmarks, the
/// simulation) comes through here; `lumen import --force` is the one way past it.
pub fn import(mesh: &Mesh, centerline: &Centerline, params: &ImportParams) -> Result<(lumen_detect::Tube, ImportReport), ImportError> {
    let (tube, report) = build_tube(mesh, centerline, params)?;
    refused(assess(&report, &Thresholds::default()))?;
    Ok((tube, report))
}

/// A tube from a model file (or anywhere but [`import`]) behind the gate's checks on the tube
/// alone ([`quality::check_tube`]): a model that folds is refused with its rings.
pub fn check(tube: &lumen_detect::Tube) -> Result<(), ImportError> {
    refused(quality::check_tube(tube))
}

/// The gate's verdict: [`ImportError::Refused`] with the problems, if there are any.
fn refused(problems: Vec<Problem>) -> Result<(), ImportError> {
    if problems.is_empty() {
        Ok(())
    } else {
        Err(ImportError::Refused { problems })
    }
}

impl ImportError {
    /// Names `path` in a parse error from a `parse_*` function (which does not know the file).
    pub(crate) fn in_file(self, path: &std::path::Path) -> Self {
        let file = path.display().to_string();
        match self {
            ImportError::Parse { line, message, .. } => ImportError::Parse { file, line, message },
            ImportError::Format { message, .. } => ImportError::Format { file, message },
            other => other,
        }
    }
}

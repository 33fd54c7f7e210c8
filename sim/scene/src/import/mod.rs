//! Real colons: a tube model from a triangle surface and a midline.
//!
//! 1. [`load_mesh`] reads the surface (OBJ, STL binary or ASCII) and [`load_centerline_csv`]
//!    the midline.
//! 2. [`build_tube`] resamples the midline every `ring_spacing` along its arc (after a light
//!    Gaussian smoothing of its points), smooths its tangents (CT midlines are noisy and ring
//!    planes follow the tangent), and carries a rotation-minimising frame `(n, b)` along it. At
//!    each ring it casts `spokes` rays in the ring's plane, from the midline point, with parry3d
//!    against the surface's `TriMesh`, and keeps the first wall hit as the radial vector.
//! 3. Rays that do not give the ring's own wall are **repaired, and counted by kind** in the
//!    [`ImportReport`] (never silently): rays that miss; rays whose first hit is a wall seen from
//!    outside; rays that reach a *neighbouring loop* where the colon touches itself and the
//!    surface has a gap (the hit point is much nearer a part of the midline far along the arc
//!    than its own ring's point); and outliers (far above the ring's median, or a jump against
//!    the same spoke of both neighbouring rings). A repaired spoke is interpolated from the
//!    nearest kept spokes of its ring when the gap is at most a quarter turn, else set to the
//!    ring's median (rings with too few kept rays borrow the median of the nearest good rings).
//! 4. `inflate` scales every radial vector: the GCA scan was not insufflated, and `inflate = 2`
//!    turns its collapsed lumen (median radius about 9.4 mm) into a colonoscopy lumen.
//!
//! Radial vectors run counter-clockwise about the midline's tangent, spoke 0 along the frame's
//! normal, as in [`crate::colon`].
//!
//! ## The GCA colon
//! [`gca_paths`] finds `colon_20k_mm.obj` and `centerline_mm.csv` of the Edinburgh Gut Cell
//! Atlas model EdinGCA_3D_00090, by default in `../shared/data/colon-gca00090/` next to the
//! workspace. The data is CC BY 4.0; wherever it, or anything derived from it, is shown, credit
//! it with [`gca_attribution`]: "Edinburgh Gut Cell Atlas models (Comparative-Pathology/GCA-Models),
//! CC BY 4.0, doi:10.1186/s12911-023-02111-9".

mod build;
mod centerline;
mod mesh;

pub use build::{build_tube, ImportParams, ImportReport, GCA_INFLATE, GCA_TANGENT_SMOOTHING_MM};
pub use centerline::{load_centerline_csv, parse_centerline_csv, Centerline};
pub use mesh::{load_mesh, parse_obj, parse_stl, Mesh};

use std::path::{Path, PathBuf};
use thiserror::Error;

/// A file that cannot be read or a model that cannot be built.
#[derive(Debug, Error)]
pub enum ImportError {
    #[error("{0}: {1}")]
    Io(String, #[source] std::io::Error),
    #[error("{file}: line {line}: {message}")]
    Parse { file: String, line: usize, message: String },
    #[error("{0}")]
    Invalid(String),
    /// An [`ImportParams`] field out of range: which one (as `ImportParams` names it, less the
    /// unit), its value, and what it must be.
    #[error("{name} {value}: expected {expected}")]
    Param { name: &'static str, value: String, expected: String },
}

/// The attribution the GCA data's licence (CC BY 4.0) requires wherever the data or results
/// derived from it are shown.
pub const fn gca_attribution() -> &'static str {
    "Edinburgh Gut Cell Atlas models (Comparative-Pathology/GCA-Models), CC BY 4.0, doi:10.1186/s12911-023-02111-9"
}

/// File names of the GCA colon.
pub const GCA_MESH: &str = "colon_20k_mm.obj";
pub const GCA_CENTERLINE: &str = "centerline_mm.csv";

/// The default GCA data folder: `../shared/data/colon-gca00090` relative to the workspace root.
pub fn gca_default_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/colon-gca00090")
}

/// Finds the GCA colon's surface and midline: in `data` if given, else in
/// [`gca_default_dir`]. The error names the folder and the missing files.
pub fn gca_paths(data: Option<&Path>) -> Result<(PathBuf, PathBuf), String> {
    let dir = data.map(Path::to_path_buf).unwrap_or_else(gca_default_dir);
    let shown = dir.canonicalize().unwrap_or_else(|_| dir.clone());
    let (mesh, line) = (dir.join(GCA_MESH), dir.join(GCA_CENTERLINE));
    let missing: Vec<&str> = [(&mesh, GCA_MESH), (&line, GCA_CENTERLINE)].iter().filter(|(p, _)| !p.is_file()).map(|(_, n)| *n).collect();
    if missing.is_empty() {
        Ok((mesh, line))
    } else {
        Err(format!(
            "the GCA colon (EdinGCA_3D_00090) is not available: {} not found in {}{}",
            missing.join(" and "),
            shown.display(),
            if data.is_none() { " (the default location, ../shared/data/colon-gca00090 next to the workspace; pass a folder holding both files to use another)" } else { "" }
        ))
    }
}

//! The real colon: the Edinburgh Gut Cell Atlas model EdinGCA_3D_00090 (surface and midline in
//! millimetres, CC BY 4.0), imported through `lumen-import` with [`ImportParams::gca`].
//!
//! [`paths`] finds `colon_20k_mm.obj` and `centerline_mm.csv`, by default in
//! `../shared/data/colon-gca00090/` next to the workspace; [`load`] builds the tube. Wherever
//! the data or anything derived from it is shown, credit it with [`attribution`].

use lumen_detect::Tube;
use lumen_import::{import, load_centerline_csv, load_mesh, Centerline, ImportError, ImportParams, ImportReport, Mesh};
use std::path::{Path, PathBuf};

/// File name of the GCA colon's surface.
pub const MESH: &str = "colon_20k_mm.obj";
/// File name of the GCA colon's midline.
pub const CENTERLINE: &str = "centerline_mm.csv";

/// Why the GCA colon could not be had.
#[derive(Debug, thiserror::Error)]
pub enum GcaError {
    /// Its files are not in the folder.
    #[error("the GCA colon (EdinGCA_3D_00090) is not available: {missing} not found in {dir}{hint}", dir = dir.display(), hint = if *default { " (the default location, ../shared/data/colon-gca00090 next to the workspace; pass a folder holding both files to use another)" } else { "" })]
    Missing { missing: String, dir: PathBuf, default: bool },
    /// A file could not be read or the tube not built.
    #[error(transparent)]
    Import(#[from] ImportError),
}

/// The attribution the GCA data's licence (CC BY 4.0) requires wherever the data or results
/// derived from it are shown.
pub const fn attribution() -> &'static str {
    "Edinburgh Gut Cell Atlas models (Comparative-Pathology/GCA-Models), CC BY 4.0, doi:10.1186/s12911-023-02111-9"
}

/// The default data folder: `../shared/data/colon-gca00090` beside the workspace.
pub fn default_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/colon-gca00090")
}

/// The surface and midline files: in `data` if given, else in [`default_dir`]. The error names
/// the folder and the missing files.
pub fn paths(data: Option<&Path>) -> Result<(PathBuf, PathBuf), GcaError> {
    let dir = data.map(Path::to_path_buf).unwrap_or_else(default_dir);
    let shown = dir.canonicalize().unwrap_or_else(|_| dir.clone());
    let (mesh, line) = (dir.join(MESH), dir.join(CENTERLINE));
    let missing: Vec<&str> = [(&mesh, MESH), (&line, CENTERLINE)].iter().filter(|(p, _)| !p.is_file()).map(|(_, n)| *n).collect();
    if missing.is_empty() {
        Ok((mesh, line))
    } else {
        Err(GcaError::Missing { missing: missing.join(" and "), dir: shown, default: data.is_none() })
    }
}

/// The GCA colon's surface and midline, read once, to import at any parameters.
pub struct Source {
    pub mesh: Mesh,
    pub line: Centerline,
}

impl Source {
    /// Reads the files from `data` (see [`paths`]).
    pub fn read(data: Option<&Path>) -> Result<Self, GcaError> {
        let (mesh, line) = paths(data)?;
        Ok(Self { mesh: load_mesh(&mesh)?, line: load_centerline_csv(&line)? })
    }

    /// The tube imported with `params`, and what the import repaired, behind the quality gate
    /// ([`lumen_import::import`]: the same import and verdict as `lumen import`).
    pub fn tube(&self, params: &ImportParams) -> Result<(Tube, ImportReport), ImportError> {
        import(&self.mesh, &self.line, params)
    }
}

/// The GCA colon from `data` (see [`paths`]) imported with [`ImportParams::gca`] at inflation
/// `inflate` (the scan is not insufflated; [`lumen_import::GCA_INFLATE`] is the default).
pub fn load(data: Option<&Path>, inflate: f32) -> Result<Tube, GcaError> {
    let params = ImportParams { inflate, ..ImportParams::gca() };
    Ok(Source::read(data)?.tube(&params)?.0)
}

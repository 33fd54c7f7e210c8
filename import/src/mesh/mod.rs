//! Triangle surfaces from OBJ and STL files.

mod obj;
mod stl;

pub use obj::parse_obj;
pub use stl::parse_stl;
use stl::is_binary_stl;

use crate::ImportError;
use std::path::Path;

/// An indexed triangle surface.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    pub vertices: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// Axis-aligned bounds `(min, max)`; zeros when empty.
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        if self.vertices.is_empty() {
            return ([0.0; 3], [0.0; 3]);
        }
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for v in &self.vertices {
            for d in 0..3 {
                lo[d] = lo[d].min(v[d]);
                hi[d] = hi[d].max(v[d]);
            }
        }
        (lo, hi)
    }

    /// Signed volume (positive when the triangles face outwards, for a closed surface).
    pub fn signed_volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i as usize].map(|x| x as f64));
                (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0
            })
            .sum()
    }
}

/// Loads an OBJ (`.obj`) or STL (`.stl`, binary or ASCII) surface; other extensions are
/// sniffed by content.
pub fn load_mesh(path: impl AsRef<Path>) -> Result<Mesh, ImportError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| ImportError::Io(path.display().to_string(), e))?;
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    let mesh = match ext.as_deref() {
        Some("obj") => parse_obj(&String::from_utf8_lossy(&bytes)),
        Some("stl") => parse_stl(&bytes),
        _ => {
            if is_binary_stl(&bytes) || bytes.starts_with(b"solid") {
                parse_stl(&bytes)
            } else {
                parse_obj(&String::from_utf8_lossy(&bytes))
            }
        }
    };
    mesh.map_err(|e| match e {
        ImportError::Parse { line, message, .. } => ImportError::Parse { file: path.display().to_string(), line, message },
        other => other,
    })
}

pub(crate) fn perr(line: usize, message: impl Into<String>) -> ImportError {
    ImportError::Parse { file: String::new(), line, message: message.into() }
}

pub(crate) fn num(tok: Option<&str>, line: usize, what: &str) -> Result<f32, ImportError> {
    let t = tok.ok_or_else(|| perr(line, format!("missing {what}")))?;
    let v: f32 = t.parse().map_err(|_| perr(line, format!("{what}: not a number: {t:?}")))?;
    if !v.is_finite() {
        return Err(perr(line, format!("{what} is not finite: {t}")));
    }
    Ok(v)
}

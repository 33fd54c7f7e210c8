//! Triangle surfaces from files: OBJ, STL, PLY, legacy VTK and VTK XML polydata, one module
//! per format, and [`load_mesh`], which picks the reader by extension or content.

mod obj;
mod ply;
mod stl;
mod vtk;
mod vtp;

pub use obj::{parse_obj, write_obj};
pub use ply::parse_ply;
use stl::is_binary_stl;
pub use stl::parse_stl;
pub use vtk::parse_vtk;
pub use vtp::parse_vtp;

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

/// The surface formats [`load_mesh`] reads, as its error for any other file lists them.
pub const SURFACE_FORMATS: &str = "OBJ (.obj), STL binary or ASCII (.stl), PLY ASCII or binary (.ply), legacy VTK polydata (.vtk), VTK XML polydata (.vtp)";

/// Loads a triangle surface, by extension: `.obj`, `.stl`, `.ply`, `.vtk` (legacy polydata) and
/// `.vtp` (XML polydata). Other files are sniffed by content: `ply` magic, `# vtk DataFile`,
/// `<?xml` or `<VTKFile`, a binary STL's size, `solid`, else OBJ when some line is a `v` or `f`
/// line. Errors name the file; a file that is none of these lists [`SURFACE_FORMATS`].
pub fn load_mesh(path: impl AsRef<Path>) -> Result<Mesh, ImportError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| ImportError::Io(path.display().to_string(), e))?;
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    let format = match ext.as_deref() {
        Some("obj") => Some(Format::Obj),
        Some("stl") => Some(Format::Stl),
        Some("ply") => Some(Format::Ply),
        Some("vtk") => Some(Format::Vtk),
        Some("vtp") => Some(Format::Vtp),
        _ => sniff(&bytes),
    };
    let mesh = match format {
        Some(Format::Obj) => parse_obj(&String::from_utf8_lossy(&bytes)),
        Some(Format::Stl) => parse_stl(&bytes),
        Some(Format::Ply) => parse_ply(&bytes),
        Some(Format::Vtk) => parse_vtk(&bytes),
        Some(Format::Vtp) => parse_vtp(&bytes),
        None => Err(ferr(format!("not a surface format this reads; supported are {SURFACE_FORMATS}"))),
    };
    mesh.map_err(|e| e.in_file(path))
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Format {
    Obj,
    Stl,
    Ply,
    Vtk,
    Vtp,
}

/// The format of a file by its first bytes (for files without a known extension).
fn sniff(bytes: &[u8]) -> Option<Format> {
    let head = &bytes[..bytes.len().min(256)];
    let trimmed = head.trim_ascii_start();
    if head.starts_with(b"ply\n") || head.starts_with(b"ply\r\n") {
        Some(Format::Ply)
    } else if head.starts_with(b"# vtk DataFile") {
        Some(Format::Vtk)
    } else if trimmed.starts_with(b"<?xml") || trimmed.starts_with(b"<VTKFile") {
        Some(Format::Vtp)
    } else if is_binary_stl(bytes) || trimmed.starts_with(b"solid") {
        Some(Format::Stl)
    } else if std::str::from_utf8(bytes).is_ok_and(|t| t.lines().any(|l| matches!(l.split_whitespace().next(), Some("v" | "f")))) {
        Some(Format::Obj)
    } else {
        None
    }
}

/// An error about the file as a whole or a place in binary data (the caller names the file).
pub(crate) fn ferr(message: impl Into<String>) -> ImportError {
    ImportError::Format { file: String::new(), message: message.into() }
}

/// The error for a surface without triangles, the same from every reader.
pub(crate) fn no_triangles() -> ImportError {
    ferr("no triangles")
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

/// A number type of binary data (PLY, VTK and VTP each name them their own way).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Num {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Num {
    pub(crate) fn size(self) -> usize {
        use Num::*;
        match self {
            I8 | U8 => 1,
            I16 | U16 => 2,
            I32 | U32 | F32 => 4,
            I64 | U64 | F64 => 8,
        }
    }

    pub(crate) fn is_integer(self) -> bool {
        !matches!(self, Num::F32 | Num::F64)
    }

    /// The value in `b` (exactly `size` bytes), big- or little-endian.
    pub(crate) fn read(self, b: &[u8], big: bool) -> f64 {
        use Num::*;
        macro_rules! get {
            ($t:ty) => {{
                let a = b.try_into().expect("size bytes");
                (if big { <$t>::from_be_bytes(a) } else { <$t>::from_le_bytes(a) }) as f64
            }};
        }
        match self {
            I8 => b[0] as i8 as f64,
            U8 => b[0] as f64,
            I16 => get!(i16),
            U16 => get!(u16),
            I32 => get!(i32),
            U32 => get!(u32),
            I64 => get!(i64),
            U64 => get!(u64),
            F32 => get!(f32),
            F64 => get!(f64),
        }
    }
}

/// Adds a polygon, fanned from its first vertex (as OBJ faces are).
pub(crate) fn push_polygon(tris: &mut Vec<[u32; 3]>, poly: &[u32]) {
    for k in 1..poly.len().saturating_sub(1) {
        tris.push([poly[0], poly[k], poly[k + 1]]);
    }
}

/// Adds a triangle strip: triangle `k` is `(s[k], s[k+1], s[k+2])`, with its first two vertices
/// swapped when `k` is odd so that every triangle keeps the strip's winding; degenerate
/// triangles (strips are joined by repeating a vertex) are dropped.
pub(crate) fn push_strip(tris: &mut Vec<[u32; 3]>, s: &[u32]) {
    for k in 0..s.len().saturating_sub(2) {
        let t = if k % 2 == 0 { [s[k], s[k + 1], s[k + 2]] } else { [s[k + 1], s[k], s[k + 2]] };
        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
            tris.push(t);
        }
    }
}

//! Triangle surfaces from OBJ and STL files.

use crate::ImportError;
use std::collections::HashMap;
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

fn perr(line: usize, message: impl Into<String>) -> ImportError {
    ImportError::Parse { file: String::new(), line, message: message.into() }
}

fn num(tok: Option<&str>, line: usize, what: &str) -> Result<f32, ImportError> {
    let t = tok.ok_or_else(|| perr(line, format!("missing {what}")))?;
    let v: f32 = t.parse().map_err(|_| perr(line, format!("{what}: not a number: {t:?}")))?;
    if !v.is_finite() {
        return Err(perr(line, format!("{what} is not finite: {t}")));
    }
    Ok(v)
}

/// Parses Wavefront OBJ text: `v x y z [w]` and `f` lines (indices 1-based or negative, in the
/// forms `i`, `i/t`, `i/t/n`, `i//n`); polygons are fanned from their first vertex; every other
/// line (normals, texture coordinates, groups, materials, comments) is ignored.
pub fn parse_obj(text: &str) -> Result<Mesh, ImportError> {
    let mut m = Mesh::default();
    for (ln, raw) in text.lines().enumerate() {
        let line = ln + 1;
        let s = raw.split('#').next().unwrap_or("").trim();
        let mut it = s.split_whitespace();
        match it.next() {
            Some("v") => {
                let x = num(it.next(), line, "x")?;
                let y = num(it.next(), line, "y")?;
                let z = num(it.next(), line, "z")?;
                m.vertices.push([x, y, z]);
            }
            Some("f") => {
                let mut idx = Vec::with_capacity(4);
                for tok in it {
                    let first = tok.split('/').next().unwrap_or("");
                    let i: i64 = first.parse().map_err(|_| perr(line, format!("bad vertex reference {tok:?}")))?;
                    let n = m.vertices.len() as i64;
                    let abs = if i > 0 {
                        i - 1
                    } else if i < 0 {
                        n + i
                    } else {
                        -1
                    };
                    if abs < 0 || abs >= n {
                        return Err(perr(line, format!("vertex {i} does not exist ({n} so far)")));
                    }
                    idx.push(abs as u32);
                }
                if idx.len() < 3 {
                    return Err(perr(line, format!("a face needs 3 vertices, got {}", idx.len())));
                }
                for k in 1..idx.len() - 1 {
                    m.triangles.push([idx[0], idx[k], idx[k + 1]]);
                }
            }
            _ => {}
        }
    }
    if m.triangles.is_empty() {
        return Err(perr(0, "no faces"));
    }
    Ok(m)
}

fn is_binary_stl(b: &[u8]) -> bool {
    b.len() >= 84 && {
        let n = u32::from_le_bytes([b[80], b[81], b[82], b[83]]) as u64;
        84 + 50 * n == b.len() as u64
    }
}

/// Parses STL, binary (80-byte header, count, 50 bytes per triangle) or ASCII (`facet` /
/// `vertex` lines). Equal vertices are merged.
pub fn parse_stl(bytes: &[u8]) -> Result<Mesh, ImportError> {
    let mut soup: Vec<[f32; 3]> = Vec::new();
    if is_binary_stl(bytes) {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        soup.reserve(n * 3);
        for t in 0..n {
            let base = 84 + 50 * t + 12;
            for v in 0..3 {
                let mut p = [0f32; 3];
                for (d, c) in p.iter_mut().enumerate() {
                    let o = base + 12 * v + 4 * d;
                    *c = f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
                }
                if !p.iter().all(|c| c.is_finite()) {
                    return Err(perr(0, format!("binary STL triangle {t}: vertex {v} is not finite")));
                }
                soup.push(p);
            }
        }
    } else {
        let text = std::str::from_utf8(bytes).map_err(|_| perr(0, "neither a binary STL (size does not match its triangle count) nor ASCII text"))?;
        if !text.trim_start().starts_with("solid") {
            return Err(perr(1, "not an STL file: ASCII STL starts with `solid`, binary STL size must be 84 + 50 n"));
        }
        for (ln, raw) in text.lines().enumerate() {
            let mut it = raw.split_whitespace();
            if it.next() == Some("vertex") {
                let line = ln + 1;
                soup.push([num(it.next(), line, "x")?, num(it.next(), line, "y")?, num(it.next(), line, "z")?]);
            }
        }
        if !soup.len().is_multiple_of(3) {
            return Err(perr(0, format!("{} vertices is not a whole number of triangles", soup.len())));
        }
    }
    if soup.is_empty() {
        return Err(perr(0, "no triangles"));
    }
    let mut m = Mesh::default();
    let mut index: HashMap<[u32; 3], u32> = HashMap::new();
    let mut tri = [0u32; 3];
    for (i, p) in soup.iter().enumerate() {
        let key = p.map(|c| if c == 0.0 { 0 } else { c.to_bits() });
        let id = *index.entry(key).or_insert_with(|| {
            m.vertices.push(*p);
            (m.vertices.len() - 1) as u32
        });
        tri[i % 3] = id;
        if i % 3 == 2 {
            m.triangles.push(tri);
        }
    }
    Ok(m)
}

//! STL surfaces, binary and ASCII.

use super::{ferr, no_triangles, num, perr, Mesh};
use crate::ImportError;
use std::collections::HashMap;

pub(crate) fn is_binary_stl(b: &[u8]) -> bool {
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
                    return Err(ferr(format!("binary STL triangle {t}: vertex {v} is not finite: {p:?}")));
                }
                soup.push(p);
            }
        }
    } else {
        let text = std::str::from_utf8(bytes).map_err(|_| ferr("neither a binary STL (size does not match its triangle count) nor ASCII text"))?;
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
            return Err(ferr(format!("{} vertices is not a whole number of triangles", soup.len())));
        }
    }
    if soup.is_empty() {
        return Err(no_triangles());
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

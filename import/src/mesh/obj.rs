//! Wavefront OBJ surfaces.

use super::{no_triangles, num, perr, Mesh};
use crate::ImportError;

/// Writes `mesh` as Wavefront OBJ text (`v` and 1-based `f` lines), which [`parse_obj`] reads
/// back exactly (Rust's shortest round-trip `f32` formatting).
pub fn write_obj(mesh: &Mesh, out: &mut impl std::io::Write) -> std::io::Result<()> {
    for v in &mesh.vertices {
        writeln!(out, "v {} {} {}", v[0], v[1], v[2])?;
    }
    for t in &mesh.triangles {
        writeln!(out, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
    }
    Ok(())
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
        return Err(no_triangles());
    }
    Ok(m)
}

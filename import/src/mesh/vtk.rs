//! Legacy VTK polydata surfaces (`.vtk`), ASCII and BINARY.
//!
//! Hand-written: `vtkio` 0.6.3 (its last release) builds, but reads the VTK 5.1
//! `OFFSETS`/`CONNECTIVITY` polygons as no polygons without an error, and names no line in its
//! errors.

use super::{ferr, no_triangles, perr, push_polygon, push_strip, Mesh, Num};
use crate::ImportError;

/// A legacy VTK data type name.
fn data_type(name: &str) -> Option<Num> {
    use Num::*;
    Some(match name {
        "char" | "vtktypeint8" => I8,
        "unsigned_char" | "vtktypeuint8" => U8,
        "short" | "vtktypeint16" => I16,
        "unsigned_short" | "vtktypeuint16" => U16,
        "int" | "vtktypeint32" => I32,
        "unsigned_int" | "vtktypeuint32" => U32,
        "vtktypeint64" => I64,
        "vtktypeuint64" => U64,
        "float" | "vtktypefloat32" => F32,
        "double" | "vtktypefloat64" => F64,
        _ => return None,
    })
}

/// Keywords, counts and ASCII numbers as words; BINARY data as big-endian bytes.
struct Cursor<'a> {
    b: &'a [u8],
    pos: usize,
    line: usize,
    binary: bool,
}

/// Numbers read from the file, with the line of each when ASCII (for errors).
struct Values {
    v: Vec<f64>,
    lines: Vec<usize>,
}

impl Values {
    /// An error at value `k`: its line (ASCII) or `item` (BINARY).
    fn err(&self, k: usize, item: String, message: String) -> ImportError {
        match self.lines.get(k) {
            Some(&line) => perr(line, format!("{item}: {message}")),
            None => ferr(format!("{item}: {message}")),
        }
    }
}

impl<'a> Cursor<'a> {
    fn skip_space(&mut self) {
        while let Some(&c) = self.b.get(self.pos) {
            if !c.is_ascii_whitespace() {
                break;
            }
            if c == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
    }

    /// The next word, or `None` at the end of the file.
    fn word(&mut self) -> Option<&'a str> {
        self.skip_space();
        let start = self.pos;
        while self.b.get(self.pos).is_some_and(|c| !c.is_ascii_whitespace()) {
            self.pos += 1;
        }
        (self.pos > start).then(|| std::str::from_utf8(&self.b[start..self.pos]).unwrap_or("\u{fffd}"))
    }

    fn expect(&mut self, what: &str) -> Result<&'a str, ImportError> {
        self.word().ok_or_else(|| perr(self.line, format!("the file ends before {what}")))
    }

    fn count(&mut self, what: &str) -> Result<usize, ImportError> {
        let w = self.expect(what)?;
        w.parse().map_err(|_| perr(self.line, format!("{what}: {w:?} is not a count")))
    }

    /// The rest of the current line, through its newline.
    fn rest_of_line(&mut self) -> &'a str {
        let start = self.pos;
        let len = self.b[start..].iter().position(|&c| c == b'\n').unwrap_or(self.b.len() - start);
        self.pos = (start + len + 1).min(self.b.len());
        self.line += 1;
        std::str::from_utf8(&self.b[start..start + len]).unwrap_or("").trim()
    }

    /// `n` numbers of type `ty` (named `what` in errors): words when ASCII, big-endian bytes
    /// after the keyword line when BINARY.
    fn values(&mut self, n: usize, ty: Num, what: &str) -> Result<Values, ImportError> {
        if self.binary {
            self.rest_of_line();
            let len = n.checked_mul(ty.size()).filter(|&l| l <= self.b.len() - self.pos);
            let Some(len) = len else {
                return Err(ferr(format!("{what}: truncated: {n} values of {} bytes, {} bytes left in the file", ty.size(), self.b.len() - self.pos)));
            };
            let v = self.b[self.pos..self.pos + len].chunks_exact(ty.size()).map(|c| ty.read(c, true)).collect();
            self.pos += len;
            return Ok(Values { v, lines: Vec::new() });
        }
        let mut out = Values { v: Vec::with_capacity(n.min(self.b.len() / 2)), lines: Vec::with_capacity(n.min(self.b.len() / 2)) };
        for k in 0..n {
            let w = self.word().ok_or_else(|| perr(self.line, format!("{what}: the file ends after {k} of {n} values")))?;
            let v: f64 = w.parse().map_err(|_| perr(self.line, format!("{what}: not a number: {w:?}")))?;
            if ty.is_integer() && v.fract() != 0.0 {
                return Err(perr(self.line, format!("{what}: not a whole number: {w:?}")));
            }
            out.v.push(v);
            out.lines.push(self.line);
        }
        Ok(out)
    }
}

/// Cells as read, in either layout: offsets into a connectivity list.
struct Cells {
    offsets: Vec<usize>,
    ids: Values,
}

/// Reads the cells after a `POLYGONS a b` (or other cell) line: `a` cells of `n i0 i1 ...` in
/// `b` ints (the classic layout), or `OFFSETS` (`a` values) and `CONNECTIVITY` (`b` values) as
/// VTK 5.1 writes them.
fn read_cells(c: &mut Cursor, kind: &str) -> Result<Cells, ImportError> {
    let a = c.count(&format!("{kind}: the cell count"))?;
    let b = c.count(&format!("{kind}: the size"))?;
    let (pos, line) = (c.pos, c.line);
    if c.word() == Some("OFFSETS") {
        let ty = c.expect("the OFFSETS type")?;
        let ty = data_type(ty).filter(|t| t.is_integer()).ok_or_else(|| perr(c.line, format!("OFFSETS type {ty:?}: expected vtktypeint64 or vtktypeint32")))?;
        let off = c.values(a, ty, &format!("{kind} OFFSETS"))?;
        if c.word() != Some("CONNECTIVITY") {
            return Err(perr(c.line, format!("{kind}: expected CONNECTIVITY after OFFSETS")));
        }
        let ty = c.expect("the CONNECTIVITY type")?;
        let ty = data_type(ty).filter(|t| t.is_integer()).ok_or_else(|| perr(c.line, format!("CONNECTIVITY type {ty:?}: expected vtktypeint64 or vtktypeint32")))?;
        let ids = c.values(b, ty, &format!("{kind} CONNECTIVITY"))?;
        let mut offsets = Vec::with_capacity(a);
        for (k, &o) in off.v.iter().enumerate() {
            let prev = offsets.last().copied().unwrap_or(0);
            if (k == 0 && o != 0.0) || o < prev as f64 || o > b as f64 {
                return Err(off.err(k, format!("{kind} offset {k}"), format!("{o} is out of order or beyond the {b} ids")));
            }
            offsets.push(o as usize);
        }
        if offsets.last().is_some_and(|&l| l != b) {
            return Err(off.err(a - 1, format!("{kind} offset {}", a - 1), format!("the last offset must be the CONNECTIVITY size {b}")));
        }
        return Ok(Cells { offsets, ids });
    }
    (c.pos, c.line) = (pos, line);
    let raw = c.values(b, Num::I32, kind)?;
    let mut offsets = vec![0];
    let mut ids = Values { v: Vec::with_capacity(b), lines: Vec::new() };
    let mut k = 0;
    for cell in 0..a {
        let n = *raw.v.get(k).ok_or_else(|| raw.err(b.saturating_sub(1), format!("{kind} cell {cell}"), format!("{b} ints hold only {cell} of {a} cells")))?;
        if n < 0.0 || k + 1 + n as usize > b {
            return Err(raw.err(k, format!("{kind} cell {cell}"), format!("{n} vertices do not fit in the {b} ints")));
        }
        for j in k + 1..=k + n as usize {
            ids.v.push(raw.v[j]);
            if let Some(&l) = raw.lines.get(j) {
                ids.lines.push(l);
            }
        }
        k += 1 + n as usize;
        offsets.push(ids.v.len());
    }
    if k != b {
        return Err(raw.err(k.min(b.saturating_sub(1)), kind.to_string(), format!("{a} cells use {k} of the {b} ints")));
    }
    Ok(Cells { offsets, ids })
}

/// Parses a legacy VTK file (`# vtk DataFile Version ...`), ASCII or BINARY, holding
/// `DATASET POLYDATA`: `POINTS` (float or double), `POLYGONS` (fanned from their first vertex)
/// and `TRIANGLE_STRIPS`, in the classic cell layout or VTK 5.1's `OFFSETS`/`CONNECTIVITY`.
/// `VERTICES`, `LINES` and `METADATA` are skipped; reading ends at `POINT_DATA`, `CELL_DATA` or
/// `FIELD`. Errors name the line (ASCII) or the point or cell (BINARY).
pub fn parse_vtk(bytes: &[u8]) -> Result<Mesh, ImportError> {
    let mut c = Cursor { b: bytes, pos: 0, line: 1, binary: false };
    if !c.rest_of_line().starts_with("# vtk DataFile") {
        return Err(perr(1, "not a legacy VTK file: the first line must be `# vtk DataFile Version ...`"));
    }
    c.rest_of_line(); // the title
    c.binary = match c.rest_of_line().to_ascii_uppercase().as_str() {
        "ASCII" => false,
        "BINARY" => true,
        other => return Err(perr(3, format!("expected ASCII or BINARY, got {other:?}"))),
    };
    if c.word() != Some("DATASET") {
        return Err(perr(c.line, "expected `DATASET POLYDATA`"));
    }
    let kind = c.expect("the DATASET type")?.to_ascii_uppercase();
    if kind != "POLYDATA" {
        return Err(perr(c.line, format!("a VTK {kind} dataset, not a surface: expected DATASET POLYDATA")));
    }
    let mut m = Mesh::default();
    let mut points_seen = false;
    while let Some(key) = c.word() {
        match key {
            "POINTS" => {
                let n = c.count("POINTS: the count")?;
                if n > u32::MAX as usize {
                    return Err(perr(c.line, format!("{n} points; at most {} are allowed", u32::MAX)));
                }
                let ty = c.expect("the POINTS type")?;
                let ty = data_type(ty).ok_or_else(|| perr(c.line, format!("POINTS type {ty:?}: expected float or double")))?;
                let v = c.values(n.saturating_mul(3), ty, "POINTS")?;
                for (i, p) in v.v.chunks_exact(3).enumerate() {
                    let q = [p[0] as f32, p[1] as f32, p[2] as f32];
                    if !q.iter().all(|x| x.is_finite()) {
                        return Err(v.err(3 * i, format!("point {i}"), format!("not finite: {p:?}")));
                    }
                    m.vertices.push(q);
                }
                points_seen = true;
            }
            "VERTICES" | "LINES" | "POLYGONS" | "TRIANGLE_STRIPS" => {
                let cells = read_cells(&mut c, key)?;
                if key == "VERTICES" || key == "LINES" {
                    continue;
                }
                if !points_seen {
                    return Err(perr(c.line, format!("{key} before POINTS")));
                }
                let nv = m.vertices.len();
                let mut ids = Vec::new();
                for (cell, w) in cells.offsets.windows(2).enumerate() {
                    ids.clear();
                    for k in w[0]..w[1] {
                        let i = cells.ids.v[k];
                        if !(0.0..nv as f64).contains(&i) {
                            return Err(cells.ids.err(k, format!("{key} cell {cell}"), format!("point index {i} is out of range ({nv} points)")));
                        }
                        ids.push(i as u32);
                    }
                    if key == "POLYGONS" {
                        if ids.len() < 3 {
                            return Err(cells.ids.err(w[0], format!("{key} cell {cell}"), format!("a polygon needs 3 points, got {}", ids.len())));
                        }
                        push_polygon(&mut m.triangles, &ids);
                    } else {
                        push_strip(&mut m.triangles, &ids);
                    }
                }
            }
            "METADATA" => {
                // Information keys, as text, up to a blank line.
                c.rest_of_line();
                while c.pos < c.b.len() && !c.rest_of_line().is_empty() {}
            }
            "POINT_DATA" | "CELL_DATA" | "FIELD" => break,
            other => return Err(perr(c.line, format!("unknown section {other:?} in POLYDATA"))),
        }
    }
    if m.triangles.is_empty() {
        return Err(no_triangles());
    }
    Ok(m)
}

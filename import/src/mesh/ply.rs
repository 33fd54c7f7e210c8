//! PLY (Stanford polygon) surfaces: ASCII, binary little-endian and binary big-endian.
//!
//! Hand-written: the `ply-rs` crate is unmaintained since 2020, and a surface needs only the
//! vertex positions and the face lists.

use super::{ferr, no_triangles, perr, push_polygon, Mesh, Num};
use crate::ImportError;

/// A PLY scalar type by any of its names (`uchar` or `uint8`, ...).
fn scalar(name: &str) -> Option<Num> {
    use Num::*;
    Some(match name {
        "char" | "int8" => I8,
        "uchar" | "uint8" => U8,
        "short" | "int16" => I16,
        "ushort" | "uint16" => U16,
        "int" | "int32" => I32,
        "uint" | "uint32" => U32,
        "float" | "float32" => F32,
        "double" | "float64" => F64,
        _ => return None,
    })
}

#[derive(Debug)]
enum Property {
    Scalar { name: String, ty: Num },
    List { name: String, count: Num, item: Num },
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    LittleEndian,
    BigEndian,
}

/// The header: encoding, elements in order, the header's line count and the body's first byte.
struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    lines: usize,
    body: usize,
}

fn parse_header(bytes: &[u8]) -> Result<Header, ImportError> {
    let mut pos = 0;
    let mut line = 0;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(len) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(perr(line + 1, "the header has no `end_header` line"));
        };
        line += 1;
        let raw = std::str::from_utf8(&bytes[pos..pos + len]).map_err(|_| perr(line, "the header is not text"))?;
        pos += len + 1;
        let mut it = raw.split_whitespace();
        let key = it.next();
        if line == 1 {
            if key != Some("ply") || it.next().is_some() {
                return Err(perr(1, "not a PLY file: the first line must be `ply`"));
            }
            continue;
        }
        match key {
            Some("format") => {
                encoding = Some(match it.next() {
                    Some("ascii") => Encoding::Ascii,
                    Some("binary_little_endian") => Encoding::LittleEndian,
                    Some("binary_big_endian") => Encoding::BigEndian,
                    other => return Err(perr(line, format!("unknown format {:?}: expected ascii, binary_little_endian or binary_big_endian", other.unwrap_or("")))),
                });
            }
            Some("element") => {
                let (Some(name), Some(count)) = (it.next(), it.next()) else {
                    return Err(perr(line, "expected `element <name> <count>`"));
                };
                let count = count.parse().map_err(|_| perr(line, format!("element {name}: count {count:?} is not a whole number")))?;
                elements.push(Element { name: name.to_string(), count, props: Vec::new() });
            }
            Some("property") => {
                let Some(el) = elements.last_mut() else {
                    return Err(perr(line, "a property before any element"));
                };
                let words: Vec<&str> = it.collect();
                let ty = |t: &str| scalar(t).ok_or_else(|| perr(line, format!("unknown property type {t:?}")));
                let prop = match words.as_slice() {
                    ["list", count, item, name] => Property::List { name: name.to_string(), count: ty(count)?, item: ty(item)? },
                    [t, name] if *t != "list" => Property::Scalar { name: name.to_string(), ty: ty(t)? },
                    _ => return Err(perr(line, "expected `property <type> <name>` or `property list <count type> <index type> <name>`")),
                };
                el.props.push(prop);
            }
            Some("end_header") => break,
            Some("comment" | "obj_info") | None => {}
            Some(other) => return Err(perr(line, format!("unknown header line {other:?}"))),
        }
    }
    let encoding = encoding.ok_or_else(|| perr(line, "the header has no `format` line"))?;
    Ok(Header { encoding, elements, lines: line, body: pos })
}

/// The items of the body, in order, whatever the encoding.
trait Items {
    /// Starts item `i` of element `el` (ASCII: takes the next line).
    fn begin(&mut self, el: &str, i: usize) -> Result<(), ImportError>;
    fn value(&mut self, ty: Num) -> Result<f64, ImportError>;
    /// Ends an item whose properties were all read (ASCII: nothing may be left on the line).
    fn end(&mut self) -> Result<(), ImportError>;
    /// Skips an item of an element this reader does not use.
    fn skip(&mut self, el: &Element, i: usize) -> Result<(), ImportError>;
    /// An error at the current item: its line (ASCII) or its element and index (binary).
    fn err(&self, message: String) -> ImportError;
}

struct Ascii<'a> {
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    first_line: usize,
    line: usize,
    tokens: Vec<&'a str>,
    next: usize,
}

impl<'a> Ascii<'a> {
    fn next_line(&mut self, el: &str, i: usize) -> Result<&'a str, ImportError> {
        for (k, raw) in self.lines.by_ref() {
            if !raw.trim().is_empty() {
                self.line = self.first_line + k;
                return Ok(raw);
            }
        }
        Err(perr(self.line + 1, format!("the file ends before {el} {i}")))
    }
}

impl Items for Ascii<'_> {
    fn begin(&mut self, el: &str, i: usize) -> Result<(), ImportError> {
        self.tokens = self.next_line(el, i)?.split_whitespace().collect();
        self.next = 0;
        Ok(())
    }

    fn value(&mut self, ty: Num) -> Result<f64, ImportError> {
        let t = *self.tokens.get(self.next).ok_or_else(|| self.err(format!("{} values, expected more", self.tokens.len())))?;
        self.next += 1;
        let v: f64 = t.parse().map_err(|_| self.err(format!("not a number: {t:?}")))?;
        if ty.is_integer() && v.fract() != 0.0 {
            return Err(self.err(format!("not a whole number: {t:?}")));
        }
        Ok(v)
    }

    fn end(&mut self) -> Result<(), ImportError> {
        if self.next < self.tokens.len() {
            return Err(self.err(format!("{} values, expected {}", self.tokens.len(), self.next)));
        }
        Ok(())
    }

    fn skip(&mut self, el: &Element, i: usize) -> Result<(), ImportError> {
        self.next_line(&el.name, i).map(|_| ())
    }

    fn err(&self, message: String) -> ImportError {
        perr(self.line, message)
    }
}

struct Binary<'a> {
    bytes: &'a [u8],
    pos: usize,
    big: bool,
    el: String,
    item: usize,
}

impl Items for Binary<'_> {
    fn begin(&mut self, el: &str, i: usize) -> Result<(), ImportError> {
        if self.el != el {
            self.el = el.to_string();
        }
        self.item = i;
        Ok(())
    }

    fn value(&mut self, ty: Num) -> Result<f64, ImportError> {
        let end = self.pos + ty.size();
        let b = self.bytes.get(self.pos..end).ok_or_else(|| self.err(format!("truncated: the file ends at byte {}", self.bytes.len())))?;
        self.pos = end;
        Ok(ty.read(b, self.big))
    }

    fn end(&mut self) -> Result<(), ImportError> {
        Ok(())
    }

    fn skip(&mut self, el: &Element, i: usize) -> Result<(), ImportError> {
        self.begin(&el.name, i)?;
        for p in &el.props {
            match *p {
                Property::Scalar { ty, .. } => {
                    self.value(ty)?;
                }
                Property::List { count, item, .. } => {
                    let n = list_len(self, count)?;
                    for _ in 0..n {
                        self.value(item)?;
                    }
                }
            }
        }
        Ok(())
    }

    fn err(&self, message: String) -> ImportError {
        ferr(format!("{} {}: {message}", self.el, self.item))
    }
}

fn list_len(src: &mut dyn Items, ty: Num) -> Result<usize, ImportError> {
    let n = src.value(ty)?;
    if !(0.0..=u32::MAX as f64).contains(&n) || n.fract() != 0.0 {
        return Err(src.err(format!("list length {n} is not a count")));
    }
    Ok(n as usize)
}

/// Parses a PLY file: `element vertex` with scalar properties `x`, `y`, `z` (any type; other
/// properties are skipped), and `element face` with a list property `vertex_indices` (or
/// `vertex_index`), whose polygons are fanned from their first vertex. Other elements are
/// skipped (ASCII: one line per item; binary: by their property sizes). Errors name the line
/// (ASCII) or the element and item (binary).
pub fn parse_ply(bytes: &[u8]) -> Result<Mesh, ImportError> {
    let h = parse_header(bytes)?;
    let vertex = h.elements.iter().find(|e| e.name == "vertex").ok_or_else(|| ferr("no `element vertex` in the header"))?;
    let nv = vertex.count;
    if nv > u32::MAX as usize {
        return Err(ferr(format!("{nv} vertices; at most {} are allowed", u32::MAX)));
    }
    for axis in ["x", "y", "z"] {
        if !vertex.props.iter().any(|p| matches!(p, Property::Scalar { name, .. } if name == axis)) {
            return Err(ferr(format!("element vertex has no scalar property {axis}")));
        }
    }
    if let Some(face) = h.elements.iter().find(|e| e.name == "face") {
        if !face.props.iter().any(|p| matches!(p, Property::List { name, .. } if name == "vertex_indices" || name == "vertex_index")) {
            return Err(ferr("element face has no list property vertex_indices (or vertex_index)"));
        }
    }
    let mut src: Box<dyn Items> = match h.encoding {
        Encoding::Ascii => {
            let body = std::str::from_utf8(&bytes[h.body..]).map_err(|_| ferr("an ASCII PLY body that is not text"))?;
            Box::new(Ascii { lines: body.lines().enumerate(), first_line: h.lines + 1, line: h.lines, tokens: Vec::new(), next: 0 })
        }
        e => Box::new(Binary { bytes, pos: h.body, big: e == Encoding::BigEndian, el: String::new(), item: 0 }),
    };
    let mut m = Mesh::default();
    // Counts come from the file: reserve no more than its size could hold.
    m.vertices.reserve(nv.min(bytes.len() / 3));
    let mut poly: Vec<u32> = Vec::new();
    for el in &h.elements {
        let (is_vertex, is_face) = (el.name == "vertex", el.name == "face");
        for i in 0..el.count {
            if !is_vertex && !is_face {
                src.skip(el, i)?;
                continue;
            }
            src.begin(&el.name, i)?;
            let mut p = [0f64; 3];
            poly.clear();
            for prop in &el.props {
                match prop {
                    Property::Scalar { name, ty } => {
                        let v = src.value(*ty)?;
                        if let Some(d) = ["x", "y", "z"].iter().position(|a| is_vertex && a == name) {
                            p[d] = v;
                        }
                    }
                    Property::List { name, count, item } => {
                        let n = list_len(src.as_mut(), *count)?;
                        let keep = is_face && (name == "vertex_indices" || name == "vertex_index");
                        for _ in 0..n {
                            let v = src.value(*item)?;
                            if keep {
                                if !(0.0..nv as f64).contains(&v) {
                                    return Err(src.err(format!("vertex index {v} is out of range ({nv} vertices)")));
                                }
                                poly.push(v as u32);
                            }
                        }
                        if keep && n < 3 {
                            return Err(src.err(format!("a face needs 3 vertices, got {n}")));
                        }
                    }
                }
            }
            src.end()?;
            if is_vertex {
                let v = p.map(|c| c as f32);
                if !v.iter().all(|c| c.is_finite()) {
                    return Err(src.err(format!("coordinates are not finite: {p:?}")));
                }
                m.vertices.push(v);
            } else {
                push_polygon(&mut m.triangles, &poly);
            }
        }
    }
    if m.triangles.is_empty() {
        return Err(no_triangles());
    }
    Ok(m)
}

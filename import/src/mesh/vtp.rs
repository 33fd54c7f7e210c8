//! VTK XML polydata surfaces (`.vtp`): `Points` and `Polys` (and `Strips`) of each `Piece`,
//! with data arrays inline as `ascii` or base64 `binary`, or `appended` (raw or base64).
//!
//! Hand-written on quick-xml and base64 (`vtkio` 0.6.3 was tried and passed over: see
//! [`super::vtk`]); compressed files are refused with a message saying so.

use super::{ferr, no_triangles, perr, push_polygon, push_strip, Mesh, Num};
use crate::ImportError;
use base64::Engine;
use quick_xml::events::{BytesStart, Event};

fn data_type(name: &str) -> Option<Num> {
    use Num::*;
    Some(match name {
        "Int8" => I8,
        "UInt8" => U8,
        "Int16" => I16,
        "UInt16" => U16,
        "Int32" => I32,
        "UInt32" => U32,
        "Int64" => I64,
        "UInt64" => U64,
        "Float32" => F32,
        "Float64" => F64,
        _ => return None,
    })
}

/// The `VTKFile` settings binary data depends on.
#[derive(Clone, Copy)]
struct Layout {
    big: bool,
    /// Bytes of the length that precedes each binary block (`header_type`).
    header: usize,
}

/// A `DataArray` as declared, and where its text lies in the XML.
#[derive(Default)]
struct Array {
    /// The element holding it (`Points`, `Polys`, ...).
    parent: String,
    name: String,
    ty: Option<Num>,
    components: usize,
    format: String,
    offset: usize,
    /// The byte range of its text in the XML.
    text: Option<(usize, usize)>,
    /// The line of its start tag.
    line: usize,
}

/// Numbers decoded from an array, with where each came from (for errors).
struct Values {
    v: Vec<f64>,
    /// Per value, its line (ascii arrays); empty for binary data.
    lines: Vec<usize>,
    what: String,
}

impl Values {
    fn err(&self, k: usize, message: String) -> ImportError {
        match self.lines.get(k) {
            Some(&line) => perr(line, format!("{} value {k}: {message}", self.what)),
            None => ferr(format!("{} value {k}: {message}", self.what)),
        }
    }
}

fn line_at(xml: &str, pos: usize) -> usize {
    1 + xml.as_bytes()[..pos.min(xml.len())].iter().filter(|&&c| c == b'\n').count()
}

fn attr(e: &BytesStart, key: &str) -> Result<Option<String>, ImportError> {
    for a in e.attributes() {
        let a = a.map_err(|err| ferr(format!("a bad attribute: {err}")))?;
        if a.key.as_ref() == key {
            return Ok(Some(a.normalized_value(quick_xml::XmlVersion::default()).map_err(|err| ferr(format!("attribute {key}: {err}")))?.into_owned()));
        }
    }
    Ok(None)
}

fn count_attr(e: &BytesStart, key: &str, line: usize) -> Result<usize, ImportError> {
    match attr(e, key)? {
        None => Ok(0),
        Some(v) => v.trim().parse().map_err(|_| perr(line, format!("{key}=\"{v}\" is not a count"))),
    }
}

/// The data after `<AppendedData encoding="...">` and its `_` marker.
struct Appended<'a> {
    base64: bool,
    data: &'a [u8],
}

/// Decodes base64 text holding a length header and its block (VTK encodes them separately, some
/// writers together): the block's bytes.
fn base64_block(text: &[u8], layout: Layout, what: &str) -> Result<Vec<u8>, ImportError> {
    let s: Vec<u8> = text.iter().copied().filter(|c| !c.is_ascii_whitespace()).collect();
    let b64 = base64::engine::general_purpose::STANDARD;
    let hl = layout.header.div_ceil(3) * 4;
    let bad = |e: base64::DecodeError| ferr(format!("{what}: bad base64: {e}"));
    let (len, data) = if s.len() >= hl && s[hl - 1] == b'=' {
        let h = b64.decode(&s[..hl]).map_err(bad)?;
        (read_len(&h, layout), &s[hl..])
    } else {
        let all = b64.decode(&s).map_err(bad)?;
        if all.len() < layout.header {
            return Err(ferr(format!("{what}: truncated: {} bytes, less than its length header", all.len())));
        }
        let len = read_len(&all, layout);
        let data = all[layout.header..].to_vec();
        if (data.len() as u64) < len {
            return Err(ferr(format!("{what}: truncated: {} bytes of the {len} its header gives", data.len())));
        }
        return Ok(data[..len as usize].to_vec());
    };
    // Only the block's own characters: appended data runs on into the next array.
    let chars = usize::try_from(len).ok().and_then(|l| l.checked_add(2)).and_then(|l| (l / 3).checked_mul(4)).unwrap_or(usize::MAX);
    if data.len() < chars {
        return Err(ferr(format!("{what}: truncated: {} base64 characters of the {chars} its {len} bytes need", data.len())));
    }
    let block = b64.decode(&data[..chars]).map_err(bad)?;
    Ok(block[..(len as usize).min(block.len())].to_vec())
}

fn read_len(h: &[u8], layout: Layout) -> u64 {
    Num::read(if layout.header == 8 { Num::U64 } else { Num::U32 }, &h[..layout.header], layout.big) as u64
}

/// The numbers of an array.
fn decode(a: &Array, xml: &str, appended: Option<&Appended>, layout: Layout) -> Result<Values, ImportError> {
    let what = if a.name.is_empty() { a.parent.clone() } else { format!("{} {}", a.parent, a.name) };
    let ty = a.ty.ok_or_else(|| perr(a.line, format!("{what}: no type")))?;
    let text = a.text.map(|(s, e)| &xml[s..e]).unwrap_or("");
    let bytes = match a.format.as_str() {
        "ascii" => {
            let start = a.text.map(|t| t.0).unwrap_or(0);
            let mut out = Values { v: Vec::new(), lines: Vec::new(), what };
            let base = xml.as_ptr() as usize;
            let (mut line, mut upto) = (line_at(xml, start), start);
            for w in text.split_ascii_whitespace() {
                let at = w.as_ptr() as usize - base;
                line += xml.as_bytes()[upto..at].iter().filter(|&&c| c == b'\n').count();
                upto = at;
                let v: f64 = w.parse().map_err(|_| perr(line, format!("{}: not a number: {w:?}", out.what)))?;
                if ty.is_integer() && v.fract() != 0.0 {
                    return Err(perr(line, format!("{}: not a whole number: {w:?}", out.what)));
                }
                out.v.push(v);
                out.lines.push(line);
            }
            return Ok(out);
        }
        "binary" => base64_block(text.as_bytes(), layout, &what)?,
        "appended" => {
            let app = appended.ok_or_else(|| perr(a.line, format!("{what}: format=\"appended\" but the file has no AppendedData")))?;
            let data = app.data.get(a.offset..).ok_or_else(|| ferr(format!("{what}: truncated: offset {} is beyond the appended data's {} bytes", a.offset, app.data.len())))?;
            if app.base64 {
                base64_block(data, layout, &what)?
            } else {
                let h = data.get(..layout.header).ok_or_else(|| ferr(format!("{what}: truncated: the appended data ends in its length header")))?;
                let len = read_len(h, layout);
                let body = &data[layout.header..];
                if (body.len() as u64) < len {
                    return Err(ferr(format!("{what}: truncated: {} bytes left of the {len} its header gives", body.len())));
                }
                body[..len as usize].to_vec()
            }
        }
        other => return Err(perr(a.line, format!("{what}: format {other:?}: expected ascii, binary or appended"))),
    };
    if !bytes.len().is_multiple_of(ty.size()) {
        return Err(ferr(format!("{what}: {} bytes is not a whole number of {}-byte values", bytes.len(), ty.size())));
    }
    Ok(Values { v: bytes.chunks_exact(ty.size()).map(|c| ty.read(c, layout.big)).collect(), lines: Vec::new(), what })
}

/// One `Piece`: its declared counts and arrays.
#[derive(Default)]
struct Piece {
    points: usize,
    line: usize,
    arrays: Vec<Array>,
}

fn add_piece(m: &mut Mesh, p: &Piece, xml: &str, appended: Option<&Appended>, layout: Layout) -> Result<(), ImportError> {
    let find = |parent: &str, name: Option<&str>| p.arrays.iter().find(|a| a.parent == parent && name.is_none_or(|n| a.name.eq_ignore_ascii_case(n)));
    let base = m.vertices.len();
    if p.points > 0 {
        let a = find("Points", None).ok_or_else(|| perr(p.line, "a Piece with points but no Points DataArray"))?;
        if a.components != 3 {
            return Err(perr(a.line, format!("Points: NumberOfComponents=\"{}\", expected 3", a.components)));
        }
        let v = decode(a, xml, appended, layout)?;
        if v.v.len() != 3 * p.points {
            return Err(perr(a.line, format!("Points: {} values for NumberOfPoints=\"{}\" (3 each)", v.v.len(), p.points)));
        }
        for (i, c) in v.v.chunks_exact(3).enumerate() {
            let q = [c[0] as f32, c[1] as f32, c[2] as f32];
            if !q.iter().all(|x| x.is_finite()) {
                return Err(v.err(3 * i, format!("point {i} is not finite: {c:?}")));
            }
            m.vertices.push(q);
        }
        if m.vertices.len() > u32::MAX as usize {
            return Err(ferr(format!("more than {} points", u32::MAX)));
        }
    }
    for parent in ["Polys", "Strips"] {
        let (Some(conn), Some(offs)) = (find(parent, Some("connectivity")), find(parent, Some("offsets"))) else {
            if find(parent, None).is_some() {
                return Err(perr(p.line, format!("{parent} needs DataArrays named connectivity and offsets")));
            }
            continue;
        };
        let ids = decode(conn, xml, appended, layout)?;
        let off = decode(offs, xml, appended, layout)?;
        let mut start = 0usize;
        let mut cell = Vec::new();
        for (c, &end) in off.v.iter().enumerate() {
            if end < start as f64 || end > ids.v.len() as f64 {
                return Err(off.err(c, format!("offset {end} is out of order or beyond the {} ids", ids.v.len())));
            }
            cell.clear();
            for k in start..end as usize {
                let i = ids.v[k];
                if !(0.0..p.points as f64).contains(&i) {
                    return Err(ids.err(k, format!("point index {i} is out of range ({} points)", p.points)));
                }
                cell.push((base + i as usize) as u32);
            }
            if parent == "Polys" {
                if cell.len() < 3 {
                    return Err(off.err(c, format!("a polygon needs 3 points, got {}", cell.len())));
                }
                push_polygon(&mut m.triangles, &cell);
            } else {
                push_strip(&mut m.triangles, &cell);
            }
            start = end as usize;
        }
    }
    Ok(())
}

/// Parses a VTK XML `PolyData` file (`.vtp`): the points and the polygons (fanned from their
/// first vertex) and triangle strips of every piece. Errors name the line (ascii data and
/// markup) or the array and value index (binary data).
pub fn parse_vtp(bytes: &[u8]) -> Result<Mesh, ImportError> {
    // Raw appended data is not XML: split it off before parsing the markup.
    let (markup, appended) = match bytes.windows(13).position(|w| w == b"<AppendedData") {
        None => (bytes, None),
        Some(at) => {
            let tag_end = at + bytes[at..].iter().position(|&c| c == b'>').ok_or_else(|| ferr("an unterminated AppendedData tag"))?;
            let tag = String::from_utf8_lossy(&bytes[at..tag_end]);
            let base64 = tag.contains("\"base64\"");
            let mark = tag_end + bytes[tag_end..].iter().position(|&c| c == b'_').ok_or_else(|| ferr("AppendedData without its `_` marker"))?;
            (&bytes[..at], Some(Appended { base64, data: &bytes[mark + 1..] }))
        }
    };
    let xml = std::str::from_utf8(markup).map_err(|_| ferr("the XML is not UTF-8 text"))?;
    let mut r = quick_xml::Reader::from_str(xml);
    let mut stack: Vec<String> = Vec::new();
    let mut layout = Layout { big: false, header: 4 };
    let mut seen_file = false;
    let mut piece: Option<Piece> = None;
    let mut m = Mesh::default();
    loop {
        let before = r.buffer_position() as usize;
        let ev = r.read_event().map_err(|e| perr(line_at(xml, r.error_position() as usize), format!("bad XML: {e}")))?;
        let line = line_at(xml, before);
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let name = String::from_utf8_lossy(e.name().as_ref().as_bytes()).into_owned();
                match name.as_str() {
                    "VTKFile" => {
                        seen_file = true;
                        let ty = attr(e, "type")?.unwrap_or_default();
                        if ty != "PolyData" {
                            return Err(perr(line, format!("a VTK XML {ty} file, not a surface: expected type=\"PolyData\"")));
                        }
                        if let Some(c) = attr(e, "compressor")? {
                            return Err(perr(line, format!("compressed data ({c}) is not read; write the file uncompressed")));
                        }
                        layout.big = attr(e, "byte_order")?.as_deref() == Some("BigEndian");
                        layout.header = match attr(e, "header_type")?.as_deref() {
                            None | Some("UInt32") => 4,
                            Some("UInt64") => 8,
                            Some(other) => return Err(perr(line, format!("header_type {other:?}: expected UInt32 or UInt64"))),
                        };
                    }
                    "Piece" => piece = Some(Piece { points: count_attr(e, "NumberOfPoints", line)?, line, arrays: Vec::new() }),
                    "DataArray" => {
                        if let Some(p) = piece.as_mut() {
                            let ty = attr(e, "type")?.unwrap_or_default();
                            p.arrays.push(Array {
                                parent: stack.last().cloned().unwrap_or_default(),
                                name: attr(e, "Name")?.unwrap_or_default(),
                                ty: Some(data_type(&ty).ok_or_else(|| perr(line, format!("DataArray type {ty:?}: expected Int8..UInt64, Float32 or Float64")))?),
                                components: attr(e, "NumberOfComponents")?.map_or(Ok(1), |c| c.trim().parse().map_err(|_| perr(line, format!("NumberOfComponents {c:?}"))))?,
                                format: attr(e, "format")?.unwrap_or_else(|| "ascii".into()),
                                offset: count_attr(e, "offset", line)?,
                                text: None,
                                line,
                            });
                        }
                    }
                    _ => {}
                }
                if matches!(ev, Event::Start(_)) {
                    stack.push(name);
                }
            }
            Event::Text(_) if stack.last().is_some_and(|s| s == "DataArray") => {
                if let Some(a) = piece.as_mut().and_then(|p| p.arrays.last_mut()) {
                    let end = r.buffer_position() as usize;
                    a.text = Some((a.text.map_or(before, |t| t.0), end));
                }
            }
            Event::End(_) => {
                let closed = stack.pop();
                if let Some(p) = piece.take_if(|_| closed.as_deref() == Some("Piece")) {
                    add_piece(&mut m, &p, xml, appended.as_ref(), layout)?;
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if !seen_file {
        return Err(ferr("not a VTK XML file: no VTKFile element"));
    }
    // Arrays in appended data: the markup was cut before the pieces closed.
    if let Some(p) = piece.take() {
        add_piece(&mut m, &p, xml, appended.as_ref(), layout)?;
    }
    if m.triangles.is_empty() {
        return Err(no_triangles());
    }
    Ok(m)
}

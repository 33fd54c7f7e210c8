//! Import: the same square pyramid written as PLY, legacy VTK and VTK XML loads to the same
//! surface; each reader's errors name the file and the place; JSON midlines in every shape.

use lumen_import::*;
use std::path::{Path, PathBuf};

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lumen-import-formats-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A unit square pyramid of height 1: base corners 0..4 at z = 0, apex 4.
const PYRAMID: [[f32; 3]; 5] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.5, 0.5, 1.0]];
/// Its outward faces: the base quad, then the four sides (as `import.rs`'s OBJ pyramid).
const FACES: [&[u32]; 5] = [&[0, 3, 2, 1], &[0, 1, 4], &[1, 2, 4], &[2, 3, 4], &[0, 4, 3]];
/// The four sides alone, and the base as a triangle strip with the same outward winding.
const SIDES: [&[u32]; 4] = [&[0, 1, 4], &[1, 2, 4], &[2, 3, 4], &[0, 4, 3]];
const BASE_STRIP: [u32; 4] = [0, 3, 1, 2];

/// The pyramid as OBJ reads it: the reference every format must match.
fn reference() -> Mesh {
    let mut obj = String::new();
    for v in PYRAMID {
        obj.push_str(&format!("v {} {} {}\n", v[0], v[1], v[2]));
    }
    for f in FACES {
        obj.push_str(&format!("f {}\n", f.iter().map(|i| (i + 1).to_string()).collect::<Vec<_>>().join(" ")));
    }
    parse_obj(&obj).unwrap()
}

/// Same points, six triangles, outward, volume 1/3.
fn assert_pyramid(m: &Mesh, what: &str) {
    assert_eq!(m.vertices, PYRAMID.to_vec(), "{what}");
    assert_eq!(m.triangles.len(), 6, "{what}: {:?}", m.triangles);
    assert!((m.signed_volume() - 1.0 / 3.0).abs() < 1e-6, "{what}: volume {}", m.signed_volume());
}

fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// Binary numbers for the writers below.
enum N {
    U8(u8),
    I32(i32),
    I64(i64),
    F32(f32),
    F64(f64),
}

fn put(out: &mut Vec<u8>, big: bool, values: &[N]) {
    for v in values {
        macro_rules! b {
            ($x:expr) => {
                if big {
                    out.extend_from_slice(&$x.to_be_bytes())
                } else {
                    out.extend_from_slice(&$x.to_le_bytes())
                }
            };
        }
        match *v {
            N::U8(x) => out.push(x),
            N::I32(x) => b!(x),
            N::I64(x) => b!(x),
            N::F32(x) => b!(x),
            N::F64(x) => b!(x),
        }
    }
}

// ---- PLY ----

/// The header of a PLY pyramid with an extra vertex property (`quality`), a double `y`, an
/// extra face property before the list, and an extra element with a list (`edge`) between.
fn ply_header(format: &str, faces: usize) -> String {
    format!(
        "ply\nformat {format} 1.0\ncomment written by the lumen-import test\nelement vertex 5\nproperty float x\nproperty double y\nproperty float z\nproperty uchar quality\n\
         element edge 2\nproperty int vertex1\nproperty list uchar float weights\nelement face {faces}\nproperty uchar intensity\nproperty list uchar int vertex_indices\nend_header\n"
    )
}

fn ply_ascii() -> String {
    let mut s = ply_header("ascii", 5);
    for v in PYRAMID {
        s.push_str(&format!("{} {} {} 7\n", v[0], v[1], v[2]));
    }
    s.push_str("0 2 0.5 0.25\n3 0\n");
    for f in FACES {
        s.push_str(&format!("9 {} {}\n", f.len(), f.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(" ")));
    }
    s
}

fn ply_binary(big: bool, vertices: &[[f32; 3]], faces: &[&[u32]]) -> Vec<u8> {
    let mut out = ply_header(if big { "binary_big_endian" } else { "binary_little_endian" }, faces.len()).into_bytes();
    for v in vertices {
        put(&mut out, big, &[N::F32(v[0]), N::F64(v[1] as f64), N::F32(v[2]), N::U8(7)]);
    }
    put(&mut out, big, &[N::I32(0), N::U8(2), N::F32(0.5), N::F32(0.25), N::I32(3), N::U8(0)]);
    for f in faces {
        put(&mut out, big, &[N::U8(9), N::U8(f.len() as u8)]);
        put(&mut out, big, &f.iter().map(|&i| N::I32(i as i32)).collect::<Vec<_>>());
    }
    out
}

#[test]
fn ply_ascii_and_binary_load_the_pyramid() {
    let d = tmp_dir("ply");
    let want = reference();
    let files = [
        write(&d, "ascii.ply", ply_ascii()),
        write(&d, "le.ply", ply_binary(false, &PYRAMID, &FACES)),
        write(&d, "be.PLY", ply_binary(true, &PYRAMID, &FACES)),
        write(&d, "sniffed.surface", ply_binary(true, &PYRAMID, &FACES)),
    ];
    for f in &files {
        let m = load_mesh(f).unwrap_or_else(|e| panic!("{e}"));
        assert_pyramid(&m, &f.display().to_string());
        assert_eq!(m, want, "{}: fanned as OBJ fans", f.display());
    }
    // `vertex_index` is the other name of the list.
    let text = ply_ascii().replace("vertex_indices", "vertex_index");
    assert_eq!(parse_ply(text.as_bytes()).unwrap(), want);
}

#[test]
fn ply_errors_name_the_file_and_the_place() {
    let d = tmp_dir("ply-errors");
    // ASCII: after 15 header lines, 5 vertices and 2 edges, the fourth face is on line 26.
    let bad = ply_ascii().replace("9 3 2 3 4\n", "9 3 2 3 9\n");
    let e = load_mesh(write(&d, "bad-index.ply", bad)).unwrap_err().to_string();
    assert!(e.contains("bad-index.ply") && e.contains("line 26") && e.contains("vertex index 9") && e.contains("5 vertices"), "{e}");
    let nan = ply_ascii().replace("0.5 0.5 1 7", "0.5 NaN 1 7");
    let e = load_mesh(write(&d, "nan.ply", nan)).unwrap_err().to_string();
    assert!(e.contains("nan.ply") && e.contains("line 20") && e.contains("NaN"), "{e}");
    // Binary: the place is the element and item.
    let mut v = PYRAMID;
    v[2][0] = f32::INFINITY;
    let e = load_mesh(write(&d, "inf.ply", ply_binary(false, &v, &FACES))).unwrap_err().to_string();
    assert!(e.contains("inf.ply") && e.contains("vertex 2") && e.contains("inf"), "{e}");
    let e = load_mesh(write(&d, "index.ply", ply_binary(true, &PYRAMID, &[&[0, 1, 5]]))).unwrap_err().to_string();
    assert!(e.contains("index.ply") && e.contains("face 0") && e.contains("vertex index 5"), "{e}");
    let full = ply_binary(false, &PYRAMID, &FACES);
    let e = load_mesh(write(&d, "short.ply", &full[..full.len() - 2])).unwrap_err().to_string();
    assert!(e.contains("short.ply") && e.contains("face 4") && e.contains("truncated"), "{e}");
    // No faces: an empty surface, named.
    let e = load_mesh(write(&d, "empty.ply", ply_binary(false, &PYRAMID, &[]))).unwrap_err().to_string();
    assert!(e.contains("empty.ply") && e.contains("no triangles"), "{e}");
}

// ---- legacy VTK ----

fn vtk_points(version: &str, binary: bool, ty: &str) -> Vec<u8> {
    let mut out = format!("# vtk DataFile Version {version}\npyramid\n{}\nDATASET POLYDATA\nPOINTS 5 {ty}\n", if binary { "BINARY" } else { "ASCII" }).into_bytes();
    for v in PYRAMID {
        if binary {
            put(&mut out, true, &v.map(|c| if ty == "double" { N::F64(c as f64) } else { N::F32(c) }));
        } else {
            out.extend_from_slice(format!("{} {} {}\n", v[0], v[1], v[2]).as_bytes());
        }
    }
    if binary {
        out.push(b'\n');
    }
    out
}

/// Cells as VTK lists them, classic (`n i0 i1 ...`) or as 5.1 offsets and connectivity.
fn vtk_cells(out: &mut Vec<u8>, key: &str, cells: &[&[u32]], modern: bool, binary: bool) {
    let ids: Vec<u32> = cells.iter().flat_map(|c| c.iter().copied()).collect();
    let ints = |out: &mut Vec<u8>, v: &[i64], wide: bool| {
        if binary {
            put(out, true, &v.iter().map(|&x| if wide { N::I64(x) } else { N::I32(x as i32) }).collect::<Vec<_>>());
            out.push(b'\n');
        } else {
            out.extend_from_slice(format!("{}\n", v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(" ")).as_bytes());
        }
    };
    if modern {
        let mut offsets = vec![0i64];
        for c in cells {
            offsets.push(offsets.last().unwrap() + c.len() as i64);
        }
        out.extend_from_slice(format!("{key} {} {}\nOFFSETS vtktypeint64\n", offsets.len(), ids.len()).as_bytes());
        ints(out, &offsets, true);
        out.extend_from_slice(b"CONNECTIVITY vtktypeint64\n");
        ints(out, &ids.iter().map(|&i| i as i64).collect::<Vec<_>>(), true);
    } else {
        out.extend_from_slice(format!("{key} {} {}\n", cells.len(), ids.len() + cells.len()).as_bytes());
        let cell = |c: &&[u32]| std::iter::once(c.len() as i64).chain(c.iter().map(|&i| i as i64)).collect::<Vec<_>>();
        if binary {
            ints(out, &cells.iter().flat_map(cell).collect::<Vec<_>>(), false);
        } else {
            // One cell a line, as VTK writes them.
            for c in cells {
                ints(out, &cell(c), false);
            }
        }
    }
}

/// The pyramid as legacy VTK: all polygons, or the sides as polygons and the base as a strip.
fn vtk(version: &str, binary: bool, modern: bool, strip: bool) -> Vec<u8> {
    let mut out = vtk_points(version, binary, if binary { "double" } else { "float" });
    if modern {
        out.extend_from_slice(b"METADATA\nINFORMATION 0\n\n");
    }
    if strip {
        vtk_cells(&mut out, "LINES", &[&[0, 4]], modern, binary);
        vtk_cells(&mut out, "POLYGONS", &SIDES, modern, binary);
        vtk_cells(&mut out, "TRIANGLE_STRIPS", &[&BASE_STRIP], modern, binary);
    } else {
        vtk_cells(&mut out, "POLYGONS", &FACES, modern, binary);
    }
    out.extend_from_slice(b"CELL_DATA 5\nSCALARS id int 1\nLOOKUP_TABLE default\n0 1 2 3 4\n");
    out
}

#[test]
fn legacy_vtk_ascii_and_binary_in_both_cell_layouts_load_the_pyramid() {
    let d = tmp_dir("vtk");
    let want = reference();
    for binary in [false, true] {
        for modern in [false, true] {
            for strip in [false, true] {
                let what = format!("binary {binary}, 5.1 layout {modern}, strip {strip}");
                let name = format!("p-{binary}-{modern}-{strip}.vtk");
                let m = load_mesh(write(&d, &name, vtk(if modern { "5.1" } else { "3.0" }, binary, modern, strip))).unwrap_or_else(|e| panic!("{what}: {e}"));
                assert_pyramid(&m, &what);
                if !strip {
                    assert_eq!(m, want, "{what}");
                } else {
                    // The strip gives the base's two triangles, both outward (-z).
                    let base: Vec<_> = m.triangles[4..].to_vec();
                    assert_eq!(base, vec![[0, 3, 1], [1, 3, 2]], "{what}");
                }
            }
        }
    }
    // Sniffed by content.
    let m = load_mesh(write(&d, "sniffed.data", vtk("3.0", true, false, true))).unwrap();
    assert_pyramid(&m, "sniffed");
}

#[test]
fn legacy_vtk_errors_name_the_file_and_the_place() {
    let d = tmp_dir("vtk-errors");
    let text = String::from_utf8(vtk("3.0", false, false, false)).unwrap();
    // Line 15 is the fourth polygon, `3 2 3 4` (points on lines 6 to 10).
    let e = load_mesh(write(&d, "index.vtk", text.replace("3 2 3 4\n", "3 2 3 7\n"))).unwrap_err().to_string();
    assert!(e.contains("index.vtk") && e.contains("line 15") && e.contains("point index 7") && e.contains("5 points"), "{e}");
    let e = load_mesh(write(&d, "nan.vtk", text.replace("1 1 0\n", "1 nan 0\n"))).unwrap_err().to_string();
    assert!(e.contains("nan.vtk") && e.contains("line 8") && e.contains("point 2") && e.contains("NaN"), "{e}");
    let full = vtk("5.1", true, true, false);
    let cut = full.windows(12).position(|w| w == b"CONNECTIVITY").unwrap() + 30;
    let e = load_mesh(write(&d, "short.vtk", &full[..cut])).unwrap_err().to_string();
    assert!(e.contains("short.vtk") && e.contains("POLYGONS CONNECTIVITY") && e.contains("truncated"), "{e}");
    let grid = "# vtk DataFile Version 3.0\ngrid\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 1 float\n0 0 0\n";
    let e = load_mesh(write(&d, "grid.vtk", grid)).unwrap_err().to_string();
    assert!(e.contains("grid.vtk") && e.contains("UNSTRUCTURED_GRID") && e.contains("POLYDATA"), "{e}");
    let e = load_mesh(write(&d, "points.vtk", vtk_points("3.0", false, "float"))).unwrap_err().to_string();
    assert!(e.contains("points.vtk") && e.contains("no triangles"), "{e}");
}

// ---- VTK XML ----

fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            s.push(if k <= c.len() { A[(n >> (18 - 6 * k)) as usize & 63] as char } else { '=' });
        }
    }
    s
}

/// How a `.vtp` test file holds its arrays.
#[derive(Clone, Copy, PartialEq)]
enum Vtp {
    Ascii,
    /// base64 inline, the length header encoded apart (as VTK does) or with the data (`joint`).
    Base64 {
        joint: bool,
    },
    AppendedRaw,
}

fn vtp(how: Vtp, points: &[[f32; 3]], polys: &[&[u32]], strips: &[&[u32]]) -> Vec<u8> {
    let mut appended: Vec<u8> = Vec::new();
    let mut array = |name: &str, ty: &str, comps: usize, bytes: Vec<u8>, text: String| -> String {
        let head = format!("<DataArray type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"{comps}\"");
        match how {
            Vtp::Ascii => format!("{head} format=\"ascii\">\n          {text}\n        </DataArray>"),
            Vtp::Base64 { joint } => {
                let len = (bytes.len() as u32).to_le_bytes();
                let data = if joint { base64(&[&len[..], &bytes].concat()) } else { base64(&len) + &base64(&bytes) };
                format!("{head} format=\"binary\">\n          {data}\n        </DataArray>")
            }
            Vtp::AppendedRaw => {
                let at = appended.len();
                appended.extend_from_slice(&(bytes.len() as u64).to_le_bytes());
                appended.extend_from_slice(&bytes);
                format!("{head} format=\"appended\" offset=\"{at}\"/>")
            }
        }
    };
    let join = |v: &[String]| v.join(" ");
    let pts = array("Points", "Float64", 3, points.iter().flatten().flat_map(|&c| (c as f64).to_le_bytes()).collect(), join(&points.iter().flatten().map(|c| c.to_string()).collect::<Vec<_>>()));
    let mut cells = String::new();
    for (tag, list) in [("Polys", polys), ("Strips", strips)] {
        if list.is_empty() {
            continue;
        }
        let ids: Vec<u32> = list.iter().flat_map(|c| c.iter().copied()).collect();
        let offsets: Vec<u32> = list.iter().scan(0, |s, c| Some(*s + c.len() as u32).inspect(|&x| *s = x)).collect();
        let conn = array("connectivity", "Int32", 1, ids.iter().flat_map(|&i| (i as i32).to_le_bytes()).collect(), join(&ids.iter().map(|i| i.to_string()).collect::<Vec<_>>()));
        let offs = array("offsets", "Int64", 1, offsets.iter().flat_map(|&i| (i as i64).to_le_bytes()).collect(), join(&offsets.iter().map(|i| i.to_string()).collect::<Vec<_>>()));
        cells.push_str(&format!("      <{tag}>\n        {conn}\n        {offs}\n      </{tag}>\n"));
    }
    let header = if how == Vtp::AppendedRaw { " header_type=\"UInt64\"" } else { "" };
    let mut out = format!(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\"{header}>\n  <PolyData>\n    <Piece NumberOfPoints=\"{}\" NumberOfPolys=\"{}\" NumberOfStrips=\"{}\">\n      <PointData Scalars=\"id\">\n        <DataArray type=\"Int32\" Name=\"id\" format=\"ascii\">0 1 2 3 4</DataArray>\n      </PointData>\n      <Points>\n        {pts}\n      </Points>\n{cells}    </Piece>\n  </PolyData>\n",
        points.len(),
        polys.len(),
        strips.len()
    )
    .into_bytes();
    if how == Vtp::AppendedRaw {
        out.extend_from_slice(b"  <AppendedData encoding=\"raw\">\n   _");
        out.extend_from_slice(&appended);
        out.extend_from_slice(b"\n  </AppendedData>\n");
    }
    out.extend_from_slice(b"</VTKFile>\n");
    out
}

#[test]
fn vtp_ascii_base64_and_appended_load_the_pyramid() {
    let d = tmp_dir("vtp");
    let want = reference();
    for how in [Vtp::Ascii, Vtp::Base64 { joint: false }, Vtp::Base64 { joint: true }, Vtp::AppendedRaw] {
        let m = load_mesh(write(&d, "p.vtp", vtp(how, &PYRAMID, &FACES, &[]))).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m, want);
        let m = load_mesh(write(&d, "strip.vtp", vtp(how, &PYRAMID, &SIDES, &[&BASE_STRIP]))).unwrap_or_else(|e| panic!("{e}"));
        assert_pyramid(&m, "vtp with a strip");
        assert_eq!(m.triangles[4..], [[0, 3, 1], [1, 3, 2]]);
    }
    let m = load_mesh(write(&d, "sniffed.xml", vtp(Vtp::Base64 { joint: false }, &PYRAMID, &FACES, &[]))).unwrap();
    assert_eq!(m, want);
}

#[test]
fn vtp_errors_name_the_file_and_the_place() {
    let d = tmp_dir("vtp-errors");
    // The connectivity is on line 15 of the ascii file.
    let text = String::from_utf8(vtp(Vtp::Ascii, &PYRAMID, &FACES, &[])).unwrap();
    let bad = text.replace("0 3 2 1 0 1 4", "0 3 2 1 0 1 8");
    let e = load_mesh(write(&d, "index.vtp", bad)).unwrap_err().to_string();
    assert!(e.contains("index.vtp") && e.contains("line 15") && e.contains("point index 8") && e.contains("connectivity"), "{e}");
    let mut v = PYRAMID;
    v[3][2] = f32::NAN;
    let e = load_mesh(write(&d, "nan.vtp", vtp(Vtp::Base64 { joint: false }, &v, &FACES, &[]))).unwrap_err().to_string();
    assert!(e.contains("nan.vtp") && e.contains("Points value 9") && e.contains("point 3") && e.contains("NaN"), "{e}");
    let full = vtp(Vtp::AppendedRaw, &PYRAMID, &FACES, &[]);
    let cut = full.len() - 40;
    let e = load_mesh(write(&d, "short.vtp", &full[..cut])).unwrap_err().to_string();
    assert!(e.contains("short.vtp") && e.contains("truncated"), "{e}");
    let grid = text.replace("type=\"PolyData\"", "type=\"UnstructuredGrid\"");
    let e = load_mesh(write(&d, "grid.vtu", grid)).unwrap_err().to_string();
    assert!(e.contains("grid.vtu") && e.contains("UnstructuredGrid") && e.contains("PolyData"), "{e}");
    let e = load_mesh(write(&d, "empty.vtp", vtp(Vtp::Ascii, &PYRAMID, &[], &[]))).unwrap_err().to_string();
    assert!(e.contains("empty.vtp") && e.contains("no triangles"), "{e}");
}

#[test]
fn an_unsupported_file_lists_the_formats() {
    let d = tmp_dir("unsupported");
    for (name, bytes) in [("model.glb", &b"glTF\x02\x00\x00\x00binary"[..]), ("notes.dat", b"just some text\nno vertices here\n")] {
        let e = load_mesh(write(&d, name, bytes)).unwrap_err().to_string();
        assert!(e.contains(name), "{e}");
        for f in ["OBJ", "STL", "PLY", "VTK", ".vtp"] {
            assert!(e.contains(f), "{f} missing from: {e}");
        }
    }
}

// ---- JSON midlines ----

#[test]
fn json_midlines_in_every_shape_give_the_same_points() {
    let want = vec![[0.0, 0.0, 0.0], [1.5, -2.0, 3.0], [2.0, 4.0, 1e3]];
    let shapes = [
        r#"[[0,0,0],[1.5,-2,3],[2,4,1e3]]"#,
        r#"[{"x":0,"y":0,"z":0},{"x":1.5,"y":-2,"z":3,"label":"b"},{"z":1000,"y":4,"x":2}]"#,
        r#"{"points":[[0,0,0],[1.5,-2,3],[2,4,1000]]}"#,
        r#"{"units":"mm","centerline":[{"x":0,"y":0,"z":0},{"x":1.5,"y":-2,"z":3},{"x":2,"y":4,"z":1000}]}"#,
        r#"{"path":[[0,0,0],[1.5,-2,3],[2,4,1000]]}"#,
        r#"{"@schema":"https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/Markups/Resources/Schema/markups-schema-v1.0.3.json#",
            "markups":[{"type":"Curve","coordinateSystem":"LPS","controlPoints":[
              {"id":"1","label":"C-1","position":[0.0,0.0,0.0]},
              {"id":"2","label":"C-2","position":[1.5,-2.0,3.0]},
              {"id":"3","label":"C-3","position":[2.0,4.0,1000.0]}]}]}"#,
    ];
    let d = tmp_dir("json");
    for (k, s) in shapes.iter().enumerate() {
        let c = parse_centerline_json(s).unwrap_or_else(|e| panic!("shape {k}: {e}"));
        assert_eq!(c.points, want, "shape {k}");
        assert_eq!(load_centerline(write(&d, &format!("c{k}.json"), s)).unwrap().points, want, "shape {k}");
    }
    // Without the extension, JSON is told from CSV by its first character.
    assert_eq!(load_centerline(write(&d, "c.mid", shapes[2])).unwrap().points, want);
    assert_eq!(load_centerline(write(&d, "c.csv", "x,y,z\n0,0,0\n1.5,-2,3\n2,4,1000\n")).unwrap().points, want);
}

#[test]
fn json_midline_errors_name_the_point_and_the_file() {
    let d = tmp_dir("json-errors");
    let e = load_centerline(write(&d, "short.json", "[[0,0,0],[1,2]]")).unwrap_err().to_string();
    assert!(e.contains("short.json") && e.contains("point 1: expected 3 numbers, got 2 values"), "{e}");
    let e = parse_centerline_json(r#"[{"x":0,"y":0,"z":0},{"x":1,"y":"2","z":3}]"#).unwrap_err().to_string();
    assert!(e.contains("point 1") && e.contains("y is a string"), "{e}");
    let e = parse_centerline_json(r#"[[0,0,0],[1,2,1e39]]"#).unwrap_err().to_string();
    assert!(e.contains("point 1") && e.contains("not finite"), "{e}");
    let e = load_centerline(write(&d, "syntax.json", "[[0,0,0],\n[1,2,3]\n")).unwrap_err().to_string();
    assert!(e.contains("syntax.json") && e.contains("line 3"), "{e}");
    let e = parse_centerline_json(r#"{"name":"colon"}"#).unwrap_err().to_string();
    assert!(e.contains("points"), "{e}");
    assert!(parse_centerline_json("[[0,0,0]]").is_err(), "one point is not a midline");
}

/// The writers read back exactly: an OBJ of awkward floats, midlines with and without arc lengths.
#[test]
fn obj_and_midline_writers_read_back_exactly() {
    let m = Mesh { vertices: vec![[0.1, -1e-7, 123456.79], [1.0 / 3.0, 2.5e10, -0.0], [7.0, 8.0, 9.0]], triangles: vec![[0, 1, 2], [2, 1, 0]] };
    let mut text = Vec::new();
    write_obj(&m, &mut text).unwrap();
    assert_eq!(parse_obj(std::str::from_utf8(&text).unwrap()).unwrap(), m);
    for s in [Some(vec![0.0, 0.1, 1.0 / 3.0]), None] {
        let line = Centerline { points: vec![[0.1, 0.2, 0.3], [1.0 / 3.0, -4.0, 5e-5], [7.0, 8.0, 9.25]], s, radius_median: None };
        let mut csv = Vec::new();
        write_centerline_csv(&line, &mut csv).unwrap();
        assert_eq!(parse_centerline_csv(std::str::from_utf8(&csv).unwrap()).unwrap(), line);
    }
}

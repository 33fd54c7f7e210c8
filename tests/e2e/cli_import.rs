//! `lumen import`, run as a process: a cylinder surface written here becomes a tube whose spokes
//! reach its wall; broken inputs are refused with the file and line; files in other units are
//! refused until declared; VTK and JSON import like OBJ and CSV.

use lumen_detect::model::{load_native, parse_text};
use lumen_detect::Body;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const LUMEN: &str = env!("CARGO_BIN_EXE_lumen");
/// Cylinder: radius (mm), length along z (mm), facets around, rings of vertices.
const R: f32 = 10.0;
const LEN: f32 = 100.0;
const AROUND: usize = 96;
const ALONG: usize = 51;

fn dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lumen-import-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// An open cylinder about the z axis as an OBJ (two triangles per quad).
fn cylinder_obj() -> String {
    let mut s = String::from("# cylinder\n");
    for j in 0..ALONG {
        let z = LEN * j as f32 / (ALONG - 1) as f32;
        for i in 0..AROUND {
            let a = std::f32::consts::TAU * i as f32 / AROUND as f32;
            s += &format!("v {} {} {}\n", R * a.cos(), R * a.sin(), z);
        }
    }
    let id = |j: usize, i: usize| j * AROUND + i % AROUND + 1;
    for j in 0..ALONG - 1 {
        for i in 0..AROUND {
            s += &format!("f {} {} {}\nf {} {} {}\n", id(j, i), id(j + 1, i), id(j + 1, i + 1), id(j, i), id(j + 1, i + 1), id(j, i + 1));
        }
    }
    s
}

fn import(d: &Path, mesh: &str, out: &str, extra: &[&str]) -> Output {
    let mut csv = String::from("x,y,z\n");
    for k in 0..=18 {
        csv += &format!("0,0,{}\n", 5.0 + 5.0 * k as f32);
    }
    std::fs::write(d.join("c.csv"), csv).unwrap();
    Command::new(LUMEN).arg("import").arg(d.join(mesh)).arg("--centerline").arg(d.join("c.csv")).args(["--spokes", "16", "--ring-spacing", "2", "-o"]).arg(d.join(out)).args(extra).output().unwrap()
}

#[test]
fn a_cylinder_becomes_a_tube_whose_spokes_reach_its_wall() {
    let d = dir("cyl");
    std::fs::write(d.join("cyl.obj"), cylinder_obj()).unwrap();
    let out = import(&d, "cyl.obj", "cyl.lumen", &["--inflate", "1.5"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}{}", stdout, String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("rays kept their first wall hit"), "{stdout}");
    let Body::Tube(t) = load_native(&std::fs::read(d.join("cyl.lumen")).unwrap()).unwrap() else { panic!("not a tube") };
    assert_eq!(t.spokes, 16);
    // 90 mm of midline every 2 mm.
    assert!((45..=47).contains(&t.rings()), "{} rings", t.rings());
    // The facets are chords of the circle: a hit lies between R cos(pi / AROUND) and R.
    let lo = 1.5 * R * (std::f32::consts::PI / AROUND as f32).cos() - 1e-3;
    for (k, r) in t.radial.iter().enumerate() {
        let len = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
        assert!(len >= lo && len <= 1.5 * R + 1e-3, "spoke {k}: {len} mm");
        assert!(r[2].abs() < 1e-3, "spoke {k} leaves the ring plane: {r:?}");
    }
    // The text format holds the same model.
    let out = import(&d, "cyl.obj", "cyl.txt", &["--inflate", "1.5"]);
    assert!(out.status.success());
    let text = parse_text(&std::fs::read_to_string(d.join("cyl.txt")).unwrap()).unwrap();
    assert_eq!(text.rings(), t.rings());
    for (a, b) in text.radial.iter().zip(&t.radial) {
        assert!((0..3).all(|i| (a[i] - b[i]).abs() <= 1e-4 * R), "{a:?} vs {b:?}");
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn broken_inputs_are_refused_with_file_and_line() {
    let d = dir("bad");
    std::fs::write(d.join("bad.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 zero\nf 1 2 3\n").unwrap();
    let out = import(&d, "bad.obj", "bad.lumen", &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("bad.obj") && err.contains("line 3"), "{err}");
    assert!(!d.join("bad.lumen").exists(), "a model was written from a broken mesh");
    let out = import(&d, "absent.obj", "x.lumen", &[]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("absent.obj"));
    std::fs::write(d.join("cyl.obj"), cylinder_obj()).unwrap();
    let out = import(&d, "cyl.obj", "x.lumen", &["--inflate=-1"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--inflate"));
    let out = import(&d, "cyl.obj", "x.lumen", &["--fidelity=-1"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--fidelity"));
    let _ = std::fs::remove_dir_all(&d);
}

/// The midline CSV of [`import`], mapped point by point.
fn midline_csv(f: impl Fn([f32; 3]) -> [f32; 3]) -> String {
    let mut csv = String::from("x,y,z\n");
    for k in 0..=18 {
        let p = f([0.0, 0.0, 5.0 + 5.0 * k as f32]);
        csv += &format!("{},{},{}\n", p[0], p[1], p[2]);
    }
    csv
}

fn run(d: &Path, mesh: &str, line: &str, out: &str, extra: &[&str]) -> (bool, String, String) {
    let o =
        Command::new(LUMEN).arg("import").arg(d.join(mesh)).arg("--centerline").arg(d.join(line)).args(["--spokes", "16", "--ring-spacing", "2", "-o"]).arg(d.join(out)).args(extra).output().unwrap();
    (o.status.success(), String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned())
}

#[test]
fn files_in_other_units_are_refused_until_declared_and_force_writes_anyway() {
    let d = dir("units");
    // The cylinder and its midline in metres.
    let metres: String = cylinder_obj()
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(v) => format!("v {}\n", v.split_whitespace().map(|x| (x.parse::<f32>().unwrap() * 1e-3).to_string()).collect::<Vec<_>>().join(" ")),
            None => format!("{l}\n"),
        })
        .collect();
    std::fs::write(d.join("m.obj"), metres).unwrap();
    std::fs::write(d.join("m.csv"), midline_csv(|p| p.map(|x| x * 1e-3))).unwrap();
    let (ok, _, err) = run(&d, "m.obj", "m.csv", "m.lumen", &[]);
    assert!(!ok && err.contains("--units") && !d.join("m.lumen").exists(), "{err}");
    let (ok, out, err) = run(&d, "m.obj", "m.csv", "m.lumen", &["--units", "m"]);
    assert!(ok && out.contains("Radius min") && d.join("m.lumen").exists(), "{out}{err}");
    let Body::Tube(t) = load_native(&std::fs::read(d.join("m.lumen")).unwrap()).unwrap() else { panic!("not a tube") };
    let r = t.radial[0];
    assert!(((r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt() - R).abs() < 0.01, "{r:?}: the model is in mm");
    // A midline in 0.5 mm voxels from (-10, -10, 0) beside the surface in mm.
    std::fs::write(d.join("cyl.obj"), cylinder_obj()).unwrap();
    std::fs::write(d.join("v.csv"), midline_csv(|p| [(p[0] + 10.0) / 0.5, (p[1] + 10.0) / 0.5, p[2] / 0.5])).unwrap();
    let (ok, _, err) = run(&d, "cyl.obj", "v.csv", "v.lumen", &[]);
    assert!(!ok && err.contains("problem: the midline reaches") && err.contains("same units") && err.contains("not a usable tube"), "{err}");
    assert!(!d.join("v.lumen").exists());
    let (ok, _, err) = run(&d, "cyl.obj", "v.csv", "v.lumen", &["--force"]);
    assert!(ok && err.contains("problem: the midline reaches") && d.join("v.lumen").exists(), "--force: {err}");
    let (ok, out, err) = run(&d, "cyl.obj", "v.csv", "v2.lumen", &["--centerline-units", "voxel", "--voxel-size", "0.5", "--voxel-origin", "-10,-10,0"]);
    assert!(ok && !err.contains("problem") && out.contains("0 (0.00%) were repaired"), "{out}{err}");
    let (ok, _, err) = run(&d, "cyl.obj", "v.csv", "v3.lumen", &["--centerline-units", "voxel"]);
    assert!(!ok && err.contains("--voxel-size"), "{err}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_vtk_surface_and_a_json_midline_import_like_obj_and_csv() {
    let d = dir("vtk");
    let obj = cylinder_obj();
    let verts: Vec<&str> = obj.lines().filter_map(|l| l.strip_prefix("v ")).collect();
    let faces: Vec<Vec<usize>> = obj.lines().filter_map(|l| l.strip_prefix("f ")).map(|f| f.split_whitespace().map(|i| i.parse::<usize>().unwrap() - 1).collect()).collect();
    let mut vtk = format!("# vtk DataFile Version 3.0\ncylinder\nASCII\nDATASET POLYDATA\nPOINTS {} float\n", verts.len());
    verts.iter().for_each(|v| vtk += &format!("{v}\n"));
    vtk += &format!("POLYGONS {} {}\n", faces.len(), faces.len() * 4);
    faces.iter().for_each(|f| vtk += &format!("3 {} {} {}\n", f[0], f[1], f[2]));
    std::fs::write(d.join("cyl.vtk"), vtk).unwrap();
    std::fs::write(d.join("cyl.obj"), obj).unwrap();
    let points: Vec<String> = (0..=18).map(|k| format!("[0, 0, {}]", 5 + 5 * k)).collect();
    std::fs::write(d.join("c.json"), format!("{{\"points\": [{}]}}", points.join(", "))).unwrap();
    std::fs::write(d.join("c.csv"), midline_csv(|p| p)).unwrap();
    let (ok, _, err) = run(&d, "cyl.vtk", "c.json", "a.lumen", &[]);
    assert!(ok, "{err}");
    let (ok, _, err) = run(&d, "cyl.obj", "c.csv", "b.lumen", &[]);
    assert!(ok, "{err}");
    assert_eq!(std::fs::read(d.join("a.lumen")).unwrap(), std::fs::read(d.join("b.lumen")).unwrap());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn the_readmes_import_of_the_real_colon_is_the_gca_scenes_colon_at_48_spokes() {
    let Ok((mesh, line)) = lumen_scene::gca::paths(None) else {
        eprintln!("skipped: the GCA colon is not at ../shared/data/colon-gca00090");
        return;
    };
    let d = dir("gca");
    // The README's "bring your own colon" command.
    let out = Command::new(LUMEN).arg("import").arg(&mesh).arg("--centerline").arg(&line).args(["--spokes", "48", "--inflate", "2", "-o"]).arg(d.join("gca.lumen")).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && stdout.contains("Wall (before inflation) to surface"), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    let (Body::Tube(t), info) = lumen_detect::model::load_native_with(&std::fs::read(d.join("gca.lumen")).unwrap()).unwrap() else { panic!("not a tube") };
    // The gca scene's colon (ImportParams::gca) but for its 32 spokes.
    let params = lumen_import::ImportParams { spokes: 48, ..lumen_import::ImportParams::gca() };
    let (scene, report) = lumen_scene::gca::Source::read(None).unwrap().tube(&params).unwrap();
    assert_eq!(t, scene, "so `lumen demo --model gca.lumen` runs the gca scene's colon at 48 spokes");
    // The README's figure: the wall's p99 distance to the surface under 0.5 mm, stored in the
    // model as measured.
    let info = info.expect("the import's fidelity in the model");
    assert_eq!(info.fidelity_mm, [report.fidelity.p50, report.fidelity.p99, report.fidelity.max]);
    assert!(info.fidelity_mm[1] < 0.5, "{info:?}");
    let _ = std::fs::remove_dir_all(&d);
}

/// A closed tube of radius `r` about a gentle S-curve in the x-z plane, `len` mm along z, as an
/// OBJ, and its midline as a CSV: a small colon for a whole import-to-bench run.
fn s_tube(r: f32, len: f32) -> (String, String) {
    let (around, along) = (48, (len / 4.0) as usize + 1);
    let x = |z: f32| 20.0 * (std::f32::consts::TAU * z / len).sin();
    let dx = |z: f32| 20.0 * std::f32::consts::TAU / len * (std::f32::consts::TAU * z / len).cos();
    let mut obj = String::from("# an S-curved tube\n");
    for j in 0..along {
        let z = len * j as f32 / (along - 1) as f32;
        // The ring plane is normal to the curve's tangent (1 along z, dx along x).
        let n = (1.0 + dx(z) * dx(z)).sqrt();
        let (ux, uz) = (1.0 / n, -dx(z) / n);
        for i in 0..around {
            let a = std::f32::consts::TAU * i as f32 / around as f32;
            obj += &format!("v {} {} {}\n", x(z) + r * a.cos() * ux, r * a.sin(), z + r * a.cos() * uz);
        }
    }
    let id = |j: usize, i: usize| j * around + i % around + 1;
    for j in 0..along - 1 {
        for i in 0..around {
            obj += &format!("f {} {} {}\nf {} {} {}\n", id(j, i), id(j + 1, i), id(j + 1, i + 1), id(j, i), id(j + 1, i + 1), id(j, i + 1));
        }
    }
    let (bottom, top) = (along * around + 1, along * around + 2);
    obj += &format!("v {} 0 0\nv {} 0 {len}\n", x(0.0), x(len));
    for i in 0..around {
        obj += &format!("f {bottom} {} {}\nf {top} {} {}\n", id(0, i + 1), id(0, i), id(along - 1, i), id(along - 1, i + 1));
    }
    let mut csv = String::from("x,y,z\n");
    let mut z = 2.0;
    while z <= len - 2.0 {
        csv += &format!("{},0,{z}\n", x(z));
        z += 1.0;
    }
    (obj, csv)
}

#[test]
fn bench_detect_runs_on_a_model_lumen_import_wrote() {
    let d = dir("bench");
    let (obj, csv) = s_tube(12.0, 240.0);
    std::fs::write(d.join("s.obj"), obj).unwrap();
    std::fs::write(d.join("s.csv"), csv).unwrap();
    let o = Command::new(LUMEN).arg("import").arg(d.join("s.obj")).arg("--centerline").arg(d.join("s.csv")).args(["--spokes", "24", "-o"]).arg(d.join("s.lumen")).output().unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && stdout.contains("with the import's fidelity"), "{stdout}{}", String::from_utf8_lossy(&o.stderr));
    let (_, info) = lumen_detect::model::load_native_with(&std::fs::read(d.join("s.lumen")).unwrap()).unwrap();
    let info = info.expect("the import's fidelity in the model");
    assert!(info.fidelity_mm[1] < 0.2 && info.report.contains("rays kept their first wall hit"), "{info:?}");
    // The bench on that model alone, its fidelity beside the detection errors.
    let out = d.join("out");
    let o = Command::new(LUMEN).args(["bench", "detect", "--quick", "--no-progress", "--model"]).arg(d.join("s.lumen")).arg("--out").arg(&out).output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    let p99 = format!("{:.3}", info.fidelity_mm[1]);
    assert!(stderr.contains("model     B24 x4 default") && stderr.contains("model     B24 import: wall to surface") && stderr.contains(&p99), "{stderr}");
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("| model | 24 |") && md.contains("## Import fidelity") && md.contains(&format!("/ {p99} /")) && md.contains("s.lumen"), "{md}");
    assert!(!md.contains("| generated |") && !md.contains("| gca |"), "the model alone: {md}");
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    let scene = &json["scenes"][0];
    assert_eq!(scene["scene"], "model");
    assert_eq!(scene["import_fidelity_mm"][1].as_f64(), Some(info.fidelity_mm[1]));
    assert!(json["runs"].as_array().unwrap().iter().all(|r| r["scene"] == "model" && r["spokes"] == 24));
    // A model file that is not there, or not a model: the error names it.
    for (file, says) in [("absent.lumen", "No such file"), ("s.csv", "LUMN")] {
        let o = Command::new(LUMEN).args(["bench", "detect", "--quick", "--no-progress", "--model"]).arg(d.join(file)).arg("--out").arg(d.join("out2")).output().unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && stderr.contains(&d.join(file).display().to_string()) && stderr.contains(says), "{file}: {stderr}");
    }
    assert!(!d.join("out2").exists(), "no report without a model");
    let _ = std::fs::remove_dir_all(&d);
}

/// A tube that folds: round rings of radius 10 along a quarter circle of radius 6 (planes along
/// the midline's tangent), between two straight runs.
fn folded_tube() -> lumen_detect::Tube {
    let (r, bend, spokes) = (10.0f32, 6.0f32, 16usize);
    let mut frames: Vec<([f32; 3], [f32; 3])> = (1..=30).rev().map(|m| ([bend, -(m as f32), 0.0], [0.0, 1.0, 0.0])).collect();
    for m in 0..=20 {
        let a = std::f32::consts::FRAC_PI_2 * m as f32 / 20.0;
        frames.push(([bend * a.cos(), bend * a.sin(), 0.0], [-a.sin(), a.cos(), 0.0]));
    }
    frames.extend((1..=30).map(|m| ([-(m as f32), bend, 0.0], [-1.0, 0.0, 0.0])));
    let (mut points, mut radial) = (Vec::new(), Vec::new());
    for (p, t) in frames {
        points.push(p);
        let e1 = [t[1], -t[0], 0.0];
        for k in 0..spokes {
            let a = std::f32::consts::TAU * k as f32 / spokes as f32;
            radial.push([r * e1[0] * a.cos(), r * e1[1] * a.cos(), r * a.sin()]);
        }
    }
    lumen_detect::Tube::new(points, radial, spokes).unwrap()
}

#[test]
fn a_model_file_that_folds_is_refused_by_the_demo_and_the_bench_with_its_cause() {
    let d = dir("folded");
    let tube = folded_tube();
    assert!(tube.folds().spokes > 0);
    std::fs::write(d.join("f.lumen"), lumen_detect::model::save_native(&Body::Tube(tube.clone()))).unwrap();
    let says = "reach past another ring's plane inside its section";
    let o = Command::new(LUMEN).args(["demo", "--frames", "10", "--no-record", "--model"]).arg(d.join("f.lumen")).arg("--out").arg(d.join("demo")).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains(says) && err.contains("f.lumen"), "{err}");
    let o = Command::new(LUMEN).args(["bench", "detect", "--quick", "--no-progress", "--model"]).arg(d.join("f.lumen")).arg("--out").arg(d.join("bench")).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains(says) && err.contains("f.lumen"), "{err}");
    // Clipped short of its crossings, the same tube passes the gate.
    let mut clipped = tube;
    assert!(clipped.clip_folds().spokes > 0);
    assert!(lumen_import::check(&clipped).is_ok());
}

/// `lumen generate` writes a surface and a midline the import reads, the same for the same seed,
/// another for another; a flag out of range is named and nothing is written.
#[test]
fn generate_writes_a_seeded_surface_and_midline_for_the_import() {
    let d = dir("generate");
    let run = |seed: &str, out: &str, extra: &[&str]| Command::new(LUMEN).args(["generate", "--seed", seed, "--voxel", "2.5", "-o"]).arg(d.join(out)).args(extra).output().unwrap();
    let a = run("4", "a", &[]);
    let stdout = String::from_utf8_lossy(&a.stdout);
    assert!(a.status.success(), "{stdout}{}", String::from_utf8_lossy(&a.stderr));
    assert!(stdout.contains("sigmoid hairpin") && stdout.contains("next: lumen import"), "{stdout}");
    let mesh = lumen_import::load_mesh(d.join("a/surface.obj")).unwrap();
    let line = lumen_import::load_centerline(d.join("a/midline.csv")).unwrap();
    assert!(mesh.triangles.len() > 10_000 && line.points.len() > 600, "{} triangles, {} points", mesh.triangles.len(), line.points.len());
    // The midline starts at the anus, the origin, and runs a point per millimetre.
    assert_eq!(line.points[0], [0.0, 0.0, 0.0]);
    assert!((line.length() - (line.points.len() - 1) as f64).abs() < 1.0, "{} mm over {} points", line.length(), line.points.len());
    assert!(run("4", "b", &[]).status.success());
    for f in ["surface.obj", "midline.csv"] {
        assert_eq!(std::fs::read(d.join("a").join(f)).unwrap(), std::fs::read(d.join("b").join(f)).unwrap(), "{f} differs for the same seed");
    }
    assert!(run("5", "c", &[]).status.success());
    assert_ne!(std::fs::read(d.join("a/midline.csv")).unwrap(), std::fs::read(d.join("c/midline.csv")).unwrap());
    for (flag, value, says) in [("--radius", "40,30", "--radius"), ("--canal-radius", "0.5", "--canal-radius"), ("--radius", "30", "--radius")] {
        let out = run("4", "bad", &[flag, value]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(says), "{flag} {value}: {stderr}");
        assert!(!d.join("bad").exists(), "{flag} {value} wrote files");
    }
}

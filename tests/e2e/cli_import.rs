//! `lumen import`, run as a process: a cylinder surface written here becomes a tube whose spokes
//! reach its wall; broken inputs are refused with the file and line.

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
    let _ = std::fs::remove_dir_all(&d);
}

//! The real colon (Edinburgh Gut Cell Atlas EdinGCA_3D_00090, CC BY 4.0,
//! doi:10.1186/s12911-023-02111-9), when its files are at ../shared/data/colon-gca00090.

use lumen_import::probe::Lumen;
use lumen_import::*;
use lumen_scene::endoscope::{Frame, Insertion};
use std::time::Instant;

fn gca() -> Option<(Mesh, Centerline)> {
    match lumen_scene::gca::paths(None) {
        Ok((m, c)) => {
            let t0 = Instant::now();
            let loaded = (load_mesh(m).unwrap(), load_centerline_csv(c).unwrap());
            eprintln!("loaded in {:?}", t0.elapsed());
            Some(loaded)
        }
        Err(e) => {
            eprintln!("skipped: {e}");
            None
        }
    }
}

#[test]
fn real_colon_imports_with_plausible_numbers() {
    let Some((mesh, line)) = gca() else { return };
    eprintln!("data: {}", lumen_scene::gca::attribution());
    assert_eq!(mesh.triangles.len(), 20_000);
    assert_eq!(mesh.vertices.len(), 10_000);
    assert_eq!(line.points.len(), 1375);
    assert!((line.length() - 1248.6).abs() < 2.0, "midline {:.1} mm", line.length());
    let t0 = Instant::now();
    let (tube, rep) = build_tube(&mesh, &line, &ImportParams::gca()).unwrap();
    eprintln!("built in {:?}\n{rep}", t0.elapsed());
    assert_eq!(tube.rings(), 1249);
    assert_eq!(rep.rays, 1249 * 32);
    assert!(rep.oriented);
    // The scan's median lumen radius is about 9.4 mm; inflated twice.
    let [_, p5, med, p95, _] = rep.radius_mm;
    assert!((med - 2.0 * 9.4).abs() < 2.0, "median radius {med:.2} mm");
    assert!(p5 > 2.0 * 4.0 && p95 < 2.0 * 25.0, "p5 {p5:.1}, p95 {p95:.1} mm");
    // Repairs exist (the colon touches itself) but are few.
    assert!(rep.repaired() > 0 && rep.repaired_fraction() < 0.10, "{rep}");
    assert_eq!(rep.kept + rep.repaired(), rep.rays);
    assert_eq!(rep.missed + rep.from_outside + rep.neighbouring_loop + rep.outliers, rep.repaired());
    assert_eq!(rep.interpolated + rep.clamped, rep.repaired());
    assert_eq!(tube.first_non_star(), None);
    // It passes the quality gate, oriented as given, and its wall (before inflation) lies on
    // the surface but where rays were repaired and where rings cross in tight bends.
    assert!(assess(&rep, &Thresholds::default()).is_empty(), "{:?}", assess(&rep, &Thresholds::default()));
    assert!(!rep.flipped && rep.orientation_agreement > 0.99 && rep.turns_back.is_empty());
    let w = rep.fidelity;
    assert!(w.p50 < 0.05 && w.p99 < 1.5 && w.max < 20.0, "{w:?}");
    // No spoke ends inside another ring's section, at the scan's width and inflated 2 and 4
    // times (the hard class: lumens far wider than the flexures' bend radius).
    assert_eq!(tube.folds(), lumen_detect::model::FoldReport::default());
    for inflate in [1.0, 4.0] {
        let (t, r) = import(&mesh, &line, &ImportParams { inflate, ..ImportParams::gca() }).unwrap_or_else(|e| panic!("inflate {inflate}: {e}"));
        assert_eq!((t.folds().spokes, r.folds.spokes), (0, 0), "inflate {inflate}: {r}");
        eprintln!("inflate {inflate}: {r}");
        if inflate == 1.0 {
            assert!(r.fidelity.p99 <= 0.55 && r.clipped.spokes < 200, "{r}");
        }
    }
}

#[test]
fn a_double_walled_colon_in_a_data_folder_is_refused_by_the_scene_as_by_lumen_import() {
    use lumen_scene::gca::{load, CENTERLINE, MESH};
    // A cylinder of radius 12 along z, written twice over itself.
    let d = std::env::temp_dir().join(format!("lumen-scene-{}-doubled", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let (around, along) = (48usize, 41usize);
    let mut obj = String::new();
    for j in 0..along {
        for i in 0..around {
            let a = std::f32::consts::TAU * i as f32 / around as f32;
            obj += &format!("v {} {} {}\n", 12.0 * a.cos(), 12.0 * a.sin(), 5.0 * j as f32);
        }
    }
    let id = |j: usize, i: usize| j * around + i % around + 1;
    for _ in 0..2 {
        for j in 0..along - 1 {
            for i in 0..around {
                obj += &format!("f {} {} {}\nf {} {} {}\n", id(j, i), id(j + 1, i), id(j + 1, i + 1), id(j, i), id(j + 1, i + 1), id(j, i + 1));
            }
        }
    }
    std::fs::write(d.join(MESH), obj).unwrap();
    let csv: String = (0..=38).map(|k| format!("0,0,{}\n", 5.0 + 5.0 * k as f32)).collect();
    std::fs::write(d.join(CENTERLINE), format!("x,y,z\n{csv}")).unwrap();
    let err = load(Some(&d), 2.0).unwrap_err().to_string();
    assert!(err.contains("refused") && err.contains("doubled wall"), "{err}");
}

#[test]
fn scope_frames_in_the_real_colon_stay_inside_except_recorded_escapes() {
    let Some((mesh, line)) = gca() else { return };
    let (colon, _) = build_tube(&mesh, &line, &ImportParams::gca()).unwrap();
    let frames: Vec<Frame> = Insertion::default().frames(&colon, 60, 700.0, 1.0, 2).collect();
    let mut escaped = 0;
    for f in &frames {
        let lumen = Lumen::new(&f.colon);
        for j in 0..f.inserted {
            let p = lumen.locate(f.scope.points[j], (f.arc_mm[j] as usize).saturating_sub(2)).expect("inserted point in the colon");
            if f.escaped.contains(&j) {
                assert!(p.gap() < 0.0);
                escaped += 1;
            } else {
                assert!(p.gap() > 0.0, "frame {}: point {j} outside but not recorded", f.index);
            }
        }
    }
    eprintln!("{escaped} escaped samples over {} frames", frames.len());
}

#[test]
fn gca_paths_names_what_is_missing() {
    use lumen_scene::gca::{attribution, default_dir, paths, CENTERLINE, MESH};
    let d = std::env::temp_dir().join(format!("lumen-scene-{}-gca", std::process::id()));
    // Empty, whatever an earlier run of the same process id left there.
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let err = paths(Some(&d)).unwrap_err().to_string();
    assert!(err.contains(MESH) && err.contains(CENTERLINE) && err.contains(&d.canonicalize().unwrap().display().to_string()), "{err}");
    std::fs::write(d.join(MESH), "").unwrap();
    let err = paths(Some(&d)).unwrap_err().to_string();
    assert!(!err.contains(MESH) && err.contains(CENTERLINE), "{err}");
    std::fs::write(d.join(CENTERLINE), "").unwrap();
    assert_eq!(paths(Some(&d)).unwrap(), (d.join(MESH), d.join(CENTERLINE)));
    std::fs::remove_dir_all(&d).unwrap();
    assert!(default_dir().ends_with("shared/data/colon-gca00090"));
    assert!(attribution().contains("CC BY 4.0") && attribution().contains("doi:10.1186/s12911-023-02111-9"));
}

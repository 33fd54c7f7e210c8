//! Import: OBJ / STL / CSV parsing, and tubes built by ray casting on known surfaces.

use lumen_import::*;
use std::path::PathBuf;

type V = nalgebra::Vector3<f64>;

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lumen-import-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

const PYRAMID_OBJ: &str = "# a square pyramid, outward faces, in every face syntax
o pyramid
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0.5 0.5 1.0
vt 0 0
vn 0 0 1
f 1 4 3 2
f 1/1 2/1 5/1
f 2//1 3//1 5//1
f 3/1/1 4/1/1 5/1/1   # trailing comment
f -5 -1 -2
";

#[test]
fn obj_faces_in_every_form_are_fanned() {
    let m = parse_obj(PYRAMID_OBJ).unwrap();
    assert_eq!(m.vertices.len(), 5);
    assert_eq!(m.triangles, vec![[0, 3, 2], [0, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [0, 4, 3]]);
    assert!((m.signed_volume() - 1.0 / 3.0).abs() < 1e-6, "volume {}", m.signed_volume());
    let err = parse_obj("v 0 0 0\nv 1 0 0\nf 1 2 9\n").unwrap_err().to_string();
    assert!(err.contains("line 3") && err.contains('9'), "{err}");
    let err = parse_obj("v 0 0 zero\n").unwrap_err().to_string();
    assert!(err.contains("line 1"), "{err}");
    let d = tmp_dir("obj");
    let path = d.join("p.OBJ");
    std::fs::write(&path, PYRAMID_OBJ).unwrap();
    assert_eq!(load_mesh(&path).unwrap(), m);
    let err = load_mesh(d.join("absent.obj")).unwrap_err().to_string();
    assert!(err.contains("absent.obj"), "{err}");
}

fn pyramid_triangles() -> Vec<[[f32; 3]; 3]> {
    let m = parse_obj(PYRAMID_OBJ).unwrap();
    m.triangles.iter().map(|t| t.map(|i| m.vertices[i as usize])).collect()
}

#[test]
fn stl_ascii_and_binary_give_the_same_mesh() {
    let tris = pyramid_triangles();
    let mut ascii = String::from("solid pyramid\n");
    for t in &tris {
        ascii.push_str("  facet normal 0 0 0\n    outer loop\n");
        for v in t {
            ascii.push_str(&format!("      vertex {:e} {} {}\n", v[0], v[1], v[2]));
        }
        ascii.push_str("    endloop\n  endfacet\n");
    }
    ascii.push_str("endsolid pyramid\n");
    let mut bin = vec![0u8; 80];
    bin[..6].copy_from_slice(b"binary");
    bin.extend_from_slice(&(tris.len() as u32).to_le_bytes());
    for t in &tris {
        bin.extend(std::iter::repeat_n(0u8, 12)); // normal
        for v in t {
            for c in v {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        bin.extend_from_slice(&0u16.to_le_bytes());
    }
    assert_eq!(bin.len(), 84 + 50 * tris.len());
    let d = tmp_dir("stl");
    std::fs::write(d.join("a.stl"), &ascii).unwrap();
    std::fs::write(d.join("b.stl"), &bin).unwrap();
    std::fs::write(d.join("b.mesh"), &bin).unwrap(); // sniffed by content
    let a = load_mesh(d.join("a.stl")).unwrap();
    let b = load_mesh(d.join("b.stl")).unwrap();
    let c = load_mesh(d.join("b.mesh")).unwrap();
    for m in [&a, &b, &c] {
        assert_eq!(m.vertices.len(), 5, "equal vertices merged");
        assert_eq!(m.triangles.len(), 6);
        assert!((m.signed_volume() - 1.0 / 3.0).abs() < 1e-6);
    }
    assert_eq!(a, b);
    assert_eq!(b, c);
    assert!(parse_stl(b"solid x\n facet normal 0 0 1\n outer loop\n vertex 0 0 0\n vertex 1 0 0\n endloop\nendfacet\n").is_err());
    assert!(parse_stl(&bin[..bin.len() - 1]).is_err());
}

#[test]
fn centerline_csv_with_header_comments_and_nan() {
    let text = "# s_mm,x_mm,y_mm,z_mm,r_median_mm\n# anus at s=0, and a comment with commas\n0.0,1,2,3,5.5\n1.0,1,2,4,NaN\n\n2.0,1,2,5,6\n# trailing comment\n";
    let c = parse_centerline_csv(text).unwrap();
    assert_eq!(c.points, vec![[1.0, 2.0, 3.0], [1.0, 2.0, 4.0], [1.0, 2.0, 5.0]]);
    assert_eq!(c.s, Some(vec![0.0, 1.0, 2.0]));
    let r = c.radius_median.clone().unwrap();
    assert_eq!(r[0], 5.5);
    assert!(r[1].is_nan());
    assert!((c.length() - 2.0).abs() < 1e-9);
    // No header: three columns are x y z, whitespace separated is fine.
    let c = parse_centerline_csv("0 0 0\n0 0 1\n0 1 1\n").unwrap();
    assert_eq!(c.points.len(), 3);
    assert_eq!(c.s, None);
    let err = parse_centerline_csv("x,y,z\n0,0,0\n0,0,oops\n").unwrap_err().to_string();
    assert!(err.contains("line 3"), "{err}");
    assert!(parse_centerline_csv("x,y,z\n0,0,0\n").is_err(), "one point is not a midline");
    assert!(parse_centerline_csv("x,y,z\n0,0,0\n0,0,NaN\n").is_err(), "coordinates must be finite");
}

/// A closed cylinder along z from 0 to `len`, axis through (cx, 0), outward faces.
fn cylinder(cx: f32, r: f32, len: f32, around: usize, along: usize) -> Mesh {
    let mut m = Mesh::default();
    for i in 0..=along {
        let z = len * i as f32 / along as f32;
        for k in 0..around {
            let a = std::f32::consts::TAU * k as f32 / around as f32;
            m.vertices.push([cx + r * a.cos(), r * a.sin(), z]);
        }
    }
    let id = |i: usize, k: usize| (i * around + k % around) as u32;
    for i in 0..along {
        for k in 0..around {
            m.triangles.push([id(i, k), id(i, k + 1), id(i + 1, k + 1)]);
            m.triangles.push([id(i, k), id(i + 1, k + 1), id(i + 1, k)]);
        }
    }
    let (bottom, top) = (m.vertices.len() as u32, m.vertices.len() as u32 + 1);
    m.vertices.push([cx, 0.0, 0.0]);
    m.vertices.push([cx, 0.0, len]);
    for k in 0..around {
        m.triangles.push([bottom, id(0, k + 1), id(0, k)]);
        m.triangles.push([top, id(along, k), id(along, k + 1)]);
    }
    m
}

fn merge(a: &Mesh, b: &Mesh) -> Mesh {
    let mut m = a.clone();
    let off = m.vertices.len() as u32;
    m.vertices.extend_from_slice(&b.vertices);
    m.triangles.extend(b.triangles.iter().map(|t| t.map(|i| i + off)));
    m
}

/// Drops the triangles of `m` whose centroid lies inside the infinite cylinder (cx, 0, r).
fn cut(m: &Mesh, cx: f32, r: f32) -> Mesh {
    let mut out = m.clone();
    out.triangles.retain(|t| {
        let c = t.iter().fold([0.0f32; 3], |acc, &i| {
            let v = m.vertices[i as usize];
            [acc[0] + v[0] / 3.0, acc[1] + v[1] / 3.0, acc[2] + v[2] / 3.0]
        });
        (c[0] - cx).powi(2) + c[1].powi(2) >= r * r
    });
    out
}

fn axis(n: usize) -> Centerline {
    Centerline { points: (0..n).map(|i| [0.0, 0.0, 5.0 + 90.0 * i as f32 / (n - 1) as f32]).collect(), ..Default::default() }
}

fn radii(t: &lumen_detect::Tube) -> (f32, f32) {
    t.radial.iter().map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()).fold((f32::INFINITY, 0.0f32), |(a, b), r| (a.min(r), b.max(r)))
}

#[test]
fn a_cylinder_imports_with_its_radius_and_no_repairs() {
    let mesh = cylinder(0.0, 10.0, 100.0, 64, 20);
    assert!(mesh.signed_volume() > 0.0);
    let params = ImportParams { spokes: 32, ring_spacing: 1.0, inflate: 1.0, ..Default::default() };
    let (tube, rep) = build_tube(&mesh, &axis(10), &params).unwrap();
    eprintln!("{rep}");
    assert_eq!(tube.rings(), 91);
    assert_eq!(tube.spokes, 32);
    assert_eq!(rep.rays, 91 * 32);
    assert_eq!(rep.repaired(), 0, "{rep}");
    assert_eq!(rep.kept, rep.rays);
    assert!(rep.oriented);
    let (lo, hi) = radii(&tube);
    // 64-gon inscribed in radius 10: between 10 cos(pi/64) and 10.
    assert!(lo > 9.985 && hi < 10.001, "radii {lo}..{hi}");
    assert_eq!(tube.first_non_star(), None);
    assert!((rep.radius_mm[2] - 10.0).abs() < 0.02);
    assert_eq!(rep.folds, lumen_detect::model::FoldReport::default());
    let text = rep.to_string();
    assert!(text.contains("91 rings x 32 spokes") && text.contains("0 (0.00%) were repaired"), "{text}");
    // Inflated twice.
    let (tube2, rep2) = build_tube(&mesh, &axis(10), &ImportParams { inflate: 2.0, ..params.clone() }).unwrap();
    let (lo, hi) = radii(&tube2);
    assert!(lo > 19.97 && hi < 20.002, "inflated radii {lo}..{hi}");
    assert_eq!(rep2.repaired(), 0);
    // Spokes run counter-clockwise about the midline's direction (+z), spoke 0 at +x.
    let (s0, s1) = (tube.spoke(50, 0), tube.spoke(50, 1));
    assert!(s0[0] > 9.9 && s0[1].abs() < 1e-3);
    assert!(s0[0] * s1[1] - s0[1] * s1[0] > 0.0);
}

#[test]
fn a_second_cylinder_fused_to_it_is_repaired_and_counted() {
    // Two parallel cylinders 18 mm apart overlap by 2 mm; keeping only the outside parts of
    // each gives one surface with a slit between the lumens, like the GCA colon where it touches
    // itself. Rays within about 26 degrees of +x pass the slit and hit the far wall of the
    // second lumen (23.9 to 28 mm away).
    let (a, b) = (cylinder(0.0, 10.0, 100.0, 64, 20), cylinder(18.0, 10.0, 100.0, 64, 20));
    let fused = merge(&cut(&a, 18.0, 10.0), &cut(&b, 0.0, 10.0));
    let params = ImportParams { spokes: 32, ring_spacing: 1.0, inflate: 1.0, ..Default::default() };
    let (tube, rep) = build_tube(&fused, &axis(10), &params).unwrap();
    eprintln!("{rep}");
    // Five rays per ring (0, +-11.25, +-22.5 degrees) reach the other lumen.
    assert_eq!(rep.repaired(), 5 * 91, "{rep}");
    assert_eq!(rep.outliers, 5 * 91);
    assert_eq!(rep.interpolated, 5 * 91);
    assert_eq!(rep.kept + rep.repaired(), rep.rays);
    let (lo, hi) = radii(&tube);
    assert!(lo > 9.9 && hi < 10.05, "repaired radii {lo}..{hi}");
    assert!(rep.to_string().contains(&format!("{} were outliers", 5 * 91)));

    // Overlapping complete surfaces: the first hit is the second cylinder's wall, from outside.
    let both = merge(&a, &b);
    let (tube, rep) = build_tube(&both, &axis(10), &params).unwrap();
    eprintln!("{rep}");
    assert_eq!(rep.from_outside, 5 * 91, "{rep}");
    assert_eq!(rep.repaired(), rep.from_outside);
    let (lo, hi) = radii(&tube);
    assert!(lo > 9.9 && hi < 10.05, "repaired radii {lo}..{hi}");
}

#[test]
fn bad_parameters_are_refused() {
    let mesh = cylinder(0.0, 10.0, 100.0, 16, 4);
    for (p, named) in [
        (ImportParams { spokes: 2, ..Default::default() }, "spokes 2"),
        (ImportParams { spokes: 257, ..Default::default() }, "spokes 257"),
        (ImportParams { ring_spacing: 0.0, ..Default::default() }, "ring_spacing 0"),
        (ImportParams { inflate: -1.0, ..Default::default() }, "inflate -1"),
        (ImportParams { tangent_smoothing_mm: -1.0, ..Default::default() }, "tangent_smoothing -1"),
        (ImportParams { point_smoothing_mm: f32::NAN, ..Default::default() }, "point_smoothing NaN"),
        (ImportParams { fidelity_mm: -1.0, ..Default::default() }, "fidelity -1"),
        (ImportParams { tangent_smoothing_mm: 8.0, widest_smoothing_mm: 4.0, ..Default::default() }, "widest_smoothing 4: expected a number >= the tangent smoothing (8)"),
    ] {
        let e = build_tube(&mesh, &axis(3), &p).unwrap_err().to_string();
        assert!(e.contains(named), "{e}");
        assert_eq!(p.validate().unwrap_err().to_string(), e);
    }
    assert!(ImportParams::default().validate().is_ok() && ImportParams::gca().validate().is_ok());
    assert!(build_tube(&Mesh::default(), &axis(3), &ImportParams::default()).is_err());
    let one = Centerline { points: vec![[0.0; 3], [0.0; 3]], ..Default::default() };
    assert!(build_tube(&mesh, &one, &ImportParams::default()).is_err());
}

/// A midline up the axis of the lumen at `x = a`, across at z = 95 and down the axis at `x = b`:
/// two legs of one colon side by side, like a loop that doubles back.
fn hairpin(a: f32, b: f32) -> Centerline {
    let mut points: Vec<[f32; 3]> = (0..=90).map(|i| [a, 0.0, 5.0 + i as f32]).collect();
    points.extend((1..(b - a) as usize).map(|i| [a + i as f32, 0.0, 95.0]));
    points.extend((0..=90).map(|i| [b, 0.0, 95.0 - i as f32]));
    Centerline { points, ..Default::default() }
}

#[test]
fn a_midline_off_the_lumens_centre_keeps_its_far_wall() {
    // The midline runs 8 mm off the axis of a 10 mm cylinder: its rays reach the wall from 2 to
    // 18 mm away (median 6), gradually all around. The far wall is the ring's own, continuous
    // with its neighbours; rays far above their ring's median were once repaired there, and the
    // interpolated wall lay up to 4 mm inside the surface.
    let mesh = cylinder(0.0, 10.0, 100.0, 64, 20);
    let line = Centerline { points: (0..10).map(|i| [8.0, 0.0, 5.0 + 10.0 * i as f32]).collect(), ..Default::default() };
    let (tube, rep) = build_tube(&mesh, &line, &ImportParams::default()).unwrap();
    eprintln!("{rep}");
    assert_eq!(rep.repaired(), 0, "{rep}");
    let (lo, hi) = radii(&tube);
    assert!(lo > 1.95 && lo < 2.05 && hi > 17.9 && hi < 18.01, "radii {lo}..{hi}");
    let w = rep.fidelity;
    // Chords of up to 3.5 mm between spokes on a 10 mm circle: 0.15 mm inside it at most.
    assert!(w.max < 0.16 && w.near_repaired == 0 && w.kept_p99 == w.p99, "{w:?}");
}

#[test]
fn a_loop_behind_the_wall_is_not_a_neighbouring_loop() {
    // Two closed lumens 2 mm apart, wall to wall: a 10 mm one and a 3 mm one beside it, the
    // midline up the first and down the second. The first's rays towards the second (within
    // about 26 degrees of +x) hit its own wall 5 mm from the second's midline, nearer than 3/4
    // of the ray, but the second's midline does not see them (its own wall is in the way): they
    // are the ring's own wall and are kept.
    let mesh = merge(&cylinder(0.0, 10.0, 100.0, 64, 20), &cylinder(15.0, 3.0, 100.0, 32, 20));
    // (One smoothing: wider ones tilt the legs' planes towards the bend and into the walls.)
    let (tube, rep) = build_tube(&mesh, &hairpin(0.0, 15.0), &ImportParams { widest_smoothing_mm: 4.0, ..Default::default() }).unwrap();
    eprintln!("{rep}");
    // The first leg's rings (z = 5 to 90) keep every ray, and their wall lies on the surface
    // (up to z = 80: nearer the bend the ring planes tilt).
    for (i, t) in rep.ring_tallies.iter().enumerate().take(86) {
        assert_eq!(t.repaired, 0, "ring {i}: {t:?}\n{rep}");
    }
    // (Rings within the crossbar's sections' reach of the top, where the midline crosses from
    // one lumen to the other through the walls, are clipped short of those sections.)
    for i in 0..30 {
        for k in 0..tube.spokes {
            // The tip's distance from the first lumen's axis (x = y = 0): planes near the bend
            // tilt, so spokes are longer than the radius, but every tip lies on the wall.
            let (v, p) = (tube.spoke(i, k), tube.points[i]);
            let r = ((v[0] + p[0]).powi(2) + (v[1] + p[1]).powi(2)).sqrt();
            assert!(r > 9.98 && r < 10.01, "ring {i} spoke {k}: {r}");
        }
    }
}

#[test]
fn a_neighbouring_loop_through_a_gap_is_still_repaired() {
    // The two lumens of `a_second_cylinder_fused_to_it_is_repaired_and_counted`, joined by a
    // slit along their length, now with the midline up one and down the other: the rays through
    // the slit hit the other lumen's far wall, which that lumen's midline sees. They are counted
    // as a neighbouring loop and repaired, and the fidelity tells their wall points apart.
    let (a, b) = (cylinder(0.0, 10.0, 100.0, 64, 20), cylinder(18.0, 10.0, 100.0, 64, 20));
    let fused = merge(&cut(&a, 18.0, 10.0), &cut(&b, 0.0, 10.0));
    let (tube, rep) = build_tube(&fused, &hairpin(0.0, 18.0), &ImportParams { widest_smoothing_mm: 4.0, ..Default::default() }).unwrap();
    eprintln!("{rep}");
    // Five rays per ring of either leg, away from the bend at the top.
    for (i, t) in rep.ring_tallies.iter().enumerate().take(70) {
        assert_eq!(t.repaired, 5, "ring {i}: {t:?}\n{rep}");
    }
    assert!(rep.neighbouring_loop >= 2 * 5 * 70, "{rep}");
    // (Nearer the top, spokes are clipped short of the crossbar's sections.)
    for i in 0..60 {
        for k in 0..tube.spokes {
            let v = tube.spoke(i, k);
            let r = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            assert!(r > 9.0 && r < 10.05, "ring {i} spoke {k}: {r}");
        }
    }
    let w = rep.fidelity;
    // The repaired wall bridges the 8.7 mm slit, up to 4.4 mm from its edges; between kept
    // spokes the wall is on the surface.
    assert!(w.near_repaired > 0 && w.p99 > 3.0 && w.kept_p99 < 0.1, "{w:?}");
}

#[test]
fn a_bend_tighter_than_the_lumen_is_sliced_with_planes_that_do_not_cross_inside_it() {
    // A wide cylinder (radius 30) and a midline that turns 90 degrees on a 5 mm arc inside it:
    // planes along the midline's tangent cross 5 mm from it, and the spokes on the bend's inside
    // reach the wall 20 mm or more beyond. The import fans the planes (wider smoothing there) and
    // clips what still crosses: no spoke ends inside another ring's section.
    let mesh = cylinder(0.0, 30.0, 100.0, 96, 40);
    let mut points: Vec<[f32; 3]> = (0..=30).map(|i| [0.0, 0.0, 10.0 + i as f32]).collect();
    let arc: Vec<[f32; 3]> = (1..=8)
        .map(|i| {
            let a = std::f32::consts::FRAC_PI_2 * i as f32 / 8.0;
            [5.0 - 5.0 * a.cos(), 0.0, 40.0 + 5.0 * a.sin()]
        })
        .collect();
    points.extend(arc);
    points.extend((1..=15).map(|i| [5.0 + i as f32, 0.0, 45.0]));
    let line = Centerline { points, ..Default::default() };
    let params = ImportParams { tangent_smoothing_mm: 0.5, point_smoothing_mm: 0.0, ..Default::default() };
    let (tube, rep) = build_tube(&mesh, &line, &params).unwrap();
    eprintln!("{rep}");
    assert_eq!(rep.folds, lumen_detect::model::FoldReport::default(), "{rep}");
    assert_eq!(tube.folds(), rep.folds);
    assert!(rep.smoothing_mm > 0.5 && rep.widths_tried > 1 && rep.max_tilt_deg > 10.0, "{rep}");
    assert!(rep.to_string().contains("no spoke reaches past another ring's plane inside its section"), "{rep}");
    // The same tube with every ring's plane along its own tangent (the import's planes turned
    // back, spokes cast again by their length in the plane) folds: what the fan avoided.
    let mut flat = tube.clone();
    let n = flat.rings();
    for i in 0..n {
        let (a, c) = (flat.points[i.saturating_sub(1)], flat.points[(i + 1).min(n - 1)]);
        let t = V::new((c[0] - a[0]) as f64, (c[1] - a[1]) as f64, (c[2] - a[2]) as f64).normalize();
        let e1 = if t.cross(&V::y()).norm() > 0.1 { t.cross(&V::y()).normalize() } else { t.cross(&V::x()).normalize() };
        let e2 = t.cross(&e1);
        for k in 0..flat.spokes {
            let a = std::f64::consts::TAU * k as f64 / flat.spokes as f64;
            let d = e1 * a.cos() + e2 * a.sin();
            // The cylinder's wall along d from the point (radius 30 about the z axis).
            let p = flat.points[i];
            let (px, py, dx, dy) = (p[0] as f64, p[1] as f64, d.x, d.y);
            let (qa, qb, qc) = (dx * dx + dy * dy, 2.0 * (px * dx + py * dy), px * px + py * py - 900.0);
            let r = if qa < 1e-12 { 60.0 } else { (-qb + (qb * qb - 4.0 * qa * qc).sqrt()) / (2.0 * qa) };
            flat.radial[i * flat.spokes + k] = [(d.x * r) as f32, (d.y * r) as f32, (d.z * r) as f32];
        }
    }
    let folded = flat.folds();
    assert!(folded.spokes > 10 && folded.max_cut > 5.0, "{folded:?}");
    // The wall stays on the surface.
    assert!(rep.fidelity.p99 < 0.5, "{:?}", rep.fidelity);
}

/// A tube along z of radius `r + amp cos(lobes a)` at angle `a`: folds running along it, as a
/// colon's taeniae do, which the chords between spokes cut across.
fn fluted(r: f32, amp: f32, lobes: f32, len: f32, around: usize, along: usize) -> Mesh {
    let mut m = cylinder(0.0, r, len, around, along);
    for v in m.vertices.iter_mut().take((along + 1) * around) {
        let a = v[1].atan2(v[0]);
        let s = (r + amp * (lobes * a).cos()) / r;
        (v[0], v[1]) = (v[0] * s, v[1] * s);
    }
    m
}

#[test]
fn spokes_are_raised_until_the_wall_is_true_to_the_surface() {
    let mesh = fluted(20.0, 3.0, 8.0, 100.0, 256, 20);
    let fixed = ImportParams { spokes: 32, ..Default::default() };
    let (_, at32) = build_tube(&mesh, &axis(10), &fixed).unwrap();
    assert!(at32.fidelity.p99 > 0.5, "32 spokes: p99 {} mm", at32.fidelity.p99);
    assert!(at32.spokes_tried.is_empty());
    let (tube, rep) = build_tube(&mesh, &axis(10), &ImportParams { fidelity_mm: 0.5, ..fixed.clone() }).unwrap();
    eprintln!("{rep}");
    assert!(rep.spokes > 32 && tube.spokes == rep.spokes, "kept {} spokes", rep.spokes);
    assert!(rep.fidelity.p99 <= 0.5 && rep.fidelity.p99 < at32.fidelity.p99, "p99 {} mm", rep.fidelity.p99);
    assert_eq!(rep.spokes_tried.first().map(|t| t.0), Some(32));
    assert_eq!(rep.spokes_tried.last().map(|t| t.0), Some(rep.spokes), "{:?}", rep.spokes_tried);
    assert!(rep.spokes_tried.iter().rev().skip(1).all(|t| t.1 > 0.5), "stops at the first within 0.5 mm: {:?}", rep.spokes_tried);
    assert!(rep.to_string().contains(&format!("32 ({:.2} mm)", at32.fidelity.p99)), "{rep}");
    // A smooth wall is true at 32 spokes: nothing is raised.
    let (_, smooth) = build_tube(&cylinder(0.0, 10.0, 100.0, 64, 20), &axis(10), &ImportParams { fidelity_mm: 0.5, ..fixed.clone() }).unwrap();
    assert_eq!((smooth.spokes, smooth.spokes_tried.len()), (32, 0));
    // Never past MAX_AUTO_SPOKES: the finest folds are kept at the truest count tried.
    let (_, fine) = build_tube(&fluted(20.0, 2.0, 40.0, 100.0, 512, 20), &axis(10), &ImportParams { fidelity_mm: 0.5, ..fixed }).unwrap();
    assert_eq!(fine.spokes_tried.last().map(|t| t.0), Some(MAX_AUTO_SPOKES), "{:?}", fine.spokes_tried);
    let best = fine.spokes_tried.iter().map(|t| t.1).fold(f64::INFINITY, f64::min);
    assert_eq!(fine.fidelity.p99, best);
}

#[test]
fn loops_inflated_past_the_space_between_them_are_reported_as_overlapping() {
    // Two 10 mm lumens, axes 25 mm apart (5 mm of tissue between the walls), one colon up the
    // first and down the second. As imported their parts keep apart; inflated 1.6 times (16 mm
    // spokes) each leg's wall reaches 7 mm into the other, side by side, where no ring plane
    // crosses another inside the lumen.
    let mesh = merge(&cylinder(0.0, 10.0, 100.0, 64, 20), &cylinder(25.0, 10.0, 100.0, 64, 20));
    let params = ImportParams { widest_smoothing_mm: 4.0, ..Default::default() };
    let (_, apart) = build_tube(&mesh, &hairpin(0.0, 25.0), &params).unwrap();
    eprintln!("{apart}");
    assert_eq!(apart.overlaps.tips, 0, "{apart}");
    assert!(apart.to_string().contains("No spoke tip lies inside another part of the lumen"), "{apart}");
    let (_, inflated) = build_tube(&mesh, &hairpin(0.0, 25.0), &ImportParams { inflate: 1.6, ..params }).unwrap();
    eprintln!("{inflated}");
    let o = inflated.overlaps;
    // The spokes towards the other leg, along the legs (547 tips of 81 rings when written);
    // the farthest pairs are a leg's bottom and the other's.
    assert!(o.tips >= 300 && o.rings >= 60 && o.farthest >= 100, "{o:?}\n{inflated}");
    assert_eq!(inflated.folds.spokes, 0, "{inflated}");
    assert!(inflated.to_string().contains(&format!("{} spoke tips of {} rings lie inside another part of the lumen", o.tips, o.rings)), "{inflated}");
}

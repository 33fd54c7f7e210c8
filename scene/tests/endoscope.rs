//! The kinematic insertion: inside the lumen except recorded escapes, ~1 mm per frame, local
//! wall deformation, determinism.

use lumen_import::probe::Lumen;
use lumen_scene::colon::{generate, ColonParams};
use lumen_scene::endoscope::{colonoscopy_scene, Frame, Insertion};

fn dist(a: [f32; 3], b: [f32; 3]) -> f64 {
    (0..3).map(|d| (a[d] as f64 - b[d] as f64).powi(2)).sum::<f64>().sqrt()
}

fn seg_dist(p: [f32; 3], a: [f32; 3], b: [f32; 3]) -> f64 {
    let ab: Vec<f64> = (0..3).map(|d| b[d] as f64 - a[d] as f64).collect();
    let ap: Vec<f64> = (0..3).map(|d| p[d] as f64 - a[d] as f64).collect();
    let l2: f64 = ab.iter().map(|x| x * x).sum();
    let u = if l2 > 0.0 { (ab.iter().zip(&ap).map(|(x, y)| x * y).sum::<f64>() / l2).clamp(0.0, 1.0) } else { 0.0 };
    (0..3).map(|d| (ap[d] - u * ab[d]).powi(2)).sum::<f64>().sqrt()
}

#[test]
fn scope_stays_in_the_lumen_except_recorded_escapes() {
    let rest = generate(&ColonParams::seeded(3));
    let ins = Insertion::default();
    let r = ins.radius_mm as f64;
    let spacing = ins.length_mm as f64 / (ins.points - 1) as f64;
    let frames: Vec<Frame> = ins.frames(&rest, 160, 950.0, 1.0, 3).collect();
    assert_eq!(frames.len(), 160);
    let (mut escape_frames, mut escapes, mut contacts_min, mut deepest_press) = (0, 0, usize::MAX, 0.0f64);
    let mut worst_escape = (f64::INFINITY, 0.0f64);
    for (fi, f) in frames.iter().enumerate() {
        assert_eq!(f.index, fi);
        assert_eq!(f.scope.points.len(), 160);
        assert_eq!(f.colon.rings(), rest.rings());
        assert!((f.depth_mm - (950.0 + fi as f32)).abs() < 1e-3);
        let lumen = Lumen::new(&f.colon);
        let mut contacts = 0;
        for j in 0..f.scope.points.len() {
            let p = f.scope.points[j];
            if j >= f.inserted {
                // Not inserted: behind the first ring's plane, on the line out of the anus.
                assert!(lumen.locate(p, 0).is_none(), "frame {fi}: point {j} is not inserted but lies in the colon");
                continue;
            }
            let hint = ((f.arc_mm[j] / 1.2) as usize).saturating_sub(2);
            let probe = lumen.locate(p, hint).unwrap_or_else(|| panic!("frame {fi}: inserted point {j} is not in the colon"));
            assert!((probe.s - f.arc_mm[j] as f64).abs() < 3.0, "frame {fi}: point {j} at s {} vs recorded {}", probe.s, f.arc_mm[j]);
            if let Some(e) = f.escaped.iter().position(|&x| x == j) {
                // Pushed through: the centre is outside the wall by the recorded amount.
                let out = -probe.gap();
                assert!(out > 0.0 && out < 6.0, "frame {fi}: escaped point {j} is {out:.2} mm outside");
                assert!((out - f.escaped_by_mm[e] as f64).abs() < 0.05, "frame {fi}: point {j} {out:.2} mm out, recorded {}", f.escaped_by_mm[e]);
                worst_escape = (worst_escape.0.min(out), worst_escape.1.max(out));
                escapes += 1;
            } else {
                // Inside: the centre inside the (deformed) wall; away from escapes well inside,
                // with the surface at most a couple of millimetres into the wall.
                assert!(probe.gap() > 0.0, "frame {fi}: point {j} is outside but not recorded");
                if f.escaped.iter().all(|&e| e.abs_diff(j) > 2) {
                    assert!(probe.gap() > 2.0, "frame {fi}: point {j} centre only {:.2} mm inside", probe.gap());
                    let press = r - probe.gap();
                    assert!(press < 2.5, "frame {fi}: point {j} presses {press:.2} mm into the wall");
                    if press > 0.0 {
                        contacts += 1;
                        deepest_press = deepest_press.max(press);
                    }
                }
            }
        }
        contacts_min = contacts_min.min(contacts);
        if !f.escaped.is_empty() {
            assert!(f.escaping);
            escape_frames += 1;
            assert_eq!(f.escaped.len(), f.escaped_by_mm.len());
            assert!(f.escaped.windows(2).all(|w| w[0] < w[1]));
        }
        // Control points about one spacing apart (escapes bulge out a little).
        for w in f.scope.points.windows(2) {
            let d = dist(w[0], w[1]);
            assert!(d > 0.8 * spacing && d < 1.3 * spacing, "frame {fi}: control points {d:.2} mm apart");
        }
        // The midline is the rest colon's.
        assert_eq!(f.colon.points, rest.points);
        // Only tips near the scope move, outwards (checked every fourth frame: it is slow).
        if fi % 4 != 0 {
            continue;
        }
        let mut moved = 0;
        for i in 0..rest.rings() {
            for k in 0..rest.spokes {
                let (a, b) = (rest.spoke(i, k), f.colon.spoke(i, k));
                if a == b {
                    continue;
                }
                moved += 1;
                let grow = dist(b, [0.0; 3]) - dist(a, [0.0; 3]);
                assert!(grow > 0.0 && grow < 3.0 * r, "frame {fi}: tip {i}/{k} moved {grow:.2} mm");
                let tip = [rest.points[i][0] + a[0], rest.points[i][1] + a[1], rest.points[i][2] + a[2]];
                let near = f.scope.points.windows(2).map(|w| seg_dist(tip, w[0], w[1])).fold(f64::INFINITY, f64::min);
                assert!(near < r + 12.0, "frame {fi}: tip {i}/{k} moved but is {near:.1} mm from the scope's axis");
            }
        }
        assert_eq!(moved, f.deformed_tips);
        assert!(moved > 0 && moved < rest.radial.len() / 10, "frame {fi}: {moved} tips moved");
    }
    eprintln!(
        "{escape_frames} frames with escapes ({escapes} escaped samples, {:.2}-{:.2} mm out); at least {contacts_min} pressing samples per frame, deepest {deepest_press:.2} mm",
        worst_escape.0, worst_escape.1
    );
    assert!(escape_frames >= 8, "only {escape_frames} frames with escapes");
    assert!(worst_escape.1 > 2.0, "escapes reach only {:.2} mm outside", worst_escape.1);
    assert!(contacts_min >= 5, "a frame with only {contacts_min} samples pressing on the wall");
    // About 1 mm per frame: the tip exactly. The scope behind it rides the outer wall of bends, a
    // path longer than the midline there (shorter where it cuts an inner curve), so the inserted
    // length grows between a quarter and two and a half times as fast as the depth; where an escape bulges the scope out, the part behind the bulge shifts by
    // its extra length too (a few millimetres over several frames).
    for w in frames.windows(2) {
        let tip = dist(w[0].scope.points[0], w[1].scope.points[0]);
        assert!((tip - 1.0).abs() < 0.1, "tip moved {tip:.3} mm");
        let calm = !w[0].escaping && !w[1].escaping;
        let n = w[0].inserted.min(w[1].inserted);
        let mean = (0..n).map(|j| dist(w[0].scope.points[j], w[1].scope.points[j])).sum::<f64>() / n as f64;
        let handle = dist(w[0].scope.points[159], w[1].scope.points[159]);
        let (lo, hi) = if calm { (0.25, 2.5) } else { (0.0, 5.0) };
        assert!(mean > lo && mean < hi, "frame {}: inserted part moved {mean:.3} mm on average", w[1].index);
        assert!(handle > lo && handle < hi, "frame {}: handle moved {handle:.3} mm", w[1].index);
    }
}

#[test]
fn frames_are_deterministic_and_seeded() {
    let colon = generate(&ColonParams::seeded(5));
    let ins = Insertion::default();
    let a: Vec<Frame> = ins.frames(&colon, 60, 600.0, 1.0, 9).collect();
    let b: Vec<Frame> = ins.frames(&colon, 60, 600.0, 1.0, 9).collect();
    assert!(a == b, "same seed, different frames");
    let c: Vec<Frame> = ins.frames(&colon, 60, 600.0, 1.0, 10).collect();
    assert!(a != c, "different seeds, same frames");
    let none: Vec<Frame> = Insertion { escapes: false, ..Insertion::default() }.frames(&colon, 60, 600.0, 1.0, 9).collect();
    assert!(none.iter().all(|f| f.escaped.is_empty()));
    // The tip stops short of the caecum's end.
    let end: Vec<Frame> = ins.frames(&colon, 3, 1490.0, 10.0, 1).collect();
    assert!(end.iter().all(|f| f.depth_mm <= 1470.0 + 1e-3), "{:?}", end.iter().map(|f| f.depth_mm).collect::<Vec<_>>());
}

#[test]
fn colonoscopy_scene_has_the_scope_in_one_metre() {
    let (colon, scope) = colonoscopy_scene(1);
    assert_eq!(scope.points.len(), 160);
    assert_eq!(scope.radius, vec![6.5]);
    let length: f64 = scope.points.windows(2).map(|w| dist(w[0], w[1])).sum();
    assert!(length > 0.98 * 1600.0 && length <= 1600.0 + 1e-2, "scope {length:.1} mm");
    let lumen = Lumen::new(&colon);
    let tip = lumen.locate(scope.points[0], 800).expect("tip inside");
    assert!((tip.s - 1000.0).abs() < 2.0, "tip at {:.1} mm", tip.s);
    assert!(tip.rho < 1.0, "tip {:.2} mm off the midline", tip.rho);
    let pressing = (0..scope.points.len()).filter_map(|j| lumen.locate(scope.points[j], 0)).filter(|p| p.gap() < 6.5).count();
    assert!(pressing >= 10, "{pressing} samples pressing");
}

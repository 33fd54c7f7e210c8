//! lumen-bench: the metrics on hand-made cases with known answers, the parry baseline against
//! the reference, the report's JSON, and a tiny sweep end to end.

use lumen_bench::metrics::{evaluate, plan, Place, Reported, Tally, Truth, TruthParams, DENSE_PER_SEGMENT};
use lumen_bench::{ColonKind, MethodKind, Options, ParryBaseline, ParryShape};
use lumen_detect::{ContactKind, Rod, Scene, Tube};
use std::f32::consts::TAU;

/// A straight tube along x from -20 to 120 mm, rings every 2 mm, `spokes` spokes of length 10
/// (spoke 0 along +y, counter-clockwise about +x).
fn straight_tube(spokes: usize) -> Tube {
    let rings = 71;
    let points = (0..rings).map(|i| [-20.0 + 2.0 * i as f32, 0.0, 0.0]).collect();
    let radial = (0..rings)
        .flat_map(|_| {
            (0..spokes).map(move |k| {
                let a = k as f32 * TAU / spokes as f32;
                [0.0, 10.0 * a.cos(), 10.0 * a.sin()]
            })
        })
        .collect();
    Tube::new(points, radial, spokes).unwrap()
}

/// Apothem of the tube's polygon: the wall's distance from the axis mid-edge.
fn apothem(spokes: usize) -> f32 {
    10.0 * (std::f32::consts::PI / spokes as f32).cos()
}

/// A rod of radius 2 along the axis, x = 0..100 every 10 mm, with control point 5 (x = 50)
/// pushed to y = 12: through the wall (at about 9.95 there) by about 2 mm.
fn escaping_rod() -> (Rod, Vec<f32>) {
    let points = (0..11).map(|j| [10.0 * j as f32, if j == 5 { 12.0 } else { 0.0 }, 0.0]).collect();
    let arc = (0..11).map(|j| 20.0 + 10.0 * j as f32).collect();
    (Rod::new(points, vec![2.0]).unwrap(), arc)
}

fn truth(tube: &Tube, rod: &Rod, arc: &[f32], extra: &[lumen_bench::metrics::QueryPoint]) -> Truth {
    Truth::new(tube, rod, rod.points.len(), arc, 0.5, TruthParams { steps: 4, window_mm: 60.0, threads: 1 }, extra)
}

/// Judges `reported` at precision `x` on one frame.
fn judge(tube: &Tube, rod: &Rod, arc: &[f32], x: usize, reported: &[Reported]) -> (Truth, Tally) {
    let extra = plan(reported, x, arc);
    let t = truth(tube, rod, arc, &extra);
    let mut tally = Tally::default();
    evaluate(&t, x, 0, reported, t.extra(), &mut tally);
    (t, tally)
}

/// A perfect report: every sample whose reference depth is positive, with the reference's
/// depth, normal and wall point.
fn perfect(t: &Truth, x: usize) -> Vec<Reported> {
    (0..t.samples(x))
        .filter_map(|s| {
            let d = t.dense()[t.sample_index(x, s)];
            (d.depth() > 0.0).then_some(Reported { sample: s as u32, at: None, depth: d.depth(), normal: d.q.normal, wall: d.q.point, place: None })
        })
        .collect()
}

#[test]
fn reference_along_the_hand_made_rod_has_the_known_geometry() {
    let tube = straight_tube(32);
    let (rod, arc) = escaping_rod();
    let t = truth(&tube, &rod, &arc, &[]);
    // 10 segments, 64 dense points each, plus the last.
    assert_eq!(t.dense().len(), 10 * DENSE_PER_SEGMENT + 1);
    assert_eq!(t.samples(2), 21);
    // The pushed control point: 12 - 9.952 outside the polygon wall (it sits on spoke 0's
    // vertex direction, where the wall is the vertex itself at 10: sd = 2).
    let esc = t.dense()[t.sample_index(2, 10)];
    assert!((esc.q.sd - 2.0).abs() < 1e-3, "sd at the pushed point {}", esc.q.sd);
    assert!((esc.q.normal[1] - 1.0).abs() < 1e-3, "outward normal +y: {:?}", esc.q.normal);
    // A control point on the axis: the nearest wall is mid-edge, at the apothem.
    let axis = t.dense()[t.sample_index(2, 2)];
    assert!((axis.q.sd + apothem(32)).abs() < 1e-3, "sd on the axis {}", axis.q.sd);
    // Straight, untwisted tube: the reference is exact (only midline curvature counts, none).
    assert!(t.bound() < 1e-4, "bound {}", t.bound());
    assert_eq!(t.folded_cells(), 0);
}

#[test]
fn a_perfect_report_has_no_error_and_detects_the_escape() {
    let tube = straight_tube(32);
    let (rod, arc) = escaping_rod();
    let x = 2;
    let t = truth(&tube, &rod, &arc, &[]);
    let rep = perfect(&t, x);
    // Only the pushed control point's sample penetrates at x = 2 (the midpoints either side are
    // about 4 mm from the wall).
    assert_eq!(rep.iter().map(|c| c.sample).collect::<Vec<_>>(), vec![10]);
    let (_, tally) = judge(&tube, &rod, &arc, x, &rep);
    let m = tally.metrics();
    assert_eq!(m.contacts_evaluated, 1);
    assert_eq!(m.escaped_total, 1);
    assert_eq!(m.escaped_detected, 1);
    assert_eq!(m.false_contacts, 0);
    assert_eq!(m.missed, 0, "{:?}", tally.findings);
    assert!(m.penetrating_dense > 20, "penetrating dense points {}", m.penetrating_dense);
    assert!(m.depth_err_max_mm.unwrap() < 1e-6);
    assert!(m.normal_err_p99_deg.unwrap() < 0.01);
}

#[test]
fn nothing_reported_is_one_missed_place_and_an_undetected_escape() {
    let tube = straight_tube(32);
    let (rod, arc) = escaping_rod();
    let (_, tally) = judge(&tube, &rod, &arc, 2, &[]);
    let m = tally.metrics();
    assert_eq!(m.missed, 1, "one place, around x = 50");
    assert_eq!(m.missed_dense, m.penetrating_dense);
    assert!(m.penetrating_dense > 20);
    assert_eq!((m.escaped_detected, m.escaped_total), (0, 1));
    assert_eq!(m.contacts_evaluated, 0);
    assert_eq!(m.depth_err_p99_mm, None);
    let f = tally.findings.iter().find(|f| f.kind == "missed").unwrap();
    assert!(f.point[0] > 40.0 && f.point[0] < 50.0, "the run starts before x = 50: {:?}", f.point);
}

#[test]
fn another_wall_is_judged_on_its_own_wall_point() {
    // Sample 9 (x = 45, on the way up to the pushed control point) is nearest the +y wall. A
    // contact flagged as another wall of it (`FLAG_OTHER_WALL`), at the wall's vertex at 45
    // degrees (spoke 4), is right about that wall: its depth is `r - |p - w|` and its normal
    // the wall's there, though the sample's nearest wall is elsewhere and nearer. Judged as its
    // sample's nearest, its depth would be off by 3 mm.
    let tube = straight_tube(32);
    let (rod, arc) = escaping_rod();
    let x = 2;
    let t = truth(&tube, &rod, &arc, &[]);
    let d = t.dense()[t.sample_index(x, 9)];
    let s45 = std::f32::consts::FRAC_1_SQRT_2;
    let w = [d.p[0], 10.0 * s45, 10.0 * s45];
    let to_w = ((w[0] - d.p[0]).powi(2) + (w[1] - d.p[1]).powi(2) + (w[2] - d.p[2]).powi(2)).sqrt();
    let other = |flags: u8| Reported { sample: 9, at: None, depth: d.r - to_w, normal: [0.0, s45, s45], wall: w, place: Some(Place { ring: 0, spoke: 4, param: 0.0, flags }) };
    let m = judge(&tube, &rod, &arc, x, &[other(4)]).1.metrics();
    assert_eq!(m.contacts_evaluated, 1);
    assert!(m.depth_err_max_mm.unwrap() < 1e-3, "depth error {:?}", m.depth_err_max_mm);
    assert!(m.normal_err_p99_deg.unwrap() < 0.5, "normal error {:?}", m.normal_err_p99_deg);
    // 5 mm from touching: a false contact, as any contact reported that far off.
    assert!(d.r - to_w < -5.0);
    assert_eq!(m.false_contacts, 1);
    // Unflagged, it is judged against the sample's nearest wall.
    let m = judge(&tube, &rod, &arc, x, &[other(0)]).1.metrics();
    assert!(m.depth_err_max_mm.unwrap() > 3.0, "depth error {:?}", m.depth_err_max_mm);
}

#[test]
fn a_flipped_contact_and_a_far_one_are_counted_wrong() {
    let tube = straight_tube(32);
    let (rod, arc) = escaping_rod();
    let x = 2;
    let t = truth(&tube, &rod, &arc, &[]);
    let esc = t.dense()[t.sample_index(x, 10)];
    let far = t.dense()[t.sample_index(x, 2)];
    let flip = |n: [f32; 3]| n.map(|v| -v);
    let rep = vec![
        // The published method's answer at an escaped sample: distance to the wall as if
        // inside, collision vector towards the wall (flipped).
        Reported { sample: 2, at: None, depth: 0.5, normal: [0.0, 1.0, 0.0], wall: [10.0, 9.95, 0.0], place: None },
        Reported { sample: 10, at: None, depth: esc.r - esc.q.sd, normal: flip(esc.q.normal), wall: esc.q.point, place: None },
    ];
    let (_, tally) = judge(&tube, &rod, &arc, x, &rep);
    let m = tally.metrics();
    assert_eq!(m.contacts_evaluated, 2);
    // Sample 2 is on the axis, 7.95 mm from touching: a false contact.
    assert_eq!(m.false_contacts, 1);
    assert!(far.depth() < -7.9);
    assert_eq!((m.escaped_detected, m.escaped_total), (0, 1));
    // Depth errors: |0.5 - (-7.95)| at sample 2, 2 sd at sample 10.
    let e2 = (0.5 - far.depth()).abs() as f64;
    let e10 = (2.0 * esc.q.sd) as f64;
    assert!((m.depth_err_max_mm.unwrap() - e2.max(e10)).abs() < 1e-4);
    assert!((m.depth_err_mean_mm.unwrap() - 0.5 * (e2 + e10)).abs() < 1e-4);
    assert!(m.normal_err_p99_deg.unwrap() > 179.0);
    // The escape is still "reported" near the penetrating stretch: nothing missed.
    assert_eq!(m.missed, 0);
}

#[test]
fn parry_baseline_agrees_with_the_reference_on_a_straight_tube() {
    // 64 spokes; a rod of radius 4, 6.5 mm off the axis towards the middle of the wall's first
    // edge (0.45 mm into the wall, all along; towards a vertex, two edges would be equally
    // near), and the same rod with its middle pushed through the wall.
    let tube = straight_tube(64);
    let (cos, sin) = ((std::f32::consts::PI / 64.0).cos(), (std::f32::consts::PI / 64.0).sin());
    for pushed in [false, true] {
        let points: Vec<[f32; 3]> = (0..11)
            .map(|j| {
                let off = if pushed && j == 5 { 12.0 } else { 6.5 };
                [10.0 * j as f32, off * cos, off * sin]
            })
            .collect();
        let arc: Vec<f32> = (0..11).map(|j| 20.0 + 10.0 * j as f32).collect();
        let rod = Rod::new(points, vec![4.0]).unwrap();
        let scene = Scene::new().tube("colon", tube.clone()).rod("scope", rod.clone()).pair("scope", "colon", ContactKind::Interior).precision(4);
        for shape in [ParryShape::RoundSegments, ParryShape::Capsules] {
            let mut p = ParryBaseline::new(&scene.spec(), &scene.state(), shape).unwrap();
            assert_eq!(p.triangles(), 2 * 70 * 64);
            let contacts = p.detect(&scene.state()).to_vec();
            let reported: Vec<Reported> = contacts.iter().map(Reported::of_parry).collect();
            let extra = plan(&reported, 4, &arc);
            let t = truth(&tube, &rod, &arc, &extra);
            let mut worst = 0.0f32;
            let mut outside = 0;
            for (i, c) in contacts.iter().enumerate() {
                let q = t.extra()[2 * i].q;
                if q.sd > 0.0 {
                    // Axis point through the wall: no exact agreement to expect (parry's answer
                    // is the shorter way out of the triangle it crosses, either side).
                    outside += 1;
                    continue;
                }
                worst = worst.max((c.depth - (q.sd + c.radius)).abs());
                let n = lumen_bench::metrics::angle_deg(c.normal, q.normal);
                assert!(n < 0.5, "{shape:?} normal off by {n} deg at {c:?}");
            }
            // The same flat facets as the reference's (an untwisted straight tube is exact):
            // agreement to f32 rounding.
            assert!(worst < 2e-3, "{shape:?} pushed {pushed}: depth off by {worst}");
            if pushed {
                assert!(outside >= 1, "{shape:?}: the pushed point is outside");
            } else {
                // 40 capsules along a rod 0.45 mm into the wall: every one touches.
                assert_eq!(contacts.len(), 40, "{shape:?}");
                assert_eq!(outside, 0);
                let d = 4.0 - (apothem(64) - 6.5);
                assert!(contacts.iter().all(|c| (c.depth - d).abs() < 0.01), "{shape:?}: expected about {d}");
            }
        }
    }
}

fn tiny() -> Options {
    Options {
        scenes: vec![ColonKind::Generated],
        precisions: vec![1, 2],
        spokes: vec![12],
        frames: 10,
        warmup: 2,
        repeats: 1,
        eval_every: 5,
        eval_escapes_every: 0,
        reference_steps_generated: 2,
        reference_window_mm: 40.0,
        threads: 1,
        generated_length_mm: 300.0,
        generated_ring_spacing_mm: 3.0,
        default_precision: 2,
        doubled_spokes: 12,
        ..Options::quick()
    }
}

#[test]
fn tiny_sweep_writes_a_complete_report() {
    let opts = tiny();
    let report = lumen_bench::run(&opts, false).unwrap();
    assert_eq!(report.runs.len(), 2 * 5);
    assert_eq!(report.scenes.len(), 1);
    let s = &report.scenes[0];
    assert_eq!((s.spokes, s.frames, s.eval_frames.clone()), (12, 10, vec![0, 5]));
    assert_eq!(s.rings, 101, "300 mm at 3 mm");
    for r in &report.runs {
        assert_eq!(r.frames_timed, 8, "{}", r.method);
        assert_eq!(r.metrics.frames_evaluated, 2);
        assert!(r.median_us > 0.0 && r.p99_us >= r.median_us);
        assert_eq!(r.rings, 101);
    }
    for x in [1, 2] {
        let d = report.run("generated", "default", 12, x).unwrap();
        let th = report.run("generated", "thesis", 12, x).unwrap();
        let pa = report.run("generated", "parry", 12, x).unwrap();
        let se = report.run("generated", "sections", 12, x).unwrap();
        let re = report.run("generated", "refined", 12, x).unwrap();
        // Ratios against oneself are exactly 1; the others are each other's inverses.
        assert_eq!(d.time_vs_default, Some(1.0));
        assert_eq!(th.speedup_vs_thesis, Some(1.0));
        assert_eq!(pa.speedup_vs_parry, Some(1.0));
        assert!(d.speedup_vs_thesis.unwrap() > 0.0 && d.speedup_vs_parry.unwrap() > 0.0);
        assert!(se.time_vs_default.unwrap() > 0.0 && re.time_vs_default.unwrap() > 0.0);
        // All five judged on the same samples.
        assert_eq!(d.metrics.escaped_total, th.metrics.escaped_total);
        assert_eq!(d.metrics.escaped_total, se.metrics.escaped_total);
        assert_eq!(d.metrics.escaped_total, re.metrics.escaped_total);
        assert_eq!(d.metrics.penetrating_dense, pa.metrics.penetrating_dense);
        assert!(d.metrics.contacts_evaluated > 0, "the scope presses on the wall");
    }
    assert_eq!(report.rings_doubled.len(), 2);
    for (dbl, how, rings) in [(&report.rings_doubled[0], "denser", 201), (&report.rings_doubled[1], "longer", 202)] {
        assert_eq!((dbl.how.as_str(), dbl.rings, dbl.rings_doubled, dbl.x), (how, 101, rings, 2));
        assert!(dbl.median_us > 0.0 && dbl.median_us_doubled > 0.0);
    }
    // Longer: the same endoscope in the same colon, extended past its end: the same contacts.
    assert_eq!(report.rings_doubled[1].contacts_per_frame, report.rings_doubled[1].contacts_per_frame_doubled);

    let dir = std::env::temp_dir().join(format!("lumen-bench-test-{}", std::process::id()));
    report.write(&dir).unwrap();
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(md.contains("| generated | 12 | 101 | 2 | default |"), "{md}");
    let svg = std::fs::read_to_string(dir.join("speed_vs_error.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("scene: generated") && svg.contains("default") && svg.contains("refined") && svg.contains("sections"));

    // The JSON: the keys the issue requires on every run, the revision and the machine.
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    let runs = json["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 10);
    let keys = [
        "scene",
        "method",
        "x",
        "spokes",
        "rings",
        "median_us",
        "p99_us",
        "speedup_vs_thesis",
        "speedup_vs_parry",
        "missed",
        "false_contacts",
        "depth_err_p99_mm",
        "depth_err_max_mm",
        "normal_err_p99_deg",
        "escaped_detected",
        "escaped_total",
    ];
    for r in runs {
        for k in keys {
            assert!(r.get(k).is_some(), "run without {k}: {r}");
        }
        assert!(["thesis", "default", "sections", "refined", "parry"].contains(&r["method"].as_str().unwrap()));
        assert_eq!(r["scene"], "generated");
        assert_eq!(r["spokes"], 12);
    }
    assert!(!json["git_revision"].as_str().unwrap().is_empty());
    // It reads back, so --replot can redraw it.
    let back = lumen_bench::Report::from_json(&json.to_string()).unwrap();
    assert_eq!(back.runs.len(), 10);
    assert_eq!(back.markdown(), report.markdown());
    assert!(json["machine"]["cores"].as_u64().unwrap() >= 1);
    assert!(!json["machine"]["cpu"].as_str().unwrap().is_empty());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn absent_real_colon_is_said_clearly() {
    let mut opts = tiny();
    opts.set_scene("gca").unwrap();
    opts.data = Some("/nonexistent/colon".into());
    match lumen_bench::run(&opts, false) {
        Err(lumen_bench::Error::NoScenes(why)) => {
            assert_eq!(why.len(), 1);
            assert!(why[0].contains("gca scene skipped") && why[0].contains("not available") && why[0].contains("/nonexistent/colon"), "{}", why[0]);
        }
        other => panic!("expected NoScenes, got {:?}", other.map(|r| r.runs.len())),
    }
    assert!(opts.set_scene("colon").is_err());
    let q = Options::from_flags(true, Some("generated"), None).unwrap();
    assert!(q.quick && q.scenes == vec![ColonKind::Generated] && q.spokes == vec![32]);
    assert_eq!(Options::full().precisions, vec![1, 2, 4, 8, 16]);
    assert_eq!(Options::full().spokes, vec![16, 32, 64]);
    assert_eq!(MethodKind::parse("parry"), Some(MethodKind::Parry));
}

#[test]
fn the_report_shows_import_fidelity_beside_the_detection_errors() {
    let mut report = lumen_bench::Report::default();
    assert!(!report.markdown().contains("Import fidelity"));
    report.scenes.push(lumen_bench::report::SceneInfo { scene: "gca".into(), spokes: 32, import_fidelity_mm: Some([0.0085, 1.133, 14.13]), ..Default::default() });
    let md = report.markdown();
    assert!(md.contains("## Import fidelity") && md.contains("| gca | 32 | 0.009 / 1.133 / 14.13 |"), "{md}");
    let back = lumen_bench::Report::from_json(&serde_json::to_string(&report).unwrap()).unwrap();
    assert_eq!(back.scenes[0].import_fidelity_mm, Some([0.0085, 1.133, 14.13]));
}

#[test]
fn a_model_file_runs_as_its_colon_and_reports_the_fidelity_it_stores() {
    use lumen_detect::model::{save_native_with, to_text, ImportInfo};
    let dir = std::env::temp_dir().join(format!("lumen-bench-model-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // The tiny sweep's generated colon, written as a model with an import's figures.
    let base = Options { reference_steps_gca: 2, rings_doubled: false, ..tiny() };
    let (colon, _) = lumen_bench::scenes::colon(ColonKind::Generated, 12, 1.0, &base, None).unwrap();
    let info = ImportInfo { fidelity_mm: [0.01, 0.42, 3.5], kept_p99_mm: 0.3, samples: 4848, report: "Imported 101 rings x 12 spokes".into() };
    let path = dir.join("gen.lumen");
    std::fs::write(&path, save_native_with(&lumen_detect::Body::Tube(colon.clone()), Some(&info))).unwrap();
    let generated = lumen_bench::run(&base, false).unwrap();
    // The model alone (no scenes), at its own 12 spokes whatever --spokes says.
    let opts = Options { scenes: vec![], model: Some(path.clone()), spokes: vec![16, 32], ..base.clone() };
    let report = lumen_bench::run(&opts, false).unwrap();
    assert_eq!(report.runs.len(), 2 * 5);
    assert_eq!(report.scenes.len(), 1);
    let s = &report.scenes[0];
    assert_eq!((s.scene.as_str(), s.spokes, s.rings), ("model", 12, 101));
    assert_eq!((s.import_fidelity_mm, s.import_kept_p99_mm), (Some([0.01, 0.42, 3.5]), Some(0.3)));
    assert_eq!(s.model.as_deref(), Some(path.display().to_string().as_str()));
    // The same colon and frames as the generated scene: the same contacts, judged the same.
    for r in &report.runs {
        let g = generated.run("generated", &r.method, 12, r.x).unwrap();
        assert_eq!(
            (r.metrics.missed, r.metrics.false_contacts, r.metrics.escaped_total, r.metrics.depth_err_p99_mm),
            (g.metrics.missed, g.metrics.false_contacts, g.metrics.escaped_total, g.metrics.depth_err_p99_mm),
            "{}",
            r.method
        );
    }
    let md = report.markdown();
    assert!(md.contains("| model | 12 | 0.010 / 0.420 / 3.50 | 0.300 |") && md.contains("`model` is the model file") && md.contains("| model | 12 | 101 | 2 | default |"), "{md}");
    assert_eq!(report.fidelity_note("model").unwrap(), "wall to surface p50 / p99 / max 0.010 / 0.420 / 3.50 mm");
    // The text format holds the tube alone: run, and said to store no fidelity.
    let txt = dir.join("gen.txt");
    std::fs::write(&txt, to_text(&colon)).unwrap();
    let report = lumen_bench::run(&Options { model: Some(txt), precisions: vec![1], methods: vec![MethodKind::Default], ..opts.clone() }, false).unwrap();
    assert_eq!(report.scenes[0].import_fidelity_mm, None);
    assert!(report.markdown().contains("| model | 12 | not stored in the model file"));
    assert_eq!(report.fidelity_note("model").unwrap(), "wall to surface not stored in the model file");
    // Beside a scene, after it.
    let both = lumen_bench::run(&Options { scenes: vec![ColonKind::Generated], precisions: vec![1], methods: vec![MethodKind::Default], ..opts.clone() }, false).unwrap();
    assert_eq!(both.runs.iter().map(|r| (r.scene.as_str(), r.spokes)).collect::<Vec<_>>(), [("generated", 16), ("generated", 32), ("model", 12)]);
    // A file that is not there, or not a model: an error naming it, whatever else there is.
    for (file, says) in [("absent.lumen", "No such file"), ("junk.lumen", "LUMN")] {
        std::fs::write(dir.join("junk.lumen"), "not a model").unwrap();
        let e = lumen_bench::run(&Options { scenes: vec![ColonKind::Generated], model: Some(dir.join(file)), ..opts.clone() }, false).unwrap_err().to_string();
        assert!(e.contains(&dir.join(file).display().to_string()) && e.contains(says), "{e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

//! Property tests over random tubes and rods: no NaN or panic on anything (even tubes bent
//! tighter than their radius, whose wall folds through itself), and the same contacts after any
//! rigid motion on valid tubes.

#[path = "../../detect/tests/common/mod.rs"]
mod common;
use common::*;
use lumen_detect::{Contact, Detector, Method, Rod, Tube};
use lumen_proto::contact::FLAG_OTHER_WALL;
use proptest::prelude::*;
use std::f32::consts::TAU;

/// A random tube: a midline turning by bounded angles and star-shaped rings (uniform spoke
/// angles). Valid tubes bend no tighter than twice their radius, have 8 spokes or more and a
/// smooth wall (lobes around, a swell along); wild ones bend sharply, go down to triangles,
/// draw every spoke length at random and repeat control points.
fn tube_strategy(valid: bool) -> impl Strategy<Value = Tube> {
    (2usize..30, 3usize..20, 1.0f32..8.0, 4.0f32..15.0, any::<u64>()).prop_map(move |(rings, spokes, step, radius, seed)| {
        // A valid tube bends no tighter than twice its largest radius: its wall never folds.
        let max_turn = if valid { step / (2.0 * 1.4 * radius) } else { 0.8 };
        // Sections of a real lumen need many spokes; wild tubes go down to triangles.
        let spokes = if valid { spokes.max(8) } else { spokes };
        let mut rng = seed;
        let mut next = move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f32 / (1u64 << 53) as f32
        };
        let lobes = (0.15 * next(), TAU * next());
        let mut p = [0.0f32; 3];
        let mut dir = [1.0f32, 0.0, 0.0];
        let mut points = vec![];
        for i in 0..rings {
            points.push(p);
            let turn = [next() - 0.5, next() - 0.5, next() - 0.5];
            dir = add(dir, scale(turn, max_turn));
            dir = scale(dir, 1.0 / norm(dir));
            // Coincident points only in wild tubes: two different rings at one point make a
            // zero-length morph, a surface with no meaningful nearest point.
            let dup = !valid && i > 0 && next() < 0.1;
            if !dup {
                p = add(p, scale(dir, step));
            }
        }
        // Ring frames transported along the midline (rotation-minimising), so spoke k of one ring
        // faces spoke k of the next and the wall does not twist.
        let cross = |a: [f32; 3], b: [f32; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
        let mut frame_u = [0.0f32, 1.0, 0.0];
        let radial = (0..rings)
            .flat_map(|i| {
                let t = if i + 1 < rings { sub(points[i + 1], points[i]) } else { sub(points[i], points[i - 1]) };
                let t = if norm(t) > 0.0 { scale(t, 1.0 / norm(t)) } else { [1.0, 0.0, 0.0] };
                let mut u = sub(frame_u, scale(t, dot(frame_u, t)));
                if norm(u) < 1e-3 {
                    u = cross(t, if t[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] });
                }
                let u = scale(u, 1.0 / norm(u));
                frame_u = u;
                let v = cross(t, u);
                (0..spokes).map(|k| (u, v, k)).collect::<Vec<_>>()
            })
            .enumerate()
            .map(|(j, (u, v, k))| {
                let a = k as f32 * TAU / spokes as f32;
                let r = if valid {
                    // A smooth wall: lobes around the ring, a slow swell along the tube.
                    let i = (j / spokes) as f32;
                    radius * (1.0 + lobes.0 * (2.0 * a + lobes.1).sin() + 0.1 * (3.0 * a).cos()) * (1.0 + 0.15 * (0.4 * i + lobes.1).sin())
                } else {
                    radius * (0.6 + 0.8 * next())
                };
                add(scale(u, r * a.cos()), scale(v, r * a.sin()))
            })
            .collect();
        Tube::new(points, radial, spokes).unwrap()
    })
}

/// A rod near the tube: points jittered around the midline, some outside the wall (within
/// about a radius of it for valid tubes, anywhere near for wild ones).
fn scene_strategy(valid: bool) -> impl Strategy<Value = (Tube, Rod)> {
    (tube_strategy(valid), 2usize..12, 0.3f32..6.0, prop::collection::vec((-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0), 12)).prop_map(move |(t, n, r, jit)| {
        let size = (0..t.spokes).map(|k| norm(t.spoke(0, k))).fold(0.0, f32::max);
        let span = if valid { 1.2 * size } else { 20.0 };
        let pts = (0..n)
            .map(|j| {
                let i = (j * (t.rings() - 1)) / (n - 1).max(1);
                let (x, y, z) = jit[j];
                add(t.points[i], [x * span, y * span, z * span])
            })
            .collect();
        (t, rod(pts, r))
    })
}

fn rotate(p: [f32; 3], axis: [f32; 3], ang: f32) -> [f64; 3] {
    let k = {
        let n = norm(axis);
        axis.map(|v| (v / n) as f64)
    };
    let p = p.map(|v| v as f64);
    let (s, c) = (ang as f64).sin_cos();
    let kxp = [k[1] * p[2] - k[2] * p[1], k[2] * p[0] - k[0] * p[2], k[0] * p[1] - k[1] * p[0]];
    let kp = k[0] * p[0] + k[1] * p[1] + k[2] * p[2];
    [0, 1, 2].map(|i| p[i] * c + kxp[i] * s + k[i] * kp * (1.0 - c))
}

/// Each sample's first contact (not flagged `FLAG_OTHER_WALL`).
fn firsts(cs: &[Contact]) -> Vec<Contact> {
    cs.iter().filter(|c| c.flags & FLAG_OTHER_WALL == 0).copied().collect()
}

fn check_contacts(cs: &[Contact]) -> Result<(), TestCaseError> {
    for c in cs {
        let vals = c.point_a.iter().chain(&c.point_b).chain(&c.normal).chain(&c.weights_b).chain([&c.depth, &c.param_a, &c.param_b]);
        prop_assert!(vals.clone().all(|v| v.is_finite()), "non-finite: {:?}", c);
        prop_assert!((norm(c.normal) - 1.0).abs() < 1e-3, "normal {:?}", c.normal);
        prop_assert!((c.weights_b.iter().sum::<f32>() - 1.0).abs() < 1e-4);
        prop_assert!(c.weights_b.iter().all(|w| (-1e-6..=1.0 + 1e-6).contains(w)));
        prop_assert!((0.0..=1.0).contains(&c.param_a) && (0.0..=1.0).contains(&c.param_b));
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn never_nan_or_panic((t, r) in scene_strategy(false), x in 1u32..6) {
        for (m, nearest) in [(Method::Signed, false), (Method::Signed, true), (Method::Thesis, false)] {
            let cs = run(&interior(t.clone(), r.clone(), x, m).nearest(nearest));
            check_contacts(&cs)?;
            if m == Method::Signed {
                prop_assert!(cs.iter().all(|c| c.depth > 0.0));
            }
        }
    }

    #[test]
    fn invariant_under_rigid_motion((t, r) in scene_strategy(true), axis in (-1.0f32..1.0, -1.0f32..1.0, 0.1f32..1.0), ang in 0.0f32..std::f32::consts::TAU, shift in (-1e3f32..1e3, -1e3f32..1e3, -1e3f32..1e3)) {
        let axis = [axis.0, axis.1, axis.2];
        let shift = [shift.0 as f64, shift.1 as f64, shift.2 as f64];
        let mp = |p: [f32; 3]| { let q = rotate(p, axis, ang); [0, 1, 2].map(|i| (q[i] + shift[i]) as f32) };
        let mv = |p: [f32; 3]| rotate(p, axis, ang).map(|v| v as f32);
        let t2 = Tube::new(t.points.iter().map(|&p| mp(p)).collect(), t.radial.iter().map(|&v| mv(v)).collect(), t.spokes).unwrap();
        let r2 = rod(r.points.iter().map(|&p| mp(p)).collect(), r.radius[0]);
        // Tolerance: the inputs' rounding at the moved scene's magnitude, relative to its size.
        let tol = 1e-3 * (1.0 + r.radius[0]) + 2e-6 * 1.8e3;
        let a = run(&interior(t, r.clone(), 3, Method::Signed));
        let b = run(&interior(t2, r2, 3, Method::Signed));
        // Each sample's first contact, its nearest wall (other walls follow it, flagged).
        let first_of = |cs: &[Contact], s: u32| cs.iter().find(|c| c.sample == s && c.flags & FLAG_OTHER_WALL == 0).copied();
        let depth_of = |cs: &[Contact], s: u32| first_of(cs, s).map(|c| c.depth);
        // The wall is only C0 across a ring (its slope along the tube changes there): a sample
        // within rounding of a ring's plane is read on either side of that crease.
        let crease = |c: &Contact| c.param_b < 1e-4 || c.param_b > 1.0 - 1e-4;
        let (a, b) = (firsts(&a), firsts(&b));
        for c in &a {
            match first_of(&b, c.sample) {
                Some(d) if crease(c) || crease(&d) => prop_assert!((d.depth - c.depth).abs() < 0.02 * (1.0 + r.radius[0]), "sample {} on a ring: {} vs {}", c.sample, c.depth, d.depth),
                Some(d) => prop_assert!((d.depth - c.depth).abs() < tol, "sample {}: {} vs {}", c.sample, c.depth, d.depth),
                None => prop_assert!(c.depth < tol, "sample {} lost after the motion (depth {})", c.sample, c.depth),
            }
        }
        for c in &b {
            if depth_of(&a, c.sample).is_none() {
                prop_assert!(c.depth < tol, "sample {} appeared after the motion (depth {})", c.sample, c.depth);
            }
        }
    }
}

#[test]
fn detector_reuse_matches_fresh_detectors() {
    // History must never change the answer on a smooth sequence: coherent frames equal fresh
    // (re-acquiring) detectors frame by frame.
    let colon = arc(100, 120.0, 2.5, 18.0, 20);
    let mk = |f: usize| {
        let y = 9.0 + 9.0 * (f as f32 * 0.15).sin();
        interior(colon.clone(), line([5.0 + f as f32, y, 2.0], [150.0 + f as f32, y + 60.0, 2.0], 25, 5.0), 3, Method::Signed)
    };
    let mut d = Detector::new(&mk(0).spec().validate().unwrap());
    for f in 0..60 {
        let s = mk(f);
        let warm = d.detect(&s.state()).unwrap().to_vec();
        assert_eq!(warm, run(&s), "frame {f}");
    }
}

#[test]
fn generated_scenes_exercise_contacts_inside_and_outside() {
    // The properties above mean little if the random scenes rarely touch: check that they do.
    use lumen_detect::proto::contact::FLAG_OUTSIDE;
    use proptest::strategy::ValueTree;
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let (mut with, mut outside, n) = (0, 0, 200);
    for _ in 0..n {
        let (t, r) = scene_strategy(true).new_tree(&mut runner).unwrap().current();
        let cs = run(&interior(t, r, 3, Method::Signed));
        with += usize::from(!cs.is_empty());
        outside += usize::from(cs.iter().any(|c| c.flags & FLAG_OUTSIDE != 0));
    }
    assert!(with > n / 2, "{with} of {n} scenes have contacts");
    assert!(outside > n / 5, "{outside} of {n} scenes have samples outside the wall");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 100, ..ProptestConfig::default() })]

    /// Garbage that skipped validation (NaN, infinities, huge values anywhere) never panics or
    /// hangs the unchecked path, nor makes it answer anything non-finite, and the checked path
    /// rejects it.
    #[test]
    fn prevalidated_path_survives_garbage((t, r) in scene_strategy(false), hits in prop::collection::vec((any::<prop::sample::Index>(), prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(-f32::INFINITY), Just(3.0e38f32), Just(-1e-40f32)]), 1..6)) {
        for m in [Method::Signed, Method::Thesis] {
            let scene = interior(t.clone(), r.clone(), 2, m);
            let mut state = scene.state();
            for (i, v) in &hits {
                let n = state.len();
                state[i.index(n)] = *v;
            }
            let in_range = state.iter().all(|v| v.is_finite() && v.abs() <= lumen_proto::limits::MAX_COORDINATE);
            let mut d = Detector::new(&scene.spec().validate().unwrap());
            // The unchecked path may refuse what came out non-finite; whatever it answers is finite.
            if let Ok(contacts) = d.detect_prevalidated(&state) {
                prop_assert!(contacts.iter().all(|c| c.depth.is_finite() && c.normal.iter().chain(&c.point_a).chain(&c.point_b).all(|v| v.is_finite())));
            }
            prop_assert_eq!(d.detect(&state).is_ok(), in_range);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Near the wall every reported depth agrees with the dense reference at the same sample and
    /// no sample the reference puts in contact is missed (tolerance relative to the tube's
    /// size); far outside, every sample is a contact.
    #[test]
    fn depth_matches_the_dense_reference((t, r) in scene_strategy(true)) {
        let reference = lumen_oracle::Reference::new(&t, 0.5, 12);
        let size = (0..t.spokes).map(|k| norm(t.spoke(0, k))).fold(0.0, f32::max);
        let tol = 0.02 * size + reference.bound();
        for nearest in [false, true] {
            let scene = interior(t.clone(), r.clone(), 3, Method::Signed).nearest(nearest);
            let cs = run(&scene);
            let flat: Vec<f32> = r.points.iter().flatten().copied().collect();
            let mut samples = lumen_detect::samples::RodSamples::default();
            samples.fill(&lumen_detect::view::RodView::new(&flat, r.points.len(), lumen_detect::V3::zeros()), |_| r.radius[0], 3, 0.5);
            let (last_ring, first_ring) = (t.points[t.rings() - 1], t.points[0]);
            for (s, p) in samples.pos.iter().enumerate() {
                let p = [p.x, p.y, p.z];
                let q = reference.query(p);
                let want = r.radius[0] + q.sd;
                // Beyond or near the open ends (within 2 sizes of the end rings' planes) the reference
                // is capped and the pipeline open, reporting nothing past an end by design: skip.
                let along = |from: [f32; 3], dir: [f32; 3]| dot(sub(p, from), dir) / norm(dir).max(f32::MIN_POSITIVE);
                let n = t.rings();
                if along(first_ring, sub(t.points[1], t.points[0])) < 2.0 * size || along(last_ring, sub(t.points[n - 2], t.points[n - 1])) < 2.0 * size {
                    continue;
                }
                let found = cs.iter().find(|c| c.sample as usize == s);
                if q.sd.abs() <= 0.25 * size {
                    // Near the wall, where contacts are resolved: the reference's depth.
                    match found {
                        Some(c) => prop_assert!((c.depth - want).abs() < tol, "nearest {nearest}: sample {s}: depth {} reference {want} (tol {tol})", c.depth),
                        None => prop_assert!(want < tol, "nearest {nearest}: sample {s} missed: reference depth {want} (tol {tol})"),
                    }
                } else if q.sd > 0.0 {
                    // Far outside (tangent planes of a twisting wall extrapolate poorly there): still a
                    // contact, deeper than the rod is thick, however far out.
                    prop_assert!(found.is_some_and(|c| c.depth > r.radius[0]), "nearest {nearest}: sample {s}, {} outside: {:?}", q.sd, found.map(|c| c.depth));
                }
            }
        }
    }
}

//! Hard cases on curved tubes, checked against the dense reference (`lumen-oracle`): the same
//! continuous wall finely tessellated, with exact distances.

#[path = "../../detect/tests/common/mod.rs"]
mod common;
use common::*;
use lumen_detect::samples::RodSamples;
use lumen_detect::view::RodView;
use lumen_detect::{Contact, Method, Rod, Scene, Tube, V3};
use lumen_oracle::Reference;
use lumen_proto::contact::FLAG_OTHER_WALL;
use std::f32::consts::{FRAC_1_SQRT_2, PI, TAU};

/// Every rod sample as the detector takes it (same spline, same count).
fn samples(rod: &Rod, x: usize) -> Vec<([f32; 3], f32)> {
    let flat: Vec<f32> = rod.points.iter().flatten().copied().collect();
    let mut s = RodSamples::default();
    s.fill(&RodView::new(&flat, rod.points.len(), V3::zeros()), |i| rod.radius[i.min(rod.radius.len() - 1)], x, 0.5);
    s.pos.iter().zip(&s.radius).map(|(p, r)| ([p.x, p.y, p.z], *r)).collect()
}

struct Agreement {
    /// Largest |depth - reference depth| over reported contacts.
    worst: f32,
    /// Samples the reference puts deeper than `tol` that were not reported.
    missed: Vec<u32>,
    /// Reported contacts.
    reported: usize,
    /// Largest angle (rad) between a contact's normal and the reference wall normal at the
    /// nearest point, or at the contact's own wall point where that is nearer in angle.
    worst_normal: f32,
    /// Second contacts of a sample (`FLAG_OTHER_WALL`): another wall than its nearest, judged on
    /// their own wall point: the largest of its reference distance from the wall, of the
    /// error of the depth the sample has there, and (rad) of the angle between the contact's
    /// normal and the reference normal there.
    second: usize,
    second_off: f32,
    second_normal: f32,
}

/// Compares contacts of `tube`/`rod` with the reference at every sample. Samples whose
/// reference wall point is within `end_skip` of a ring-0 / last-ring plane are ignored (the
/// reference is capped there, the pipeline open).
fn agree(tube: &Tube, rod: &Rod, x: usize, cs: &[Contact], tol: f32) -> Agreement {
    let reference = Reference::new(tube, 0.5, 16);
    let samples = samples(rod, x);
    let mut a = Agreement { worst: 0.0, missed: vec![], reported: cs.len(), worst_normal: 0.0, second: 0, second_off: 0.0, second_normal: 0.0 };
    for (s, (p, r)) in samples.iter().enumerate() {
        let q = reference.query(*p);
        let want = r + q.sd;
        for c in cs.iter().filter(|c| c.sample as usize == s && c.flags & FLAG_OTHER_WALL != 0) {
            let w = reference.query(c.point_b);
            let to_wall = norm(add(w.point, scale(*p, -1.0)));
            a.second += 1;
            a.second_off = a.second_off.max(w.sd.abs()).max((c.depth - (r - to_wall)).abs());
            a.second_normal = a.second_normal.max(dot(c.normal, w.normal).clamp(-1.0, 1.0).acos());
        }
        match cs.iter().find(|c| c.sample as usize == s && c.flags & FLAG_OTHER_WALL == 0) {
            Some(c) => {
                a.worst = a.worst.max((c.depth - want).abs());
                // Where two wall points are (nearly) equally near, "the normal at the nearest
                // point" jumps between them: accept the wall normal at our own contact point
                // too, since the depth check already holds that point to be (nearly) nearest.
                let at_ours = reference.query(c.point_b).normal;
                let angle = |n: [f32; 3]| dot(c.normal, n).clamp(-1.0, 1.0).acos();
                a.worst_normal = a.worst_normal.max(angle(q.normal).min(angle(at_ours)));
            }
            None if want > tol => a.missed.push(s as u32),
            None => {}
        }
    }
    a
}

#[test]
fn hard_hairpin_180_degrees() {
    // A U-turn: centreline radius 30 for a tube of radius 12 (a sigmoid-like hairpin), rings
    // every 3 degrees. One rod hugs the outer wall around the bend, one the inner wall.
    let colon = arc(61, 30.0, PI, 12.0, 32);
    for (offset, label) in [(8.0f32, "outer"), (-8.0, "inner")] {
        let rr = 30.0 + offset;
        let scope = rod(
            (0..25)
                .map(|i| {
                    let p = 0.05 * PI + 0.9 * PI * i as f32 / 24.0;
                    [rr * p.sin(), 30.0 - rr * p.cos(), 0.5]
                })
                .collect(),
            5.0,
        );
        for m in [Method::Signed, Method::Thesis] {
            let cs = run(&interior(colon.clone(), scope.clone(), 4, m));
            let a = agree(&colon, &scope, 4, &cs, 0.05);
            assert!(a.reported > 60, "{label} {m:?}: {} contacts", a.reported);
            assert!(a.worst < 0.03, "{label} {m:?}: depth error {}", a.worst);
            assert!(a.missed.is_empty(), "{label} {m:?}: missed {:?}", a.missed);
            assert!(a.worst_normal < 6f32.to_radians(), "{label} {m:?}: normal error {} deg", a.worst_normal.to_degrees());
        }
    }
}

#[test]
fn hard_kink_90_degrees() {
    // The midline turns 90 degrees at one control point (rings every 4, radius 10): the spline
    // rounds the corner with a radius near the ring spacing, tighter than the tube, so the inner
    // wall folds through itself. Outside the fold the answers must match the reference; inside
    // it nothing may be NaN.
    let n = 21;
    let centre = |i: usize| if i <= 10 { [i as f32 * 4.0, 0.0, 0.0] } else { [40.0, (i - 10) as f32 * 4.0, 0.0] };
    let colon = tube(n, 24, centre, |i, k| {
        let a = k as f32 * TAU / 24.0;
        // Rings perpendicular to the local direction (the corner ring bisects the turn).
        let t: [f32; 3] = if i < 10 {
            [1.0, 0.0, 0.0]
        } else if i > 10 {
            [0.0, 1.0, 0.0]
        } else {
            [FRAC_1_SQRT_2, FRAC_1_SQRT_2, 0.0]
        };
        let u = [-t[1], t[0], 0.0];
        add(scale(u, 10.0 * a.cos()), scale([0.0, 0.0, 1.0], 10.0 * a.sin()))
    });
    // Outer corner: a rod cutting the corner at (x, y) far from the fold, pressed on the outer wall.
    let outer = line([20.0, -7.0, 0.0], [47.0, -7.0, 0.0], 10, 3.0);
    let outer2 = line([47.0, -7.0, 0.0], [47.0, 20.0, 0.0], 10, 3.0);
    for scope in [outer, outer2] {
        let cs = run(&interior(colon.clone(), scope.clone(), 4, Method::Signed));
        let a = agree(&colon, &scope, 4, &cs, 0.05);
        assert!(a.reported > 15, "{} contacts", a.reported);
        assert!(a.worst < 0.05, "depth error {}", a.worst);
        assert!(a.missed.is_empty(), "missed {:?}", a.missed);
    }
    // Through the fold on the inner side: finite, unit normals, no panic.
    let inner = line([30.0, 7.0, 0.0], [33.0, 10.0, 0.0], 6, 3.0);
    for m in [Method::Signed, Method::Thesis] {
        for c in run(&interior(colon.clone(), inner.clone(), 4, m)) {
            assert!(c.depth.is_finite() && (norm(c.normal) - 1.0).abs() < 1e-4, "{c:?}");
        }
    }
}

#[test]
fn hard_rings_tilted_against_the_midline() {
    // A straight midline along x whose rings are circles of radius 10 in planes tilted 30
    // degrees about z: the wall is an elliptic cylinder, and the rings' own planes (not the
    // midline's normal planes) slice it.
    let tilt = 30f32.to_radians();
    let e1 = [tilt.sin(), tilt.cos(), 0.0];
    let colon = tube(
        16,
        32,
        |i| [i as f32 * 4.0, 0.0, 0.0],
        |_, k| {
            let a = k as f32 * TAU / 32.0;
            add(scale(e1, 10.0 * a.cos()), scale([0.0, 0.0, 1.0], 10.0 * a.sin()))
        },
    );
    // Across x the section is an ellipse with half-axes 10 cos 30 = 8.66 (y) and 10 (z).
    for (y, z) in [(6.5, 0.0), (-4.0, 6.5), (0.0, 8.0), (7.0, -3.0), (9.5, 0.0)] {
        let scope = line([15.0, y, z], [45.0, y, z], 6, 3.0);
        let cs = run(&interior(colon.clone(), scope.clone(), 4, Method::Signed));
        let a = agree(&colon, &scope, 4, &cs, 0.02);
        assert!(a.reported > 10, "({y}, {z}): {} contacts", a.reported);
        assert!(a.worst < 0.01, "({y}, {z}): depth error {}", a.worst);
        assert!(a.missed.is_empty(), "({y}, {z}): missed {:?}", a.missed);
        assert!(a.worst_normal < 4f32.to_radians(), "({y}, {z}): normal error {} deg", a.worst_normal.to_degrees());
    }
}

/// A gently curving tube whose radius ripples along it (haustral folds: `amp` deep every
/// `period`) and around it, with a rod of radius 6.5 pressed into the folds.
fn haustral(amp: f32, period: f32) -> (Tube, Rod) {
    let colon = tube(
        120,
        32,
        |i| {
            let s = i as f32 * 1.5;
            [s, 20.0 * (s / 60.0).sin(), 0.0]
        },
        |i, k| {
            let s = i as f32 * 1.5;
            let a = k as f32 * TAU / 32.0;
            let r = 22.0 + amp * (s * TAU / period).cos() + 1.5 * (3.0 * a).sin();
            let t = {
                let d = [1.0, 20.0 / 60.0 * (s / 60.0).cos(), 0.0];
                scale(d, 1.0 / norm(d))
            };
            let u = [-t[1], t[0], 0.0];
            add(scale(u, r * a.cos()), scale([0.0, 0.0, 1.0], r * a.sin()))
        },
    );
    let scope = rod(
        (0..20)
            .map(|j| {
                let s = 20.0 + j as f32 * 7.0;
                [s, 20.0 * (s / 60.0).sin() + 16.0, 1.0]
            })
            .collect(),
        6.5,
    );
    (colon, scope)
}

/// One frame of the signed method at x = 4, with `set` applied to the detector first.
fn signed_with(colon: &Tube, scope: &Rod, set: impl FnOnce(&mut lumen_detect::Detector)) -> Vec<Contact> {
    detect_with(&interior(colon.clone(), scope.clone(), 4, Method::Signed), set)
}

/// One frame of `scene`, with `set` applied to the detector first.
fn detect_with(scene: &Scene, set: impl FnOnce(&mut lumen_detect::Detector)) -> Vec<Contact> {
    let mut d = lumen_detect::Detector::new(&scene.spec().validate().unwrap());
    set(&mut d);
    d.detect(&scene.state()).unwrap().to_vec()
}

/// The `sections` reading with `refine` axial re-projections.
fn with_refine(colon: &Tube, scope: &Rod, refine: u32) -> Vec<Contact> {
    signed_with(colon, scope, |d| {
        d.set_nearest(false);
        d.set_refine(refine)
    })
}

#[test]
fn hard_haustral_folds() {
    // Folds 2 deep every 40: the wall slopes up to 17 degrees along the tube, where a radial
    // answer is off by the slope's cosine and only true distances agree with the reference.
    // Its curvature radius (20) exceeds the rod's, so the nearest wall point is well defined.
    let (colon, scope) = haustral(2.0, 40.0);
    for refine in [0, 1] {
        let a = agree(&colon, &scope, 4, &with_refine(&colon, &scope, refine), 0.05);
        assert!(a.reported > 20);
        assert!(a.missed.is_empty(), "refine {refine}: missed {:?}", a.missed);
        let tol = if refine == 0 { 0.05 } else { 0.02 };
        assert!(a.worst < tol, "refine {refine}: depth error {}", a.worst);
        assert!(a.worst_normal < 3f32.to_radians(), "refine {refine}: normal error {} deg", a.worst_normal.to_degrees());
    }
    let a = agree(&colon, &scope, 4, &run(&interior(colon.clone(), scope.clone(), 4, Method::Thesis)), 0.05);
    assert!(a.worst > 0.1, "the published unsigned edge distance is radial: {}", a.worst);
}

#[test]
fn hard_folds_sharper_than_the_rod() {
    // Folds 3 deep every 25: the wall's curvature radius (5) is below the rod's (6.5), so the
    // rod lies in valleys touching both sides. Depth stays well defined; refinement reaches it.
    let (colon, scope) = haustral(3.0, 25.0);
    let errs: Vec<f32> = (0..3).map(|r| agree(&colon, &scope, 4, &with_refine(&colon, &scope, r), 0.1).worst).collect();
    assert!(errs[0] < 0.3 && errs[1] < 0.15 && errs[2] < 0.07, "depth error by refinement: {errs:?}");
}

#[test]
fn a_scene_declares_its_refinement() {
    // The spec's `refine` is the detector's: the same contacts as set on the detector, and the
    // refined depths nearer the reference on folds sharper than the rod.
    let (colon, scope) = haustral(3.0, 25.0);
    let declared = detect_with(&interior(colon.clone(), scope.clone(), 4, Method::Signed).nearest(false).refine(1), |_| {});
    assert_eq!(declared, with_refine(&colon, &scope, 1));
    let (once, never) = (agree(&colon, &scope, 4, &declared, 0.1).worst, agree(&colon, &scope, 4, &with_refine(&colon, &scope, 0), 0.1).worst);
    assert!(once < 0.6 * never, "depth error {once} refined once, {never} never");
}

fn with_nearest(colon: &Tube, scope: &Rod, on: bool) -> Vec<Contact> {
    signed_with(colon, scope, |d| d.set_nearest(on))
}

/// As [`with_nearest`] with a contact margin of 2 (as the colonoscopy of `lumen-sim` runs).
fn with_nearest_margin(colon: &Tube, scope: &Rod, on: bool) -> Vec<Contact> {
    let mut scene = interior(colon.clone(), scope.clone(), 4, Method::Signed);
    scene.margin = 2.0;
    detect_with(&scene, |d| d.set_nearest(on))
}

#[test]
fn nearest_wall_points_on_folds() {
    // Folds 2 deep every 40 (the wall sloped up to 17 degrees along the tube): the section's own
    // foot and tangent plane are off by hundredths of a millimetre and degrees of normal; the
    // nearest point of the continuous wall (the spec's `nearest`) is the reference's, to its
    // tessellation.
    let (colon, scope) = haustral(2.0, 40.0);
    // Declared in the spec (as a daemon client would) it is the same as set on the detector.
    let declared = run(&interior(colon.clone(), scope.clone(), 4, Method::Signed).nearest(true));
    assert_eq!(declared, with_nearest(&colon, &scope, true));
    // It is what a spec that says nothing gets.
    assert_eq!(declared, run(&interior(colon.clone(), scope.clone(), 4, Method::Signed)));
    assert_ne!(declared, with_nearest(&colon, &scope, false));
    let on = agree(&colon, &scope, 4, &with_nearest(&colon, &scope, true), 0.05);
    let off = agree(&colon, &scope, 4, &with_nearest(&colon, &scope, false), 0.05);
    assert!(on.missed.is_empty() && off.missed.is_empty(), "missed {:?} / {:?}", on.missed, off.missed);
    assert!(on.worst < 0.005, "nearest: depth error {}", on.worst);
    assert!(on.worst_normal < 1.5f32.to_radians(), "nearest: normal error {} deg", on.worst_normal.to_degrees());
    assert!(off.worst > 0.02 && off.worst_normal > 2f32.to_radians(), "section only: {} mm, {} deg", off.worst, off.worst_normal.to_degrees());
    // Folds sharper than the rod (3 deep every 25): the rod touches both flanks of a valley and
    // the nearest point found is the one down the flank the foot slopes to; still nearer the
    // reference than the section's tangent plane, and no sample missed that it found.
    let (colon, scope) = haustral(3.0, 25.0);
    let on = agree(&colon, &scope, 4, &with_nearest(&colon, &scope, true), 0.05);
    let off = agree(&colon, &scope, 4, &with_nearest(&colon, &scope, false), 0.05);
    assert!(on.worst < off.worst, "sharp folds: nearest {} mm, section {} mm", on.worst, off.worst);
    assert!(on.missed.iter().all(|s| off.missed.contains(s)), "sharp folds: missed {:?}, section only {:?}", on.missed, off.missed);
}

/// A straight tube along +x (rings every 1 mm, radius 20) with one sharp ring fold: the radius
/// falls to 9 over x = 40..43 and rises back over 43..46, its flanks at 75 degrees to the axis.
fn ring_fold() -> Tube {
    let radius = |x: f32| {
        if x <= 40.0 || x >= 46.0 {
            20.0
        } else if x <= 43.0 {
            20.0 - 11.0 * (x - 40.0) / 3.0
        } else {
            9.0 + 11.0 * (x - 43.0) / 3.0
        }
    };
    along_x(|i, _| radius(i as f32))
}

/// A straight tube along +x: 81 rings 1 mm apart, 32 spokes, spoke `k` of ring `i` `radius(i,
/// k)` long.
fn along_x(radius: impl Fn(usize, usize) -> f32) -> Tube {
    tube(
        81,
        32,
        |i| [i as f32, 0.0, 0.0],
        |i, k| {
            let a = k as f32 * TAU / 32.0;
            let r = radius(i, k);
            [0.0, r * a.cos(), r * a.sin()]
        },
    )
}

#[test]
fn nearest_sees_a_fold_ahead_of_the_scope_end() {
    // The scope ends at x = 37, 11 off the axis: its own section is 20 wide, so its section
    // reading puts it 2.5 clear, but the fold's front flank lies 5.26 from its centre (in the
    // (x, rho) plane: the distance of (37, 11) to the line from (40, 20) to (43, 9)), inside its
    // radius of 6.5. No other sample's section holds that flank.
    let colon = ring_fold();
    let scope = line([5.0, 11.0, 0.0], [37.0, 11.0, 0.0], 9, 6.5);
    let last = samples(&scope, 4).len() as u32 - 1;
    let want = 6.5 - 60.0 / 130f32.sqrt();
    let on = with_nearest_margin(&colon, &scope, true);
    let a = agree(&colon, &scope, 4, &on, 0.05);
    assert!(a.missed.is_empty(), "nearest missed {:?}", a.missed);
    assert!(a.worst < 0.05, "nearest: depth error {}", a.worst);
    let end = on.iter().find(|c| c.sample == last).expect("a contact at the scope's end");
    assert!((end.depth - want).abs() < 0.05, "end depth {} (want {want})", end.depth);
    assert!(end.normal[0] > 0.9, "the fold's flank faces the end: normal {:?}", end.normal);
    // The section readings put the last two samples 2.5 clear of their own sections' wall,
    // beyond the margin: both are missed.
    let off = agree(&colon, &scope, 4, &with_nearest_margin(&colon, &scope, false), 0.05);
    assert_eq!(off.missed, vec![last - 1, last], "section readings");
    // The end is read even where its section puts it beyond the margin.
    let bare = with_nearest(&colon, &scope, true);
    assert!(bare.iter().any(|c| c.sample == last && (c.depth - want).abs() < 0.05), "no margin: {bare:?}");
}

#[test]
fn nearest_holds_the_scope_end_by_the_side_wall_and_the_fold_ahead() {
    // The scope's end in a corner: against the side wall, 0.1 into it, with the fold's front
    // flank 0.5 ahead of its surface, within the margin of 2. The scope lies in the half-plane
    // through the middle of a strip (angle pi/32 between spokes 0 and 1), where the 32-gon's
    // wall is `c = cos(pi/32)` of its radius: the side wall at `rho = 20c`, the fold's front the
    // line from (40, 20c) to (43, 9c) in (x, rho), both exact (the patches are flat there).
    // One contact, the nearest wall, would let the end slide along the side wall into the fold
    // (the GCA colonoscopy's deepest penetration); the fold is the sample's second contact.
    let colon = ring_fold();
    let (a, c) = (PI / 32.0, (PI / 32.0).cos());
    let (rho, end_x) = (13.5f32, 34.5f32);
    let at = |x: f32| [x, rho * a.cos(), rho * a.sin()];
    let scope = line(at(5.0), at(end_x), 9, 6.5);
    let samples = samples(&scope, 4);
    let last = samples.len() as u32 - 1;
    let side = 6.5 - (20.0 * c - rho);
    let (fx, fr) = (3.0f32, 11.0 * c);
    let len = (fx * fx + fr * fr).sqrt();
    let fold = |x: f32| 6.5 - (fr * (40.0 - x) + fx * (20.0 * c - rho)) / len;
    let on = with_nearest_margin(&colon, &scope, true);
    let mine: Vec<&Contact> = on.iter().filter(|c| c.sample == last).collect();
    assert_eq!(mine.len(), 2, "the end's contacts: {mine:?}");
    assert!(mine[0].flags & FLAG_OTHER_WALL == 0 && (mine[0].depth - side).abs() < 0.01, "first: the side wall at depth {side}: {:?}", mine[0]);
    assert!(mine[1].flags & FLAG_OTHER_WALL != 0 && (mine[1].depth - fold(end_x)).abs() < 0.01, "second: the fold at depth {}: {:?}", fold(end_x), mine[1]);
    assert!((mine[1].normal[0] - fr / len).abs() < 0.01, "the fold's flank faces the end: {:?}", mine[1].normal);
    // Every other wall reported is the fold's front, at the depth the line gives, and the
    // samples' first contacts the side wall.
    let ag = agree(&colon, &scope, 4, &on, 0.05);
    assert!(ag.second >= 1 && ag.second_off < 0.02 && ag.second_normal < 2f32.to_radians(), "{} second contacts, off {} mm, normal {} deg", ag.second, ag.second_off, ag.second_normal.to_degrees());
    assert!(ag.worst < 0.01 && ag.missed.is_empty(), "first contacts: depth error {}, missed {:?}", ag.worst, ag.missed);
    for c in on.iter().filter(|c| c.flags & FLAG_OTHER_WALL != 0) {
        let x = samples[c.sample as usize].0[0];
        assert!((c.depth - fold(x)).abs() < 0.01, "sample {} at x = {x}: depth {} (the fold: {})", c.sample, c.depth, fold(x));
    }
    // Beyond the margin, no second wall: without a margin the fold (0.5 away) is not reported.
    let bare = with_nearest(&colon, &scope, true);
    assert!(bare.iter().all(|c| c.flags & FLAG_OTHER_WALL == 0), "no margin: {bare:?}");
}

#[test]
fn nearest_reports_no_wall_past_a_fold_crest() {
    // A scope along the axis, 2 off it, through the fold: its surface passes 0.5 inside the
    // crest. Past the crest a section on a flank reads the distance to that flank's tangent
    // plane, which extends through the lumen (at x = 44 it passes 2.8 from the sample, whose
    // nearest wall point, the crest, is 7.1 away): a contact with no wall there.
    let colon = ring_fold();
    let scope = line([20.0, 2.0, 0.0], [70.0, 2.0, 0.0], 11, 6.5);
    let off = agree(&colon, &scope, 4, &with_nearest(&colon, &scope, false), 0.05);
    assert!(off.reported > 0 && off.worst > 2.0, "section readings: {} contacts, worst depth error {}", off.reported, off.worst);
    let on = agree(&colon, &scope, 4, &with_nearest(&colon, &scope, true), 0.05);
    assert_eq!(on.reported, 0, "nearest: contacts where the wall is 0.5 away");
    assert!(on.missed.is_empty());
}

/// A straight tube along +x (rings every 1 mm, radius 20) with a fold thinner than the ring
/// spacing: ring 40's spokes 4 to 10 (of 32) reach 6 mm from the axis, with a spur on ring 39
/// and a tail over rings 41 and 42, so the fold is a blade 2 mm wide at its root whose crest
/// runs along ring 40's section and across the next rings: where a thin haustral fold or the
/// septum between two loops lies in one ring's plane and its neighbours' rays pass beside it
/// (a generated insufflated colon's hairpin, imported at 48 spokes, has one 35 mm tall).
fn blade() -> Tube {
    along_x(|i, k| {
        let short = (i == 39 && k == 5) || (i == 40 && (4..=10).contains(&k)) || (i == 41 && (7..=10).contains(&k)) || (i == 42 && (9..=10).contains(&k));
        if short {
            6.0
        } else {
            20.0
        }
    })
}

#[test]
fn nearest_reads_the_crest_of_a_fold_thinner_than_the_ring_spacing() {
    // A scope's tip (radius 6.5) before and behind the blade, 1 to 6 mm from ring 40, 0 to 14
    // mm from the axis, over the blade's spokes and past its sides: its nearest wall point
    // often lies on a ring's section (the crest, or the blade's side), where the patch on the
    // tip's side faces it and the patch beyond the ring faces away, and where each patch's
    // Newton step sends a descent over the ring into the other. Every wall the reference puts
    // within 0.05 mm of touching is a contact, at the reference's depth.
    let colon = blade();
    let reference = Reference::new(&colon, 0.5, 16);
    let (mut placed, mut touching, mut missed, mut worst) = (0, 0, vec![], (0.0f32, [0.0f32; 3]));
    for dir in [-1.0f32, 1.0] {
        for gap in [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0] {
            for rho in [0.0f32, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 14.0] {
                for step in 0..21 {
                    let a = (2.0 + 0.5 * step as f32) * TAU / 32.0;
                    let tip = [40.0 + dir * gap, rho * a.cos(), rho * a.sin()];
                    let scope = rod(vec![add(tip, [dir * 3.0, 0.0, 0.0]), tip], 6.5);
                    let cs = run(&interior(colon.clone(), scope, 4, Method::Signed));
                    placed += 1;
                    let want = 6.5 + reference.query(tip).sd;
                    touching += usize::from(want > 0.05);
                    match cs.iter().find(|c| c.sample == 4 && c.flags & FLAG_OTHER_WALL == 0) {
                        Some(c) if (c.depth - want).abs() > worst.0 => worst = ((c.depth - want).abs(), tip),
                        Some(_) => {}
                        None if want > 0.05 => missed.push((tip, want)),
                        None => {}
                    }
                }
            }
        }
    }
    assert!(touching > 1000, "{touching} of {placed} tips touch the wall");
    assert!(missed.is_empty(), "{} of {placed} tips missed (tip, reference depth): {:?}", missed.len(), &missed[..missed.len().min(10)]);
    assert!(worst.0 < 0.05, "depth error {:.3} mm at {:?} ({placed} placements)", worst.0, worst.1);
}

/// A straight tube along +x whose sections are ellipses of semi-axes `a` (y) and `b` (z).
fn elliptic(a: f32, b: f32) -> Tube {
    tube(
        31,
        32,
        |i| [i as f32 * 2.0, 0.0, 0.0],
        |_, k| {
            let t = k as f32 * TAU / 32.0;
            [0.0, a * t.cos(), b * t.sin()]
        },
    )
}

#[test]
fn a_scope_wider_than_the_lumen_is_held_all_around() {
    // A collapsed segment: a round lumen of radius 4 around a scope of radius 6 (near its
    // midline, 0.3 off), and a flattened one (12 by 5) with the scope 3 off the midline along
    // the wide axis, where its own sector's wall is 9 away and the walls pressing on it lie a
    // quarter turn round.
    for (colon, (dy, dz), label) in [(straight(31, 2.0, 4.0, 32), (0.3, 0.1), "round"), (elliptic(12.0, 5.0), (3.0, 0.0), "flat")] {
        let scope = line([10.0, dy, dz], [50.0, dy, dz], 9, 6.0);
        for nearest in [false, true] {
            let cs = with_nearest(&colon, &scope, nearest);
            let a = agree(&colon, &scope, 4, &cs, 0.05);
            let tag = format!("{label}, nearest {nearest}");
            assert!(a.missed.is_empty(), "{tag}: missed {:?}", a.missed);
            assert!(a.worst < 0.05, "{tag}: depth error {}", a.worst);
            assert!(a.worst_normal < 6f32.to_radians(), "{tag}: normal error {} deg", a.worst_normal.to_degrees());
            assert!(a.second_off < 0.05, "{tag}: other walls off by {}", a.second_off);
            assert!(a.second_normal < 6f32.to_radians(), "{tag}: other walls' normals off by {} deg", a.second_normal.to_degrees());
            // Every sample is held from opposite sides: its normals do not all lie in one half.
            for s in 0..33u32 {
                let ns: Vec<[f32; 3]> = cs.iter().filter(|c| c.sample == s).map(|c| c.normal).collect();
                let opposed = ns.iter().any(|m| ns.iter().any(|n| dot(*m, *n) < -0.9));
                assert!(opposed, "{tag}: sample {s} held from one side only: {ns:?}");
                if label == "round" {
                    assert_eq!(ns.len(), 4, "{tag}: sample {s}: a wall each quarter turn: {ns:?}");
                    let sum = ns.iter().fold([0.0; 3], |acc, n| add(acc, *n));
                    assert!(norm(sum) < 0.5, "{tag}: sample {s}: pushed to one side: {ns:?}");
                }
            }
        }
    }
}

/// A scope's tip (radius 6.5 mm, the rod's end) pressed 0.5 mm into the wall of the generated
/// insufflated colon (seed 1: lumens of 25 to 50 mm, haustral folds, bends a third to a half
/// of the lumen's radius) at every 4th ring and 6th spoke: between two folds, and on the inner
/// side of a bend where ring planes fan, the wall is a crease whose second flank can lie many
/// rings along the tube from the tip's own section. Every wall the reference puts within
/// 0.05 mm of touching is a contact, at the reference's depth.
#[test]
fn hard_tip_in_the_creases_of_an_insufflated_colon() {
    let (colon, _) = lumen_scene::insufflated::load(1).unwrap();
    let reference = Reference::new(&colon, 0.5, 16);
    let (mut placed, mut missed, mut worst) = (0, vec![], (0.0f32, 0usize, 0usize));
    for i in (20..colon.rings() - 20).step_by(4) {
        for k in (0..colon.spokes).step_by(6) {
            let (c, v) = (colon.points[i], colon.spoke(i, k));
            let len = norm(v);
            if len < 12.0 {
                continue;
            }
            let u = scale(v, 1.0 / len);
            let tip = add(c, scale(u, len - 6.0));
            let scope = rod(vec![add(tip, scale(u, -3.0)), tip], 6.5);
            let cs = run(&interior(colon.clone(), scope, 4, Method::Signed));
            placed += 1;
            let want = 6.5 + reference.query(tip).sd;
            match cs.iter().find(|c| c.sample == 4 && c.flags & FLAG_OTHER_WALL == 0) {
                Some(c) if (c.depth - want).abs() > worst.0 => worst = ((c.depth - want).abs(), i, k),
                Some(_) => {}
                None if want > 0.05 => missed.push((i, k, want)),
                None => {}
            }
        }
    }
    assert!(placed > 1000, "{placed} placements");
    assert!(missed.is_empty(), "{} of {placed} tips missed (ring, spoke, reference depth): {:?}", missed.len(), &missed[..missed.len().min(10)]);
    assert!(worst.0 < 0.05, "depth error {:.3} mm at ring {} spoke {} ({placed} placements)", worst.0, worst.1, worst.2);
}

//! Hard cases, one test each, asserting numbers against exact answers (straight tubes, where
//! the wall is a prism over a polygon and distances are 2D) or the dense reference (curved ones,
//! in `hard_reference.rs`).

mod common;
use common::*;
use lumen_detect::proto::contact::{FLAG_NOT_STAR, FLAG_OTHER_WALL, FLAG_OUTSIDE};
use lumen_detect::proto::{BodySpec, PairSpec, Shape};
use lumen_detect::{ContactKind, Detector, InputError, Method, Scene, SceneSpec, SpecError, Tube};
use std::f32::consts::{PI, TAU};

/// Signed distance from 2D point `p` to the polygon `poly` (negative inside), brute force.
fn polygon_sd(poly: &[[f32; 2]], p: [f32; 2]) -> f32 {
    let mut best = f32::INFINITY;
    let mut inside = false;
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let w = [b[0] - a[0], b[1] - a[1]];
        let ww = w[0] * w[0] + w[1] * w[1];
        let l = (((p[0] - a[0]) * w[0] + (p[1] - a[1]) * w[1]) / ww).clamp(0.0, 1.0);
        let d = ((a[0] + w[0] * l - p[0]).powi(2) + (a[1] + w[1] * l - p[1]).powi(2)).sqrt();
        best = best.min(d);
        if (a[1] > p[1]) != (b[1] > p[1]) && p[0] < a[0] + (p[1] - a[1]) / (b[1] - a[1]) * w[0] {
            inside = !inside;
        }
    }
    if inside {
        -best
    } else {
        best
    }
}

/// Spokes of a straight tube along +x as (y, z) polygon.
fn section(t: &Tube, ring: usize) -> Vec<[f32; 2]> {
    (0..t.spokes).map(|k| [t.spoke(ring, k)[1], t.spoke(ring, k)[2]]).collect()
}

/// A tube along x, rings 1 apart: spoke `k` of ring `i` is `(0, y, z)` for `(y, z) =
/// wall(i, k, (cos a, sin a))`, `a` the spoke's angle (`k` turns of `TAU / spokes`).
fn along_x(rings: usize, spokes: usize, wall: impl Fn(usize, usize, (f32, f32)) -> (f32, f32)) -> Tube {
    tube(
        rings,
        spokes,
        |i| [i as f32, 0.0, 0.0],
        |i, k| {
            let a = k as f32 * TAU / spokes as f32;
            let (y, z) = wall(i, k, (a.cos(), a.sin()));
            [0.0, y, z]
        },
    )
}

/// A slit along x (90 rings 1 apart, 32 spokes): a lumen 40 wide, its floor 7 below the
/// midline and its ceiling `ceiling(i)` above it at ring `i`.
fn slit(ceiling: impl Fn(usize) -> f32) -> Tube {
    along_x(90, 32, |i, _, (c, s)| {
        let up = if s > 0.0 {
            ceiling(i) / s
        } else if s < 0.0 {
            -7.0 / s
        } else {
            f32::INFINITY
        };
        let t = (20.0 / c.abs().max(1e-6)).min(up);
        (t * c, t * s)
    })
}

fn assert_finite(cs: &[lumen_detect::Contact]) {
    for c in cs {
        let all = c.point_a.iter().chain(&c.point_b).chain(&c.normal).chain(&c.weights_b).chain([&c.depth, &c.param_a, &c.param_b]);
        assert!(all.clone().all(|v| v.is_finite()), "non-finite contact {c:?}");
        assert!((norm(c.normal) - 1.0).abs() < 1e-4, "normal not unit: {c:?}");
    }
}

#[test]
fn hard_coincident_control_points() {
    // Ring 3 duplicated (and ring 0 too): the same surface as without duplicates.
    let base = straight(8, 5.0, 10.0, 16);
    let dup = |t: &Tube| {
        let mut idx: Vec<usize> = (0..t.rings()).collect();
        idx.insert(3, 3);
        idx.insert(0, 0);
        let points = idx.iter().map(|&i| t.points[i]).collect();
        let radial = idx.iter().flat_map(|&i| (0..t.spokes).map(move |k| (i, k))).map(|(i, k)| t.spoke(i, k)).collect();
        Tube::new(points, radial, t.spokes).unwrap()
    };
    let scope = line([1.0, 6.0, 0.5], [34.0, 6.0, 0.5], 6, 5.0);
    for m in [Method::Signed, Method::Thesis] {
        let a = run(&interior(base.clone(), scope.clone(), 4, m));
        let b = run(&interior(dup(&base), scope.clone(), 4, m));
        assert_finite(&b);
        assert_eq!(a.len(), b.len(), "{m:?}");
        for (x, y) in a.iter().zip(&b) {
            assert!((x.depth - y.depth).abs() < 1e-4, "{m:?}: {} vs {}", x.depth, y.depth);
        }
    }
}

#[test]
fn hard_only_two_control_points() {
    // One straight segment: covered end to end (the original code had no leaf for it).
    let colon = straight(2, 40.0, 10.0, 16);
    let scope = line([0.0, 7.0, 0.0], [40.0, 7.0, 0.0], 2, 4.0);
    for m in [Method::Signed, Method::Thesis] {
        let cs = run(&interior(colon.clone(), scope.clone(), 8, m));
        assert_eq!(cs.len(), 9, "{m:?}: every sample including both ends");
        let want = 4.0 + polygon_sd(&section(&colon, 0), [7.0, 0.0]);
        for c in &cs {
            assert!((c.depth - want).abs() < 1e-4, "{m:?}: depth {} want {want}", c.depth);
        }
    }
}

#[test]
fn hard_collapsed_section() {
    // Ring 5 of 11 pinched to 1e-6 of the radius: a rod through it touches everywhere near it
    // and nothing is NaN; right at the pinch the wall is at the midline, so depth = r + |offset|.
    let colon = tube(
        11,
        16,
        |i| [i as f32 * 5.0, 0.0, 0.0],
        |i, k| {
            let r = if i == 5 { 1e-5 } else { 10.0 };
            let a = k as f32 * TAU / 16.0;
            [0.0, r * a.cos(), r * a.sin()]
        },
    );
    let scope = line([2.0, 0.5, 0.0], [48.0, 0.5, 0.0], 24, 2.0);
    let cs = run(&interior(colon, scope, 2, Method::Signed));
    assert_finite(&cs);
    // Around the pinch the wall is a cone: in the (x, rho) plane along spoke 0 it is the line
    // from (20, 10) to (25, 0). The sample at x = 25 (index 23) is outside it, at distance
    // 0.5 * 5 / sqrt(125) from that line.
    let at_pinch = cs.iter().find(|c| c.sample == 23).expect("a contact at x = 25");
    let want = 2.0 + 0.5 * 5.0 / 125f32.sqrt();
    assert!((at_pinch.depth - want).abs() < 1e-3, "depth at the pinch {} want {want}", at_pinch.depth);
    assert_ne!(at_pinch.flags & FLAG_OUTSIDE, 0);
    // Where the wall is 10 away (x < 20 or x > 30, minus the cone) nothing touches.
    assert!(cs.iter().all(|c| (17..=29).contains(&c.sample)), "{:?}", cs.iter().map(|c| c.sample).collect::<Vec<_>>());
}

#[test]
fn hard_zero_length_spoke() {
    // Spoke 0 (+y) has length 0 on every ring: the wall runs along the midline there, so a rod
    // at (y, z) = (2, 0) is outside the lumen, 2 from that wall line... the section is a
    // polygon through the origin; the 2D polygon distance is exact.
    let colon = tube(
        6,
        12,
        |i| [i as f32 * 5.0, 0.0, 0.0],
        |_, k| {
            let r = if k == 0 { 0.0 } else { 10.0 };
            let a = k as f32 * TAU / 12.0;
            [0.0, r * a.cos(), r * a.sin()]
        },
    );
    let poly = section(&colon, 0);
    for (y, z) in [(2.0, 0.0), (1.0, 3.0), (-3.0, 0.5), (0.0, -4.0)] {
        let scope = line([3.0, y, z], [22.0, y, z], 3, 1.5);
        let cs = run(&interior(colon.clone(), scope, 1, Method::Signed));
        assert_finite(&cs);
        let want = 1.5 + polygon_sd(&poly, [y, z]);
        if want > 0.0 {
            assert_eq!(cs.len(), 3, "at ({y}, {z})");
        }
        for c in &cs {
            assert!((c.depth - want).abs() < 1e-4, "at ({y}, {z}): depth {} want {want}", c.depth);
        }
    }
}

#[test]
fn hard_rod_exactly_on_the_midline() {
    // Thin rod on the axis: no contact. Every direction is equally near; nothing NaN.
    let colon = straight(10, 5.0, 10.0, 24);
    let cs = run(&interior(colon.clone(), line([0.0, 0.0, 0.0], [45.0, 0.0, 0.0], 10, 3.0), 4, Method::Signed));
    assert!(cs.is_empty());
    // Just thick enough to touch the nearest edges: depth r - R cos(pi/B), all around: a wall
    // each quarter turn, held from every side.
    let r = 10.0 * (PI / 24.0).cos() + 0.25;
    let cs = run(&interior(colon, line([0.0, 0.0, 0.0], [45.0, 0.0, 0.0], 10, r), 4, Method::Signed));
    assert_eq!(cs.len(), (9 * 4 + 1) * 4);
    assert_finite(&cs);
    for c in &cs {
        assert!((c.depth - 0.25).abs() < 1e-4, "depth {}", c.depth);
    }
    for s in 0..37 {
        let sum = cs.iter().filter(|c| c.sample == s).fold([0.0; 3], |acc, c| add(acc, c.normal));
        assert!(norm(sum) < 0.2, "sample {s} pushed to one side: {sum:?}");
    }
}

#[test]
fn hard_rod_exactly_on_a_spoke() {
    // Along the direction of spoke 5 (a sector boundary): the same answer from both sides, the
    // same sector every time.
    let b = 20;
    let colon = straight(10, 5.0, 10.0, b);
    let a = 5.0 * TAU / b as f32;
    let (y, z) = (7.0 * a.cos(), 7.0 * a.sin());
    let scope = line([1.0, y, z], [44.0, y, z], 8, 4.0);
    let first = run(&interior(colon.clone(), scope.clone(), 2, Method::Signed));
    let want = 4.0 + polygon_sd(&section(&colon, 0), [y, z]);
    assert_eq!(first.len(), 15);
    for c in &first {
        assert!((c.depth - want).abs() < 1e-4, "depth {} want {want}", c.depth);
        assert!(c.spoke_b == 4 || c.spoke_b == 5, "sector {}", c.spoke_b);
    }
    assert_eq!(first, run(&interior(colon, scope, 2, Method::Signed)), "deterministic");
}

#[test]
fn hard_rod_fully_outside_the_tube() {
    // The whole rod 3 radii off the axis, along spoke 0: positive depth however far out, the
    // wall's outward normal (+y), flagged outside. The published method sees nothing.
    let colon = straight(20, 5.0, 10.0, 16);
    let scope = line([5.0, 30.0, 0.0], [90.0, 30.0, 0.0], 12, 2.0);
    let cs = run(&interior(colon.clone(), scope.clone(), 2, Method::Signed));
    assert_eq!(cs.len(), 23);
    for c in &cs {
        assert!((c.depth - 22.0).abs() < 1e-3, "depth {}", c.depth);
        assert!(c.normal[1] > 0.9999, "normal {:?}", c.normal);
        assert_ne!(c.flags & FLAG_OUTSIDE, 0);
    }
    assert!(run(&interior(colon, scope, 2, Method::Thesis)).is_empty());
}

#[test]
fn hard_crossing_the_wall_back_and_forth() {
    // Over 200 frames the rod swings from y = 4 to y = 16 and back (wall at 10): depth tracks
    // y - 10 + r exactly, and the normal never flips (the published normal does).
    let colon = straight(20, 5.0, 10.0, 16);
    let mk = |y: f32, m| interior(colon.clone(), line([10.0, y, 0.0], [80.0, y, 0.0], 8, 3.0), 1, m);
    let spec = mk(4.0, Method::Signed).spec();
    let mut signed = Detector::new(&spec.validate().unwrap());
    let mut thesis = Detector::new(&mk(4.0, Method::Thesis).spec().validate().unwrap());
    let mut thesis_flips = 0;
    let mut prev_thesis: Option<[f32; 3]> = None;
    for f in 0..200 {
        let y = 10.0 - 6.0 * (f as f32 * TAU / 100.0).cos();
        let st = mk(y, Method::Signed).state();
        let cs = signed.detect(&st).unwrap();
        let want = 3.0 + polygon_sd(&section(&colon, 0), [y, 0.0]);
        if want > 0.0 {
            assert_eq!(cs.len(), 8, "frame {f}");
        }
        for c in cs {
            assert!((c.depth - want).abs() < 1e-3, "frame {f}: depth {} want {want}", c.depth);
            assert!(c.normal[1] > 0.98, "frame {f}: normal {:?}", c.normal);
        }
        if let Some(c) = thesis.detect(&st).unwrap().first() {
            if prev_thesis.is_some_and(|p| dot(p, c.normal) < 0.0) {
                thesis_flips += 1;
            }
            prev_thesis = Some(c.normal);
        }
    }
    assert!(thesis_flips > 0, "the published collision vector flips when the rod crosses");
}

#[test]
fn hard_rod_thicker_than_the_tube() {
    let colon = straight(10, 5.0, 10.0, 16);
    let cs = run(&interior(colon.clone(), line([0.0, 1.0, 0.0], [45.0, 1.0, 0.0], 6, 15.0), 2, Method::Signed));
    let want = 15.0 + polygon_sd(&section(&colon, 0), [1.0, 0.0]);
    // Each sample's first contact is its nearest wall; the walls a quarter and a half turn round
    // press on it too, flagged as other walls, each deeper than the first.
    let first: Vec<_> = cs.iter().filter(|c| c.flags & FLAG_OTHER_WALL == 0).collect();
    assert_eq!(first.len(), 11);
    for c in first {
        assert!((c.depth - want).abs() < 1e-4, "depth {} want {want}", c.depth);
        assert!(c.normal[1] > 0.98, "towards the nearest wall, +y: {:?}", c.normal);
    }
    for s in 0..11 {
        let others: Vec<_> = cs.iter().filter(|c| c.sample == s && c.flags & FLAG_OTHER_WALL != 0).collect();
        assert_eq!(others.len(), 3, "sample {s}");
        assert!(others.iter().any(|c| c.normal[1] < -0.98), "sample {s}: the opposite wall: {others:?}");
        assert!(others.iter().all(|c| c.depth < want && c.depth > 15.0 - 11.0), "sample {s}: {others:?}");
    }
}

#[test]
fn hard_very_thin_rod() {
    // r = 1e-4 R, centre 0.5 r inside the wall (mid-sector): depth 0.5 r to 1% of r.
    let colon = straight(10, 5.0, 10.0, 16);
    let r = 1e-3;
    let edge = 10.0 * (PI / 16.0).cos(); // mid-sector wall distance from the axis
    let (c, s) = ((PI / 16.0).cos(), (PI / 16.0).sin());
    let rho = edge - 0.5 * r; // along the edge's normal
    let cs = run(&interior(colon, line([2.0, rho * c, rho * s], [40.0, rho * c, rho * s], 5, r), 2, Method::Signed));
    assert_eq!(cs.len(), 9);
    for ct in &cs {
        assert!((ct.depth - 0.5 * r).abs() < 0.01 * r, "depth {}", ct.depth);
    }
}

#[test]
fn hard_rod_entering_through_the_open_end() {
    // The tube spans x in [0, 50]; the rod runs from x = -40 (outside the patient) to x = 30,
    // pressed against the wall: only samples past the first ring's plane give contacts.
    let colon = straight(11, 5.0, 10.0, 16);
    let scope = line([-40.0, 8.0, 0.0], [30.0, 8.0, 0.0], 15, 3.0);
    for m in [Method::Signed, Method::Thesis] {
        let cs = run(&interior(colon.clone(), scope.clone(), 2, m));
        assert!(!cs.is_empty());
        for c in &cs {
            let x = sample_point(&interior(colon.clone(), scope.clone(), 2, m), c)[0];
            assert!(x >= -1e-4 || m == Method::Thesis && x > -3.0 - 1e-3, "{m:?}: contact at x = {x}");
        }
        if m == Method::Signed {
            // Samples every 2.5 from x = -40: x = 0, 2.5, ... 30 are inside: 13.
            assert_eq!(cs.len(), 13);
        }
    }
}

#[test]
fn hard_spokes_clockwise_and_counterclockwise() {
    let ccw = straight(10, 5.0, 10.0, 16);
    let cw = tube(10, 16, |i| ccw.points[i], |i, k| ccw.spoke(i, (16 - k) % 16));
    for (y, z) in [(7.0, 1.0), (-2.0, 8.5), (0.3, -7.7), (12.0, 3.0)] {
        let scope = line([2.0, y, z], [40.0, y, z], 5, 3.0);
        let a = run(&interior(ccw.clone(), scope.clone(), 2, Method::Signed));
        let b = run(&interior(cw.clone(), scope, 2, Method::Signed));
        assert_eq!(a.len(), b.len());
        assert!(!a.is_empty());
        for (p, q) in a.iter().zip(&b) {
            assert!((p.depth - q.depth).abs() < 1e-4);
            assert!(dot(p.normal, q.normal) > 0.99999);
            // The same wall tips carry the weight: spoke k of one is spoke 16 - k of the other.
            assert_eq!((16 - p.spoke_b as usize) % 16, (q.spoke_b as usize + 1) % 16);
        }
    }
}

#[test]
fn hard_non_uniform_spoke_angles() {
    // Twelve spokes at irregular angles and lengths: exact prism distances.
    let angles = [0.0f32, 0.2, 0.9, 1.1, 1.9, 2.6, 2.8, 3.5, 4.4, 4.9, 5.5, 6.0];
    let lens = [10.0f32, 12.0, 9.0, 11.0, 10.5, 8.0, 9.5, 12.5, 10.0, 9.0, 11.5, 10.0];
    let colon = tube(8, 12, |i| [i as f32 * 5.0, 0.0, 0.0], |_, k| [0.0, lens[k] * angles[k].cos(), lens[k] * angles[k].sin()]);
    let poly = section(&colon, 0);
    let mut checked = 0;
    for j in 0..40 {
        let a = j as f32 * TAU / 40.0;
        let rho = 6.0 + 2.0 * (j % 3) as f32;
        let (y, z) = (rho * a.cos(), rho * a.sin());
        let cs = run(&interior(colon.clone(), line([2.0, y, z], [30.0, y, z], 3, 3.0), 1, Method::Signed));
        let want = 3.0 + polygon_sd(&poly, [y, z]);
        // Each sample's first contact is its nearest wall; where the section is narrow enough
        // that another edge may touch it, that edge is a contact too, on the wall and touching.
        let (first, others): (Vec<&lumen_detect::Contact>, Vec<_>) = cs.iter().partition(|c| c.flags & FLAG_OTHER_WALL == 0);
        assert_eq!(first.len(), if want > 0.0 { 3 } else { 0 }, "angle {a}: want {want}");
        for c in first {
            assert!((c.depth - want).abs() < 1e-4, "angle {a}: {} want {want}", c.depth);
            checked += 1;
        }
        for c in others {
            let on_wall = polygon_sd(&poly, [c.point_b[1], c.point_b[2]]).abs();
            assert!(c.depth > 0.0 && c.depth <= want + 1e-4 && on_wall < 1e-3, "angle {a}: other wall {c:?}");
        }
    }
    assert!(checked > 30);
}

#[test]
fn hard_non_star_section_is_flagged() {
    // Ring 4's spokes 3 and 4 swapped: the polygon folds. The model check names the ring, and
    // contacts computed there carry the flag instead of passing as clean geometry.
    let good = straight(10, 5.0, 10.0, 12);
    let bad = tube(
        10,
        12,
        |i| good.points[i],
        |i, k| {
            let k = if i == 4 && (k == 3 || k == 4) { 7 - k } else { k };
            good.spoke(i, k)
        },
    );
    assert_eq!(good.first_non_star(), None);
    assert_eq!(bad.first_non_star().map(|(ring, _)| ring), Some(4));
    let a = 3.5 * TAU / 12.0;
    let scope = line([12.0, 8.0 * a.cos(), 8.0 * a.sin()], [28.0, 8.0 * a.cos(), 8.0 * a.sin()], 5, 3.0);
    let cs = run(&interior(bad, scope, 2, Method::Signed));
    assert_finite(&cs);
    assert!(cs.iter().any(|c| c.flags & FLAG_NOT_STAR != 0 && (c.index_b == 3 || c.index_b == 4)), "{cs:?}");
}

#[test]
fn hard_translated_and_rotated_scene() {
    // 100 body lengths away (the tube is 50 long: 5,000 units) and rotated: the same contacts,
    // depths within 1% of the rod radius (only the inputs' rounding differs).
    let colon = arc(40, 60.0, PI / 2.0, 12.0, 32);
    let scope = rod(
        (0..12)
            .map(|i| {
                let p = 0.1 + 1.2 * i as f32 / 11.0 * 0.6;
                [69.0 * p.sin(), 60.0 - 69.0 * p.cos(), 1.0]
            })
            .collect(),
        4.0,
    );
    let base = interior(colon.clone(), scope.clone(), 4, Method::Signed);
    let want = run(&base);
    assert!(want.len() > 20);
    let (ax, ang, shift) = ([0.48f32, 0.6, 0.64], 1.1f32, [5000.0f32, -3000.0, 4000.0]);
    let rot = |p: [f32; 3]| {
        // Rodrigues in f64, then rounded: the moved scene is as exact as f32 inputs can be.
        let (k, p64) = (ax.map(|v| v as f64), p.map(|v| v as f64));
        let (s, c) = (ang as f64).sin_cos();
        let kxp = [k[1] * p64[2] - k[2] * p64[1], k[2] * p64[0] - k[0] * p64[2], k[0] * p64[1] - k[1] * p64[0]];
        let kp = k[0] * p64[0] + k[1] * p64[1] + k[2] * p64[2];
        [0, 1, 2].map(|i| p64[i] * c + kxp[i] * s + k[i] * kp * (1.0 - c))
    };
    let moved_point = |p: [f32; 3]| {
        let r = rot(p);
        [0, 1, 2].map(|i| (r[i] + shift[i] as f64) as f32)
    };
    let moved_vec = |p: [f32; 3]| rot(p).map(|v| v as f32);
    let colon2 = Tube::new(colon.points.iter().map(|&p| moved_point(p)).collect(), colon.radial.iter().map(|&v| moved_vec(v)).collect(), colon.spokes).unwrap();
    let scope2 = rod(scope.points.iter().map(|&p| moved_point(p)).collect(), 4.0);
    for m in [Method::Signed, Method::Thesis] {
        let want = run(&interior(colon.clone(), scope.clone(), 4, m));
        let got = run(&interior(colon2.clone(), scope2.clone(), 4, m));
        assert_eq!(want.len(), got.len(), "{m:?}");
        for (a, b) in want.iter().zip(&got) {
            assert_eq!(a.sample, b.sample);
            assert!((a.depth - b.depth).abs() < 0.01 * 4.0, "{m:?}: {} vs {}", a.depth, b.depth);
            assert!(dot(moved_vec(a.normal), b.normal) > 0.999, "{m:?}");
        }
    }
}

#[test]
fn hard_uniform_scaling_mm_to_m() {
    let colon = arc(30, 80.0, PI / 2.0, 15.0, 16);
    let scope = rod(
        (0..10)
            .map(|i| {
                let p = 0.2 + 1.1 * i as f32 / 9.0;
                [91.0 * p.sin(), 80.0 - 91.0 * p.cos(), 2.0]
            })
            .collect(),
        5.0,
    );
    let scaled = |s: f32| {
        let t = Tube::new(colon.points.iter().map(|p| p.map(|v| v * s)).collect(), colon.radial.iter().map(|p| p.map(|v| v * s)).collect(), 16).unwrap();
        let r = rod(scope.points.iter().map(|p| p.map(|v| v * s)).collect(), 5.0 * s);
        (t, r)
    };
    for m in [Method::Signed, Method::Thesis] {
        let base = run(&interior(colon.clone(), scope.clone(), 4, m));
        assert!(base.len() > 10);
        // A power of two scales every operation exactly: bit-identical contacts, scaled.
        let (t, r) = scaled(1024.0);
        let big = run(&interior(t, r, 4, m));
        assert_eq!(base.len(), big.len());
        for (a, b) in base.iter().zip(&big) {
            assert_eq!(a.depth * 1024.0, b.depth, "{m:?}");
            assert_eq!(a.normal, b.normal);
            assert_eq!(a.point_b.map(|v| v * 1024.0), b.point_b);
        }
        // Millimetres to metres: the same contacts to f32 rounding.
        let (t, r) = scaled(1e-3);
        let small = run(&interior(t, r, 4, m));
        assert_eq!(base.len(), small.len());
        for (a, b) in base.iter().zip(&small) {
            assert!((a.depth * 1e-3 - b.depth).abs() < 1e-4 * 5e-3, "{m:?}: {} vs {}", a.depth * 1e-3, b.depth);
            assert!(dot(a.normal, b.normal) > 0.99999);
        }
    }
}

#[test]
fn hard_nan_or_inf_in_any_input() {
    let scene = interior(straight(10, 5.0, 10.0, 8), line([1.0, 7.0, 0.0], [40.0, 7.0, 0.0], 6, 4.0), 2, Method::Signed);
    let mut d = Detector::new(&scene.spec().validate().unwrap());
    let good = scene.state();
    let n_good = d.detect(&good).unwrap().len();
    assert!(n_good > 0);
    let stride = 9 * 3;
    let cases: [(usize, f32, &str); 4] = [
        (7 * stride + (1 + 3) * 3 + 1, f32::NAN, "body \"colon\": radial vector 3 of ring 7"),
        (2 * stride, f32::INFINITY, "body \"colon\": control point 2"),
        (10 * stride + 4 * 3 + 2, f32::NEG_INFINITY, "body \"scope\": control point 4"),
        (10 * stride, f32::NAN, "body \"scope\": control point 0"),
    ];
    for (i, v, msg) in cases {
        let mut bad = good.clone();
        bad[i] = v;
        let e = d.detect(&bad).unwrap_err();
        assert!(e.to_string().starts_with(msg), "{e}");
        // Nothing is lost: the next good frame works and history continues.
        assert_eq!(d.detect(&good).unwrap().len(), n_good);
        assert_eq!(d.stats().reacquired, 0);
    }
    assert_eq!(d.detect(&good[1..]).unwrap_err(), InputError::StateLength { expected: good.len(), got: good.len() - 1 });
}

#[test]
fn hard_counts_beyond_limits() {
    let body = |shape| BodySpec { name: "colon".into(), shape };
    let rod = BodySpec { name: "scope".into(), shape: Shape::Rod { points: 4, radius: vec![1.0] } };
    let pair = vec![PairSpec { a: "scope".into(), b: "colon".into(), kind: ContactKind::Interior }];
    let spec = |shape| SceneSpec::new(vec![body(shape), rod.clone()], pair.clone());
    let err = |s: SceneSpec| s.validate().expect_err("rejected");
    assert!(matches!(err(spec(Shape::Tube { rings: 65_537, spokes: 8 })), SpecError::PointCount { count: 65_537, .. }));
    assert!(matches!(err(spec(Shape::Tube { rings: 1, spokes: 8 })), SpecError::PointCount { count: 1, .. }));
    assert!(matches!(err(spec(Shape::Tube { rings: 10, spokes: 257 })), SpecError::SpokeCount { count: 257, .. }));
    assert!(matches!(err(spec(Shape::Tube { rings: 10, spokes: 2 })), SpecError::SpokeCount { count: 2, .. }));
    let mut s = spec(Shape::Tube { rings: 10, spokes: 8 });
    s.precision = 1000;
    assert_eq!(err(s), SpecError::Precision(1000));
    // The largest legal tube works end to end.
    let t = straight(65_536, 0.01, 1.0, 3);
    let cs = run(&interior(t, line([1.0, 0.6, 0.0], [2.0, 0.6, 0.0], 2, 0.2), 1, Method::Signed));
    assert_eq!(cs.len(), 2);
}

#[test]
fn hard_self_contact_of_a_loop() {
    // A rod of radius 1 forming a loop whose way out passes about 1.5 above its way in: contacts
    // where the branches cross, none between neighbouring samples.
    let r = 1.0;
    let mut pts: Vec<[f32; 3]> = (0..8).map(|i| [i as f32 * 2.0, 0.0, 0.0]).collect();
    for i in 0..=12 {
        let a = i as f32 * TAU / 12.0;
        pts.push([14.0 + 6.0 * a.sin(), 6.0 - 6.0 * a.cos(), 1.5 * i as f32 / 12.0]);
    }
    pts.extend((1..6).map(|i| [14.0 + i as f32 * 2.0, 0.0, 1.5]));
    let n_pts = pts.len();
    // Brute-force reference on the same spline, 64 points per segment: the closest approach
    // of two points further apart along the rod than pi r.
    let dense: Vec<[f32; 3]> = (0..n_pts - 1)
        .flat_map(|j| {
            let c = lumen_detect::spline::Cubic::of_chain(|i| lumen_detect::V3::from(pts[i]), n_pts, j, 0.5);
            (0..64).map(move |m| c.at(m as f32 / 64.0).into())
        })
        .collect();
    let mut arc = vec![0.0f32];
    for w in dense.windows(2) {
        arc.push(arc.last().unwrap() + norm(sub(w[1], w[0])));
    }
    let mut dmin = f32::INFINITY;
    for i in 0..dense.len() {
        for j in i + 1..dense.len() {
            if arc[j] - arc[i] > PI * r {
                dmin = dmin.min(norm(sub(dense[i], dense[j])));
            }
        }
    }
    assert!((1.3..1.5).contains(&dmin), "the branches pass about 1.5 apart: {dmin}");
    let scene = Scene::new().rod("scope", rod(pts, r)).pair("scope", "scope", ContactKind::SelfContact).precision(4);
    let cs = run(&scene);
    let deepest = cs.iter().map(|c| c.depth).fold(f32::MIN, f32::max);
    assert!((deepest - (2.0 * r - dmin)).abs() < 0.01, "deepest {deepest}, reference {}", 2.0 * r - dmin);
    let last = ((n_pts - 1) * 4) as u32;
    assert!(cs.iter().any(|c| c.sample < 7 * 4 + 2) && cs.iter().any(|c| c.sample > last - 5 * 4 - 2), "both branches");
    for c in &cs {
        assert!(c.depth <= deepest && c.depth > 0.0, "depth {}", c.depth);
        assert!(c.normal[2].abs() > 0.7, "normal across the crossing: {:?}", c.normal);
        assert_eq!(c.kind, ContactKind::SelfContact as u8);
        let s = c.sample as usize;
        // The loop's far side (points 11 to 17, 6 or more from the crossing) touches nothing.
        assert!(!(11 * 4..=17 * 4).contains(&s), "sample {s} is not at the crossing");
    }
    // Without the loop (a straight rod bent gently) nothing touches itself.
    let straight_rod = Scene::new().rod("scope", line([0.0, 0.0, 0.0], [50.0, 0.0, 0.0], 25, r)).pair("scope", "scope", ContactKind::SelfContact);
    assert!(run(&straight_rod).is_empty());
}

#[test]
fn hard_rod_against_rod_and_tube_exterior() {
    // Two parallel rods 3 apart with radii 1 and 2.5: depth 0.5, normal from a to b.
    let a = line([0.0, 0.0, 0.0], [20.0, 0.0, 0.0], 5, 1.0);
    let b = line([-5.0, 3.0, 0.0], [25.0, 3.0, 0.0], 7, 2.5);
    let scene = Scene::new().rod("a", a).rod("b", b).pair("a", "b", ContactKind::Exterior).precision(2);
    let cs = run(&scene);
    assert_eq!(cs.len(), 9);
    for c in &cs {
        assert!((c.depth - 0.5).abs() < 1e-5 && (c.normal[1] - 1.0).abs() < 1e-6, "{c:?}");
        assert!((c.weights_b[0] + c.weights_b[1] - 1.0).abs() < 1e-6);
    }
    // A rod lying on the outside of a tube: depth r - (rho - R) toward the tube (normal -y).
    let colon = straight(10, 5.0, 10.0, 16);
    let scope = line([5.0, 12.0, 0.0], [40.0, 12.0, 0.0], 6, 3.0);
    let scene = Scene::new().tube("colon", colon).rod("scope", scope).pair("scope", "colon", ContactKind::Exterior).precision(2);
    let cs = run(&scene);
    assert_eq!(cs.len(), 11);
    for c in &cs {
        assert!((c.depth - 1.0).abs() < 1e-4 && c.normal[1] < -0.9999, "{c:?}");
        assert_eq!(c.kind, ContactKind::Exterior as u8);
    }
}

#[test]
fn hard_only_declared_pairs_are_computed() {
    let colon = straight(10, 5.0, 10.0, 16);
    let scope = line([5.0, 30.0, 0.0], [40.0, 30.0, 0.0], 6, 3.0);
    let scene = Scene::new().tube("colon", colon).rod("scope", scope).pair("scope", "scope", ContactKind::SelfContact);
    let mut d = Detector::new(&scene.spec().validate().unwrap());
    assert!(d.detect(&scene.state()).unwrap().is_empty(), "the rod is far outside, but interior was not declared");
    assert_eq!(d.stats().walked + d.stats().reacquired, 0, "and no tube work was done");
}

#[test]
fn hard_fold_crest_across_the_strips_is_never_missed() {
    // A haustral fold whose crest runs obliquely across the strips, as where ring planes are
    // tilted against a fold: spoke k is 53 long up to ring 15 + |k - 24| and 39 from there on
    // (48 spokes, rings 1 apart). Every spoke's tip is a point of the wall, so no sample's
    // nearest wall is farther than its nearest tip: a sample within the rod's radius of a tip
    // overlaps the wall at least that much, and must be reported at least that deep. Rods run
    // along the tube at several angles and distances from the axis, past the crest.
    let (rings, spokes) = (60, 48);
    let crest = |k: usize| 15 + k.abs_diff(24);
    let colon = along_x(rings, spokes, |i, k, (c, s)| {
        let r = if i < crest(k) { 53.0 } else { 39.0 };
        (r * c, r * s)
    });
    let tips: Vec<V> = (0..rings).flat_map(|i| (0..spokes).map(move |k| (i, k))).map(|(i, k)| add(colon.points[i], colon.spoke(i, k))).collect();
    let (r, x) = (6.5, 4u32);
    // Checks sample `s` at `p` against the nearest tip; whether it overlapped one.
    let check = |cs: &[lumen_detect::Contact], s: usize, p: V, what: &str| {
        let near = tips.iter().map(|&t| norm(sub(t, p))).fold(f32::INFINITY, f32::min);
        let overlap = r - near;
        if overlap < 0.05 {
            return false;
        }
        let got = cs.iter().filter(|c| c.sample as usize == s).map(|c| c.depth).fold(f32::NEG_INFINITY, f32::max);
        assert!(got >= overlap - 1e-3, "{what}, sample {s} at {p:?}: a tip {near:.4} away (overlap {overlap:.4}), reported {got}");
        true
    };
    let mut deep = 0;
    for step in 0..24 {
        let a = (16.0 + step as f32 * 0.75) * TAU / spokes as f32;
        for rho in [31.0f32, 33.5, 36.0] {
            let (y, z) = (rho * a.cos(), rho * a.sin());
            let cs = run(&interior(colon.clone(), line([1.0, y, z], [57.0, y, z], 57, r), x, Method::Signed));
            assert_finite(&cs);
            let what = format!("angle {:.2} spokes, {rho} from the axis", a * spokes as f32 / TAU);
            deep += (0..56 * x as usize + 1).filter(|&s| check(&cs, s, [1.0 + s as f32 / x as f32, y, z], &what)).count();
        }
    }
    assert!(deep > 100, "only {deep} samples overlap a tip");
    // The same for the rod's end, which reads other walls around it: rods that stop in front of
    // the crest.
    let mut ends = 0;
    for step in 0..32 {
        let a = (14.0 + step as f32 * 0.625) * TAU / spokes as f32;
        for rho in [30.0f32, 33.5, 36.0] {
            for stop in [10.0f32, 11.5, 13.0] {
                let (y, z) = (rho * a.cos(), rho * a.sin());
                let cs = run(&interior(colon.clone(), line([stop - 12.0, y, z], [stop, y, z], 13, r), x, Method::Signed));
                assert_finite(&cs);
                ends += check(&cs, 12 * x as usize, [stop, y, z], &format!("the rod's end, angle {:.2} spokes", a * spokes as f32 / TAU)) as usize;
            }
        }
    }
    assert!(ends > 20, "only {ends} rod ends overlap a tip");
}

#[test]
fn hard_slit_whose_far_wall_runs_down_along_the_tube() {
    // A slit: a lumen 40 wide, its floor 7 below the midline, its ceiling 7.5 above up to ring
    // 50 and from there running down along the tube at 45 degrees to 2 above at ring 55.5
    // (rings 1 apart, 32 spokes). A rod of radius 6.5 along the slit, 0.5 below the midline:
    // its section's nearest wall is the floor, 6.5 away, and the ceiling in the section is
    // farther, but ahead along the tube the ramp comes nearer: a sample at x up to 55 overlaps
    // it by `6.5 - (58 - x) / sqrt(2)`, and must be reported that deep. No ring seed about the
    // floor's strips lies on the ceiling; the section sees it across the lumen.
    let colon = slit(|i| (7.5 - (i as f32 - 50.0).max(0.0)).max(2.0));
    let (r, x) = (6.5, 4u32);
    // The margin of a physics client (2, as `lumen sim`'s): walls within it are reported too.
    let mut scene = interior(colon, line([30.0, 0.0, -0.5], [70.0, 0.0, -0.5], 41, r), x, Method::Signed);
    scene.margin = 2.0;
    let cs = run(&scene);
    assert_finite(&cs);
    let mut checked = 0;
    for s in 0..40 * x as usize + 1 {
        let px = 30.0 + s as f32 / x as f32;
        let ramp = (58.0 - px) / 2f32.sqrt();
        // Where the sample's own section crosses the ramp (x past 50) and the ramp's nearest
        // point lies on it: the section sees the ceiling across the lumen, and a descent from
        // there runs down the ramp. (Short of x = 50 the section's ceiling is the flat part, a
        // minimum of its own the ramp's basin does not reach: the next test, from the neighbours'
        // walls.)
        let foot = 0.5 * (px + 58.0);
        if px <= 50.0 || px > 55.0 || foot > 55.0 || r - ramp < 0.05 {
            continue;
        }
        let want = r - ramp;
        let got = cs.iter().filter(|c| c.sample as usize == s).map(|c| c.depth).fold(f32::NEG_INFINITY, f32::max);
        assert!(got >= want - 0.05, "sample {s} at x {px}: the ramp {ramp:.3} away (overlap {want:.3}), reported {got}");
        checked += 1;
    }
    assert!(checked >= 8, "only {checked} samples checked");
}

#[test]
fn hard_slits_with_a_ramp_at_any_angle_ahead_of_or_behind_the_samples() {
    // The class of the slit above: a lumen 40 wide, its floor 7 below the midline, its ceiling
    // flat at `h` above it up to ring 50, then a ramp down at `angle` to 2 above (rings 1 apart,
    // 32 spokes), the rod (radius 6.5, `z` below the midline) along it either way. Every sample
    // the ramp overlaps by more than 0.05, its nearest ramp point a ring or more from both kinks
    // (the spline rounds them), is reported at least that deep less 0.05: also the samples
    // short of the ramp, whose own section's ceiling is the flat part (a minimum of its own).
    let (r, x) = (6.5, 4u32);
    let (mut checked, mut before, mut misses) = (0, 0, Vec::new());
    for angle in [30.0f32, 45.0, 60.0] {
        let (sin, cos) = angle.to_radians().sin_cos();
        for h in [7.5f32, 8.0] {
            let end = 50.0 + (h - 2.0) * cos / sin;
            let colon = slit(|i| (h - (i as f32 - 50.0).max(0.0) * sin / cos).max(2.0));
            // The ramp: the points with `x sin + z cos = 50 sin + h cos`, the lumen below it.
            let plane = 50.0 * sin + h * cos;
            for z in [-0.5f32, 0.0] {
                for forward in [true, false] {
                    let (a, b) = if forward { (30.0, 70.0) } else { (70.0, 30.0) };
                    let mut scene = interior(colon.clone(), line([a, 0.0, z], [b, 0.0, z], 41, r), x, Method::Signed);
                    scene.margin = 2.0;
                    let cs = run(&scene);
                    assert_finite(&cs);
                    for s in 0..40 * x as usize + 1 {
                        let px = a + (b - a) * s as f32 / (40 * x) as f32;
                        let dist = plane - (px * sin + z * cos);
                        let foot = px + dist * sin;
                        let want = r - dist;
                        if foot < 51.0 || foot > end - 1.0 || want < 0.05 {
                            continue;
                        }
                        let got = cs.iter().filter(|c| c.sample as usize == s).map(|c| c.depth).fold(f32::NEG_INFINITY, f32::max);
                        if got < want - 0.05 {
                            let way = if forward { "forward" } else { "backward" };
                            misses.push(format!("ramp at {angle} deg, ceiling {h}, rod at z {z} {way}: sample {s} at x {px}: the ramp {dist:.3} away (overlap {want:.3}), reported {got}"));
                        }
                        checked += 1;
                        before += (px <= 50.0) as usize;
                    }
                }
            }
        }
    }
    assert!(misses.is_empty(), "{} of {checked} samples read shallow:\n{}", misses.len(), misses.join("\n"));
    assert!(checked >= 100 && before >= 10, "only {checked} samples checked, {before} short of the ramp");
}

#[test]
fn hard_a_wall_that_passes_over_itself_a_little() {
    // A straight tube of radius 10 whose ring 10 is swept back by `back` (its tips 1 to 1.25
    // behind its own plane, past ring 9's) and in by `inward`: the wall folds into a thin flap
    // pointing back, and near it a sample's section says inside while the nearest wall point
    // faces it from behind. Any wall point bounds the distance to the wall, whichever way it
    // faces: every sample of a rod of radius 2 run along the flap, within the margin of the
    // wall, is read at least as deep as the nearest spoke tip (a wall point) says.
    let spokes = 32;
    let (r, x) = (2.0, 4u32);
    let (mut checked, mut misses) = (0, Vec::new());
    for back in [1.0f32, 1.25] {
        for inward in [0.5f32, 0.75, 1.0] {
            let colon = tube(
                30,
                spokes,
                |i| [i as f32, 0.0, 0.0],
                |i, k| {
                    let a = k as f32 * TAU / spokes as f32;
                    let (rad, dx) = if i == 10 { (10.0 - inward, -back) } else { (10.0, 0.0) };
                    [dx, rad * a.cos(), rad * a.sin()]
                },
            );
            let tips: Vec<V> = (0..30).flat_map(|i| (0..spokes).map(move |k| (i, k))).map(|(i, k)| add(colon.points[i], colon.spoke(i, k))).collect();
            for rho in [6.0f32, 6.5, 7.0, 7.5, 8.0, 8.5] {
                // The margin of a physics client (2, as `lumen sim`'s).
                let mut scene = interior(colon.clone(), line([2.0, rho, 0.3], [20.0, rho, 0.3], 19, r), x, Method::Signed);
                scene.margin = 2.0;
                let cs = run(&scene);
                assert_finite(&cs);
                for s in 0..18 * x as usize + 1 {
                    let p = [2.0 + s as f32 / x as f32, rho, 0.3];
                    let near = tips.iter().map(|&t| norm(sub(t, p))).fold(f32::INFINITY, f32::min);
                    if r - near <= 0.01 {
                        continue;
                    }
                    checked += 1;
                    let got = cs.iter().filter(|c| c.sample as usize == s).map(|c| c.depth).fold(f32::NEG_INFINITY, f32::max);
                    if got < r - near - 1e-3 {
                        misses.push(format!("back {back}, in {inward}, sample at {p:?}: a tip {near:.3} away, reported depth {got}"));
                    }
                }
            }
        }
    }
    assert!(misses.is_empty(), "{} of {checked} samples read shallower than a tip:\n{}", misses.len(), misses.join("\n"));
    assert!(checked >= 100, "only {checked} samples near a tip");
}

#[test]
fn hard_a_scope_outside_a_narrow_canal_beside_which_a_wide_loop_passes() {
    // A canal of radius 3 along +z from the origin (40 rings 1 apart), a U-turn of radius 50
    // in the x-z plane widening to 40, and a wide loop running back down past the canal's start
    // (x = -100, to z = -200). A scope of radius 6.5 comes up from z = -300 at x = 5 into the
    // canal, 5 off its axis: its centre lies 2 outside the canal's wall, and each sample there
    // must be read against the canal (depth about 6.5 + 2), not against the loop 65 away that
    // the samples outside the body beside it are read against.
    let (spokes, canal, arc) = (32, 40usize, 157usize);
    let rings = canal + arc + 240;
    let place = move |i: usize| -> (V, V, f32) {
        // (centre, the section's first axis e1, lumen radius); e2 is +y throughout.
        if i < canal {
            ([0.0, 0.0, i as f32], [1.0, 0.0, 0.0], 3.0)
        } else if i < canal + arc {
            let th = PI * (i - canal) as f32 / arc as f32;
            let (s, c) = th.sin_cos();
            ([-50.0 + 50.0 * c, 0.0, 40.0 + 50.0 * s], [c, 0.0, s], 3.0 + 37.0 * th / PI)
        } else {
            ([-100.0, 0.0, 40.0 - (i - canal - arc) as f32], [-1.0, 0.0, 0.0], 40.0)
        }
    };
    let colon = tube(
        rings,
        spokes,
        |i| place(i).0,
        |i, k| {
            let (_, e1, r) = place(i);
            let a = k as f32 * TAU / spokes as f32;
            [r * a.cos() * e1[0], r * a.sin(), r * a.cos() * e1[2]]
        },
    );
    let (r, x) = (6.5f32, 4u32);
    let mut scene = interior(colon, line([5.0, 0.0, -300.0], [5.0, 0.0, 30.0], 34, r), x, Method::Signed);
    scene.margin = 2.0;
    let cs = run(&scene);
    assert_finite(&cs);
    let n = 33 * x as usize;
    let mut checked = 0;
    for s in 0..=n {
        let z = -300.0 + 330.0 * s as f32 / n as f32;
        if !(2.0..=28.0).contains(&z) {
            continue;
        }
        let depth = cs.iter().filter(|c| c.sample as usize == s).map(|c| c.depth).fold(f32::NEG_INFINITY, f32::max);
        assert!((depth - 8.5).abs() < 0.3, "sample {s} at z {z}: depth {depth}, the canal's wall 2 inside it (about 8.5)");
        checked += 1;
    }
    assert!(checked >= 10, "only {checked} samples in the canal");
}

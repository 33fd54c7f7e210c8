//! The default method on shapes with exact answers.

mod common;
use common::*;
use lumen_detect::proto::contact::FLAG_OUTSIDE;
use lumen_detect::{Detector, Method};
use std::f32::consts::PI;

#[test]
fn straight_tube_depth_normal_and_weights_are_exact() {
    // Rod at height y = 5 in a tube of radius 10, along spoke 0 (+y). The section is a
    // 32-gon: the nearest wall point lies on an edge next to the spoke, whose line is
    // 10 cos(pi/32) from the axis, so the distance is (10 - 5) cos(pi/32).
    let scene = interior(straight(11, 5.0, 10.0, 32), line([5.0, 5.0, 0.0], [45.0, 5.0, 0.0], 5, 6.0), 2, Method::Signed);
    let cs = run(&scene);
    assert_eq!(cs.len(), 9, "every sample touches");
    let h = (PI / 32.0).cos();
    for c in &cs {
        assert!((c.depth - (6.0 - 5.0 * h)).abs() < 1e-4, "depth {}", c.depth);
        // Normal of edge 0 or edge 31: (0, cos, +-sin) of pi/32.
        assert!((c.normal[1] - h).abs() < 1e-5 && (c.normal[2].abs() - (PI / 32.0).sin()).abs() < 1e-5, "normal {:?}", c.normal);
        assert!((dot(sub(c.point_b, [c.point_b[0], 5.0, 0.0]), c.normal) - 5.0 * h).abs() < 1e-4);
        assert!((c.weights_b.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        assert_eq!(c.flags & FLAG_OUTSIDE, 0);
    }
    // Ordered by sample; ring index follows x. The first sample lies on ring 1's plane
    // exactly: the lower of the two segments it divides answers, at its end.
    assert!(cs.windows(2).all(|w| w[0].sample < w[1].sample));
    assert_eq!(cs[0].index_b, 0);
    assert!((cs[0].param_b - 1.0).abs() < 1e-5);
}

#[test]
fn mid_sector_uses_the_chord_not_the_circle() {
    // Between two spokes the wall is the straight edge: at angle pi/B its distance from the
    // axis is R cos(pi/B).
    let b = 16;
    let a = PI / b as f32;
    let y = 4.0 * a.cos();
    let z = 4.0 * a.sin();
    let scene = interior(straight(6, 5.0, 10.0, b), line([2.0, y, z], [22.0, y, z], 3, 6.5), 1, Method::Signed);
    let cs = run(&scene);
    let want = 6.5 - (10.0 * a.cos() - 4.0);
    assert_eq!(cs.len(), 3);
    for c in &cs {
        assert!((c.depth - want).abs() < 1e-4, "depth {} want {want}", c.depth);
    }
}

#[test]
fn outside_samples_stay_contacts_with_the_wall_normal() {
    let scene = interior(straight(11, 5.0, 10.0, 32), line([5.0, 14.0, 0.0], [45.0, 14.0, 0.0], 5, 3.0), 1, Method::Signed);
    let cs = run(&scene);
    assert_eq!(cs.len(), 5);
    // Outside a convex corner the nearest wall point is the corner itself: 4 away.
    for c in &cs {
        assert!((c.depth - 7.0).abs() < 1e-4, "depth {}", c.depth);
        assert!((c.normal[1] - 1.0).abs() < 1e-5, "normal {:?}", c.normal);
        assert!((c.point_b[1] - 10.0).abs() < 1e-4 && c.point_b[2].abs() < 1e-4);
        assert_ne!(c.flags & FLAG_OUTSIDE, 0);
    }
    // The published method loses them: no contacts at all.
    let thesis = run(&interior(straight(11, 5.0, 10.0, 32), line([5.0, 14.0, 0.0], [45.0, 14.0, 0.0], 5, 3.0), 1, Method::Thesis));
    assert!(thesis.is_empty(), "{thesis:?}");
}

#[test]
fn thesis_agrees_inside_where_the_published_method_works() {
    let mk = |m| interior(straight(11, 5.0, 10.0, 32), line([5.0, 5.0, 0.0], [45.0, 5.0, 0.0], 5, 6.0), 2, m);
    let a = run(&mk(Method::Signed));
    let b = run(&mk(Method::Thesis));
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.sample, y.sample);
        assert!((x.depth - y.depth).abs() < 1e-4);
        assert!((x.normal[1] - y.normal[1]).abs() < 1e-4);
    }
}

#[test]
fn bend_outer_wall_depth_matches_the_torus() {
    // Quarter bend, centreline radius 100, tube radius 20; rod on the outer side at 15 from the
    // midline: wall distance 5 (up to the polygon's sagitta at a spoke: none, spoke 2 of 8 is
    // the bend plane's outward direction? use many spokes and compare within the sagitta).
    let b = 64;
    let colon = arc(60, 100.0, PI / 2.0, 20.0, b);
    let phi = |t: f32| t * PI / 2.0;
    let pts: Vec<V> = (0..9)
        .map(|i| {
            let p = phi(0.2 + 0.6 * i as f32 / 8.0);
            let rr = 100.0 + 15.0; // outer side: away from the bend centre (0, 100)
            [rr * p.sin(), 100.0 - rr * p.cos(), 0.0]
        })
        .collect();
    let scene = interior(colon, rod(pts, 6.0), 4, Method::Signed);
    let cs = run(&scene);
    assert!(cs.len() >= 30, "{}", cs.len());
    for c in &cs {
        // The rod is a spline through points on the circle of radius 115: within 0.05 of it.
        // The rod's spline sags off the circle near its ends: measure from where it is.
        let p = sample_point(&scene, c);
        let rho = norm([p[0], p[1] - 100.0, p[2]]);
        assert!((rho - 115.0).abs() < 0.2, "rho {rho}");
        let want = 6.0 - (120.0 - rho) * (PI / b as f32).cos();
        assert!((c.depth - want).abs() < 2e-3, "sample {}: depth {} want {want}", c.sample, c.depth);
        let radial = [p[0], p[1] - 100.0, 0.0];
        let n = scale(radial, 1.0 / norm(radial));
        // Inside, next to spoke 32 (the outward direction): the nearest wall is one of the two
        // adjacent strips, whose normals lean pi/64 off the radial direction.
        assert!((dot(n, c.normal) - (PI / 64.0).cos()).abs() < 2e-3, "normal {:?} vs {:?}", c.normal, n);
    }
}

/// A 9-point scope of radius 6.5, 15 mm off the axis of a straight colon, slid `f` mm along it.
fn slid(colon: &lumen_detect::Tube, f: usize) -> lumen_detect::Scene {
    let x0 = 20.0 + f as f32;
    interior(colon.clone(), line([x0, 15.0, 0.0], [x0 + 40.0, 15.0, 0.0], 9, 6.5), 4, Method::Signed)
}

#[test]
fn coherence_walks_instead_of_reacquiring() {
    let colon = straight(200, 1.0, 20.0, 32);
    let mut d = Detector::new(&slid(&colon, 0).spec().validate().unwrap());
    for f in 0..50 {
        let n = d.detect(&slid(&colon, f).state()).unwrap().len();
        assert_eq!(n, 33);
        let st = d.stats();
        if f == 0 {
            assert_eq!(st.reacquired, 1, "first frame: one BVH query seeds the walk");
        } else {
            assert_eq!((st.reacquired, st.walked), (0, 33), "frame {f}");
        }
    }
}

#[test]
fn the_frame_walks_the_tube_once_along_the_rod() {
    // Rings every 0.25 mm and a 40 mm scope sliding 1 mm per frame. The first sample walks the
    // 4 planes it moved; every other one starts where the sample before it ended (as a session
    // without history does), so a frame crosses the 160 planes the scope spans once, not a
    // walk per sample from anywhere.
    let colon = straight(801, 0.25, 20.0, 32);
    let mut d = Detector::new(&slid(&colon, 0).spec().validate().unwrap());
    for f in 0..20 {
        assert_eq!(d.detect(&slid(&colon, f).state()).unwrap().len(), 33);
        let st = d.stats();
        if f > 0 {
            assert_eq!((st.reacquired, st.walked), (0, 33), "frame {f}");
            assert!((160..=168).contains(&st.planes), "frame {f}: {} planes crossed by 33 samples", st.planes);
        }
    }
}

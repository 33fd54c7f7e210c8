//! Tubes that bend tighter than they are wide: neighbouring ring planes cross inside the lumen,
//! so a point can lie between the planes of several segments. The lumen is the union of the
//! sections; a sample reported outside the wall must be outside every section whose planes
//! bracket it.

mod common;
use common::*;
use lumen_detect::section::{Axial, TubeCache};
use lumen_detect::view::TubeView;
use lumen_detect::{Detector, Method, V3};
use std::f32::consts::{FRAC_1_SQRT_2, TAU};

#[test]
fn a_sample_reported_outside_is_outside_every_section_that_brackets_it() {
    // The midline turns 90 degrees at one control point (rings every 4 mm, radius 10, 24
    // spokes): the spline rounds the corner tighter than the tube is wide, so ring planes cross
    // inside the lumen around the inner corner at (30, 10).
    let centre = |i: usize| if i <= 10 { [i as f32 * 4.0, 0.0, 0.0] } else { [40.0, (i - 10) as f32 * 4.0, 0.0] };
    let colon = tube(21, 24, centre, |i, k| {
        let a = k as f32 * TAU / 24.0;
        let t: [f32; 3] = if i < 10 {
            [1.0, 0.0, 0.0]
        } else if i > 10 {
            [0.0, 1.0, 0.0]
        } else {
            [FRAC_1_SQRT_2, FRAC_1_SQRT_2, 0.0]
        };
        add(scale([-t[1], t[0], 0.0], 10.0 * a.cos()), scale([0.0, 0.0, 1.0], 10.0 * a.sin()))
    });
    let mut data = Vec::new();
    colon.write_state(&mut data);
    let t = TubeView::new(&data, colon.rings(), 24, V3::zeros());
    let mut cache = TubeCache::default();
    cache.begin(colon.rings(), 0.5);
    // Rods along x across the corner region, at every height y and a few z, sampled at their
    // control points; a detector per rod, so every sample starts from a fresh walk.
    let (mut checked, mut outside) = (0, 0);
    for j in 0..29 {
        let (y, z) = (-8.0 + j as f32, [-4.0, 0.0, 4.0][j % 3]);
        let pts: Vec<[f32; 3]> = (0..15).map(|i| [20.0 + 2.0 * i as f32, y, z]).collect();
        let scope = rod(pts, 0.5);
        let scene = interior(colon.clone(), scope, 1, Method::Signed);
        let mut d = Detector::new(&scene.spec().validate().unwrap());
        for c in d.detect(&scene.state()).unwrap() {
            // The sample: the rod's surface point less the radius along the normal.
            let p = V3::from(c.point_a) - V3::from(c.normal) * 0.5;
            // The most-inside reading over every segment whose planes bracket the point.
            let mut union = f32::INFINITY;
            for i in 0..t.segments() {
                if let Axial::In { seg, u } = cache.axial(&t, &p, i, 0) {
                    union = union.min(cache.gap(&t, &p, seg, u, None, 0).sd);
                }
            }
            let sd = c.depth - 0.5;
            checked += 1;
            if sd > 0.0 {
                outside += 1;
                assert!(union > 0.0, "sample at {p:?} reported {sd:.3} mm outside, but a bracketing section holds it ({union:.3} mm)");
            }
            // Never deeper inside than the union says: the reading is one of the union's.
            assert!(sd >= union - 1e-3, "sample at {p:?}: {sd:.3} mm, union {union:.3} mm");
        }
    }
    eprintln!("{checked} contacts checked, {outside} outside");
    assert!(checked > 80 && outside > 10, "{checked} contacts, {outside} outside: the sweep must reach the wall");
}

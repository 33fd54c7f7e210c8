use super::*;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

const R: f64 = 10.0;
const B: usize = 64;

/// Straight tube along +x: `rings` rings 10 apart, a regular `B`-gon of circumradius `R`,
/// spokes counter-clockwise about +x (`ccw`) or clockwise.
fn straight(rings: usize, ccw: bool, offset: [f32; 3]) -> Tube {
    let s = if ccw { 1.0 } else { -1.0 };
    let points = (0..rings).map(|i| [offset[0] + 10.0 * i as f32, offset[1], offset[2]]).collect();
    let ring: Vec<[f32; 3]> = (0..B)
        .map(|k| {
            let a = s * TAU * k as f64 / B as f64;
            [0.0, (R * a.cos()) as f32, (R * a.sin()) as f32]
        })
        .collect();
    let radial = (0..rings).flat_map(|_| ring.iter().copied()).collect();
    Tube::new(points, radial, B).unwrap()
}

/// Signed distance in the (y, z) plane to the polygon of the tube's first ring (`f32` tips, so
/// exactly the polygon the tube has): negative inside.
fn polygon_sd(t: &Tube, y: f64, z: f64) -> f64 {
    let v: Vec<(f64, f64)> = (0..t.spokes).map(|k| (t.spoke(0, k)[1] as f64, t.spoke(0, k)[2] as f64)).collect();
    let mut d = f64::MAX;
    let mut crossings = 0;
    for k in 0..v.len() {
        let (a, b) = (v[k], v[(k + 1) % v.len()]);
        let (ex, ey) = (b.0 - a.0, b.1 - a.1);
        let w = (((y - a.0) * ex + (z - a.1) * ey) / (ex * ex + ey * ey)).clamp(0.0, 1.0);
        d = d.min((y - a.0 - w * ex).hypot(z - a.1 - w * ey));
        if (a.1 > z) != (b.1 > z) && y < a.0 + (z - a.1) / (b.1 - a.1) * ex {
            crossings += 1;
        }
    }
    if crossings % 2 == 1 {
        -d
    } else {
        d
    }
}

fn dist(a: [f32; 3], b: [f32; 3]) -> f64 {
    norm(sub(to64(a), to64(b)))
}

#[test]
fn straight_tube_is_the_polygon_prism() {
    let half = PI / B as f64;
    let apothem = R * half.cos();
    for ccw in [true, false] {
        let t = straight(6, ccw, [0.0; 3]);
        let r = Reference::new(&t, 0.5, 4);
        // Straight midline, identical rings: the tessellation is the continuous surface.
        assert!(r.bound() < 1e-5, "bound {}", r.bound());
        for x in [15.0, 22.5, 25.0, 31.25] {
            for j in 0..(4 * B) {
                // Every quarter sector: vertex angles (j % 4 == 0), mid-edge angles (== 2).
                let a = TAU * j as f64 / (4 * B) as f64;
                for rho in [0.0, 2.0, 7.0, 9.9, 10.0, 10.5, 14.0, 20.0] {
                    let (y, z) = (rho * a.cos(), rho * a.sin());
                    let p = [x as f32, y as f32, z as f32];
                    let q = r.query(p);
                    let want = polygon_sd(&t, y, z);
                    assert!((q.sd as f64 - want).abs() < 1e-4, "ccw {ccw} {p:?}: sd {} vs polygon {want}", q.sd);
                    // The polygon's sagitta is the only difference from the circle.
                    assert!((q.sd as f64 - (rho - R)).abs() <= R - apothem + 1e-4);
                    if j % 4 == 2 {
                        assert!((q.sd as f64 - (rho - apothem)).abs() < 1e-4);
                    } else if j % 4 == 0 && rho > R {
                        assert!((q.sd as f64 - (rho - R)).abs() < 1e-4);
                    } else if j % 4 == 0 {
                        assert!((q.sd as f64 - (rho - R) * half.cos()).abs() < 1e-4);
                    }
                    assert!((dist(q.point, p) - q.sd.abs() as f64).abs() < 1e-4);
                    let pr = (q.point[1] as f64).hypot(q.point[2] as f64);
                    assert!(pr > apothem - 1e-4 && pr < R + 1e-4, "wall point off the wall: {pr}");
                    assert_eq!(r.inside(p), q.sd < 0.0);
                    // Outward normals: radial up to the polygon's half angle, exactly radial
                    // across the middle of an edge.
                    let n = to64(q.normal);
                    assert!((norm(n) - 1.0).abs() < 1e-6);
                    assert!(n[0].abs() < 1e-6);
                    let radial = [0.0, a.cos(), a.sin()];
                    if rho > 0.0 {
                        assert!(dot(n, radial) >= (half + 1e-4).cos(), "{p:?}: normal {n:?}");
                    }
                    if j % 4 == 2 && rho > 0.0 {
                        assert!(dot(n, radial) > 1.0 - 1e-6, "{p:?}: normal {n:?}");
                    }
                }
            }
        }
    }
}

#[test]
fn spoke_order_does_not_matter() {
    let (a, b) = (straight(6, true, [0.0; 3]), straight(6, false, [0.0; 3]));
    let (ra, rb) = (Reference::new(&a, 0.5, 2), Reference::new(&b, 0.5, 2));
    for p in [[25.0, 3.0, -4.0], [12.0, 11.0, 1.0], [-3.0, 0.5, 0.5], [49.0, -9.5, 0.2], [52.0, 20.0, 0.0]] {
        let (qa, qb) = (ra.query(p), rb.query(p));
        assert!((qa.sd - qb.sd).abs() < 1e-5, "{p:?}: {} vs {}", qa.sd, qb.sd);
        assert!(dist(qa.normal, qb.normal) < 1e-5, "{p:?}: {:?} vs {:?}", qa.normal, qb.normal);
        assert_eq!(ra.inside(p), rb.inside(p));
    }
}

#[test]
fn ends_are_open_but_capped_for_the_sign() {
    let apothem = R * (PI / B as f64).cos();
    for ccw in [true, false] {
        let t = straight(6, ccw, [0.0; 3]);
        let r = Reference::new(&t, 0.5, 3);
        for (p, inside) in
            [([25.0, 0.0, 0.0], true), ([25.0, 9.8, 0.0], true), ([25.0, 0.0, -10.1], false), ([0.5, 0.0, 0.0], true), ([49.5, 1.0, 1.0], true), ([-0.5, 0.0, 0.0], false), ([50.5, 1.0, 1.0], false)]
        {
            assert_eq!(r.inside(p), inside, "ccw {ccw} {p:?}");
            assert_eq!(r.query(p).sd < 0.0, inside, "ccw {ccw} {p:?}");
        }
        // Just inside an end: the wall is radially `apothem` away. Just past it, the sign flips
        // but the distance is still to the open rim, not to a cap.
        assert!((r.query([0.5, 0.0, 0.0]).sd as f64 + apothem).abs() < 1e-4);
        let q = r.query([-3.0, 0.0, 0.0]);
        assert!((q.sd as f64 - (9.0 + apothem * apothem).sqrt()).abs() < 1e-4, "{}", q.sd);
        assert!(q.point[0].abs() < 1e-6);
        // Far away: positive, and the nearest point is on the far rim.
        let p = [1.0e4, 2.0e3, -3.0e3];
        let q = r.query(p);
        assert!(q.sd > 0.0 && !r.inside(p));
        assert!((q.point[0] - 50.0).abs() < 1e-3, "{:?}", q.point);
        let rim = (q.point[1] as f64).hypot(q.point[2] as f64);
        assert!(rim > apothem - 1e-3 && rim < R + 1e-3);
        let want = ((1.0e4f64 - 50.0).powi(2) + (2.0e3f64.hypot(3.0e3) - R).powi(2)).sqrt();
        assert!((q.sd as f64 - want).abs() < 1e-2 + R - apothem, "{} vs {want}", q.sd);
        assert!((dist(q.point, p) - q.sd as f64).abs() < 1e-2);
    }
}

#[test]
fn far_from_the_origin_keeps_precision() {
    let offset = [1.0e4f32, -2.0e4, 3.0e4];
    let near = Reference::new(&straight(6, true, [0.0; 3]), 0.5, 2);
    let far = Reference::new(&straight(6, true, offset), 0.5, 2);
    for p in [[25.0f32, 3.5, -7.25], [12.5, 9.875, 1.0], [31.0, -0.125, 10.5], [40.0, 0.0, 0.0]] {
        let pf = [p[0] + offset[0], p[1] + offset[1], p[2] + offset[2]];
        let (a, b) = (near.query(p), far.query(pf));
        assert!((a.sd - b.sd).abs() < 1e-6, "{} vs {}", a.sd, b.sd);
        assert!(dist(a.normal, b.normal) < 1e-6);
        // The world point is rounded to f32 at 3e4 (ulp ~ 0.002).
        assert!(norm(sub(sub(to64(b.point), to64(offset)), to64(a.point))) < 4e-3);
    }
}

// ---- Quarter torus: midline radius RC in the xy-plane, tube radius R. -------------------

const RC: f64 = 50.0;
const RINGS: usize = 17;

fn delta() -> f64 {
    FRAC_PI_2 / (RINGS - 1) as f64
}

fn torus(ccw: bool) -> Tube {
    let mut points = Vec::new();
    let mut radial = Vec::new();
    for i in 0..RINGS {
        let phi = i as f64 * delta();
        let (c, s) = (phi.cos(), phi.sin());
        points.push([(RC * c) as f32, (RC * s) as f32, 0.0]);
        for k in 0..B {
            let psi = if ccw { 1.0 } else { -1.0 } * TAU * k as f64 / B as f64;
            radial.push([(R * psi.cos() * c) as f32, (R * psi.cos() * s) as f32, (R * psi.sin()) as f32]);
        }
    }
    Tube::new(points, radial, B).unwrap()
}

/// Signed distance to the analytic torus and its outward normal.
fn torus_sd(p: D3) -> (f64, D3) {
    let rho = p[0].hypot(p[1]);
    let (er, dz) = ([p[0] / rho, p[1] / rho, 0.0], p[2]);
    let off = add(mul(er, rho - RC), [0.0, 0.0, dz]);
    (norm(off) - R, unit_or(off, er))
}

/// The continuous surface `S(i, u, k, l)` of `lumen-detect`, evaluated directly.
fn surface(t: &Tube, alpha: f32, i: usize, u: f64, k: usize, l: f64) -> D3 {
    let o = to64(t.points[0]);
    let local = |j: usize| {
        let p = sub(to64(t.points[j]), o);
        V3::new(p[0] as f32, p[1] as f32, p[2] as f32)
    };
    let c = Cubic64::of(&Cubic::of_chain(local, t.rings(), i, alpha)).at(u);
    let k1 = (k + 1) % t.spokes;
    let v = |k: usize| add(mul(to64(t.spoke(i, k)), 1.0 - u), mul(to64(t.spoke(i + 1, k)), u));
    add(o, add(c, add(mul(v(k), 1.0 - l), mul(v(k1), l))))
}

#[test]
fn quarter_torus_matches_the_analytic_torus() {
    for ccw in [true, false] {
        let t = torus(ccw);
        let r = Reference::new(&t, 0.5, 16);
        // How far the continuous surface itself is from the torus (segments 2..14, around the
        // tested range): the B-gon sagitta R (1 - cos(pi/B)) ~ 0.012, the shortening of the
        // linearly interpolated spokes R (1 - cos(delta/2)) ~ 0.012, and the Catmull-Rom
        // midline's departure from the circle (O(delta^4)). The surface is a normal graph over
        // the torus with height h, |h| <= dev, so within the torus' reach the two distance
        // functions differ by at most dev; the tessellation adds at most `bound()`.
        let mut dev = 0.0f64;
        for i in 2..14 {
            for m in 0..=16 {
                for k in 0..B {
                    for l in [0.0, 0.25, 0.5, 0.75] {
                        dev = dev.max(torus_sd(surface(&t, 0.5, i, m as f64 / 16.0, k, l)).0.abs());
                    }
                }
            }
        }
        let expected = R * (1.0 - (PI / B as f64).cos()) + R * (1.0 - (delta() / 2.0).cos());
        assert!(dev > 0.9 * expected && dev < 1.2 * expected, "dev {dev}, expected about {expected}");
        let tol = 1.1 * dev + r.bound() as f64 + 1e-4;
        assert!(tol < 0.035, "tolerance {tol}");
        let mut worst = 0.0f64;
        for f in [4.3, 6.5, 8.0, 10.2, 11.7] {
            let phi = f * delta();
            let er = [phi.cos(), phi.sin(), 0.0];
            for j in 0..24 {
                let psi = TAU * (j as f64 + 0.3) / 24.0;
                let dir = add(mul(er, psi.cos()), [0.0, 0.0, psi.sin()]);
                for rho in [0.5, 3.0, 7.0, 9.5, 10.5, 13.0, 17.0] {
                    let p = add(mul(er, RC), mul(dir, rho));
                    let (want, n_t) = torus_sd(p);
                    let pf = to32(p);
                    let q = r.query(pf);
                    let err = (q.sd as f64 - want).abs();
                    worst = worst.max(err);
                    assert!(err <= tol, "ccw {ccw} phi {f} psi {psi} rho {rho}: sd {} vs torus {want}", q.sd);
                    assert_eq!(r.inside(pf), want < 0.0);
                    assert!((dist(q.point, pf) - q.sd.abs() as f64).abs() < 1e-4);
                    assert!(torus_sd(to64(q.point)).0.abs() <= tol);
                    assert!(dot(to64(q.normal), n_t) > 0.12f64.cos(), "normal {:?} vs {n_t:?}", q.normal);
                }
            }
        }
        println!("ccw {ccw}: dev {dev:.5} (expected {expected:.5}), bound {:.5}, tol {tol:.5}, worst {worst:.5}", r.bound());
        // The comparison is not vacuous: the sagitta alone is most of the tolerance.
        assert!(worst > 0.3 * tol, "worst {worst}, tol {tol}");
    }
}

#[test]
fn bound_holds_and_shrinks_with_steps() {
    let t = torus(true);
    let mut bounds = Vec::new();
    for steps in [1, 2, 4, 8] {
        let r = Reference::new(&t, 0.5, steps);
        let bound = r.bound() as f64;
        let mut worst = 0.0f64;
        for i in 0..RINGS - 1 {
            for m in 0..7 {
                let u = (m as f64 + 0.5) / 7.0;
                for k in (0..B).step_by(5) {
                    for l in [0.0, 0.3, 0.5, 0.9] {
                        let q = r.query(to32(surface(&t, 0.5, i, u, k, l)));
                        worst = worst.max(q.sd.abs() as f64);
                    }
                }
            }
        }
        assert!(worst <= bound + 1e-4, "steps {steps}: {worst} > bound {bound}");
        println!("steps {steps}: bound {bound:.5}, worst on the surface {worst:.5}");
        if steps <= 2 {
            // Not grossly pessimistic either.
            assert!(worst > 0.2 * bound, "steps {steps}: {worst} vs bound {bound}");
        }
        bounds.push(bound);
    }
    // The twist term (spokes rotate with the ring) dominates here: first order in 1 / steps.
    assert!(bounds[3] < 0.6 * bounds[2] && bounds[2] < 0.6 * bounds[1] && bounds[1] < 0.6 * bounds[0], "{bounds:?}");
}

#[test]
fn degenerate_input_does_not_panic() {
    let circle = |r: f32| -> Vec<[f32; 3]> {
        (0..8)
            .map(|k| {
                let a = TAU * k as f64 / 8.0;
                [0.0, r * a.cos() as f32, r * a.sin() as f32]
            })
            .collect()
    };
    let finite = |q: RefQuery| q.sd.is_finite() && q.point.iter().chain(&q.normal).all(|x| x.is_finite());
    let probes = [[10.0, 0.0, 0.0], [20.0, 0.5, 0.0], [25.0, 3.0, 0.0], [-5.0, 0.0, 0.0], [60.0, 9.0, 9.0], [20.0, 0.0, 0.0]];

    // Coincident control points (twice at each end).
    let pts = vec![[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [20.0, 0.0, 0.0], [20.0, 0.0, 0.0]];
    let t = Tube::new(pts, (0..5).flat_map(|_| circle(5.0)).collect(), 8).unwrap();
    let r = Reference::new(&t, 0.5, 4);
    for p in probes {
        assert!(finite(r.query(p)), "{p:?}");
    }
    assert!(r.inside([10.0, 0.0, 0.0]));
    assert!((r.query([10.0, 0.0, 0.0]).sd as f64 + 5.0 * (PI / 8.0).cos()).abs() < 1e-4);

    // A collapsed ring in the middle (the tube pinches to a point) and a cone end.
    let pts: Vec<[f32; 3]> = (0..6).map(|i| [10.0 * i as f32, 0.0, 0.0]).collect();
    let radii = [5.0, 5.0, 0.0, 5.0, 5.0, 0.0];
    let t = Tube::new(pts, radii.iter().flat_map(|&r| circle(r)).collect(), 8).unwrap();
    let r = Reference::new(&t, 0.5, 4);
    for p in probes {
        assert!(finite(r.query(p)), "{p:?}");
    }
    assert!(r.inside([5.0, 0.0, 0.0]) && r.inside([35.0, 0.0, 0.0]) && r.inside([45.0, 0.0, 0.0]));
    assert!(!r.inside([55.0, 0.0, 0.0]) && !r.inside([20.0, 3.0, 0.0]));
    // Past the cone's tip, the tip is the nearest wall point.
    let q = r.query([55.0, 0.0, 0.0]);
    assert!((q.sd - 5.0).abs() < 1e-4 && dist(q.point, [50.0, 0.0, 0.0]) < 1e-4, "{q:?}");

    // Everything collapsed to a point: no area, positive distances.
    let t = Tube::new(vec![[1.0, 2.0, 3.0]; 3], vec![[0.0; 3]; 24], 8).unwrap();
    let r = Reference::new(&t, 0.5, 4);
    assert_eq!(r.wall_triangles(), 0);
    let q = r.query([4.0, 6.0, 3.0]);
    assert!((q.sd - 5.0).abs() < 1e-6 && q.point == [1.0, 2.0, 3.0] && !r.inside([1.0, 2.0, 3.0]));

    // Inconsistent data built by hand: one ring, missing radial vectors, no spokes, steps 0.
    for t in [
        Tube { points: vec![[0.0; 3]], radial: circle(5.0), spokes: 8 },
        Tube { points: vec![[0.0; 3], [10.0, 0.0, 0.0]], radial: circle(5.0), spokes: 8 },
        Tube { points: vec![[0.0; 3], [10.0, 0.0, 0.0]], radial: vec![], spokes: 0 },
        Tube { points: vec![], radial: vec![], spokes: 8 },
    ] {
        for steps in [0, 3] {
            let r = Reference::new(&t, 0.5, steps);
            for p in probes {
                let q = r.query(p);
                assert!(q.sd.is_finite() || r.wall_triangles() == 0);
                let _ = r.inside(p);
            }
        }
    }
}

#[test]
fn dense_rod_is_the_detector_midline() {
    // Straight, evenly spaced: Catmull-Rom is linear, radii interpolate.
    let rod = Rod::new(vec![[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [20.0, 0.0, 0.0]], vec![1.0, 2.0, 4.0]).unwrap();
    let s = dense_rod(&rod, 0.5, 4);
    assert_eq!(s.len(), 9);
    for (j, (p, r)) in s.iter().enumerate() {
        assert!((p[0] - 2.5 * j as f32).abs() < 1e-5 && p[1] == 0.0 && p[2] == 0.0, "{p:?}");
        let want = if j <= 4 { 1.0 + 0.25 * j as f32 } else { 2.0 + 0.5 * (j - 4) as f32 };
        assert!((r - want).abs() < 1e-6, "{j}: {r} vs {want}");
    }

    // Curved and far from the origin: the detector's own samples (local, f32) plus its origin.
    let pts: Vec<[f32; 3]> = (0..7)
        .map(|i| {
            let a = 0.4 * i as f32;
            [5000.0 + 30.0 * a.cos(), -800.0 + 30.0 * a.sin(), 3.0 * i as f32]
        })
        .collect();
    let rod = Rod::new(pts.clone(), vec![2.5]).unwrap();
    for alpha in [0.0, 0.5, 1.0] {
        let s = dense_rod(&rod, alpha, 10);
        assert_eq!(s.len(), 61);
        assert_eq!(s[0].0, pts[0]);
        assert_eq!(s[60].0, pts[6]);
        let flat: Vec<f32> = pts.iter().flatten().copied().collect();
        let origin = V3::new(pts[0][0], pts[0][1], pts[0][2]);
        let view = lumen_detect::view::RodView::new(&flat, pts.len(), origin);
        let mut det = lumen_detect::samples::RodSamples::default();
        det.fill(&view, |_| 2.5, 10, alpha);
        for (j, (p, r)) in s.iter().enumerate() {
            let d = det.pos[j] + origin;
            assert!(dist(*p, [d.x, d.y, d.z]) < 1e-3, "{j}: {p:?} vs {d:?}");
            assert_eq!(*r, 2.5);
        }
        // Between control points the samples really follow the curve, not the chord.
        let mid = s[5].0;
        let chord = mul(add(to64(pts[0]), to64(pts[1])), 0.5);
        assert!(norm(sub(to64(mid), chord)) > 0.1);
    }
    assert!(dense_rod(&Rod { points: vec![], radius: vec![] }, 0.5, 4).is_empty());
    assert_eq!(dense_rod(&Rod { points: vec![[1.0, 2.0, 3.0]], radius: vec![] }, 0.5, 4), vec![([1.0, 2.0, 3.0], 0.0)]);
}

/// `cargo test -p lumen-oracle --release -- --ignored --nocapture`
#[test]
#[ignore]
fn large_tube_timing() {
    let rings = 1250;
    let spokes = 32;
    let mut points = Vec::new();
    let mut radial = Vec::new();
    for i in 0..rings {
        let x = i as f32 * 1.2;
        points.push([x, 20.0 * (x / 40.0).sin(), 15.0 * (x / 55.0).cos()]);
        for k in 0..spokes {
            let a = TAU as f32 * k as f32 / spokes as f32;
            let r = 12.0 + 2.0 * (x / 13.0 + a).sin();
            radial.push([0.0, r * a.cos(), r * a.sin()]);
        }
    }
    let t = Tube::new(points.clone(), radial, spokes).unwrap();
    let start = std::time::Instant::now();
    let r = Reference::new(&t, 0.5, 8);
    let built = start.elapsed();
    println!("{r:?}: built in {built:?}");
    // Query cost grows with the depth inside the lumen: the BVH must open every triangle whose
    // box is nearer than the wall, a band that widens like sqrt(depth).
    for depth in [0.2, 1.0, 3.0, 6.0, 11.0] {
        let m = 20_000;
        let pts: Vec<[f32; 3]> = (0..m)
            .map(|j| {
                let i = j / 20 + 20;
                let (p, a) = (points[i], j as f32 * 0.37);
                let rr = 12.0 - depth;
                [p[0], p[1] + rr * a.cos(), p[2] + rr * a.sin()]
            })
            .collect();
        let start = std::time::Instant::now();
        let acc: f32 = pts.iter().map(|p| r.query(*p).sd).sum();
        println!("depth {depth}: {:?} per query (mean sd {})", start.elapsed() / m as u32, acc / m as f32);
    }
}

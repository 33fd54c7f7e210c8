//! A tube contact's `index_b`, `spoke_b`, `param_b` and `weights_b` locate its wall point on
//! the surface exactly as `proto/README.md` ("Where a tube contact lies") defines it, from the
//! frame's floats alone: a client can rebuild `point_b` (and spread a reaction) without Lumen.

mod common;
use common::*;
use lumen_detect::Method;
use std::f32::consts::TAU;

/// The README's Catmull-Rom segment `i` of `points` with parameter `alpha`, at `u`.
fn midline(points: &[V], i: usize, u: f32, alpha: f32) -> V {
    let n = points.len();
    let (p1, p2) = (points[i], points[i + 1]);
    // A missing neighbour is the segment's reflection.
    let p0 = if i > 0 { points[i - 1] } else { sub(scale(p1, 2.0), p2) };
    let p3 = if i + 2 < n { points[i + 2] } else { sub(scale(p2, 2.0), p1) };
    let dt = |a: V, b: V| norm(sub(b, a)).powf(alpha);
    let (d0, d1, d2) = (dt(p0, p1), dt(p1, p2), dt(p2, p3));
    let m1 = scale(add(sub(scale(sub(p1, p0), 1.0 / d0), scale(sub(p2, p0), 1.0 / (d0 + d1))), scale(sub(p2, p1), 1.0 / d1)), d1);
    let m2 = scale(add(sub(scale(sub(p2, p1), 1.0 / d1), scale(sub(p3, p1), 1.0 / (d1 + d2))), scale(sub(p3, p2), 1.0 / d2)), d1);
    let c2 = sub(sub(scale(sub(p2, p1), 3.0), scale(m1, 2.0)), m2);
    let c3 = add(add(scale(sub(p1, p2), 2.0), m1), m2);
    add(add(add(p1, scale(m1, u)), scale(c2, u * u)), scale(c3, u * u * u))
}

#[test]
fn a_tube_contacts_parameters_give_its_wall_point_by_the_readmes_formula() {
    // A bent tube of uneven rings (spokes of varying length, rings unevenly spaced) and a rod
    // that presses into its wall along a stretch.
    let (rings, spokes) = (14, 12);
    let centre = |i: usize| {
        let t = i as f32 * 6.0 + (i * i) as f32 * 0.3;
        [t, 8.0 * (t / 30.0).sin(), 2.0 * (t / 17.0).cos()]
    };
    let spoke = |i: usize, k: usize| {
        let a = k as f32 * TAU / spokes as f32;
        let r = 9.0 + 1.5 * (a * 2.0 + i as f32).sin();
        [0.0, r * a.cos(), r * a.sin()]
    };
    let points: Vec<V> = (0..rings).map(centre).collect();
    let wall = |i: usize, k: usize| add(points[i], spoke(i, k % spokes));
    let scope = rod((0..12).map(|j| add(centre(2 + j / 2), [3.0 * (j % 2) as f32, 7.5, 1.0])).collect(), 2.0);
    for nearest in [true, false] {
        let scene = interior(tube(rings, spokes, centre, spoke), scope.clone(), 4, Method::Signed).nearest(nearest);
        let cs = run(&scene);
        assert!(cs.len() > 10, "nearest {nearest}: {} contacts", cs.len());
        for c in &cs {
            let (i, k, u, w) = (c.index_b as usize, c.spoke_b as usize, c.param_b, c.weights_b);
            let l = w[1] + w[3];
            let expected = [(1.0 - u) * (1.0 - l), (1.0 - u) * l, u * (1.0 - l), u * l];
            assert!(w.iter().zip(expected).all(|(a, b)| (a - b).abs() < 1e-5), "nearest {nearest}: weights {w:?} are not bilinear in u {u}, l {l}");
            let v = |i: usize, k: usize| sub(wall(i, k), points[i]);
            let vk = add(scale(v(i, k), 1.0 - u), scale(v(i + 1, k), u));
            let vk1 = add(scale(v(i, k + 1), 1.0 - u), scale(v(i + 1, k + 1), u));
            let s = add(midline(&points, i, u, 0.5), add(scale(vk, 1.0 - l), scale(vk1, l)));
            let off = sub(c.point_b, s);
            if nearest {
                // The default reading: the wall point itself.
                assert!(norm(off) < 2e-3, "sample {} at ring {i} spoke {k} u {u} l {l}: S = {s:?}, point_b = {:?} ({} apart)", c.sample, c.point_b, norm(off));
            } else {
                // The sections reading: the foot on the wall's tangent plane at S.
                let along = dot(off, c.normal).abs();
                assert!(along < 2e-3 && norm(off) < 0.5, "sections: sample {} at ring {i} spoke {k} u {u} l {l}: point_b {:?} is {along} off the tangent plane at S = {s:?}", c.sample, c.point_b);
            }
        }
    }
}

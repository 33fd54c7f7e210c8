//! Tube and rod fixtures shared by the integration tests.
#![allow(dead_code)]

use lumen_detect::{Contact, ContactKind, Detector, Method, Rod, Scene, Tube};
use std::f32::consts::TAU;

pub type V = [f32; 3];

pub fn add(a: V, b: V) -> V {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
pub fn sub(a: V, b: V) -> V {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub fn scale(a: V, s: f32) -> V {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub fn dot(a: V, b: V) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub fn norm(a: V) -> f32 {
    dot(a, a).sqrt()
}

/// A tube from a centre function and a spoke function.
pub fn tube(rings: usize, spokes: usize, centre: impl Fn(usize) -> V, spoke: impl Fn(usize, usize) -> V) -> Tube {
    let points = (0..rings).map(&centre).collect();
    let radial = (0..rings).flat_map(|i| (0..spokes).map(move |k| (i, k))).map(|(i, k)| spoke(i, k)).collect();
    Tube::new(points, radial, spokes).unwrap()
}

/// Straight circular tube along +x from x = 0, rings every `spacing`, spokes counter-clockwise
/// about +x starting at +y.
pub fn straight(rings: usize, spacing: f32, radius: f32, spokes: usize) -> Tube {
    tube(
        rings,
        spokes,
        |i| [i as f32 * spacing, 0.0, 0.0],
        |_, k| {
            let a = k as f32 * TAU / spokes as f32;
            [0.0, radius * a.cos(), radius * a.sin()]
        },
    )
}

/// A circular tube bent along an arc of centreline radius `bend` in the xy-plane, from angle 0
/// through `angle`, rings perpendicular to the midline.
pub fn arc(rings: usize, bend: f32, angle: f32, radius: f32, spokes: usize) -> Tube {
    let phi = |i: usize| angle * i as f32 / (rings - 1) as f32;
    tube(
        rings,
        spokes,
        |i| [bend * phi(i).sin(), bend * (1.0 - phi(i).cos()), 0.0],
        |i, k| {
            // Frame: tangent (cos, sin, 0); normal towards the bend centre (-sin, cos, 0); z.
            let (s, c) = phi(i).sin_cos();
            let n = [-s, c, 0.0];
            let a = k as f32 * TAU / spokes as f32;
            add(scale(n, radius * a.cos()), scale([0.0, 0.0, 1.0], radius * a.sin()))
        },
    )
}

pub fn rod(points: Vec<V>, radius: f32) -> Rod {
    Rod::new(points, vec![radius]).unwrap()
}

/// A straight rod from `a` to `b` with `n` points.
pub fn line(a: V, b: V, n: usize, radius: f32) -> Rod {
    rod((0..n).map(|i| add(a, scale(sub(b, a), i as f32 / (n - 1) as f32))).collect(), radius)
}

/// Interior scene: `scope` inside `colon`.
pub fn interior(colon: Tube, scope: Rod, x: u32, method: Method) -> Scene {
    Scene::new().tube("colon", colon).rod("scope", scope).pair("scope", "colon", ContactKind::Interior).precision(x).method(method)
}

/// Runs one frame of `scene` on a fresh detector.
pub fn run(scene: &Scene) -> Vec<Contact> {
    let mut d = Detector::new(&scene.spec().validate().unwrap());
    d.detect(&scene.state()).unwrap().to_vec()
}

/// Rod sample positions as the detector computes them (for checking against a reference).
pub fn sample_point(scene: &Scene, c: &Contact) -> V {
    // point_a = sample + normal * r  (the rod surface point towards b)
    let r = match &scene.bodies[c.body_a as usize].1 {
        lumen_detect::Body::Rod(rod) => rod.radius[0],
        _ => unreachable!(),
    };
    sub(c.point_a, scale(c.normal, r))
}

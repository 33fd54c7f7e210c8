//! Colonoscopies as a scene spec and a sequence of flat frame states, for the IPC benchmark
//! and the daemon's tests:
//!
//! - [`generated`] (default): `lumen-scene`'s seeded generated colon (1.5 m, 1.2 mm rings, 32
//!   spokes, haustral folds) with its kinematic endoscope (160 points, 6.5 mm) inserted about
//!   1 mm per frame, deforming the wall at the bends.
//! - the stand-in ([`spec`], [`write_state`]): sized like it, analytic and cheap: a curved
//!   haustrated tube of 1,250 x 32 and a swaying 160-point rod.
//!
//! Deterministic; millimetres.

use lumen_detect::proto::{BodySpec, ContactKind, PairSpec, SceneSpec, Shape};
use std::f32::consts::TAU;

/// Rings of the tube.
pub const RINGS: usize = 1250;
/// Radial vectors per ring.
pub const SPOKES: usize = 32;
/// Control points of the rod.
pub const ROD_POINTS: usize = 160;
/// Rod radius, mm.
pub const ROD_RADIUS: f32 = 6.5;
const RING_STEP: f32 = 1.2;
const ROD_STEP: f32 = 5.0;

/// The spec: `colon` (tube), `scope` (rod), scope-inside-colon contacts, precision 4.
pub fn spec() -> SceneSpec {
    SceneSpec::new(
        vec![
            BodySpec { name: "colon".into(), shape: Shape::Tube { rings: RINGS, spokes: SPOKES } },
            BodySpec { name: "scope".into(), shape: Shape::Rod { points: ROD_POINTS, radius: vec![ROD_RADIUS] } },
        ],
        vec![PairSpec { a: "scope".into(), b: "colon".into(), kind: ContactKind::Interior }],
    )
}

/// `frames` consecutive frames of the generated colonoscopy (seed 1, from 600 mm deep, 1 mm
/// per frame, no escapes), and their spec.
pub fn generated(frames: usize) -> (SceneSpec, Vec<Vec<f32>>) {
    let colon = crate::generate(&crate::ColonParams::seeded(1));
    let insertion = crate::Insertion { escapes: false, ..Default::default() };
    let mut spec = None;
    let states = insertion
        .frames(&colon, frames, 600.0, 1.0, 1)
        .map(|f| {
            let scene = lumen_detect::Scene::new().tube("colon", f.colon).rod("scope", f.scope).pair("scope", "colon", ContactKind::Interior);
            spec.get_or_insert_with(|| scene.spec());
            scene.state()
        })
        .collect();
    (spec.expect("at least one frame"), states)
}

/// `frames` consecutive frames of the stand-in, and its spec.
pub fn stand_in(frames: usize) -> (SceneSpec, Vec<Vec<f32>>) {
    let spec = spec();
    let n = lumen_detect::proto::StateLayout::of(&spec).floats;
    let states = (0..frames as u64)
        .map(|k| {
            let mut s = vec![0.0; n];
            write_state(k, &mut s);
            s
        })
        .collect();
    (spec, states)
}

fn centre(s: f32) -> [f32; 3] {
    [s, 30.0 * (s / 150.0).sin(), 20.0 * (s / 230.0).sin()]
}

/// Tangent-normal-binormal frame of the midline at arc `s` (approximately arc length).
fn frame(s: f32) -> ([f32; 3], [f32; 3], [f32; 3]) {
    let (a, b) = (centre(s - 0.5), centre(s + 0.5));
    let t = norm([b[0] - a[0], b[1] - a[1], b[2] - a[2]]);
    let n = norm(cross(t, [0.0, 0.0, 1.0]));
    (t, n, cross(t, n))
}

fn wall_radius(s: f32) -> f32 {
    19.0 + 3.0 * (s / 45.0).sin()
}

/// Writes frame `k`'s state (tube then rod) into `out` (length = the spec's state size).
pub fn write_state(k: u64, out: &mut [f32]) {
    let mut o = 0;
    for i in 0..RINGS {
        let s = i as f32 * RING_STEP;
        let c = centre(s);
        let (_, n, b) = frame(s);
        let r = wall_radius(s);
        out[o..o + 3].copy_from_slice(&c);
        o += 3;
        for j in 0..SPOKES {
            let th = j as f32 * TAU / SPOKES as f32;
            let (cs, sn) = (th.cos() * r, th.sin() * r);
            out[o..o + 3].copy_from_slice(&[cs * n[0] + sn * b[0], cs * n[1] + sn * b[1], cs * n[2] + sn * b[2]]);
            o += 3;
        }
    }
    // The scope enters 2 mm further each frame (and backs out again), swaying sideways.
    let travel = RINGS as f32 * RING_STEP - ROD_STEP * ROD_POINTS as f32 - 20.0;
    let phase = (k as f32 * 2.0) % (2.0 * travel);
    let tip = 10.0 + if phase < travel { phase } else { 2.0 * travel - phase };
    for j in 0..ROD_POINTS {
        let s = tip + j as f32 * ROD_STEP;
        let c = centre(s);
        let (_, n, _) = frame(s);
        let sway = 14.0 * (j as f32 / 9.0 + k as f32 * 0.01).sin();
        out[o..o + 3].copy_from_slice(&[c[0] + sway * n[0], c[1] + sway * n[1], c[2] + sway * n[2]]);
        o += 3;
    }
    debug_assert_eq!(o, out.len());
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn norm(a: [f32; 3]) -> [f32; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumen_detect::proto::StateLayout;

    #[test]
    fn generated_colonoscopy_is_colon_sized_and_touches_the_wall() {
        let (spec, states) = generated(3);
        let layout = StateLayout::of(&spec);
        assert_eq!(spec.bodies[0].spokes(), Some(32));
        assert!((1200..1300).contains(&spec.bodies[0].points()), "{} rings", spec.bodies[0].points());
        assert_eq!(spec.bodies[1].points(), 160);
        let mut det = lumen_detect::Detector::new(&spec.validate().unwrap());
        let mut counts = Vec::new();
        for s in &states {
            assert_eq!(s.len(), layout.floats);
            counts.push(det.detect(s).unwrap().len());
        }
        assert!(counts.iter().all(|&n| n > 0), "{counts:?}");
    }

    #[test]
    fn stand_in_is_colon_sized_and_touches_the_wall() {
        let spec = spec();
        let layout = StateLayout::of(&spec);
        assert_eq!(layout.floats, 1250 * 33 * 3 + 160 * 3);
        let mut det = lumen_detect::Detector::new(&spec.validate().unwrap());
        let mut state = vec![0.0; layout.floats];
        let mut counts = Vec::new();
        for k in [0, 50, 100] {
            write_state(k, &mut state);
            counts.push(det.detect(&state).unwrap().len());
        }
        // Some rod samples press into the wall, most do not.
        assert!(counts.iter().all(|&n| n > 0 && n < 400), "{counts:?}");
    }
}

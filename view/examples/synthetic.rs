//! Serves the view of a synthetic scene (a bent tube, a rod pressing its wall, two contacts)
//! for a look at the page without a daemon: `cargo run -p lumen-view --example synthetic`,
//! then open the printed address.

use lumen_proto::{BodySpec, Contact, ContactKind, PairSpec, SceneSpec, Shape};
use lumen_view::{SceneInfo, Snapshot, Source, Stats, Viewer};
use std::time::Duration;

fn main() {
    let (rings, spokes, points) = (60, 16, 20);
    let spec = SceneSpec::new(
        vec![BodySpec { name: "colon".into(), shape: Shape::Tube { rings, spokes } }, BodySpec { name: "scope".into(), shape: Shape::Rod { points, radius: vec![3.0] } }],
        vec![PairSpec { a: "scope".into(), b: "colon".into(), kind: ContactKind::Interior }],
    );
    let viewer = Viewer::start(&std::env::args().nth(1).unwrap_or_else(|| "127.0.0.1:0".into()), SceneInfo::new(&spec, 1, Source::Live, 4, 0, "synthetic")).expect("view");
    println!("{}", viewer.url());
    for frame in 0u64.. {
        let mut state = Vec::new();
        for i in 0..rings {
            let a = i as f32 * 0.05;
            state.extend_from_slice(&[100.0 * a.cos(), 100.0 * a.sin(), 0.0]);
            for k in 0..spokes {
                let t = k as f32 / spokes as f32 * std::f32::consts::TAU;
                let r = 12.0 + 2.0 * ((i as f32 * 0.7 + frame as f32 * 0.02).sin());
                state.extend_from_slice(&[r * t.cos() * a.cos(), r * t.cos() * a.sin(), r * t.sin()]);
            }
        }
        for j in 0..points {
            let a = j as f32 * 0.1;
            state.extend_from_slice(&[95.0 * a.cos(), 95.0 * a.sin(), 0.0]);
        }
        let tip = [95.0 * 1.9f32.cos(), 95.0 * 1.9f32.sin(), 0.0];
        let contacts = vec![
            Contact { point_b: [tip[0] * 0.88, tip[1] * 0.88, 0.0], normal: [-1.9f32.cos(), -1.9f32.sin(), 0.0], depth: 0.8, ..Default::default() },
            Contact { point_b: [100.0 * 0.88, 0.0, 0.0], normal: [-1.0, 0.0, 0.0], depth: 0.2, flags: 2, ..Default::default() },
        ];
        let stats = Stats { frame, fps: 100.0, detect_us: 120.0, turnaround_us: Some(300.0), ..Default::default() }.of_contacts(&contacts);
        viewer.publish(Snapshot { state, contacts, stats });
        std::thread::sleep(Duration::from_millis(10));
    }
}

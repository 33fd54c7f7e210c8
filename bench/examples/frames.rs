//! Times the signed method frame by frame on the criterion scene (the generated colon, seed 7,
//! 1,250 rings x 32 spokes; the 160-point scope inserted 1 m and advancing 1 mm a frame, the wall
//! deformed where pressed), over and over, and prints the median. A driver for profilers, where
//! `lumen bench detect` would spend its time on the reference:
//!
//! ```sh
//! cargo build --release -p lumen-bench --example frames
//! target/release/examples/frames 4 30                    # precision x, passes over 64 frames
//! target/release/examples/frames 4 30 sections           # or refined: the spec's settings
//! target/release/examples/frames 4 30 default 2          # the colon's rings twice as dense
//! valgrind --tool=callgrind --toggle-collect='*detect_prevalidated*' target/release/examples/frames 4 3
//! ```
//!
//! It also prints a digest of the first pass's contacts, bit for bit: the same before and after
//! a change that should only make the detection faster.

use lumen_detect::{ContactKind, Detector, Method, Scene};
use lumen_scene::colon::{generate, ColonParams};
use lumen_scene::endoscope::Insertion;
use std::time::Instant;

const FRAMES: usize = 64;

fn main() {
    let arg = |i: usize, default: usize| std::env::args().nth(i).map_or(default, |s| s.parse().expect("arguments: [precision x] [passes]"));
    let (x, passes) = (arg(1, 4) as u32, arg(2, 20).max(2));
    let setting = std::env::args().nth(3).unwrap_or_else(|| "default".into());
    // `nearest` is the default's reading, declared (the name its digests were first printed under).
    let (nearest, refine) = match setting.as_str() {
        "default" | "nearest" => (true, 0),
        "sections" => (false, 0),
        "refined" => (false, 1),
        other => panic!("setting {other:?}: default, sections or refined"),
    };
    // Rings this many times denser (the rings-doubled check of `lumen bench detect`: 2).
    let denser: f32 = std::env::args().nth(4).map_or(1.0, |s| s.parse().expect("the rings' density factor"));
    let base = ColonParams::seeded(7);
    let colon = generate(&ColonParams { ring_spacing: base.ring_spacing / denser, ..base });
    let mut spec = None;
    let states: Vec<Vec<f32>> = Insertion { escapes: true, ..Insertion::default() }
        .frames(&colon, FRAMES, 1000.0, 1.0, 7)
        .map(|f| {
            let scene = Scene::new().tube("colon", f.colon).rod("scope", f.scope).pair("scope", "colon", ContactKind::Interior).precision(x).method(Method::Signed).nearest(nearest).refine(refine);
            spec.get_or_insert_with(|| scene.spec());
            scene.state()
        })
        .collect();
    let mut d = Detector::new(&spec.expect("frames").validate().expect("the scene is valid"));
    // One buffer rewritten every frame, as a physics engine writes its state in place.
    let mut buf = states[0].clone();
    let mut times = Vec::with_capacity(passes * FRAMES);
    // Each frame's fastest pass: what the frame itself costs, without the machine's hiccups.
    let mut best = [f64::INFINITY; FRAMES];
    let mut contacts = 0;
    // Every contact of the first pass, bit for bit: a change meant to leave results alone
    // (a faster evaluation) must leave this alone.
    let mut digest = std::hash::DefaultHasher::new();
    for pass in 0..passes {
        // Forward, then back: the scope pushes in and pulls out, never jumps.
        let order: Box<dyn Iterator<Item = (usize, &Vec<f32>)>> = if pass % 2 == 0 { Box::new(states.iter().enumerate()) } else { Box::new(states.iter().enumerate().rev()) };
        for (i, state) in order {
            buf.copy_from_slice(state);
            let t0 = Instant::now();
            let found = d.detect_prevalidated(&buf).expect("length checked");
            let n = found.len();
            if pass == 0 {
                digest_of(found, &mut digest);
            }
            // The first pass warms up.
            if pass > 0 {
                let us = t0.elapsed().as_secs_f64() * 1e6;
                times.push(us);
                best[i] = best[i].min(us);
                contacts += n;
            }
        }
    }
    times.sort_by(f64::total_cmp);
    let frames = times.len();
    let slowest = best.iter().copied().fold(0.0, f64::max);
    println!(
        "{setting}, x = {x}: median {:.1} us per frame over {frames} frames, p99 {:.1} us, {:.1} contacts a frame; the slowest frame at its best {slowest:.1} us",
        times[frames / 2],
        times[frames * 99 / 100],
        contacts as f64 / frames as f64
    );
    println!("digest of the first pass's contacts: {:016x}", std::hash::Hasher::finish(&digest));
}

/// Feeds every field of `contacts` to `h`, floats by their bits.
fn digest_of(contacts: &[lumen_detect::Contact], h: &mut std::hash::DefaultHasher) {
    use std::hash::Hash;
    for c in contacts {
        (c.pair, c.kind, c.flags, c.body_a, c.body_b, c.sample, c.segment_a, c.index_b, c.spoke_b).hash(h);
        let floats = [c.param_a, c.param_b].into_iter().chain(c.weights_b).chain(c.point_a).chain(c.point_b).chain(c.normal).chain([c.depth]);
        for f in floats {
            f.to_bits().hash(h);
        }
    }
}

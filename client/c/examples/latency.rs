//! Round-trip latency of the Rust client, the twin of `latency.c`: the straight-tube scene, each
//! frame copied into the frame in place, submitted, and its reply awaited; prints the median
//! and 99th percentile in microseconds. `client/latency.sh` runs it beside the C and Python
//! clients' twins, alternated.
//!
//! `cargo run --release -p lumen-c --example latency -- (local PREFIX | zenoh ENDPOINT) FRAMES`

use lumen_client::{Client, LocalOptions};
use std::time::{Duration, Instant};

const SPEC: &str = r#"{"bodies":[{"name":"colon","shape":{"tube":{"rings":11,"spokes":32}}},
    {"name":"scope","shape":{"rod":{"points":7,"radius":[2.0]}}}],
    "pairs":[{"a":"scope","b":"colon","kind":"interior"}],"precision":4}"#;

/// The straight-tube scene's state (`straight_tube_scene.h`'s `fill_state`) at `offset`.
fn state(offset: f32) -> Vec<f32> {
    let mut s = Vec::new();
    for i in 0..11 {
        s.extend([i as f32 * 10.0, 0.0, 0.0]);
        for k in 0..32 {
            let a = std::f64::consts::TAU * (k as f64 + 0.5) / 32.0;
            s.extend([0.0, (10.0 * a.cos()) as f32, (10.0 * a.sin()) as f32]);
        }
    }
    for j in 0..7 {
        s.extend([20.0 + j as f32 * 10.0, offset, 0.0]);
    }
    s
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [transport, target, frames] = args.as_slice() else { return Err("usage: latency (local PREFIX | zenoh ENDPOINT) FRAMES".into()) };
    let frames: usize = frames.parse()?;
    let client = match transport.as_str() {
        "local" => Client::local_with(LocalOptions { prefix: Some(target.clone()), name: Some("latency.rs".into()) })?,
        _ => Client::zenoh(target)?.with_name("latency.rs"),
    };
    let mut session = client.open_session(&serde_json::from_str(SPEC)?)?;
    let state = state(8.5);
    let mut times = Vec::with_capacity(frames);
    for k in 0..frames + 100 {
        let start = Instant::now();
        session.frame()?.copy_from_slice(&state);
        session.submit()?;
        let reply = session.contacts(Duration::from_secs(1))?;
        assert_eq!(reply.contacts().len(), 25, "contacts of the straight tube");
        if k >= 100 {
            times.push(start.elapsed().as_secs_f64() * 1e6);
        }
    }
    times.sort_by(f64::total_cmp);
    println!("rust: p50 {:.1} us p99 {:.1} us ({frames} frames)", times[frames / 2], times[frames * 99 / 100]);
    session.close()?;
    Ok(())
}

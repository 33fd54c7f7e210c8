//! How long opening a session takes, from the client's call to its session in hand, on each
//! transport: a daemon started for the run (`lumen serve`), the generated colonoscopy's spec
//! (1,250 rings x 32 spokes, a 160-point scope), each session closed before the next opens.
//! Prints the median, p90 and largest open per transport.
//!
//! `cargo run --release -p lumen-e2e --example open_cost -- [LUMEN_BINARY] [OPENS]`
//! (default `target/release/lumen`, 50 opens a transport).

use lumen_client::{Client, LocalOptions};
use lumen_e2e::{free_port, unique_prefix, Daemon, TestScene};
use std::path::Path;
use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let bin = args.next().unwrap_or_else(|| "target/release/lumen".into());
    let opens: usize = args.next().map_or(50, |n| n.parse().expect("OPENS: a number"));
    let d = Daemon::start(Path::new(&bin), &unique_prefix("opencost"), Some(free_port()), &[]);
    // The colonoscopy's sizes: what a simulator opens.
    let spec = TestScene::new(1250, 32, 160).spec;
    let clients = [("iceoryx2", Client::local_with(LocalOptions { prefix: Some(d.prefix.clone()), name: Some("open-cost".into()) }).unwrap()), ("zenoh", Client::zenoh(&d.endpoint()).unwrap())];
    for (name, client) in clients {
        let mut ms: Vec<f64> = (0..opens)
            .map(|_| {
                let t0 = Instant::now();
                let session = client.open_session(&spec).expect("open");
                let took = t0.elapsed().as_secs_f64() * 1e3;
                session.close().expect("close");
                took
            })
            .collect();
        ms.sort_by(f64::total_cmp);
        let at = |q: f64| ms[((ms.len() - 1) as f64 * q).round() as usize];
        println!("{name}: {opens} opens, median {:.1} ms, p90 {:.1} ms, max {:.1} ms", at(0.5), at(0.9), at(1.0));
    }
}

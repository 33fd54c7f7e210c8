//! What a session's open and close leave behind in the daemon (and the client): `lumen serve`
//! started for the run, then `CYCLES` sessions opened, sent one frame, answered and closed, one
//! after the other, on one transport; the daemon's and this process's resident memory printed
//! every `EVERY` cycles.
//!
//! `cargo run --release -p lumen-e2e --example session_cycles -- [LUMEN_BINARY] [zenoh|iceoryx2] [CYCLES] [EVERY]`
//! (default `target/release/lumen`, zenoh, 2,000 cycles, every 250).

use lumen_client::{Client, LocalOptions};
use lumen_e2e::{free_port, unique_prefix, Daemon, TestScene};
use std::path::Path;
use std::time::Duration;

/// Resident memory of process `pid`, KiB (`VmRSS` of `/proc/PID/status`).
fn rss_kib(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).expect("/proc");
    status.lines().find_map(|l| l.strip_prefix("VmRSS:")).and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok()).expect("VmRSS")
}

fn main() {
    let mut args = std::env::args().skip(1);
    let bin = args.next().unwrap_or_else(|| "target/release/lumen".into());
    let transport = args.next().unwrap_or_else(|| "zenoh".into());
    let cycles: usize = args.next().map_or(2000, |n| n.parse().expect("CYCLES: a number"));
    let every: usize = args.next().map_or(250, |n| n.parse().expect("EVERY: a number"));
    let d = Daemon::start(Path::new(&bin), &unique_prefix("cycles"), Some(free_port()), &[]);
    let pid = d.process.child.id();
    let client = match transport.as_str() {
        "zenoh" => Client::zenoh(&d.endpoint()).unwrap(),
        _ => Client::local_with(LocalOptions { prefix: Some(d.prefix.clone()), name: Some("cycles".into()) }).unwrap(),
    };
    let scene = TestScene::new(20, 8, 10);
    println!("cycle, daemon KiB, client KiB");
    for k in 0..=cycles {
        if k % every == 0 {
            println!("{k}, {}, {}", rss_kib(pid), rss_kib(std::process::id()));
        }
        if k == cycles {
            break;
        }
        let mut s = client.open_session(&scene.spec).expect("open");
        s.frame().unwrap().copy_from_slice(&scene.state(k as u64));
        s.submit().unwrap();
        s.contacts(Duration::from_secs(3)).expect("a reply");
        s.close().expect("close");
    }
}

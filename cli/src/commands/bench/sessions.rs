//! `lumen bench sessions`: what opening and closing sessions leaves behind. `--cycles` sessions
//! are opened, sent one frame, answered and closed, by `--clients` connections at once; every
//! `--every` cycles the daemon's resident memory (when it runs on this machine) and this
//! process's are printed, with the cycles a second so far.

use super::super::transport::TransportArgs;
use crate::commands::{CliError, CliResult};
use clap::Args;
use lumen_client::{Client, Transport};
use lumen_proto::{BodySpec, ContactKind, PairSpec, SceneSpec, Shape, StateLayout};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

#[derive(Debug, Args)]
pub struct SessionsArgs {
    #[command(flatten)]
    pub transport: TransportArgs,
    /// Sessions to open and close, in all.
    #[arg(long, default_value_t = 10_000, value_parser = clap::value_parser!(u64).range(1..))]
    pub cycles: u64,
    /// Print a line every this many cycles.
    #[arg(long, default_value_t = 500, value_parser = clap::value_parser!(u64).range(1..))]
    pub every: u64,
    /// Connections cycling at once, each its own client (its own zenoh connection or iceoryx2
    /// node).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..=64))]
    pub clients: u64,
}

/// How long a cycle waits for its reply.
const REPLY_WAIT: Duration = Duration::from_secs(5);

pub fn run(args: SessionsArgs) -> CliResult {
    // The daemon's memory is read where it runs: on this machine (iceoryx2, or a loopback
    // zenoh endpoint), whose pid its status gives.
    let local = match args.transport.transport() {
        Transport::Iceoryx2 => true,
        Transport::Zenoh => lumen_transport::net::is_loopback(args.transport.zenoh.as_deref().unwrap_or(super::super::transport::DEFAULT_ZENOH)),
    };
    let daemon_pid = if local { Some(args.transport.client("bench-sessions")?.status()?.pid) } else { None };
    let (spec, state) = small_scene();
    let done = AtomicUsize::new(0);
    let failed = std::sync::Mutex::new(None::<(usize, CliError)>);
    let start = Instant::now();
    println!("cycles,daemon_kib,client_kib,cycles_per_s");
    let line = |n: u64| {
        let daemon = daemon_pid.and_then(rss_kib).map_or(String::new(), |k| k.to_string());
        let client = rss_kib(std::process::id()).map_or(String::new(), |k| k.to_string());
        println!("{n},{daemon},{client},{:.1}", n as f64 / start.elapsed().as_secs_f64().max(1e-9));
    };
    line(0);
    std::thread::scope(|threads| {
        for k in 0..args.clients {
            let share = args.cycles / args.clients + u64::from(k < args.cycles % args.clients);
            let (spec, state, done, failed, transport) = (&spec, &state, &done, &failed, &args.transport);
            threads.spawn(move || {
                // Each thread its own client: an iceoryx2 one stays on the thread that made it.
                let client = match transport.client(&format!("bench-sessions-{k}")) {
                    Ok(c) => c,
                    Err(e) => {
                        failed.lock().expect("lock").get_or_insert((0, e.into()));
                        return;
                    }
                };
                for _ in 0..share {
                    if failed.lock().expect("lock").is_some() {
                        return;
                    }
                    if let Err(e) = cycle(&client, spec, state) {
                        failed.lock().expect("lock").get_or_insert((done.load(Ordering::SeqCst), e));
                        return;
                    }
                    done.fetch_add(1, Ordering::SeqCst);
                }
            });
        }
        let mut next = args.every;
        while next <= args.cycles {
            if failed.lock().expect("lock").is_some() {
                break;
            }
            if done.load(Ordering::SeqCst) as u64 >= next {
                line(next);
                next += args.every;
            } else {
                std::thread::sleep(Duration::from_millis(2));
            }
        }
    });
    if let Some((at, e)) = failed.into_inner().expect("lock") {
        eprintln!("a cycle failed after {at} cycles");
        return Err(e);
    }
    Ok(())
}

/// One session: open, one frame, its reply, close.
fn cycle(client: &Client, spec: &SceneSpec, state: &[f32]) -> Result<(), CliError> {
    let mut s = client.open_session(spec)?;
    s.frame()?.copy_from_slice(state);
    s.submit()?;
    let reply = s.contacts(REPLY_WAIT)?;
    if let Err(e) = reply.result() {
        return Err(CliError::BadFlag { flag: "bench sessions".into(), value: format!("a frame answered {e:?}"), expected: "status 0".into() });
    }
    s.close()?;
    Ok(())
}

/// A small scene: a straight tube of 20 rings of 8 spokes (radius 5 mm, 2 mm apart) and a rod
/// of 10 points along its axis, touching nothing: the session's own cost, not detection's.
fn small_scene() -> (SceneSpec, Vec<f32>) {
    let (rings, spokes, points) = (20usize, 8usize, 10usize);
    let spec = SceneSpec::new(
        vec![BodySpec { name: "tube".into(), shape: Shape::Tube { rings, spokes } }, BodySpec { name: "rod".into(), shape: Shape::Rod { points, radius: vec![1.0] } }],
        vec![PairSpec { a: "rod".into(), b: "tube".into(), kind: ContactKind::Interior }],
    );
    let mut state = Vec::with_capacity(StateLayout::of(&spec).floats);
    for i in 0..rings {
        state.extend([2.0 * i as f32, 0.0, 0.0]);
        for k in 0..spokes {
            let a = std::f32::consts::TAU * k as f32 / spokes as f32;
            state.extend([0.0, 5.0 * a.cos(), 5.0 * a.sin()]);
        }
    }
    for i in 0..points {
        state.extend([5.0 + 2.0 * i as f32, 0.0, 0.0]);
    }
    (spec, state)
}

/// Resident memory of process `pid`, KiB (`VmRSS` of `/proc/<pid>/status`), if readable.
fn rss_kib(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    status.lines().find_map(|l| l.strip_prefix("VmRSS:")).and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

//! lumen-sim against the real daemon: the same run in-process and through `lumen serve` gives
//! bit-identical figures and contacts; the daemon's error replies and absence are named.

use lumen_client::{Client, LocalOptions};
use lumen_e2e::{same_bits, unique_prefix, Daemon};
use lumen_sim::daemon::DaemonSource;
use lumen_sim::{setup, ContactSource, FrameReport, SimConfig, World};
use std::process::Command;

const LUMEN: &str = env!("CARGO_BIN_EXE_lumen");
const FRAMES: u64 = 300;

fn client(prefix: &str) -> Client {
    Client::local_with(LocalOptions { prefix: Some(prefix.into()), name: Some("sim test".into()) }).expect("local client")
}

/// A report without its wall times (the only figures that may differ between the runs).
fn untimed(r: &FrameReport) -> FrameReport {
    FrameReport { physics_s: 0.0, detect_s: 0.0, ..r.clone() }
}

#[test]
fn daemon_run_is_bit_identical_to_in_process() {
    let colon = setup::generated_colon(1, 1500.0);
    let config = SimConfig::default();
    let daemon = Daemon::start(LUMEN.as_ref(), &unique_prefix("simeq"), None, &[]);
    let client = client(&daemon.prefix);
    let session = client.open_session(&setup::scene_spec(&colon, &config.rod, &config.sim)).expect("open");
    let mut remote = World::new(&colon, config.clone(), DaemonSource::new(session)).expect("daemon world");
    let mut local = World::in_process(&colon, config).expect("in-process world");
    assert_eq!(local.fit_iterations(), remote.fit_iterations());
    assert_eq!(untimed(local.report()), untimed(remote.report()));
    let mut touched = 0;
    for _ in 0..FRAMES {
        let a = untimed(local.step().expect("in-process step"));
        let b = untimed(remote.step().expect("daemon step"));
        assert_eq!(a, b, "frame {}", a.frame);
        assert!(same_bits(local.contacts(), remote.contacts()), "contacts differ at frame {}", a.frame);
        touched += (a.contacts > 0) as u32;
    }
    assert!(touched > 0, "the scope never came near the wall: the comparison saw no contacts");
    // One round trip per detection: the fit's, the initial state's and one per frame.
    let rtt = remote.source().round_trips_us();
    assert_eq!(rtt.len() as u64, remote.fit_iterations() as u64 + 1 + FRAMES);
    assert!(rtt.iter().all(|&t| t > 0.0 && t.is_finite()), "round trips {:?}", &rtt[..10]);
}

#[test]
fn an_error_reply_names_its_status_and_message() {
    let colon = setup::generated_colon(2, 300.0);
    let config = SimConfig::default();
    let daemon = Daemon::start(LUMEN.as_ref(), &unique_prefix("simerr"), None, &[]);
    let client = client(&daemon.prefix);
    let session = client.open_session(&setup::scene_spec(&colon, &config.rod, &config.sim)).expect("open");
    let mut source = DaemonSource::new(session);
    let (frame, kept) = source.frame().expect("frame");
    assert!(!kept, "a loaned frame holds stale data: the world must write all of it");
    frame.fill(f32::NAN);
    let mut out = Vec::new();
    let e = source.detect(&mut out).expect_err("a NaN frame is refused").to_string();
    assert!(e.contains("NonFinite") && e.contains("refused frame 0"), "{e}");
    // The session goes on: the next frame is answered.
    source.frame().expect("frame").0.fill(0.0);
    let _ = source.detect(&mut out);
    assert_eq!(source.round_trips_us().len(), 1, "the refused frame has no round trip figure");
}

#[test]
fn lumen_sim_without_a_daemon_says_to_start_one() {
    let prefix = unique_prefix("nodaemon");
    let out = Command::new(LUMEN).args(["sim", "--frames", "5", "--prefix", &prefix]).output().expect("run lumen sim");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "lumen sim succeeded without a daemon");
    assert!(stderr.contains("lumen serve"), "{stderr}");
    lumen_transport::shm::remove_prefix(&prefix);
    assert!(lumen_e2e::shm_files(&prefix).is_empty());
}

/// Runs `lumen sim` against a daemon, kills the daemon (`kill -9`) once the run is under way and
/// starts another on the same prefix and port: the run must finish all its frames, exit 0, and
/// report no error.
fn lumen_sim_rides_out_a_restart(tag: &str, zenoh: bool) {
    const RUN: u64 = 400;
    let prefix = unique_prefix(tag);
    let port = zenoh.then(lumen_e2e::free_port);
    let mut daemon = Daemon::start(LUMEN.as_ref(), &prefix, port, &[]);
    let mut cmd = Command::new(LUMEN);
    cmd.args(["sim", "--frames", &RUN.to_string(), "--progress-every", "50", "--prefix", &prefix]);
    if zenoh {
        cmd.args(["--zenoh", &daemon.endpoint()]);
    }
    let mut sim = lumen_e2e::ChildProcess::spawn(cmd);
    let progress = sim.line_starting(r#"{"type":"progress""#, std::time::Duration::from_secs(120));
    assert!(progress.is_some(), "lumen sim did not get going");
    assert!(sim.child.try_wait().expect("polling lumen sim").is_none(), "lumen sim ended before the daemon was killed: the test proves nothing");
    daemon.process.kill9();
    let _restarted = Daemon::start(LUMEN.as_ref(), &prefix, port, &[]);
    let status = sim.wait_exit(std::time::Duration::from_secs(240)).expect("lumen sim finished");
    let summary = sim.line_starting(r#"{"type":"summary""#, std::time::Duration::from_secs(5)).expect("a summary line");
    assert!(status.success(), "lumen sim failed ({status}) across the restart: {summary}");
    let v: serde_json::Value = serde_json::from_str(&summary).expect("JSON");
    assert_eq!(v["error"], serde_json::Value::Null, "{summary}");
    assert_eq!(v["frames"].as_u64(), Some(RUN), "every frame run: {summary}");
}

#[test]
fn lumen_sim_rides_out_a_daemon_restart_over_iceoryx2() {
    lumen_sim_rides_out_a_restart("simrestart", false);
}

#[test]
fn lumen_sim_rides_out_a_daemon_restart_over_zenoh() {
    lumen_sim_rides_out_a_restart("zsimrestart", true);
}

/// SIGTERM to `lumen sim` while its daemon is away (killed, not back): it stops waiting within a
/// second, prints its summary and exits 130, as its docs say.
fn lumen_sim_takes_sigterm_during_an_outage(tag: &str, zenoh: bool) {
    let prefix = unique_prefix(tag);
    let port = zenoh.then(lumen_e2e::free_port);
    let mut daemon = Daemon::start(LUMEN.as_ref(), &prefix, port, &[]);
    let mut cmd = Command::new(LUMEN);
    cmd.args(["sim", "--frames", "100000", "--progress-every", "50", "--prefix", &prefix]);
    if zenoh {
        cmd.args(["--zenoh", &daemon.endpoint()]);
    }
    let mut sim = lumen_e2e::ChildProcess::spawn(cmd);
    assert!(sim.line_starting(r#"{"type":"progress""#, std::time::Duration::from_secs(120)).is_some(), "lumen sim did not get going");
    daemon.process.kill9();
    // Well into the outage: the sim is retrying.
    std::thread::sleep(std::time::Duration::from_millis(1500));
    assert!(sim.child.try_wait().unwrap().is_none(), "lumen sim gave up within 1.5 s of the daemon's death");
    let sent = std::time::Instant::now();
    sim.signal(libc::SIGTERM);
    let status = sim.wait_exit(std::time::Duration::from_secs(10)).expect("lumen sim exits after SIGTERM");
    let took = sent.elapsed();
    assert_eq!(status.code(), Some(130), "{status}");
    assert!(took < std::time::Duration::from_secs(1), "lumen sim took {took:?} to end after SIGTERM during the outage");
    let summary = sim.line_starting(r#"{"type":"summary""#, std::time::Duration::from_secs(5)).expect("a summary line");
    assert!(summary.contains("interrupted by signal 15"), "{summary}");
    lumen_transport::shm::remove_prefix(&prefix);
}

#[test]
fn lumen_sim_takes_sigterm_during_an_outage_over_iceoryx2() {
    lumen_sim_takes_sigterm_during_an_outage("simterm", false);
}

#[test]
fn lumen_sim_takes_sigterm_during_an_outage_over_zenoh() {
    lumen_sim_takes_sigterm_during_an_outage("zsimterm", true);
}

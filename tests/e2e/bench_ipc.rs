//! `lumen bench ipc`, run as a process on a few frames: the daemon it starts answers every
//! frame over iceoryx2, and `ipc.json` / `ipc.md` hold the figures the issue names, coherent
//! with each other, and nothing is left in /dev/shm.

use std::path::Path;
use std::process::{Command, Stdio};

const LUMEN: &str = env!("CARGO_BIN_EXE_lumen");

#[test]
fn a_short_ipc_benchmark_writes_coherent_figures() {
    let out = std::env::temp_dir().join(format!("lumen-bench-ipc-{}", std::process::id()));
    let child = Command::new(LUMEN).args(["bench", "ipc", "--only", "iceoryx2", "--frames", "60", "--out"]).arg(&out).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    // Its iceoryx2 prefix (`lumen_bench_<pid>_`): what it must leave nothing of.
    let prefix = format!("lumen_bench_{}_", child.id());
    let run = child.wait_with_output().unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("ipc.json")).unwrap()).unwrap();
    let runs = json["runs"].as_array().unwrap();
    let modes: Vec<&str> = runs.iter().map(|r| r["mode"].as_str().unwrap()).collect();
    assert_eq!(modes, ["back-to-back", "paced-1khz", "4-sessions"]);
    for r in runs {
        let f = |k: &str| r[k].as_f64().unwrap_or_else(|| panic!("{k} in {r}"));
        assert_eq!(r["transport"], "iceoryx2");
        assert_eq!(f("lost_frames"), 0.0, "{r}");
        // 4 sessions of half the frames each.
        assert_eq!(f("frames"), if r["mode"] == "4-sessions" { 120.0 } else { 60.0 }, "{r}");
        assert!(0.0 < f("p50_us") && f("p50_us") <= f("p99_us") && f("p99_us") <= f("p999_us"), "{r}");
        assert!(0.0 < f("detect_us") && f("detect_us") <= f("detect_p99_us"), "{r}");
        // The echo answers as many frames without detecting (the daemon reports no detection
        // time on any of its replies); which is faster is a timing, not asserted here.
        assert!(0.0 < f("echo_p50_us") && f("echo_p50_us") <= f("echo_p99_us"), "{r}");
        assert_eq!(f("echo_detect_max_us"), 0.0, "{r}");
    }
    // The machine's floor, both ways, across two cores and on one, on as many round trips.
    let wake = json["wake"].as_array().unwrap();
    let rows: Vec<(&str, &str)> = wake.iter().map(|w| (w["mode"].as_str().unwrap(), w["cores"].as_str().unwrap())).collect();
    let two = std::thread::available_parallelism().map_or(1, |n| n.get()) > 1;
    let expect: Vec<(&str, &str)> =
        [("back-to-back", "two cores"), ("back-to-back", "one core"), ("paced-1khz", "two cores"), ("paced-1khz", "one core")].into_iter().filter(|r| two || r.1 == "one core").collect();
    assert_eq!(rows, expect);
    assert!(wake.iter().all(|w| w["round_trips"] == 60 && w["p50_us"].as_f64().unwrap() > 0.0), "{wake:?}");
    // Ownership's work, timed on this run's frame (40-byte header + its floats) and a reply of
    // one contact a scope point (256-byte header + 160 records of 88 bytes), a batch a frame.
    let o = &json["ownership"];
    let floats = json["floats_per_frame"].as_u64().unwrap();
    assert_eq!((o["frame_bytes"].as_u64(), o["reply_bytes"].as_u64(), o["batches"].as_u64()), (Some(40 + 4 * floats), Some(256 + 88 * 160), Some(60)), "{o}");
    assert!(0.0 < o["p50_us"].as_f64().unwrap() && o["p50_us"].as_f64() <= o["p99_us"].as_f64(), "{o}");
    let md = std::fs::read_to_string(out.join("ipc.md")).unwrap();
    assert!(md.contains("| iceoryx2 | paced-1khz |"), "{md}");
    assert!(md.contains(&format!("cost {:.3} us a round trip at p50", o["p50_us"].as_f64().unwrap())), "{md}");
    let _ = std::fs::remove_dir_all(&out);
    let left: Vec<_> =
        std::fs::read_dir(Path::new("/dev/shm")).map(|d| d.flatten().map(|e| e.file_name().to_string_lossy().into_owned()).filter(|n| n.starts_with(&prefix)).collect()).unwrap_or_default();
    assert!(left.is_empty(), "left in /dev/shm: {left:?}");
}

/// Told where, the bench's daemon listens there and its prefix is the one given; over zenoh it
/// reads each session's daemon-side time (never the -0.0 of no sample at all).
#[test]
fn the_ipc_benchmark_runs_on_the_prefix_and_endpoint_given() {
    let out = std::env::temp_dir().join(format!("lumen-bench-ipc-z-{}", std::process::id()));
    let prefix = lumen_e2e::unique_prefix("benchz");
    let endpoint = format!("tcp/127.0.0.1:{}", lumen_e2e::free_port());
    let run = Command::new(LUMEN).args(["bench", "ipc", "--only", "zenoh", "--frames", "20", "--prefix", &prefix, "--zenoh-listen", &endpoint, "--out"]).arg(&out).output().unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("ipc.json")).unwrap()).unwrap();
    for r in json["runs"].as_array().unwrap() {
        assert_eq!(r["transport"], "zenoh");
        assert!(r["daemon_p50_us"].as_f64().unwrap() > 0.0, "{r}");
    }
    let md = std::fs::read_to_string(out.join("ipc.md")).unwrap();
    assert!(!md.contains("-0.0"), "{md}");
    let _ = std::fs::remove_dir_all(&out);
    lumen_transport::shm::remove_prefix(&prefix);
}

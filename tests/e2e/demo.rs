//! `lumen demo` end to end: daemon, physics and recorder as real processes; a headless run's
//! report, and Ctrl-C leaving nothing behind.

use lumen_e2e::{shm_files, unique_prefix, ChildProcess};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

const LUMEN: &str = env!("CARGO_BIN_EXE_lumen");

/// A fresh directory under the system's temporary directory, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> Self {
        let p = std::env::temp_dir().join(format!("lumen-{tag}-{}-{}", std::process::id(), fastrand::u64(..)));
        std::fs::create_dir_all(&p).expect("temp dir");
        Self(p)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Processes whose command line mentions `needle` (the demo's children carry its prefix).
fn processes_with(needle: &str) -> Vec<String> {
    let mut found = Vec::new();
    for e in std::fs::read_dir("/proc").expect("/proc").filter_map(|e| e.ok()) {
        let name = e.file_name().to_string_lossy().into_owned();
        if !name.chars().all(|c| c.is_ascii_digit()) {
            continue;
        }
        // Zombies have an empty command line; only live processes count.
        if let Ok(cmd) = std::fs::read(e.path().join("cmdline")) {
            let cmd = String::from_utf8_lossy(&cmd).replace('\0', " ");
            if cmd.contains(needle) {
                found.push(format!("{name}: {cmd}"));
            }
        }
    }
    found
}

fn non_empty(p: &Path) {
    let n = std::fs::metadata(p).unwrap_or_else(|e| panic!("{}: {e}", p.display())).len();
    assert!(n > 0, "{} is empty", p.display());
}

#[test]
fn headless_demo_is_sound_and_writes_its_report() {
    let out = TempDir::new("demo");
    let prefix = unique_prefix("demo");
    let run = Command::new(LUMEN).args(["demo", "--frames", "300", "--prefix", &prefix, "--out"]).arg(&out.0).output().expect("run lumen demo");
    let stdout = String::from_utf8_lossy(&run.stdout);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "lumen demo failed ({}):\n{stdout}\n{stderr}", run.status);
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(out.0.join("summary.json")).expect("summary.json")).expect("summary.json is JSON");
    let num = |k: &str| summary[k].as_f64().unwrap_or_else(|| panic!("summary.json lacks {k}: {summary}"));
    assert_eq!(num("frames"), 300.0);
    assert_eq!(num("escaped_samples_max"), 0.0);
    assert!(num("max_penetration_mm") <= 1.0, "{summary}");
    assert_eq!(num("nan_frames"), 0.0);
    assert!(num("rtt_p50_us") > 0.0 && num("rtt_p99_us") >= num("rtt_p50_us"), "{summary}");
    assert!(num("physics_fps") > 0.0);
    // The scope is within the contact margin of the wall from the start (it rides the outer
    // side of the bends), so contacts come in the first 300 frames.
    assert!(num("contacts_max") > 0.0, "{summary}");
    assert_eq!(summary["sound"], Value::Bool(true));
    // The recorder attached before the first frame (the sim holds it) and finished its file
    // when the session ended. (At full speed it may miss frames: it sees the newest only.)
    let recording = summary["recording"].as_str().unwrap_or_else(|| panic!("no recording in {summary}"));
    assert!(recording.starts_with("session ended;") && recording.contains(" replies"), "{recording}");
    for f in ["report.md", "time_per_frame.svg", "contacts_per_frame.svg", "time_vs_contacts.svg", "run.mcap"] {
        non_empty(&out.0.join(f));
    }
    let frames = std::fs::read_to_string(out.0.join("frames.jsonl")).expect("frames.jsonl");
    assert_eq!(frames.lines().count(), 300);
    assert!(stdout.contains("SOUND"), "{stdout}");
    assert!(shm_files(&prefix).is_empty(), "left in /dev/shm: {:?}", shm_files(&prefix));
    assert!(processes_with(&prefix).is_empty(), "{:?}", processes_with(&prefix));
}

#[test]
fn sigint_leaves_no_process_and_no_shared_memory() {
    let out = TempDir::new("demo-int");
    let prefix = unique_prefix("dint");
    let mut cmd = Command::new(LUMEN);
    cmd.args(["demo", "--frames", "1000000", "--prefix", &prefix, "--out"]).arg(&out.0);
    let mut demo = ChildProcess::spawn(cmd);
    assert!(demo.line_starting("lumen demo: session", Duration::from_secs(120)).is_some(), "the demo did not start its session");
    // The daemon, the sim (and the recorder) are running and have shared memory open.
    std::thread::sleep(Duration::from_millis(500));
    assert!(!shm_files(&prefix).is_empty(), "the run uses no shared memory of its prefix?");
    // The demo, the daemon, the sim and the recorder.
    assert_eq!(processes_with(&prefix).len(), 4, "{:?}", processes_with(&prefix));
    demo.signal(libc::SIGINT);
    let status = demo.wait_exit(Duration::from_secs(60)).expect("the demo exits after SIGINT");
    assert_eq!(status.code(), Some(130), "{status}");
    assert!(processes_with(&prefix).is_empty(), "left running: {:?}", processes_with(&prefix));
    assert!(shm_files(&prefix).is_empty(), "left in /dev/shm: {:?}", shm_files(&prefix));
}

/// Per-frame contacts and penetration of a demo's `frames.jsonl`.
fn frame_figures(dir: &Path) -> Vec<(u64, u64, f64)> {
    let text = std::fs::read_to_string(dir.join("frames.jsonl")).expect("frames.jsonl");
    text.lines()
        .map(|l| {
            let v: Value = serde_json::from_str(l).expect("a JSON line");
            (v["frame"].as_u64().unwrap(), v["contacts"].as_u64().unwrap(), v["max_penetration_mm"].as_f64().unwrap())
        })
        .collect()
}

#[test]
fn a_model_file_runs_as_its_scene_does_and_bad_ones_are_named() {
    let dir = TempDir::new("model");
    // The generated colon written as the model file `lumen import` writes.
    let colon = lumen_sim::setup::generated_colon(1, 1500.0);
    std::fs::write(dir.0.join("gen.lumen"), lumen_detect::model::save_native(&lumen_detect::Body::Tube(colon))).unwrap();
    let demo = |tag: &str, extra: &[&str]| {
        let out = dir.0.join(tag);
        let prefix = unique_prefix(tag);
        let run = Command::new(LUMEN).args(["demo", "--frames", "200", "--prefix", &prefix, "--out"]).arg(&out).args(extra).output().expect("run lumen demo");
        (run, out)
    };
    let model = dir.0.join("gen.lumen");
    let (run, from_model) = demo("bymodel", &["--model", model.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success() && stdout.contains("SOUND"), "{stdout}\n{}", String::from_utf8_lossy(&run.stderr));
    let summary = std::fs::read_to_string(from_model.join("summary.json")).unwrap();
    assert!(summary.contains("gen.lumen"), "the report names the model: {summary}");
    let (run, from_scene) = demo("byscene", &[]);
    assert!(run.status.success());
    // The same colon, the same physics and detection: the same frames.
    let frames = frame_figures(&from_model);
    assert_eq!(frames.len(), 200);
    assert!(frames.iter().any(|f| f.1 > 0), "no contacts in 200 frames");
    assert_eq!(frames, frame_figures(&from_scene));

    // A file that is not a model, and a missing one: named, before anything starts.
    std::fs::write(dir.0.join("junk.lumen"), b"not a model").unwrap();
    for (file, says) in [("junk.lumen", "LUMN"), ("absent.lumen", "No such file")] {
        let (run, _) = demo("bad", &["--model", dir.0.join(file).to_str().unwrap()]);
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success() && err.contains("--model") && err.contains(file) && err.contains(says), "{err}");
    }
    let (run, _) = demo("bad", &["--scope-radius", "0"]);
    assert!(!run.status.success() && String::from_utf8_lossy(&run.stderr).contains("--scope-radius"));
}

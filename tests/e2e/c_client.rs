//! Lumen through its C ABI, for real: the examples of `client/c/examples/` compiled with the
//! system's C compiler against `liblumen_c.a` and run, embedded and against a real `lumen
//! serve` on both transports, including a daemon killed (`kill -9`) and restarted under a
//! running client; and the C# wrapper (`client/csharp/`) compiled with Mono's `mcs` and run
//! against `liblumen_c.so`. Each program checks every contact against the closed form and exits
//! non-zero on a mismatch; these tests check its exit and what it printed.

use lumen_e2e::{build_c_example, free_port, lumen_c_library, unique_prefix, ChildProcess, Daemon};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Mutex;
use std::time::Duration;

const LUMEN: &str = env!("CARGO_BIN_EXE_lumen");

/// `make()`'s program, made once per test process (tests run in parallel and would otherwise
/// write the file while another runs it).
fn once(name: &str, make: impl FnOnce() -> PathBuf) -> PathBuf {
    static BUILT: Mutex<BTreeMap<String, PathBuf>> = Mutex::new(BTreeMap::new());
    let mut built = BUILT.lock().unwrap_or_else(|e| e.into_inner());
    built.entry(name.to_owned()).or_insert_with(make).clone()
}

fn example(name: &str) -> PathBuf {
    once(name, || build_c_example(name, Path::new(env!("CARGO_TARGET_TMPDIR"))))
}

/// Asserts a run succeeded and printed a line starting with each of `lines`; returns stdout.
fn expect(run: &Output, lines: &[&str]) -> String {
    let (stdout, stderr) = (String::from_utf8_lossy(&run.stdout).into_owned(), String::from_utf8_lossy(&run.stderr));
    assert!(run.status.success(), "the example failed ({}):\n{stdout}{stderr}", run.status);
    for line in lines {
        assert!(stdout.lines().any(|l| l.starts_with(line)), "no line starting {line:?} in:\n{stdout}{stderr}");
    }
    stdout
}

#[test]
fn the_embedded_example_matches_the_closed_form() {
    let run = Command::new(example("straight_tube")).output().expect("running straight_tube");
    expect(
        &run,
        &[
            "frame 0: offset 8.50: 25 contacts",
            "frame 1: offset 9.00: 25 contacts",
            "frame 2: offset 0.00: 0 contacts",
            "short state refused: state: state has 1109 floats; the scene's layout needs exactly 1110",
            "ok",
        ],
    );
}

/// What every daemon round trip prints, whatever the transport.
const ROUND_TRIP: &[&str] = &[
    "empty spec: status 9: the daemon refused: invalid scene spec: scene declares no bodies",
    "frame 0: offset 8.50: checked",
    "observer: 1 frames, 1 replies",
    "bad frame: status 6 body 1 index 1: body \"scope\": control point 1 has a non-finite coordinate (NaN)",
    "checked 40 lost 0 reconnects 0",
    "ok",
];

#[test]
fn the_c_client_round_trips_over_iceoryx2() {
    let daemon = Daemon::start(Path::new(LUMEN), &unique_prefix("c_iox"), None, &[]);
    let run = Command::new(example("round_trip")).args(["local", &daemon.prefix, "40"]).output().expect("running round_trip");
    expect(&run, ROUND_TRIP);
}

#[test]
fn the_c_client_round_trips_over_zenoh() {
    let daemon = Daemon::start(Path::new(LUMEN), &unique_prefix("c_zenoh"), Some(free_port()), &[]);
    let run = Command::new(example("round_trip")).args(["zenoh", &daemon.endpoint(), "40"]).output().expect("running round_trip");
    expect(&run, ROUND_TRIP);
}

/// Kills the daemon under a C client that has checked 20 frames, starts another on the same
/// prefix and port, and checks the client finished all its frames on a reopened session.
fn rides_out_a_restart(transport: &str, prefix: &str, port: Option<u16>) {
    let bin = Path::new(LUMEN);
    let mut daemon = Daemon::start(bin, prefix, port, &[]);
    let target = if transport == "local" { prefix.to_owned() } else { daemon.endpoint() };
    let mut cmd = Command::new(example("round_trip"));
    cmd.args([transport, &target, "200", "5"]);
    let mut client = ChildProcess::spawn(cmd);
    assert!(client.line_starting("progress 20", Duration::from_secs(30)).is_some(), "the client did not get going");
    daemon.process.kill9();
    let _restarted = Daemon::start(bin, prefix, port, &[]);
    let status = client.wait_exit(Duration::from_secs(70)).expect("the client finished within 70 s");
    let done = client.line_starting("checked ", Duration::from_secs(1)).expect("the client's tally");
    assert!(status.success(), "the client failed ({status}) after the restart: {done}");
    let fields: Vec<&str> = done.split_whitespace().collect();
    assert_eq!((fields[1], fields[5]), ("200", "1"), "all 200 frames checked, on a session reopened once: {done}");
}

#[test]
fn the_c_client_rides_out_a_daemon_restart_over_iceoryx2() {
    rides_out_a_restart("local", &unique_prefix("c_restart_iox"), None);
}

#[test]
fn the_c_client_rides_out_a_daemon_restart_over_zenoh() {
    rides_out_a_restart("zenoh", &unique_prefix("c_restart_zenoh"), Some(free_port()));
}

/// `client/csharp/Lumen.cs` and its test program compiled with Mono's `mcs` (CI installs the
/// Debian packages `mono-mcs` and `mono-runtime`; a machine without them fails here).
fn csharp_test() -> PathBuf {
    once("LumenTest.exe", build_csharp_test)
}

fn build_csharp_test() -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../client/csharp");
    let exe = Path::new(env!("CARGO_TARGET_TMPDIR")).join("LumenTest.exe");
    let built = Command::new("mcs")
        .arg(format!("-out:{}", exe.display()))
        .arg("-warnaserror")
        .arg(dir.join("Lumen.cs"))
        .arg(dir.join("tests/LumenTest.cs"))
        .output()
        .unwrap_or_else(|e| panic!("running mcs ({e}): install Mono's compiler and runtime (apt-get install mono-mcs mono-runtime; `bash .ci/test` does)"));
    assert!(built.status.success(), "mcs failed:\n{}{}", String::from_utf8_lossy(&built.stdout), String::from_utf8_lossy(&built.stderr));
    exe
}

/// Runs the C# test program under `mono` with `liblumen_c.so` on the library path.
fn run_csharp(args: &[&str]) -> Output {
    let so = lumen_c_library("liblumen_c.so");
    Command::new("mono").arg(csharp_test()).args(args).env("LD_LIBRARY_PATH", so.parent().expect("its folder")).output().expect("running mono (apt-get install mono-runtime)")
}

const CSHARP: &[&str] = &[
    "Contact: 88 bytes",
    "embedded: offset 8.50: 25 contacts, depth 0.5482",
    "embedded: offset 9.00: 25 contacts, depth 1.0482",
    "embedded: offset 0.00: 0 contacts",
    "short state: BadState: lumen_detector_detect: state: state has 3 floats; the scene's layout needs exactly 1110",
    "empty spec: BadSpec",
    "bad frame: NonFinite body 1 index 1: body \"scope\": control point 1 has a non-finite coordinate (NaN)",
    "daemon: 20 frames checked",
    "after a timeout: the newest frame's reply",
    "observer: the newest frame and its reply",
    "refused: Refused",
    "ok",
];

/// The C# lines of a run that also drops `n` sessions without Dispose and disposes 32 on
/// another thread (against a daemon of 16 sessions at most: every open past the 16th needs the
/// earlier ones closed).
fn csharp_with_lifetimes(n: usize) -> Vec<String> {
    let mut lines: Vec<String> = CSHARP[..CSHARP.len() - 1].iter().map(|l| l.to_string()).collect();
    lines.extend([format!("finalized: {n} sessions"), "disposed elsewhere: 32 sessions".into(), "ok".into()]);
    lines
}

#[test]
fn the_csharp_wrapper_detects_and_round_trips_over_iceoryx2() {
    // iceoryx2 sessions cost some 0.1 s each to open in a debug build: 100 dropped.
    let daemon = Daemon::start(Path::new(LUMEN), &unique_prefix("cs_iox"), None, &[]);
    let lines = csharp_with_lifetimes(100);
    expect(&run_csharp(&["local", &daemon.prefix, "100"]), &lines.iter().map(String::as_str).collect::<Vec<_>>());
    let status = lumen_client::Client::local_with(lumen_client::LocalOptions { prefix: Some(daemon.prefix.clone()), name: None }).unwrap().status().unwrap();
    assert!(status.sessions.is_empty(), "sessions left: {:?}", status.sessions);
}

#[test]
fn the_csharp_wrapper_round_trips_over_zenoh() {
    let daemon = Daemon::start(Path::new(LUMEN), &unique_prefix("cs_zenoh"), Some(free_port()), &[]);
    let lines = csharp_with_lifetimes(1000);
    expect(&run_csharp(&["zenoh", &daemon.endpoint(), "1000"]), &lines.iter().map(String::as_str).collect::<Vec<_>>());
}

/// The C# wrapper over TLS with a client certificate (`Client.ZenohTls`): certificates from
/// `lumen certs`, a daemon that requires client certificates, the same session checks.
#[test]
fn the_csharp_wrapper_round_trips_over_zenoh_tls_with_a_client_certificate() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("cs-certs-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let certs = Command::new(LUMEN).arg("certs").arg("--out").arg(&dir).args(["--server", "localhost", "--client", "csharp"]).output().unwrap();
    assert!(certs.status.success(), "{}", String::from_utf8_lossy(&certs.stderr));
    let p = |f: &str| dir.join(f).display().to_string();
    let port = free_port();
    let endpoint = format!("tls/localhost:{port}");
    let _d = Daemon::start(
        Path::new(LUMEN),
        &unique_prefix("cs_tls"),
        None,
        &["--zenoh-listen", &format!("tls/127.0.0.1:{port}"), "--zenoh-tls-cert", &p("server.pem"), "--zenoh-tls-key", &p("server.key"), "--zenoh-client-ca", &p("ca.pem")],
    );
    // Ready once a Rust client with the same certificate is answered.
    let tls = lumen_client::Tls { root_ca: dir.join("ca.pem"), identity: Some((dir.join("csharp.pem"), dir.join("csharp.key"))) };
    assert!((0..50).any(|_| lumen_client::Client::zenoh_with_tls(&endpoint, &tls).and_then(|c| c.status()).is_ok() || {
        std::thread::sleep(Duration::from_millis(100));
        false
    }));
    expect(&run_csharp(&["tls", &endpoint, &p("ca.pem"), &p("csharp.pem"), &p("csharp.key")]), CSHARP);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `client/csharp/examples/Latency.cs` (what `client/latency.sh` runs for C#) compiles and
/// times 50 frames on each transport, every reply with the straight tube's 25 contacts.
#[test]
fn the_csharp_latency_example_runs() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../client/csharp");
    let exe = Path::new(env!("CARGO_TARGET_TMPDIR")).join("Latency.exe");
    let built = Command::new("mcs").arg(format!("-out:{}", exe.display())).arg("-warnaserror").arg(dir.join("Lumen.cs")).arg(dir.join("examples/Latency.cs")).output().expect("running mcs");
    assert!(built.status.success(), "mcs failed:\n{}{}", String::from_utf8_lossy(&built.stdout), String::from_utf8_lossy(&built.stderr));
    let so = lumen_c_library("liblumen_c.so");
    let daemon = Daemon::start(Path::new(LUMEN), &unique_prefix("cs_latency"), Some(free_port()), &[]);
    for (transport, target) in [("local", daemon.prefix.clone()), ("zenoh", daemon.endpoint())] {
        let run = Command::new("mono").arg(&exe).args([transport, &target, "50"]).env("LD_LIBRARY_PATH", so.parent().unwrap()).output().expect("running mono");
        expect(&run, &["csharp: p50 "]);
    }
}

/// The Unity package: `client/unity/build.sh` lays it out with the debug library and checks it
/// (files, the library's functions); its package.json and assembly definitions parse and name
/// each other; `Runtime/Lumen.cs` is `client/csharp/Lumen.cs`; and the runtime and the sample,
/// compiled with Mono against a stand-in of the UnityEngine types they use, run the sample as
/// Unity would for 1,000 frames against a daemon, every reply checked against the closed form.
#[test]
fn the_unity_package_builds_and_its_sample_runs_1000_frames_against_a_daemon() {
    let unity = Path::new(env!("CARGO_MANIFEST_DIR")).join("../client/unity");
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("unity/org.lumen.client");
    let so = lumen_c_library("liblumen_c.so");
    let built = Command::new("bash").arg(unity.join("build.sh")).args(["--out", out.to_str().unwrap(), "--lib", so.to_str().unwrap()]).output().unwrap();
    assert!(built.status.success(), "build.sh failed:\n{}{}", String::from_utf8_lossy(&built.stdout), String::from_utf8_lossy(&built.stderr));
    let json = |p: &str| -> serde_json::Value { serde_json::from_str(&std::fs::read_to_string(out.join(p)).unwrap()).unwrap_or_else(|e| panic!("{p}: {e}")) };
    let package = json("package.json");
    assert_eq!(package["name"], "org.lumen.client");
    let sample = package["samples"][0]["path"].as_str().unwrap();
    assert!(out.join(sample).join("ScopeContacts.cs").is_file(), "the sample's path {sample}");
    let (runtime, samples) = (json("Runtime/Lumen.Runtime.asmdef"), json("Samples~/ScopeContacts/Lumen.Samples.asmdef"));
    assert_eq!(samples["references"][0], runtime["name"], "the sample's assembly references the runtime's");
    let wrapper = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../client/csharp/Lumen.cs")).unwrap();
    assert_eq!(std::fs::read(out.join("Runtime/Lumen.cs")).unwrap(), wrapper, "Runtime/Lumen.cs is client/csharp/Lumen.cs");
    let meta = std::fs::read_to_string(out.join("Runtime/Plugins/x86_64/liblumen_c.so.meta")).unwrap();
    assert!(meta.contains("Standalone: Linux64") && meta.contains("OS: Linux"), "the plugin is enabled for Linux");
    let stripped = std::fs::metadata(out.join("Runtime/Plugins/x86_64/liblumen_c.so")).unwrap().len();
    assert!(stripped < std::fs::metadata(&so).unwrap().len(), "the library is stripped");

    let exe = Path::new(env!("CARGO_TARGET_TMPDIR")).join("SampleRunner.exe");
    let compiled = Command::new("mcs")
        .arg(format!("-out:{}", exe.display()))
        .arg("-warnaserror")
        .arg(out.join("Runtime/Lumen.cs"))
        .arg(out.join("Samples~/ScopeContacts/ScopeContacts.cs"))
        .arg(unity.join("tests/UnityEngine.cs"))
        .arg(unity.join("tests/SampleRunner.cs"))
        .output()
        .expect("running mcs (apt-get install mono-mcs mono-runtime)");
    assert!(compiled.status.success(), "mcs failed:\n{}{}", String::from_utf8_lossy(&compiled.stdout), String::from_utf8_lossy(&compiled.stderr));
    let daemon = Daemon::start(Path::new(LUMEN), &unique_prefix("unity"), None, &[]);
    let run = Command::new("mono").arg(&exe).args(["local", &daemon.prefix, "1000"]).env("LD_LIBRARY_PATH", out.join("Runtime/Plugins/x86_64")).output().expect("running mono");
    let stdout = expect(&run, &["sample: 1000 frames answered", "ok"]);
    eprintln!("{stdout}");
}

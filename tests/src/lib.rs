//! Helpers for Lumen's multi-process end-to-end tests (the tests themselves live in
//! `tests/e2e/`, registered as tests of `lumen-cli` so Cargo hands them the `lumen` binary; see
//! `tests/README.md`).
//!
//! - [`Daemon`]: a `lumen serve` child, killed when dropped.
//! - [`ChildProcess`]: any child (e.g. the test binary re-run as a client), killed when dropped.
//! - [`unique_prefix`], [`free_port`]: isolation between tests running at once.
//! - [`shm_files`]: what a prefix left in `/dev/shm`.
//! - [`build_c_example`]: a C example of `client/c/examples/` compiled against `liblumen_c.a`.
//! - [`TestScene`]: a small tube-and-rod scene whose rod presses into the wall, frame by frame.
//! - [`client_loop`], [`spawn_client_role`]: client processes to kill, and
//!   [`kill9_and_time_freeing`]: how soon the daemon frees a killed client's session.
//! - [`closed_sessions_reopen`]: a session ended under its client, on either transport.
//! - [`browser`]: a CDP driver for headless Chromium (pages, `eval`, screenshots, init scripts).
//! - [`snippet`]: a code block of a guide page, found by its `<!-- tested: NAME -->` marker.
//! - `guide` (doctests only): the root README and the guide's pages (`docs/guide/`), whose Rust
//!   snippets rustdoc compiles, and runs unless marked `no_run` (`cargo test -p lumen-e2e --doc`).

pub mod browser;
pub mod pki;

/// The root README and every page of the guide as doc comments, so that rustdoc compiles each
/// of their Rust code blocks (and runs those not marked `no_run`) as a doctest of this crate.
#[cfg(doctest)]
pub mod guide {
    #[doc = include_str!("../../README.md")]
    pub mod readme {}
    #[doc = include_str!("../../docs/guide/README.md")]
    pub mod index {}
    #[doc = include_str!("../../docs/guide/getting-started.md")]
    pub mod getting_started {}
    #[doc = include_str!("../../docs/guide/tube-model.md")]
    pub mod tube_model {}
    #[doc = include_str!("../../docs/guide/your-colon.md")]
    pub mod your_colon {}
    #[doc = include_str!("../../docs/guide/integrating.md")]
    pub mod integrating {}
    #[doc = include_str!("../../docs/guide/protocol.md")]
    pub mod protocol {}
    #[doc = include_str!("../../docs/guide/lab.md")]
    pub mod lab {}
    #[doc = include_str!("../../docs/guide/performance.md")]
    pub mod performance {}
}

/// A code block of a markdown file: the fenced block right after the line
/// `<!-- tested: NAME -->`, without its fences, and the file's line number of its first line.
/// Panics, naming the file, when the marker is missing or there twice, or no fenced block
/// follows it: the guide's tests then fail instead of testing nothing.
pub fn snippet(file: &Path, name: &str) -> (String, usize) {
    let text = std::fs::read_to_string(file).unwrap_or_else(|e| panic!("reading {}: {e}", file.display()));
    let marker = format!("<!-- tested: {name} -->");
    let lines: Vec<&str> = text.lines().collect();
    let at: Vec<usize> = lines.iter().enumerate().filter(|(_, l)| l.trim() == marker).map(|(i, _)| i).collect();
    assert_eq!(at.len(), 1, "{}: the marker {marker} should be there exactly once (found {})", file.display(), at.len());
    let fence = at[0] + 1;
    assert!(lines.get(fence).is_some_and(|l| l.starts_with("```")), "{}:{}: a fenced code block should follow {marker}", file.display(), fence + 1);
    let body: Vec<&str> = lines[fence + 1..].iter().take_while(|l| !l.starts_with("```")).copied().collect();
    assert!(fence + 1 + body.len() < lines.len(), "{}:{}: the code block after {marker} is never closed", file.display(), fence + 1);
    (body.join("\n") + "\n", fence + 2)
}

use lumen_detect::{ContactKind, Rod, Scene, Tube};
use lumen_proto::{Contact, SceneSpec};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver};
use std::time::{Duration, Instant};

/// An iceoryx2 prefix no other test (or run) uses: `lt<pid>_<tag>_`.
pub fn unique_prefix(tag: &str) -> String {
    static N: AtomicUsize = AtomicUsize::new(0);
    format!("lt{}x{}{}_", std::process::id(), N.fetch_add(1, Ordering::Relaxed), tag)
}

/// A TCP port free on loopback right now.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).map(|a| a.port()).expect("a free port")
}

/// Files in `/dev/shm` whose names start with `prefix`.
pub fn shm_files(prefix: &str) -> Vec<String> {
    std::fs::read_dir("/dev/shm").map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).filter(|n| n.starts_with(prefix)).collect()).unwrap_or_default()
}

/// Waits until `f` holds, up to `limit`; returns whether it did.
pub fn eventually(limit: Duration, mut f: impl FnMut() -> bool) -> bool {
    let end = Instant::now() + limit;
    loop {
        if f() {
            return true;
        }
        if Instant::now() > end {
            return false;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A child process with its stdout lines on a channel; killed (SIGKILL) and reaped on drop.
pub struct ChildProcess {
    pub child: Child,
    lines: Receiver<String>,
}

impl ChildProcess {
    /// Spawns `cmd` with stdout piped (stderr inherited).
    pub fn spawn(mut cmd: Command) -> Self {
        let mut child = cmd.stdout(Stdio::piped()).stderr(Stdio::inherit()).stdin(Stdio::piped()).spawn().expect("spawning a child");
        let stdout = child.stdout.take().expect("piped");
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Self { child, lines }
    }

    /// The next stdout line starting with `prefix` within `limit`.
    pub fn line_starting(&self, prefix: &str, limit: Duration) -> Option<String> {
        let end = Instant::now() + limit;
        loop {
            let left = end.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(l) if l.starts_with(prefix) => return Some(l),
                Ok(_) => continue,
                Err(_) => return None,
            }
        }
    }

    /// The session id a [`client_loop`] child prints once it has opened (within 20 s).
    pub fn session_id(&self) -> u64 {
        let line = self.line_starting("session ", Duration::from_secs(20)).expect("the child opened a session");
        line["session ".len()..].trim().parse().expect("a session id")
    }

    /// Sends a signal.
    pub fn signal(&self, sig: i32) {
        // SAFETY: signalling our own child.
        unsafe { libc::kill(self.child.id() as i32, sig) };
    }

    /// `kill -9` and reap.
    pub fn kill9(&mut self) {
        self.signal(libc::SIGKILL);
        let _ = self.child.wait();
    }

    /// Waits for the exit up to `limit`.
    pub fn wait_exit(&mut self, limit: Duration) -> Option<ExitStatus> {
        let end = Instant::now() + limit;
        while Instant::now() < end {
            if let Ok(Some(s)) = self.child.try_wait() {
                return Some(s);
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        None
    }

    /// Closes its stdin (children of these tests exit cleanly when it closes).
    pub fn close_stdin(&mut self) {
        drop(self.child.stdin.take());
    }
}

impl Drop for ChildProcess {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

/// A `lumen serve` child.
pub struct Daemon {
    pub process: ChildProcess,
    pub prefix: String,
    pub port: Option<u16>,
}

impl Daemon {
    /// Starts `bin serve --prefix PREFIX [--zenoh-listen tcp/127.0.0.1:PORT] EXTRA...` and waits
    /// for its ready line.
    pub fn start(bin: &Path, prefix: &str, port: Option<u16>, extra: &[&str]) -> Self {
        let mut cmd = Command::new(bin);
        cmd.args(["serve", "--prefix", prefix, "--log", "warn"]);
        if let Some(p) = port {
            cmd.args(["--zenoh-listen", &format!("tcp/127.0.0.1:{p}")]);
        }
        cmd.args(extra);
        let process = ChildProcess::spawn(cmd);
        assert!(process.line_starting("lumen serve: ready", Duration::from_secs(30)).is_some(), "the daemon did not get ready");
        Self { process, prefix: prefix.to_owned(), port }
    }

    /// The zenoh endpoint.
    pub fn endpoint(&self) -> String {
        format!("tcp/127.0.0.1:{}", self.port.expect("started with a port"))
    }

    /// SIGTERM; returns the exit status (within 10 s).
    pub fn terminate(mut self) -> Option<ExitStatus> {
        self.process.signal(libc::SIGTERM);
        self.process.wait_exit(Duration::from_secs(10))
    }
}

impl Drop for Daemon {
    /// Stops the daemon cleanly (SIGTERM, so it releases its shared memory; SIGKILL after 5 s),
    /// then, if nothing else of the prefix is left, removes iceoryx2's per-prefix node counter:
    /// test runs leave nothing in /dev/shm.
    fn drop(&mut self) {
        if let Ok(None) = self.process.child.try_wait() {
            self.process.signal(libc::SIGTERM);
            self.process.wait_exit(Duration::from_secs(5));
        }
        let left = shm_files(&self.prefix);
        if left.iter().all(|f| f.ends_with(".global_mgmt")) {
            for f in left {
                let _ = std::fs::remove_file(Path::new("/dev/shm").join(f));
            }
        }
    }
}

/// A straight tube (rings along x, radius 10) and a rod inside it that sways into the wall.
pub struct TestScene {
    pub spec: SceneSpec,
    rings: usize,
    spokes: usize,
    points: usize,
}

impl TestScene {
    /// A tube of `rings` x `spokes`, a rod of `points`, interior contacts.
    pub fn new(rings: usize, spokes: usize, points: usize) -> Self {
        let me = Self { spec: SceneSpec::new(vec![], vec![]), rings, spokes, points };
        let s = me.scene(0);
        Self { spec: s.spec(), ..me }
    }

    fn scene(&self, k: u64) -> Scene {
        let (rings, spokes, points) = (self.rings, self.spokes, self.points);
        let tube = Tube::new(
            (0..rings).map(|i| [i as f32 * 4.0, 0.0, 0.0]).collect(),
            (0..rings)
                .flat_map(|_| {
                    (0..spokes).map(move |j| {
                        let a = j as f32 * std::f32::consts::TAU / spokes as f32;
                        [0.0, 10.0 * a.cos(), 10.0 * a.sin()]
                    })
                })
                .collect(),
            spokes,
        )
        .expect("valid tube");
        let len = (rings - 1) as f32 * 4.0;
        let rod = Rod::new(
            (0..points)
                .map(|j| {
                    let x = 2.0 + j as f32 * (len - 4.0) / (points - 1) as f32;
                    [x, 9.0 * (j as f32 * 0.7 + k as f32 * 0.05).sin(), 3.0 * (k as f32 * 0.03).cos()]
                })
                .collect(),
            vec![1.5],
        )
        .expect("valid rod");
        Scene::new().tube("colon", tube).rod("scope", rod).pair("scope", "colon", ContactKind::Interior)
    }

    /// Frame `k`'s state.
    pub fn state(&self, k: u64) -> Vec<f32> {
        self.scene(k).state()
    }
}

/// Two contact lists are equal bit for bit (floats compared by their bits).
pub fn same_bits(a: &[Contact], b: &[Contact]) -> bool {
    let enc = |c: &[Contact]| {
        let mut v = Vec::new();
        for x in c {
            lumen_proto::wire::encode_contact(x, &mut v);
        }
        v
    };
    enc(a) == enc(b)
}

/// A client process's loop, for tests that kill clients: opens a session of `scene` through
/// `client` and submits frames until its stdin closes, printing `session ID` once (after a
/// newline: libtest has just printed "test NAME ... " without one) and `ok FRAME CONTACTS ID`
/// per reply. Errors go to stderr and the loop goes on (a session reopens by itself when a
/// daemon comes back).
pub fn client_loop(client: lumen_client::Client, scene: &TestScene) {
    let mut s = client.open_session(&scene.spec).expect("open");
    println!("\nsession {}", s.id());
    let stdin_closed = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flag = stdin_closed.clone();
    std::thread::spawn(move || {
        let mut sink = String::new();
        while std::io::stdin().read_line(&mut sink).map(|n| n > 0).unwrap_or(false) {}
        flag.store(true, Ordering::SeqCst);
    });
    let mut k = 0u64;
    while !stdin_closed.load(Ordering::SeqCst) {
        let state = scene.state(k);
        match s.submit_state(&state) {
            Ok(_) => match s.contacts(Duration::from_millis(500)) {
                Ok(r) => println!("ok {} {} {}", r.frame(), r.contacts().len(), s.id()),
                Err(e) => eprintln!("child: contacts: {e}"),
            },
            Err(e) => {
                eprintln!("child: submit: {e}");
                std::thread::sleep(Duration::from_millis(20));
            }
        }
        k += 1;
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// This test binary re-run as a client process in its test `role_test` (which calls
/// [`client_loop`] when `LUMEN_E2E_ROLE` is set), with extra environment `envs`.
pub fn spawn_client_role(role_test: &str, envs: &[(&str, &str)]) -> ChildProcess {
    let mut cmd = std::process::Command::new(std::env::current_exe().expect("the test binary"));
    cmd.args(["--exact", role_test, "--nocapture", "--test-threads", "1"]).env("LUMEN_E2E_ROLE", "loop");
    for (k, v) in envs {
        cmd.env(k, v);
    }
    ChildProcess::spawn(cmd)
}

/// Closes `s`'s session twice from `other` (a second client of the same daemon, with `s`'s
/// proof) and checks that
/// `s` says `Disconnected` each time, not a timeout, once from `contacts` and once from
/// `contacts_async`, and then reopens on its next frame with replies bit for bit equal to
/// `reference`'s. `s` has been answered already; frames 1 and 2 of `scene` are used.
pub fn closed_sessions_reopen(s: &mut lumen_client::Session, other: &lumen_client::Client, scene: &TestScene, reference: &mut lumen_detect::Detector) {
    use lumen_client::Error;
    use lumen_proto::session::{ControlReply, ControlRequest};
    const WAIT: Duration = Duration::from_secs(3);
    // The owner's proof, sent from another connection (a stranger's close is refused).
    let close = |request: ControlRequest| {
        assert!(matches!(other.request(&request), Ok(ControlReply::Closed { .. })));
        assert!(eventually(Duration::from_secs(3), || other.status().map(|st| st.sessions.is_empty()).unwrap_or(false)));
    };
    let submit = |s: &mut lumen_client::Session, k: u64| {
        s.frame().unwrap().copy_from_slice(&scene.state(k));
        s.submit().unwrap();
    };
    let mut reopened = |s: &mut lumen_client::Session, k: u64, reconnects: u64| {
        // A new session: a new secret, so a new proof (over zenoh the id may come back).
        let old = s.close_request();
        let again = (0..5)
            .find_map(|_| {
                submit(s, k);
                s.contacts(WAIT).map(|r| r.contacts().to_vec()).ok()
            })
            .expect("answered after reopening");
        assert!(same_bits(&again, reference.detect(&scene.state(k)).unwrap()));
        assert_ne!(s.close_request(), old, "a reopened session has a secret of its own");
        assert_eq!(s.reconnects(), reconnects);
    };
    close(s.close_request());
    submit(s, 1);
    let lost = s.contacts(WAIT).map(|_| ()).unwrap_err();
    assert!(matches!(lost, Error::Disconnected), "{lost:?}");
    reopened(s, 1, 1);
    close(s.close_request());
    submit(s, 2);
    let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(1).enable_all().build().unwrap();
    let lost = rt.block_on(async { s.contacts_async(WAIT).await.map(|_| ()) }).unwrap_err();
    assert!(matches!(lost, Error::Disconnected), "{lost:?}");
    reopened(s, 2, 2);
}

/// Kills `victim` (the client of `session`) with SIGKILL and waits up to 3 s for `status` to
/// list the session no more: how long after the kill it was freed, or the last status seen.
pub fn kill9_and_time_freeing(victim: &mut ChildProcess, status: &lumen_client::Client, session: u64) -> Result<Duration, String> {
    victim.kill9();
    let killed = Instant::now();
    let mut last = String::new();
    let freed = eventually(Duration::from_secs(3), || match status.status() {
        Ok(s) => {
            last = format!("sessions {:?}", s.sessions.iter().map(|x| x.session).collect::<Vec<_>>());
            s.sessions.iter().all(|x| x.session != session)
        }
        Err(e) => {
            last = format!("status failed: {e}");
            false
        }
    });
    if freed {
        Ok(killed.elapsed())
    } else {
        Err(last)
    }
}

/// `file` (`liblumen_c.a` or `liblumen_c.so`) as cargo built it for this test run (a dependency
/// with `staticlib` and `cdylib` crate types is built whole): in the `deps` folder the test
/// runs from, or the profile folder above.
pub fn lumen_c_library(file: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("the test's own path");
    let deps = exe.parent().expect("the deps folder");
    [deps, deps.parent().expect("the profile folder")]
        .iter()
        .map(|d| d.join(file))
        .find(|p| p.is_file())
        .unwrap_or_else(|| panic!("{file} is neither in {} nor above it: the test needs lumen-c as a dependency", deps.display()))
}

/// Compiles one of `client/c/examples/` with the system's C compiler (`$CC`, else `cc`),
/// warnings as errors, against `liblumen_c.a`, into `out_dir`; returns the program.
pub fn build_c_example(name: &str, out_dir: &Path) -> PathBuf {
    let c = Path::new(env!("CARGO_MANIFEST_DIR")).join("../client/c");
    let exe = out_dir.join(name);
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let built = Command::new(&cc)
        .args(["-std=c11", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O1", "-I"])
        .arg(c.join("include"))
        .arg(c.join(format!("examples/{name}.c")))
        .arg(lumen_c_library("liblumen_c.a"))
        // What the Rust standard library needs from the system (`rustc --print native-static-libs`).
        .args(["-lgcc_s", "-lutil", "-lrt", "-lpthread", "-lm", "-ldl", "-lc", "-o"])
        .arg(&exe)
        .output()
        .unwrap_or_else(|e| panic!("running {cc}: {e}"));
    assert!(built.status.success(), "{cc} failed on {name}.c:\n{}", String::from_utf8_lossy(&built.stderr));
    exe
}

/// A slow subscriber on `key` over `z` (zenoh's defaults), run as a client role: its callback
/// sleeps half a second per sample, as a careless recorder's might. Prints `subscribed` at start
/// and on a stdin line `on`, undeclares it and prints `paused` on `off`; when stdin closes,
/// prints `saw N` (the samples it got).
pub fn slow_subscriber(z: zenoh::Session, key: &str) {
    use zenoh::Wait;
    let saw = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let subscribe = || {
        let saw = saw.clone();
        z.declare_subscriber(key.to_owned())
            .callback(move |_| {
                saw.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                std::thread::sleep(Duration::from_millis(500));
            })
            .wait()
            .expect("subscribing")
    };
    let mut sub = Some(subscribe());
    println!("\nsubscribed"); // on a line of its own: the test harness left "test ... " open
    for line in std::io::stdin().lock().lines().map_while(Result::ok) {
        match line.trim() {
            "off" => {
                if let Some(s) = sub.take() {
                    s.undeclare().wait().expect("undeclaring");
                }
                println!("paused");
            }
            "on" => {
                sub.get_or_insert_with(subscribe);
                println!("subscribed");
            }
            _ => {}
        }
    }
    println!("saw {}", saw.load(std::sync::atomic::Ordering::Relaxed));
}

/// A colon-sized session's frame rate (frames per second of round trips) with `stranger`
/// ([`slow_subscriber`] in a child) subscribed and not, alternated five times: the medians
/// (alone, beside it). Then `before_it_ends` runs with the stranger still subscribed (and
/// asleep in its callback). Fails if the stranger saw fewer than 2 samples (it then proves
/// nothing).
pub fn rate_beside_a_slow_subscriber(client: &lumen_client::Client, mut stranger: ChildProcess, before_it_ends: impl FnOnce()) -> (f64, f64) {
    // The colonoscopy's size (485 KiB frames): a slow reader's link fills within frames.
    let scene = TestScene::new(1250, 32, 160);
    let mut s = client.open_session(&scene.spec).expect("open");
    let rate = |s: &mut lumen_client::Session, frames: u64| {
        let start = Instant::now();
        for k in 0..frames {
            s.frame().expect("frame").copy_from_slice(&scene.state(k));
            s.submit().expect("submit");
            s.contacts(Duration::from_secs(3)).expect("a reply within 3 s");
        }
        frames as f64 / start.elapsed().as_secs_f64()
    };
    rate(&mut s, 30); // warm-up
    assert!(stranger.line_starting("subscribed", Duration::from_secs(20)).is_some(), "the subscriber did not start");
    let say = |p: &mut ChildProcess, what: &str, ack: &str| {
        p.child.stdin.as_mut().expect("piped").write_all(format!("{what}\n").as_bytes()).expect("writing to the subscriber");
        assert!(p.line_starting(ack, Duration::from_secs(30)).is_some(), "the subscriber did not answer {what}");
        std::thread::sleep(Duration::from_millis(300)); // the (un)subscription reaches the daemon
    };
    let (mut alone, mut beside) = (Vec::new(), Vec::new());
    for _ in 0..5 {
        say(&mut stranger, "off", "paused");
        alone.push(rate(&mut s, 200));
        say(&mut stranger, "on", "subscribed");
        beside.push(rate(&mut s, 200));
    }
    drop(s);
    before_it_ends();
    stranger.close_stdin();
    let saw: usize = stranger.line_starting("saw ", Duration::from_secs(60)).expect("the subscriber's count")["saw ".len()..].trim().parse().expect("a count");
    assert!(saw >= 2, "the slow subscriber saw {saw} samples: the test proves nothing");
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[2]
    };
    let (alone, beside) = (median(&mut alone), median(&mut beside));
    eprintln!("session frame rate, medians of 5 alternated windows: {alone:.0}/s alone, {beside:.0}/s beside a subscriber that sleeps 0.5 s per sample");
    (alone, beside)
}

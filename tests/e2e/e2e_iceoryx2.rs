//! End-to-end over iceoryx2: the real `lumen` daemon as a child process, clients in this process
//! or in child processes (this test binary re-run in a client role). Each test has its own
//! iceoryx2 prefix.

use lumen_client::{Client, Error, LocalOptions, Observed};
use lumen_detect::Detector;
use lumen_e2e::{eventually, kill9_and_time_freeing, same_bits, shm_files, unique_prefix, ChildProcess, Daemon, TestScene};
use lumen_proto::wire::Status;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

const LUMEN: &str = env!("CARGO_BIN_EXE_lumen");
const WAIT: Duration = Duration::from_secs(3);

fn client(prefix: &str) -> Client {
    Client::local_with(LocalOptions { prefix: Some(prefix.into()), name: Some("e2e".into()) }).expect("local client")
}

fn scene() -> TestScene {
    TestScene::new(40, 16, 24)
}

/// This test binary re-run as a client process ([`lumen_e2e::client_loop`]).
#[test]
fn child_role() {
    if std::env::var("LUMEN_E2E_ROLE").is_ok() {
        lumen_e2e::client_loop(Client::local().expect("client"), &scene());
    }
}

/// Files the prefix left in /dev/shm, except iceoryx2's per-prefix node counter (16 bytes,
/// persistent by design: reused by the next start, never multiplied), which is then removed.
fn leftovers(prefix: &str) -> Vec<String> {
    let files: Vec<String> = shm_files(prefix).into_iter().filter(|f| !f.ends_with(".global_mgmt")).collect();
    if files.is_empty() {
        assert!(shm_files(prefix).len() <= 1);
        let cfg = lumen_transport::shm::config(Some(prefix)).unwrap();
        // SAFETY: every process of this prefix has ended.
        let _ = unsafe { iceoryx2::testing::remove_global_mgmt_segment::<iceoryx2::service::ipc::Service>(&cfg) };
    }
    files
}

fn spawn_client(prefix: &str) -> ChildProcess {
    lumen_e2e::spawn_client_role("child_role", &[("LUMEN_IOX2_PREFIX", prefix)])
}

#[test]
fn round_trip_matches_the_in_process_detector_bit_for_bit() {
    let prefix = unique_prefix("rt");
    let daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let scene = scene();
    let client = client(&prefix);
    let mut session = client.open_session(&scene.spec).unwrap();
    assert_eq!(session.layout().floats, 40 * 17 * 3 + 24 * 3);
    let mut reference = Detector::new(&scene.spec.validate().unwrap());
    let mut total = 0;
    for k in 0..40 {
        let state = scene.state(k);
        // Written in place into shared memory.
        session.frame().unwrap().copy_from_slice(&state);
        let n = session.submit().unwrap();
        assert_eq!(n, k);
        let reply = session.contacts(WAIT).unwrap();
        assert_eq!(reply.frame(), k);
        assert_eq!(reply.result(), Ok(()));
        let expected = reference.detect(&state).unwrap();
        assert_eq!(reply.contacts().len(), expected.len(), "frame {k}");
        assert!(same_bits(reply.contacts(), expected), "frame {k} differs");
        total += expected.len();
    }
    assert!(total > 40, "the scene should produce contacts: {total}");
    let status = client.status().unwrap();
    assert_eq!(status.sessions.len(), 1);
    assert_eq!(status.sessions[0].frames, 40);
    assert!(status.sessions[0].detect.p50_us > 0.0);
    drop(session);
    drop(client);
    assert_eq!(daemon.terminate().map(|s| s.success()), Some(true), "SIGTERM ends the daemon cleanly");
    assert!(eventually(WAIT, || leftovers(&prefix).is_empty()), "leftovers: {:?}", shm_files(&prefix));
    assert!(shm_files(&prefix).is_empty());
}

#[test]
fn invalid_specs_are_refused_with_a_reason() {
    let prefix = unique_prefix("bad");
    // Limits from a config file; the flag overrides the file's max_sessions.
    let cfg = std::env::temp_dir().join(format!("{prefix}lumen.toml"));
    std::fs::write(&cfg, "[limits]\nmax_sessions = 5\nmax_observers = 2\n").unwrap();
    let daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &["--config", cfg.to_str().unwrap(), "--max-sessions", "1"]);
    let client = client(&prefix);
    let mut spec = scene().spec;
    spec.pairs[0].b = "stomach".into();
    let e = client.open_session(&spec).err().expect("refused");
    assert_eq!(e.code(), Some(lumen_proto::session::ErrorCode::Spec));
    assert!(e.to_string().contains("stomach"), "{e}");
    let _one = client.open_session(&scene().spec).unwrap();
    let e = client.open_session(&scene().spec).err().expect("full");
    assert_eq!(e.code(), Some(lumen_proto::session::ErrorCode::Busy));
    assert_eq!(client.describe(_one.id()).unwrap().max_observers, 2);
    // Processes that only open the session's services (eight nodes) take no observer's place;
    // beyond max_observers an observer gets one error that names the limit.
    let info = client.describe(_one.id()).unwrap();
    let config = lumen_transport::shm::config(Some(&prefix)).unwrap();
    let openers: Vec<_> = (0..8)
        .map(|k| {
            let node = lumen_transport::shm::node(&config, &format!("opener{k}")).unwrap();
            let frame = lumen_transport::shm::open_frame(&node, &info.frame).unwrap_or_else(|e| panic!("opener {k}: {e}"));
            let contacts = lumen_transport::shm::open_contacts(&node, &info.contacts).unwrap_or_else(|e| panic!("opener {k}: {e}"));
            (frame, contacts, node)
        })
        .collect();
    let watcher = Client::local_with(LocalOptions { prefix: Some(prefix.clone()), name: None }).unwrap();
    let observers: Vec<_> = (0..2).map(|k| watcher.observe(_one.id()).unwrap_or_else(|e| panic!("observer {k} of 2: {e}"))).collect();
    match watcher.observe(_one.id()) {
        Err(Error::ObserversFull { session, max }) => assert_eq!((session, max), (_one.id(), 2)),
        Err(e) => panic!("a third observer: {e}"),
        Ok(_) => panic!("a third observer was admitted"),
    }
    drop((observers, openers));
    let none = unique_prefix("none");
    let e = Client::local_with(LocalOptions { prefix: Some(none.clone()), name: None }).unwrap().open_session(&scene().spec).err().unwrap();
    assert!(matches!(e, Error::NoDaemon { .. }), "{e}");
    assert!(leftovers(&none).is_empty(), "a client alone leaves nothing: {:?}", shm_files(&none));
    drop(_one);
    // SIGINT stops it cleanly too.
    let mut daemon = daemon;
    daemon.process.signal(libc::SIGINT);
    assert!(daemon.process.wait_exit(WAIT).is_some_and(|s| s.success()));
    let _ = std::fs::remove_file(cfg);
}

#[test]
fn two_sessions_and_an_observer() {
    let prefix = unique_prefix("obs");
    let _daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let scene = scene();
    let client = client(&prefix);
    let mut a = client.open_session(&scene.spec).unwrap();
    let mut b = client.open_session(&scene.spec).unwrap();
    assert_ne!(a.id(), b.id());
    // `lumen status` (the CLI, another process) lists both.
    let out = Command::new(LUMEN).args(["status", "--prefix", &prefix, "--json"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: lumen_proto::session::StatusReport = serde_json::from_slice(&out.stdout).unwrap();
    let mut ids: Vec<u64> = report.sessions.iter().map(|s| s.session).collect();
    ids.sort();
    let mut want = vec![a.id(), b.id()];
    want.sort();
    assert_eq!(ids, want);
    let table = Command::new(LUMEN).args(["status", "--prefix", &prefix]).output().unwrap();
    assert!(String::from_utf8_lossy(&table.stdout).contains(&a.id().to_string()));
    let watcher = self::client(&prefix);
    let mut obs = watcher.observe(a.id()).unwrap();
    assert_eq!(obs.info().session, a.id());
    let (mut frames_seen, mut replies_seen) = (Vec::new(), Vec::new());
    for k in 0..20 {
        a.submit_state(&scene.state(k)).unwrap();
        b.submit_state(&scene.state(k + 100)).unwrap();
        let ra = a.contacts(WAIT).unwrap().contacts().to_vec();
        let rb = b.contacts(WAIT).unwrap();
        assert_eq!(rb.frame(), k);
        // The observer sees this frame and this reply (it never sees b's).
        let mut got = (false, false);
        while got != (true, true) {
            match obs.next(WAIT).unwrap() {
                Observed::Frame { header, state } => {
                    assert_eq!(header.session, a.id());
                    if header.frame == k {
                        assert_eq!(state, &scene.state(k)[..]);
                        got.0 = true;
                    }
                    frames_seen.push(header.frame);
                }
                Observed::Contacts(r) => {
                    assert_eq!(r.header().session, a.id());
                    if r.frame() == k {
                        assert!(same_bits(r.contacts(), &ra));
                        got.1 = true;
                    }
                    replies_seen.push(r.frame());
                }
            }
        }
    }
    assert!(frames_seen.contains(&19) && replies_seen.contains(&19));
    // The observer's session ends when its client leaves.
    drop(a);
    assert!(matches!(obs.next(WAIT), Err(Error::SessionEnded(_)) | Ok(_)));
}

/// What an observer of every frame sees after its session ran ahead of it.
fn drained(obs: &mut lumen_client::Observer) -> (Vec<(u64, Vec<f32>)>, Vec<u64>) {
    let (mut frames, mut replies) = (Vec::new(), Vec::new());
    loop {
        match obs.next(Duration::from_millis(300)) {
            Ok(Observed::Frame { header, state }) => frames.push((header.frame, state.to_vec())),
            Ok(Observed::Contacts(r)) => replies.push(r.frame()),
            Err(Error::Timeout(_)) => return (frames, replies),
            Err(e) => panic!("observing: {e}"),
        }
    }
}

#[test]
fn an_observer_of_every_frame_keeps_sixteen_behind_and_the_newest_observer_skips_to_the_last() {
    const KEPT: u64 = lumen_transport::shm::FRAME_BUFFER as u64;
    assert_eq!(KEPT, 16, "proto/README.md promises 16");
    let prefix = unique_prefix("every");
    let _daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let scene = scene();
    let client = client(&prefix);
    let mut a = client.open_session(&scene.spec).unwrap();
    let watcher = self::client(&prefix);
    let mut every = watcher.observe(a.id()).unwrap();
    every.every_frame();
    let mut newest = watcher.observe(a.id()).unwrap();
    let mut run = |frames: std::ops::Range<u64>| {
        for k in frames {
            a.submit_state(&scene.state(k)).unwrap();
            assert_eq!(a.contacts(WAIT).unwrap().frame(), k);
        }
    };
    // Sixteen frames while neither observer reads: every one is kept, in order, with its reply.
    run(0..KEPT);
    let (frames, replies) = drained(&mut every);
    assert_eq!(frames.iter().map(|f| f.0).collect::<Vec<_>>(), (0..KEPT).collect::<Vec<_>>());
    for (k, state) in &frames {
        assert_eq!(state, &scene.state(*k), "frame {k}");
    }
    assert_eq!(replies, (0..KEPT).collect::<Vec<_>>());
    let (frames, _) = drained(&mut newest);
    assert_eq!(frames.iter().map(|f| f.0).collect::<Vec<_>>(), [KEPT - 1]);
    // Twenty more: the client never waited for the observers; they keep the newest sixteen.
    run(KEPT..2 * KEPT + 4);
    let (frames, replies) = drained(&mut every);
    assert_eq!(frames.iter().map(|f| f.0).collect::<Vec<_>>(), (KEPT + 4..2 * KEPT + 4).collect::<Vec<_>>());
    assert_eq!(replies, (KEPT + 4..2 * KEPT + 4).collect::<Vec<_>>());
    let (frames, _) = drained(&mut newest);
    assert_eq!(frames.iter().map(|f| f.0).collect::<Vec<_>>(), [2 * KEPT + 3]);
}

#[test]
fn a_bad_frame_among_good_ones_gets_an_error_and_the_session_goes_on() {
    let prefix = unique_prefix("badf");
    let _daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let scene = scene();
    let client = client(&prefix);
    let mut s = client.open_session(&scene.spec).unwrap();
    let mut reference = Detector::new(&scene.spec.validate().unwrap());
    for k in 0..12u64 {
        let mut state = scene.state(k);
        let expect_ok = match k {
            3 => {
                state[(3 * 17 + 1 + 5) * 3 + 1] = f32::NAN; // tube ring 3, spoke 5, y
                false
            }
            4 => {
                state[40 * 17 * 3 + 5 * 3 + 1] = 1e30; // rod point 5, y: finite, but far beyond the range
                false
            }
            6 => {
                state[40 * 17 * 3 + 2 * 3] = f32::INFINITY; // rod point 2, x
                false
            }
            _ => true,
        };
        s.frame().unwrap().copy_from_slice(&state);
        match k {
            8 => s.submit_with(|h| h.version = 99).unwrap(),
            9 => s.submit_with(|h| h.bodies = 3).unwrap(),
            10 => s.submit_with(|h| h.session += 1).unwrap(),
            _ => s.submit().unwrap(),
        };
        let r = s.contacts(WAIT).unwrap();
        assert_eq!(r.frame(), k);
        let h = *r.header();
        match k {
            3 => {
                assert_eq!(r.result().unwrap_err().0, Status::NonFinite);
                assert_eq!((h.error_body, h.error_index, h.error_spoke), (0, 3, 5));
                assert!(h.message().contains("ring 3"), "{}", h.message());
            }
            4 => {
                assert_eq!(r.result().unwrap_err().0, Status::OutOfRange);
                assert_eq!((h.error_body, h.error_index, h.error_spoke, r.contacts().len()), (1, 5, u32::MAX, 0));
                assert!(h.message().contains("beyond the 1e9"), "{}", h.message());
            }
            6 => {
                assert_eq!(r.result().unwrap_err().0, Status::NonFinite);
                assert_eq!((h.error_body, h.error_index, h.error_spoke), (1, 2, u32::MAX));
            }
            8 => assert_eq!(r.result().unwrap_err().0, Status::BadVersion),
            9 => assert_eq!(r.result().unwrap_err().0, Status::BadCounts),
            10 => assert_eq!(r.result().unwrap_err().0, Status::BadSession),
            _ => {
                assert!(expect_ok);
                assert_eq!(r.result(), Ok(()));
                assert!(same_bits(r.contacts(), reference.detect(&state).unwrap()), "frame {k}");
            }
        }
    }
    // The daemon counts a frame just after sending its reply: wait for the count to settle.
    let counts = || client.status().ok().and_then(|st| st.sessions.first().map(|v| (v.frames, v.bad_frames)));
    lumen_e2e::eventually(Duration::from_secs(3), || counts() == Some((12, 6)));
    assert_eq!(counts(), Some((12, 6)));
}

/// Set `LUMEN_DEBUG_HANG=1` to keep a failing run's daemon alive for a minute (its pid is
/// printed) so it can be inspected: `gdb -p PID -batch -ex 'thread apply all bt'`.
fn hold_for_debugging(daemon: &Daemon) {
    if std::env::var_os("LUMEN_DEBUG_HANG").is_some() {
        eprintln!("LUMEN_DEBUG_HANG: daemon pid {}", daemon.process.child.id());
        std::thread::sleep(Duration::from_secs(60));
    }
}

#[test]
fn a_killed_client_is_noticed_within_a_second_and_others_go_on() {
    let prefix = unique_prefix("k9c");
    let daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let mut victim = spawn_client(&prefix);
    let mut survivor = spawn_client(&prefix);
    let victim_id: u64 = victim.session_id();
    survivor.session_id();
    assert!(victim.line_starting("ok ", WAIT).is_some() && survivor.line_starting("ok ", WAIT).is_some());
    let status = client(&prefix);
    assert_eq!(status.status().unwrap().sessions.len(), 2);
    let noticed = kill9_and_time_freeing(&mut victim, &status, victim_id).unwrap_or_else(|last| {
        hold_for_debugging(&daemon);
        panic!("the dead client's session {victim_id} was not freed; last status: {last}")
    });
    eprintln!("kill -9 of a client: session freed after {noticed:?}");
    assert!(noticed < Duration::from_millis(1500), "noticed after {noticed:?}");
    // The survivor keeps getting replies.
    for _ in 0..10 {
        assert!(survivor.line_starting("ok ", WAIT).is_some());
    }
    survivor.close_stdin();
    assert!(survivor.wait_exit(Duration::from_secs(10)).is_some());
    // The victim's shared memory is cleaned up by the daemon.
    assert!(eventually(Duration::from_secs(3), || status.status().map(|s| s.sessions.is_empty()).unwrap_or(false)));
}

/// A race, since fixed: a client killed within its session's first tick (100 ms) had
/// never been seen "present", so its session took it for one not yet attached and waited out
/// the 5 s connect grace. Here the kill follows the first reply at once, every time.
#[test]
fn a_client_killed_before_its_sessions_first_tick_is_noticed() {
    let prefix = unique_prefix("k9early");
    let daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let status = client(&prefix);
    let mut victim = spawn_client(&prefix);
    let id: u64 = victim.session_id();
    assert!(victim.line_starting("ok ", WAIT).is_some());
    let noticed = kill9_and_time_freeing(&mut victim, &status, id).unwrap_or_else(|last| {
        hold_for_debugging(&daemon);
        panic!("session {id}, whose client died at once, was not freed; last status: {last}")
    });
    eprintln!("kill -9 right after the first reply: session freed after {noticed:?}");
    assert!(noticed < Duration::from_millis(1500), "noticed after {noticed:?}");
    drop(status);
    assert_eq!(daemon.terminate().map(|s| s.success()), Some(true));
    assert!(eventually(WAIT, || leftovers(&prefix).is_empty()), "leftovers: {:?}", shm_files(&prefix));
}

#[test]
fn daemon_killed_and_restarted_clients_resume_and_nothing_is_left() {
    let prefix = unique_prefix("k9d");
    let daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let mut client_proc = spawn_client(&prefix);
    let first: u64 = client_proc.session_id();
    assert!(client_proc.line_starting("ok ", WAIT).is_some());
    let mut daemon = daemon;
    daemon.process.kill9();
    std::thread::sleep(Duration::from_millis(300));
    let daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    // The client reopens by itself: replies come again, under a new session id.
    let restarted = Instant::now();
    let deadline = restarted + Duration::from_secs(10);
    let mut resumed = false;
    while !resumed && Instant::now() < deadline {
        // Read every line (the backlog from before the kill included) until one of the new session.
        resumed = client_proc.line_starting("ok ", Duration::from_secs(1)).is_some_and(|l| l.split(' ').nth(3).is_some_and(|id| id.parse::<u64>().unwrap() != first));
    }
    assert!(resumed, "the client did not resume");
    eprintln!("daemon kill -9 + restart: client resumed {:?} after the new daemon was ready", restarted.elapsed());
    client_proc.close_stdin();
    assert!(client_proc.wait_exit(Duration::from_secs(10)).is_some_and(|s| s.success()));
    assert_eq!(daemon.terminate().map(|s| s.success()), Some(true));
    assert!(eventually(WAIT, || leftovers(&prefix).is_empty()), "leftovers: {:?}", shm_files(&prefix));
    assert!(shm_files(&prefix).is_empty());
}

#[test]
fn async_replies_match_the_blocking_ones_and_time_out() {
    let prefix = unique_prefix("async");
    let _daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let scene = scene();
    let client = client(&prefix);
    let mut s = client.open_session(&scene.spec).unwrap();
    let mut reference = Detector::new(&scene.spec.validate().unwrap());
    let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(1).enable_all().build().unwrap();
    rt.block_on(async {
        for k in 0..20u64 {
            let state = scene.state(k);
            s.frame().unwrap().copy_from_slice(&state);
            s.submit().unwrap();
            let r = s.contacts_async(WAIT).await.unwrap();
            assert_eq!(r.frame(), k);
            assert!(same_bits(r.contacts(), reference.detect(&state).unwrap()), "frame {k}");
        }
        // Nothing submitted: the wait ends with a timeout, not a reply.
        let quiet = s.contacts_async(Duration::from_millis(300)).await;
        assert!(matches!(quiet, Err(Error::Timeout(_))), "{:?}", quiet.map(|r| r.frame()));
    });
}

#[test]
fn a_session_ended_under_its_client_is_reopened_on_the_next_frame() {
    // As over zenoh: a session closed from elsewhere takes its contacts publisher with it, so
    // the client says `Disconnected` instead of timing out for ever, and reopens on the next
    // frame; blocking and async alike.
    let prefix = unique_prefix("reopen");
    let _daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let scene = scene();
    let (mine, other) = (client(&prefix), client(&prefix));
    let mut s = mine.open_session(&scene.spec).unwrap();
    let mut reference = Detector::new(&scene.spec.validate().unwrap());
    s.frame().unwrap().copy_from_slice(&scene.state(0));
    s.submit().unwrap();
    assert!(same_bits(s.contacts(WAIT).unwrap().contacts(), reference.detect(&scene.state(0)).unwrap()));
    lumen_e2e::closed_sessions_reopen(&mut s, &other, &scene, &mut reference);
}

/// `close` answers once the slot is free: with room for one session, a session closed and
/// reopened at once is never refused as busy.
#[test]
fn a_closed_sessions_slot_is_free_when_the_close_is_answered() {
    let prefix = unique_prefix("reopen");
    let _daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &["--max-sessions", "1"]);
    let client = client(&prefix);
    let scene = scene();
    for k in 0..30 {
        let s = client.open_session(&scene.spec).unwrap_or_else(|e| panic!("cycle {k}: {e}"));
        s.close().unwrap_or_else(|e| panic!("cycle {k}: {e}"));
    }
}

#[test]
fn a_strangers_publisher_and_peer_died_events_change_nothing() {
    // Before: over iceoryx2 a process could take a session's one frame-publisher slot, and
    // its "a peer died" event ended the session. The frame channel now admits spare publishers,
    // the daemon answers only the publisher of the node that opened the session (others are
    // counted as forged), and a peer-died event makes it look at its client, not end it.
    let prefix = unique_prefix("istr");
    let _daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let scene = scene();
    let owner = client(&prefix);
    let mut s = owner.open_session(&scene.spec).unwrap();
    let mut reference = Detector::new(&scene.spec.validate().unwrap());
    let mut round_trip = |s: &mut lumen_client::Session, k: u64| {
        s.submit_state(&scene.state(k)).unwrap();
        let r = s.contacts(WAIT).unwrap();
        assert_eq!((r.frame(), r.result()), (k, Ok(())), "the owner's own reply");
        assert!(same_bits(r.contacts(), reference.detect(&scene.state(k)).unwrap()), "frame {k}");
    };
    round_trip(&mut s, 0);
    let config = lumen_transport::shm::config(Some(&prefix)).unwrap();
    let node = lumen_transport::shm::node(&config, "stranger").unwrap();
    let (frame, event) = lumen_transport::shm::open_frame(&node, &s.info().frame).unwrap();
    let floats = s.layout().floats;
    let publisher = frame.publisher_builder().initial_max_slice_len(floats).create().expect("a second publisher is admitted");
    let notifier = event.notifier_builder().create().expect("a second notifier is admitted");
    for k in 0..5u64 {
        let mut sample = publisher.loan_slice_uninit(floats).unwrap();
        *sample.user_header_mut() = lumen_proto::wire::FrameHeader::new(s.id(), (1 << 62) + k, 0, floats, 2);
        sample.write_from_fn(|_| 0.0).send().unwrap();
        notifier.notify_with_custom_event_id(lumen_transport::shm::EVENT_SENT).unwrap();
    }
    notifier.notify_with_custom_event_id(lumen_transport::shm::EVENT_PEER_DIED).unwrap();
    std::thread::sleep(Duration::from_millis(300));
    assert!(s.try_contacts().unwrap().is_none(), "nothing answered the stranger's frames");
    for k in 1..20 {
        round_trip(&mut s, k);
    }
    let status = || owner.status().unwrap().sessions.into_iter().find(|x| x.session == s.id());
    assert!(eventually(WAIT, || status().is_some_and(|x| x.frames == 20)), "the session lives on");
    let st = status().unwrap();
    // Each publisher's queue holds its newest frame only, so of the five sent back to back some
    // are overwritten before the daemon looks: it counts those it saw and answers none.
    assert_eq!((st.frames, st.bad_frames), (20, 0));
    assert!((1..=5).contains(&st.forged), "forged {}", st.forged);
}

/// One daemon a prefix: a second `lumen serve` on a prefix a live daemon serves refuses to
/// start, naming the prefix (two would each answer some opens); once that daemon is killed,
/// one starts there again.
#[test]
fn a_second_daemon_on_a_served_prefix_refuses_to_start() {
    let prefix = unique_prefix("twice");
    let mut first = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let out = Command::new(LUMEN).args(["serve", "--prefix", &prefix]).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "a second daemon started: {stderr}");
    assert!(stderr.contains(&format!("another Lumen daemon already serves iceoryx2 prefix {prefix:?}")), "{stderr}");
    // The first one still serves.
    let mut s = client(&prefix).open_session(&scene().spec).unwrap();
    s.frame().unwrap().copy_from_slice(&scene().state(0));
    s.submit().unwrap();
    assert!(s.contacts(WAIT).unwrap().result().is_ok());
    drop(s);
    first.process.kill9();
    let _second = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
}

/// This test binary re-run as a client that opens a session (its frame publisher made with it),
/// prints `session <id>`, and then waits, sending nothing, until it is killed.
#[test]
fn open_and_wait_role() {
    if std::env::var("LUMEN_E2E_ROLE").is_ok() {
        let s = Client::local().expect("client").open_session(&scene().spec).expect("open");
        println!("\nsession {}", s.id());
        let _ = std::io::stdin().read_line(&mut String::new());
    }
}

/// Clients killed right after they open, before the daemon's tick sees their frame publisher
/// (iceoryx2's cleanup may then remove it first): each session is still freed within a
/// second and a half, not after the 5 s a client that never attaches is given.
#[test]
fn clients_killed_right_after_they_open_are_freed_within_a_second() {
    let prefix = unique_prefix("early");
    let _daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let status = client(&prefix);
    for round in 0..6 {
        let mut victim = lumen_e2e::spawn_client_role("open_and_wait_role", &[("LUMEN_IOX2_PREFIX", prefix.as_str())]);
        let id = victim.session_id();
        let noticed = kill9_and_time_freeing(&mut victim, &status, id).unwrap_or_else(|last| panic!("round {round}: session {id} not freed; last status: {last}"));
        eprintln!("round {round}: killed right after opening, freed after {noticed:?}");
        assert!(noticed < Duration::from_millis(1500), "round {round}: freed after {noticed:?}");
    }
}

//! End-to-end over zenoh (TCP loopback): the real daemon as a child process with its own port
//! and iceoryx2 prefix; clients in this process, or in child processes (this test binary re-run
//! in a client role) where a test kills them.

use lumen_client::{Client, Observed};
use lumen_detect::Detector;
use lumen_e2e::{free_port, same_bits, unique_prefix, Daemon, TestScene};
use lumen_proto::auth::Secret;
use lumen_proto::session::{ControlReply, ControlRequest, ErrorCode};
use lumen_proto::wire::{encode_contacts, encode_frame, ContactsHeader, FrameHeader, Status, FRAME_HEADER_BYTES};
use std::path::Path;
use std::time::Duration;
use zenoh::Wait;

const LUMEN: &str = env!("CARGO_BIN_EXE_lumen");
const WAIT: Duration = Duration::from_secs(3);

/// This test binary re-run as a zenoh client process ([`lumen_e2e::client_loop`]) of the daemon
/// at `LUMEN_E2E_ENDPOINT`.
#[test]
fn child_role() {
    if let (Ok(_), Ok(endpoint)) = (std::env::var("LUMEN_E2E_ROLE"), std::env::var("LUMEN_E2E_ENDPOINT")) {
        lumen_e2e::client_loop(Client::zenoh(&endpoint).expect("client"), &TestScene::new(40, 16, 24));
    }
}

/// This test binary re-run as a deliberately slow observer of session `LUMEN_E2E_OBSERVE`,
/// written from `proto/README.md` section 4 with raw zenoh as a foreign client would: takes a
/// place with `{"op":"observe"}`, then asks for newer frames with zenoh's default query
/// settings (congestion control block) and sleeps half a second per answer it gets, as a
/// careless VR front-end might; checks each answer is a frame and the daemon's reply to it.
/// Asks and prints `observing` at start and on a stdin line `on`, stops asking and prints
/// `paused` on `off`; when stdin closes, prints `saw N` (the answers it got) and ends.
#[test]
fn slow_observer_role() {
    let (Ok(endpoint), Ok(session)) = (std::env::var("LUMEN_E2E_ENDPOINT"), std::env::var("LUMEN_E2E_OBSERVE")) else { return };
    let config = lumen_transport::net::config("client", &[], &[endpoint]).unwrap();
    let z = zenoh::open(config).wait().unwrap();
    let place = || {
        let json = format!("{{\"op\":\"observe\",\"session\":{session}}}");
        let reply = z.get("lumen/control").payload(json).wait().unwrap().recv().unwrap();
        let v: serde_json::Value = serde_json::from_slice(&reply.result().unwrap().payload().to_bytes()).unwrap();
        assert_eq!(v["reply"], "observing", "{v}");
        v["observer"].as_str().unwrap().to_owned()
    };
    let mut token = place();
    let (lines, stdin) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::BufRead::lines(std::io::stdin().lock()).map_while(Result::ok) {
            let _ = lines.send(line);
        }
    });
    let (mut asking, mut after, mut saw) = (true, 0u64, 0usize);
    println!("\nobserving"); // on a line of its own: the test harness left "test ... " open
    loop {
        match stdin.try_recv() {
            Ok(line) if line.trim() == "on" => {
                asking = true;
                println!("observing");
            }
            Ok(line) if line.trim() == "off" => {
                asking = false;
                println!("paused");
            }
            Ok(_) => {}
            Err(std::sync::mpsc::TryRecvError::Empty) => {}
            Err(std::sync::mpsc::TryRecvError::Disconnected) => break,
        }
        if !asking {
            std::thread::sleep(Duration::from_millis(20));
            continue;
        }
        let replies = z.get(format!("lumen/session/{session}/observe?observer={token};after={after}")).wait().unwrap();
        while let Ok(reply) = replies.recv() {
            match reply.result() {
                Ok(sample) => {
                    // The frame, then the daemon's reply to it, split at the attachment's length.
                    let bytes = sample.payload().to_bytes();
                    let split = u64::from_le_bytes(sample.attachment().unwrap().to_bytes()[..].try_into().unwrap()) as usize;
                    assert_eq!((&bytes[..4], &bytes[split..split + 4]), (&b"LMNF"[..], &b"LMNC"[..]));
                    after = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
                    assert_eq!(u64::from_le_bytes(bytes[split + 16..split + 24].try_into().unwrap()), after, "the reply is to the frame");
                    saw += 1;
                    std::thread::sleep(Duration::from_millis(500));
                }
                // The place lapsed while paused: take another.
                Err(_) => token = place(),
            }
        }
    }
    println!("saw {saw}");
}

/// Frames per second of `frames` round trips of session `s`.
fn frame_rate(s: &mut lumen_client::Session, scene: &TestScene, frames: u64) -> f64 {
    let start = std::time::Instant::now();
    for k in 0..frames {
        s.frame().unwrap().copy_from_slice(&scene.state(k));
        s.submit().unwrap();
        s.contacts(WAIT).unwrap();
    }
    frames as f64 / start.elapsed().as_secs_f64()
}

#[test]
fn a_slow_observer_does_not_slow_the_client() {
    let d = daemon("zslow");
    let scene = TestScene::new(40, 16, 24);
    let client = Client::zenoh(&d.endpoint()).unwrap();
    let mut s = client.open_session(&scene.spec).unwrap();
    frame_rate(&mut s, &scene, 50); // warm-up
    let id = s.id().to_string();
    let endpoint = d.endpoint();
    let mut observer = lumen_e2e::spawn_client_role("slow_observer_role", &[("LUMEN_E2E_ENDPOINT", endpoint.as_str()), ("LUMEN_E2E_OBSERVE", id.as_str())]);
    assert!(observer.line_starting("observing", Duration::from_secs(20)).is_some(), "the observer did not start");
    // Alone and watched, alternated three times (the other tests of this binary share the
    // cores and come and go): the medians are compared.
    let say = |observer: &mut lumen_e2e::ChildProcess, what: &str, ack: &str| {
        std::io::Write::write_all(observer.child.stdin.as_mut().expect("piped"), format!("{what}\n").as_bytes()).unwrap();
        assert!(observer.line_starting(ack, Duration::from_secs(10)).is_some(), "the observer did not answer {what}");
        std::thread::sleep(Duration::from_millis(300)); // the (un)subscription reaches the daemon
    };
    let (mut alone, mut watched) = (Vec::new(), Vec::new());
    for _ in 0..3 {
        say(&mut observer, "off", "paused");
        alone.push(frame_rate(&mut s, &scene, 200));
        say(&mut observer, "on", "observing");
        watched.push(frame_rate(&mut s, &scene, 200));
    }
    observer.close_stdin();
    let saw: usize = observer.line_starting("saw ", Duration::from_secs(10)).expect("the observer's count")["saw ".len()..].trim().parse().unwrap();
    assert!(saw >= 2, "the slow observer saw {saw} samples: the test proves nothing");
    assert!(observer.wait_exit(Duration::from_secs(10)).is_some());
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[1]
    };
    let (alone, watched) = (median(&mut alone), median(&mut watched));
    eprintln!("client frame rate, medians of 3 alternated windows: {alone:.0}/s alone, {watched:.0}/s beside an observer that sleeps 0.5 s per sample");
    // Before observers asked for frames (the daemon published them): 485 frames/s fell to 15.
    assert!(watched > 0.5 * alone, "{watched:.0}/s beside the slow observer, {alone:.0}/s alone");
}

/// Frames travel with congestion control *drop*, yet a client that waits for each reply loses
/// none of its own: 1,000 colon-sized frames (485 KiB), every one answered, none skipped.
#[test]
fn a_thousand_colon_sized_frames_are_all_answered() {
    let d = daemon("zthousand");
    let scene = TestScene::new(1250, 32, 160);
    let client = Client::zenoh(&d.endpoint()).unwrap();
    let mut s = client.open_session(&scene.spec).unwrap();
    let mut skipped = 0u64;
    for k in 0..1000 {
        s.frame().unwrap().copy_from_slice(&scene.state(k));
        let sent = s.submit().unwrap();
        let reply = s.contacts(WAIT).unwrap_or_else(|e| panic!("frame {sent} unanswered: {e}"));
        assert_eq!(reply.frame(), sent);
        skipped += reply.header().skipped as u64;
    }
    assert_eq!(skipped, 0, "frames lost on the way");
}

/// A client role: a stranger's slow raw subscriber ([`lumen_e2e::slow_subscriber`]).
#[test]
fn slow_subscriber_role() {
    let (Ok(endpoint), Ok(key)) = (std::env::var("LUMEN_E2E_ENDPOINT"), std::env::var("LUMEN_E2E_SUBSCRIBE")) else { return };
    lumen_e2e::slow_subscriber(zenoh::open(lumen_transport::net::config("client", &[], &[endpoint]).unwrap()).wait().unwrap(), &key);
}

/// A stranger subscribed to every key (`lumen/**`) that reads half a sample a second costs the
/// sessions nothing measurable: a colon-sized session's frame rate with it subscribed and not,
/// alternated five times, medians compared.
#[test]
fn a_slow_raw_subscriber_does_not_slow_the_sessions() {
    let d = daemon("zslowsub");
    let endpoint = d.endpoint();
    let client = Client::zenoh(&endpoint).unwrap();
    let stranger = lumen_e2e::spawn_client_role("slow_subscriber_role", &[("LUMEN_E2E_ENDPOINT", endpoint.as_str()), ("LUMEN_E2E_SUBSCRIBE", "lumen/**")]);
    // The daemon stops promptly on SIGTERM with the stranger still subscribed and asleep.
    let mut stopped = None;
    let (alone, beside) = lumen_e2e::rate_beside_a_slow_subscriber(&client, stranger, || {
        let t0 = std::time::Instant::now();
        let status = d.terminate();
        stopped = Some((t0.elapsed(), status));
    });
    let (took, status) = stopped.expect("stopped");
    assert_eq!(status.map(|s| s.success()), Some(true), "the daemon's exit");
    // Under the rest of the suite it took up to 2.6 s; held by zenoh's 5 s block wait, 6 s.
    assert!(took < Duration::from_secs(4), "the daemon took {took:?} to stop on SIGTERM beside a slow subscriber");
    // Measured 0.82 to 1.03 of alone on the development VM, whose two cores carry the daemon,
    // the client and the subscriber (0.75 with the rest of the suite running beside it); with
    // congestion control *block* it was 0.02, or replies stopped coming.
    assert!(beside > 0.5 * alone, "{beside:.0}/s beside the slow subscriber, {alone:.0}/s alone");
}

#[test]
fn a_killed_zenoh_client_is_noticed_within_a_second_and_others_go_on() {
    let d = daemon("zk9");
    let endpoint = d.endpoint();
    let spawn = || lumen_e2e::spawn_client_role("child_role", &[("LUMEN_E2E_ENDPOINT", endpoint.as_str())]);
    let (mut victim, mut survivor) = (spawn(), spawn());
    let victim_id: u64 = victim.session_id();
    survivor.session_id();
    assert!(victim.line_starting("ok ", WAIT).is_some() && survivor.line_starting("ok ", WAIT).is_some());
    let status = Client::zenoh(&endpoint).unwrap();
    assert_eq!(status.status().unwrap().sessions.len(), 2);
    let noticed = lumen_e2e::kill9_and_time_freeing(&mut victim, &status, victim_id).unwrap_or_else(|last| panic!("the dead client's session {victim_id} was not freed; last status: {last}"));
    eprintln!("kill -9 of a zenoh client: session freed after {noticed:?}");
    assert!(noticed < Duration::from_millis(1500), "noticed after {noticed:?}");
    for _ in 0..10 {
        assert!(survivor.line_starting("ok ", WAIT).is_some(), "the other client stopped getting replies");
    }
    survivor.close_stdin();
    assert!(survivor.wait_exit(Duration::from_secs(10)).is_some());
    assert!(lumen_e2e::eventually(Duration::from_secs(3), || status.status().map(|s| s.sessions.is_empty()).unwrap_or(false)));
}

#[test]
fn a_session_ended_under_its_client_is_reopened_on_the_next_frame() {
    // A session can end on the daemon without the client hearing of it (a TLS link that drops
    // and comes back while the session is set up; here a close request from elsewhere). Its
    // frames then go unanswered: the client must say `Disconnected`, not time out for ever, and
    // reopen on the next frame.
    let d = daemon("zre");
    let scene = TestScene::new(40, 16, 24);
    let client = Client::zenoh(&d.endpoint()).unwrap();
    let mut s = client.open_session(&scene.spec).unwrap();
    let mut reference = Detector::new(&scene.spec.validate().unwrap());
    let round_trip = |s: &mut lumen_client::Session, k: u64| {
        s.frame().unwrap().copy_from_slice(&scene.state(k));
        s.submit().unwrap();
        s.contacts(WAIT).map(|r| r.contacts().to_vec())
    };
    let first = (0..5).find_map(|_| round_trip(&mut s, 0).ok()).expect("first frame answered");
    assert!(same_bits(&first, reference.detect(&scene.state(0)).unwrap()));
    lumen_e2e::closed_sessions_reopen(&mut s, &Client::zenoh(&d.endpoint()).unwrap(), &scene, &mut reference);
}

/// A daemon on its own port whose status lists every session to anyone (these tests read
/// sessions from status; the default, counts only, has its own test).
fn daemon(tag: &str) -> Daemon {
    Daemon::start(Path::new(LUMEN), &unique_prefix(tag), Some(free_port()), &["--zenoh-status", "sessions"])
}

/// Observers over zenoh take places, as many as `limits.max_observers`; each asks for the
/// newest frame and gets it with its reply; a place given back is free again; an ask without a
/// place is refused with `not_observer`; nothing is published for a mere subscriber.
#[test]
fn zenoh_observers_are_limited_and_only_those_with_a_place_get_frames() {
    let prefix = unique_prefix("zobs");
    let cfg = std::env::temp_dir().join(format!("{prefix}lumen.toml"));
    std::fs::write(&cfg, "[limits]\nmax_observers = 2\n").unwrap();
    let d = Daemon::start(Path::new(LUMEN), &prefix, Some(free_port()), &["--zenoh-status", "sessions", "--config", cfg.to_str().unwrap()]);
    let scene = TestScene::new(40, 16, 24);
    let client = Client::zenoh(&d.endpoint()).unwrap();
    let mut s = client.open_session(&scene.spec).unwrap();
    let id = s.id();
    assert_eq!(s.info().max_observers, 2);
    let raw = zenoh::open(lumen_transport::net::config("client", &[], &[d.endpoint()]).unwrap()).wait().unwrap();
    let heard = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let listen = |key: String| {
        let heard = heard.clone();
        raw.declare_subscriber(key)
            .callback(move |_| {
                heard.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            })
            .wait()
            .unwrap()
    };
    let _subs = [listen(format!("lumen/session/{id}/observe")), listen(format!("lumen/session/{id}/observe/**"))];
    let watcher = Client::zenoh(&d.endpoint()).unwrap();
    let mut first = watcher.observe(id).unwrap();
    let second = watcher.observe(id).unwrap();
    match watcher.observe(id) {
        Err(lumen_client::Error::ObserversFull { session, max }) => assert_eq!((session, max), (id, 2)),
        Err(e) => panic!("a third observer: {e}"),
        Ok(_) => panic!("a third observer was admitted"),
    }
    for k in 0..3 {
        s.frame().unwrap().copy_from_slice(&scene.state(k));
        s.submit().unwrap();
        s.contacts(WAIT).unwrap();
    }
    // The newest frame (2), then the reply to it; then frames as they come.
    match first.next(WAIT).unwrap() {
        Observed::Frame { header, state } => assert_eq!((header.frame, state), (2, &scene.state(2)[..])),
        Observed::Contacts(_) => panic!("contacts before their frame"),
    }
    match first.next(WAIT).unwrap() {
        Observed::Contacts(r) => assert_eq!((r.header().session, r.header().frame), (id, 2)),
        Observed::Frame { .. } => panic!("a frame before the reply to frame 2"),
    }
    assert!(matches!(first.next(Duration::from_millis(300)), Err(lumen_client::Error::Timeout(_))), "no frame newer than 2 yet");
    s.frame().unwrap().copy_from_slice(&scene.state(3));
    s.submit().unwrap();
    assert!(matches!(first.next(WAIT).unwrap(), Observed::Frame { header, .. } if header.frame == 3));
    // Asks without a place: a made-up token, or none.
    for selector in [format!("lumen/session/{id}/observe?observer={}", "ab".repeat(16)), format!("lumen/session/{id}/observe")] {
        let reply = raw.get(&selector).wait().unwrap().recv().unwrap_or_else(|_| panic!("{selector}: no answer"));
        let refusal: ControlReply = serde_json::from_slice(&reply.result().expect_err("an error reply").payload().to_bytes()).unwrap();
        assert!(matches!(&refusal, ControlReply::Error(e) if e.code == ErrorCode::NotObserver), "{selector}: {refusal:?}");
    }
    // A place given back (the observer dropped) is free for another.
    drop(second);
    assert!(lumen_e2e::eventually(WAIT, || watcher.observe(id).is_ok()), "the second place never came back");
    assert_eq!(heard.load(std::sync::atomic::Ordering::SeqCst), 0, "something was published on the observer keys");
    drop((first, s));
    assert_eq!(d.terminate().map(|s| s.success()), Some(true));
}

#[test]
fn zenoh_round_trip_matches_the_in_process_detector_and_observers_see_it() {
    let d = daemon("zrt");
    let scene = TestScene::new(40, 16, 24);
    let client = Client::zenoh(&d.endpoint()).unwrap();
    let mut s = client.open_session(&scene.spec).unwrap();
    assert_eq!(s.info().transport, lumen_client::Transport::Zenoh);
    let watcher = Client::zenoh(&d.endpoint()).unwrap();
    let mut obs = watcher.observe(s.id()).unwrap();
    let mut reference = Detector::new(&scene.spec.validate().unwrap());
    let mut total = 0;
    for k in 0..30 {
        let state = scene.state(k);
        s.frame().unwrap().copy_from_slice(&state);
        assert_eq!(s.submit().unwrap(), k);
        let r = s.contacts(WAIT).unwrap();
        assert_eq!((r.frame(), r.result()), (k, Ok(())));
        let expected = reference.detect(&state).unwrap();
        assert!(same_bits(r.contacts(), expected), "frame {k}");
        total += expected.len();
    }
    assert!(total > 30);
    // The observer saw frames and replies of this session, each reply after its frame.
    let (mut frames, mut replies, mut last) = (0, 0, None);
    while let Ok(o) = obs.next(Duration::from_millis(300)) {
        match o {
            Observed::Frame { header, state } => {
                assert_eq!(state, &scene.state(header.frame)[..]);
                frames += 1;
                last = Some(header.frame);
            }
            Observed::Contacts(r) => {
                assert_eq!((r.header().session, Some(r.header().frame)), (s.id(), last));
                replies += 1;
            }
        }
    }
    assert!(frames > 0 && replies > 0, "observer saw {frames} frames and {replies} replies");
    let st = client.status().unwrap();
    assert_eq!(st.sessions.len(), 1);
    assert_eq!(st.sessions[0].frames, 30);
    let id = s.id();
    drop(s);
    // The session ends when the client's liveliness token goes away; the observer is told.
    let end = loop {
        match obs.next(WAIT) {
            Ok(_) => continue,
            Err(e) => break e,
        }
    };
    assert!(matches!(end, lumen_client::Error::SessionEnded(x) if x == id), "{end}");
    // And for good, as over iceoryx2: not a timeout on the next call.
    let again = obs.next(Duration::from_millis(100)).map(|_| ()).unwrap_err();
    assert!(matches!(again, lumen_client::Error::SessionEnded(x) if x == id), "{again}");
    assert!(lumen_e2e::eventually(WAIT, || client.status().map(|s| s.sessions.is_empty()).unwrap_or(false)));
    assert_eq!(d.terminate().map(|s| s.success()), Some(true));
}

/// A session paced at 1 kHz for `window`, frame `n` carrying `states[n % len]`: the round
/// trips it made a second.
fn paced_rate(s: &mut lumen_client::Session, states: &[Vec<f32>], window: Duration) -> f64 {
    let start = std::time::Instant::now();
    let mut k = 0;
    while start.elapsed() < window {
        if let Some(wait) = (start + Duration::from_millis(k)).checked_duration_since(std::time::Instant::now()) {
            std::thread::sleep(wait);
        }
        let n = s.next_frame_number();
        s.frame().unwrap().copy_from_slice(&states[(n % states.len() as u64) as usize]);
        s.submit().unwrap();
        s.contacts(WAIT).unwrap();
        k += 1;
    }
    k as f64 / start.elapsed().as_secs_f64()
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// A zenoh observer of a session paced at 1 kHz sees at least 500 of its frames a second (it
/// asks for the next frame as soon as it has one, and the daemon answers when the frame
/// exists; asking only after the answered ask had ended capped it at about 20), and the
/// session keeps its rate within 10% of its rate unobserved (alternated windows, medians).
#[test]
fn a_zenoh_observer_keeps_up_with_a_1_khz_session_without_slowing_it() {
    let d = daemon("zobsrate");
    let scene = TestScene::new(20, 8, 10);
    let states: std::sync::Arc<Vec<Vec<f32>>> = std::sync::Arc::new((0..64).map(|k| scene.state(k)).collect());
    let client = Client::zenoh(&d.endpoint()).unwrap();
    let mut s = client.open_session(&scene.spec).unwrap();
    paced_rate(&mut s, &states, Duration::from_millis(300)); // warm-up
    let id = s.id();
    let endpoint = d.endpoint();
    let watching = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let seen = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let (w, n, expected) = (watching.clone(), seen.clone(), states.clone());
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let halt = stop.clone();
    let observer = std::thread::spawn(move || {
        let watcher = Client::zenoh(&endpoint).unwrap();
        while !halt.load(std::sync::atomic::Ordering::SeqCst) {
            if !w.load(std::sync::atomic::Ordering::SeqCst) {
                std::thread::sleep(Duration::from_millis(5));
                continue;
            }
            let mut obs = watcher.observe(id).unwrap();
            let mut last = None;
            while w.load(std::sync::atomic::Ordering::SeqCst) {
                if let Ok(Observed::Frame { header, state }) = obs.next(Duration::from_millis(200)) {
                    assert_eq!(state, &expected[(header.frame % 64) as usize][..], "frame {}", header.frame);
                    assert!(last.is_none_or(|l| header.frame > l), "frames go up");
                    last = Some(header.frame);
                    n.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                }
            }
        }
    });
    let (mut alone, mut watched, mut observed) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..3 {
        watching.store(false, std::sync::atomic::Ordering::SeqCst);
        std::thread::sleep(Duration::from_millis(300));
        alone.push(paced_rate(&mut s, &states, Duration::from_secs(1)));
        watching.store(true, std::sync::atomic::Ordering::SeqCst);
        paced_rate(&mut s, &states, Duration::from_millis(300)); // the observer takes its place
        let before = seen.load(std::sync::atomic::Ordering::SeqCst);
        let start = std::time::Instant::now();
        watched.push(paced_rate(&mut s, &states, Duration::from_secs(1)));
        observed.push((seen.load(std::sync::atomic::Ordering::SeqCst) - before) as f64 / start.elapsed().as_secs_f64());
    }
    stop.store(true, std::sync::atomic::Ordering::SeqCst);
    watching.store(false, std::sync::atomic::Ordering::SeqCst);
    observer.join().unwrap();
    let (alone, watched, observed) = (median(&mut alone), median(&mut watched), median(&mut observed));
    eprintln!("1 kHz zenoh session: {alone:.0} round trips/s alone, {watched:.0} observed; the observer saw {observed:.0} frames/s");
    assert!(observed >= 500.0, "the observer saw {observed:.0} frames a second of a {watched:.0} Hz session");
    assert!(watched >= 0.9 * alone, "observed, the session ran at {watched:.0} round trips a second, alone {alone:.0}");
}

#[test]
fn random_bytes_on_the_frame_key_never_hurt_the_daemon_or_other_sessions() {
    let d = daemon("zfz");
    let scene = TestScene::new(30, 8, 16);
    let client = Client::zenoh(&d.endpoint()).unwrap();
    let mut victim = client.open_session(&scene.spec).unwrap();
    let mut other = client.open_session(&scene.spec).unwrap();
    let mut reference = Detector::new(&scene.spec.validate().unwrap());
    let raw = zenoh::open(lumen_transport::net::config("client", &[], &[d.endpoint()]).unwrap()).wait().unwrap();
    let key = victim.info().frame.clone();
    let secret = Secret::parse(&victim.info().secret).unwrap();
    let floats = victim.layout().floats;
    let mut rng = fastrand::Rng::with_seed(4);
    let good = scene.state(0);
    let mut statuses = std::collections::HashMap::new();
    let mut short = 0u64;
    for i in 0..150u64 {
        let payload: Vec<u8> = match i % 6 {
            0 => (0..rng.usize(0..FRAME_HEADER_BYTES)).map(|_| rng.u8(..)).collect(),
            1 => (0..rng.usize(0..200_000)).map(|_| rng.u8(..)).collect(),
            2 => {
                // A valid header claiming far more floats than it carries.
                let mut v = Vec::new();
                encode_frame(&FrameHeader::new(victim.id(), i, 0, u32::MAX as usize, 2), &good[..10], &mut v);
                v
            }
            3 => {
                // The right size, with a NaN somewhere.
                let mut st = good.clone();
                st[rng.usize(0..floats)] = f32::NAN;
                let mut v = Vec::new();
                encode_frame(&FrameHeader::new(victim.id(), i, 0, floats, 2), &st, &mut v);
                v
            }
            4 => {
                // A good frame with random header bytes flipped (not the session or frame).
                let mut v = Vec::new();
                encode_frame(&FrameHeader::new(victim.id(), i, 0, floats, 2), &good, &mut v);
                let at = [0usize, 4, 32, 36][rng.usize(0..4)];
                v[at] ^= 1 + rng.u8(..254);
                v
            }
            _ => {
                let mut v = Vec::new();
                encode_frame(&FrameHeader::new(victim.id(), i, 0, floats, 2), &good, &mut v);
                v.truncate(v.len() - 1 - rng.usize(0..8));
                v
            }
        };
        // Tagged with the owner's secret and numbered in order: a buggy owner, not a stranger
        // (whose frames are dropped unanswered: `a_strangers_close_frames_and_replies_all_fail`).
        // A message shorter than a header carries no frame number, so no proof: dropped.
        let mut payload = payload;
        if payload.len() < FRAME_HEADER_BYTES {
            let tag = secret.tag([payload.as_slice()]);
            raw.put(key.clone(), payload).attachment(tag.to_vec()).wait().unwrap();
            short += 1;
            continue;
        }
        payload[16..24].copy_from_slice(&i.to_le_bytes());
        let tag = secret.message_tag(&payload[..FRAME_HEADER_BYTES], payload.len());
        raw.put(key.clone(), payload).attachment(tag.to_vec()).wait().unwrap();
        let r = victim.contacts(WAIT).expect("every fuzz frame of a header or more gets a reply");
        assert_eq!(r.frame(), i, "the reply names the frame's number, whatever else is wrong");
        let status = r.result().expect_err("no random frame is valid").0;
        *statuses.entry(status).or_insert(0) += 1;
        // The other session is unaffected, frame by frame.
        if i % 10 == 0 {
            let state = scene.state(i);
            other.submit_state(&state).unwrap();
            let r = other.contacts(WAIT).unwrap();
            assert_eq!(r.result(), Ok(()));
            assert!(same_bits(r.contacts(), reference.detect(&state).unwrap()));
        }
    }
    for s in [Status::Malformed, Status::BadLength, Status::NonFinite] {
        assert!(statuses.get(&s).copied().unwrap_or(0) > 0, "{s:?} never seen: {statuses:?}");
    }
    assert!(short >= 25, "every sixth message is shorter than a header");
    // The victim's session still works, numbered past the fuzz frames.
    victim.frame().unwrap().copy_from_slice(&good);
    victim.submit_with(|h| h.frame = 1000).unwrap();
    let r = victim.contacts(WAIT).unwrap();
    assert_eq!((r.frame(), r.result()), (1000, Ok(())));
    // The daemon counts a frame just after publishing its reply: wait for the count to settle.
    let counts = || client.status().ok().and_then(|st| st.sessions.iter().find(|x| x.session == victim.id()).map(|v| (v.frames, v.bad_frames, v.forged)));
    let answered = 150 - short;
    lumen_e2e::eventually(Duration::from_secs(3), || counts() == Some((answered + 1, answered, short)));
    assert_eq!(counts(), Some((answered + 1, answered, short)));
    assert_eq!(d.terminate().map(|s| s.success()), Some(true));
}

#[test]
fn zenoh_clients_resume_after_a_daemon_restart() {
    let prefix = unique_prefix("zk9");
    let port = free_port();
    let mut d = Daemon::start(Path::new(LUMEN), &prefix, Some(port), &[]);
    let scene = TestScene::new(30, 8, 16);
    let client = Client::zenoh(&d.endpoint()).unwrap();
    let mut s = client.open_session(&scene.spec).unwrap();
    let first = s.id();
    s.submit_state(&scene.state(0)).unwrap();
    assert_eq!(s.contacts(WAIT).unwrap().result(), Ok(()));
    d.process.kill9();
    let d = Daemon::start(Path::new(LUMEN), &prefix, Some(port), &[]);
    let restarted = std::time::Instant::now();
    let mut resumed = false;
    for k in 1.. {
        if s.submit_state(&scene.state(k)).is_err() {
            std::thread::sleep(Duration::from_millis(20)); // no daemon yet: retry shortly
        } else if let Ok(r) = s.contacts(Duration::from_millis(200)) {
            if r.result().is_ok() && s.id() != first {
                resumed = true;
                break;
            }
        }
        if restarted.elapsed() > Duration::from_secs(20) {
            break;
        }
    }
    assert!(resumed, "the zenoh client did not resume");
    eprintln!("zenoh daemon kill -9 + restart: resumed {:?} after the new daemon was ready", restarted.elapsed());
    assert_eq!(s.reconnects(), 1);
    drop(s);
    assert_eq!(d.terminate().map(|s| s.success()), Some(true));
}

/// A certificate authority and a daemon certificate for `localhost` signed by it, as PEM files
/// in a fresh folder: (folder, CA, certificate, key).
fn tls_files(tag: &str) -> (std::path::PathBuf, std::path::PathBuf, std::path::PathBuf, std::path::PathBuf) {
    let pki = lumen_e2e::pki::Pki::new(tag);
    let (cert, key) = pki.issue("localhost", false);
    (pki.dir, pki.ca, cert, key)
}

// zenoh-link-tls 1.10.2 can drop a fresh TLS link (reproduced in 4 of 40 runs of this file with
// 5 copies at once): it reads and writes one rustls stream from two tasks, and a write that
// meets a read mid-record fails ("TX task failed: handshake not complete"). zenoh reconnects,
// the daemon has ended the session (its client's token went away), and the client sees the
// daemon's token deleted and back: `Disconnected`, then the session reopens on the next frame.
// So the client here does what any client must: it keeps submitting through `Disconnected`.
#[test]
fn tls_round_trip_with_the_daemons_ca_and_refusals_without_it() {
    let (dir, ca, cert, key) = tls_files("rt");
    let port = free_port();
    let endpoint = format!("tls/localhost:{port}");
    let (cert_s, key_s) = (cert.display().to_string(), key.display().to_string());
    let d = Daemon::start(Path::new(LUMEN), &unique_prefix("ztls"), None, &["--zenoh-listen", &endpoint, "--zenoh-tls-cert", &cert_s, "--zenoh-tls-key", &key_s]);
    let scene = TestScene::new(40, 16, 24);
    let client = Client::zenoh_tls(&endpoint, &ca).unwrap();
    let mut s = client.open_session(&scene.spec).unwrap();
    let mut reference = Detector::new(&scene.spec.validate().unwrap());
    // zenoh propagates the daemon's subscription asynchronously, so a first frame can also be
    // dropped: each frame is sent until answered, through `Disconnected` and timeouts.
    for k in 0..10 {
        let state = scene.state(k);
        let mut last = None;
        let once = |s: &mut lumen_client::Session| -> Result<Vec<lumen_proto::Contact>, lumen_client::Error> {
            s.frame()?.copy_from_slice(&state);
            let n = s.submit()?;
            // A late reply to an earlier try is not this frame's.
            loop {
                let r = s.contacts(WAIT)?;
                if r.frame() == n {
                    return Ok(r.contacts().to_vec());
                }
            }
        };
        let answered = (0..5).find_map(|_| match once(&mut s) {
            Ok(cs) => Some(cs),
            Err(e) => {
                last = Some(e);
                None
            }
        });
        let cs = answered.unwrap_or_else(|| panic!("frame {k}: no reply over TLS in 5 tries; last: {last:?}"));
        assert!(same_bits(&cs, reference.detect(&state).unwrap()), "frame {k}");
    }
    // A dropped link costs one reopening; more would be a loop, not a blip.
    assert!(s.reconnects() <= 2, "{} reopenings", s.reconnects());
    drop(s);
    // A CA that did not sign the daemon's certificate is not trusted.
    let (other_dir, other_ca, _, _) = tls_files("other");
    let refused = Client::zenoh_tls(&endpoint, &other_ca).and_then(|c| c.status());
    assert!(matches!(refused, Err(lumen_client::Error::NoDaemon { .. })), "{:?}", refused.map(|_| ()));
    // Plain TCP does not speak to a TLS port.
    let plain = Client::zenoh(&format!("tcp/localhost:{port}")).and_then(|c| c.status());
    assert!(plain.is_err());
    // A missing root certificate is named.
    let missing = Client::zenoh_tls(&endpoint, &dir.join("absent.pem")).err().unwrap().to_string();
    assert!(missing.contains("absent.pem"), "{missing}");
    assert_eq!(d.terminate().map(|s| s.success()), Some(true));
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&other_dir);
}

#[test]
fn a_tls_endpoint_without_a_certificate_is_refused_at_start() {
    let out = std::process::Command::new(LUMEN).args(["serve", "--no-iceoryx2", "--zenoh-listen", "tls/localhost:1"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("certificate"), "{}", String::from_utf8_lossy(&out.stderr));
}

/// `close` answers once the slot is free, over zenoh too.
#[test]
fn a_closed_sessions_slot_is_free_when_the_close_is_answered() {
    let daemon = Daemon::start(Path::new(LUMEN), &unique_prefix("zreopen"), Some(free_port()), &["--max-sessions", "1"]);
    let client = Client::zenoh(&daemon.endpoint()).unwrap();
    let scene = TestScene::new(40, 16, 24);
    for k in 0..20 {
        let s = client.open_session(&scene.spec).unwrap_or_else(|e| panic!("cycle {k}: {e}"));
        s.close().unwrap_or_else(|e| panic!("cycle {k}: {e}"));
    }
}

#[test]
fn a_strangers_close_frames_and_replies_all_fail() {
    // The security model's attacks (service/README.md), by a second zenoh client that knows the session's id and its keys
    // (ids are in every frame header) but not the secret of its opened reply.
    let d = daemon("zstranger");
    let scene = TestScene::new(30, 8, 16);
    let owner = Client::zenoh(&d.endpoint()).unwrap();
    let mut s = owner.open_session(&scene.spec).unwrap();
    let id = s.id();
    let mut reference = Detector::new(&scene.spec.validate().unwrap());
    let stranger = Client::zenoh(&d.endpoint()).unwrap();
    let raw = zenoh::open(lumen_transport::net::config("client", &[], &[d.endpoint()]).unwrap()).wait().unwrap();
    let round_trip = |s: &mut lumen_client::Session, k: u64| {
        let state = scene.state(k);
        s.submit_state(&state).unwrap();
        let r = s.contacts(WAIT).unwrap();
        assert_eq!((r.frame(), r.result()), (k, Ok(())), "the owner's own reply");
        r.contacts().to_vec()
    };
    // The stranger watches the owner's keys: it sees every genuine frame and reply, tag and all.
    let seen_frames = raw.declare_subscriber(s.info().frame.clone()).wait().unwrap();
    let seen_replies = raw.declare_subscriber(s.info().contacts.clone()).wait().unwrap();
    std::thread::sleep(Duration::from_millis(300)); // the subscriptions reach the daemon first
    let first = round_trip(&mut s, 0);
    assert!(!first.is_empty(), "frame 0 has contacts to forge");
    assert!(same_bits(&first, reference.detect(&scene.state(0)).unwrap()));
    let (frame0, reply0) = (seen_frames.recv_timeout(WAIT).unwrap().unwrap(), seen_replies.recv_timeout(WAIT).unwrap().unwrap());
    let (frame0_tag, reply0_tag) = (frame0.attachment().unwrap().to_bytes().to_vec(), reply0.attachment().unwrap().to_bytes().to_vec());
    // Undeclared now: their bounded queues would fill with the flood below and block `raw`.
    drop((seen_frames, seen_replies));
    // Replays: frame 0's header and tag with other floats of the same length, and with its
    // number moved on to 1; reply 0's header and tag with its first contact's depth changed.
    let mut other_floats = frame0.payload().to_bytes().to_vec();
    let mut moved_on = other_floats.clone();
    let mut replaced = Vec::new();
    encode_frame(&FrameHeader::new(id, 0, 0, s.layout().floats, 2), &scene.state(9), &mut replaced);
    other_floats[FRAME_HEADER_BYTES..].copy_from_slice(&replaced[FRAME_HEADER_BYTES..]);
    moved_on[16..24].copy_from_slice(&1u64.to_le_bytes());
    raw.put(s.info().frame.clone(), other_floats).attachment(frame0_tag.clone()).wait().unwrap();
    raw.put(s.info().frame.clone(), moved_on).attachment(frame0_tag).wait().unwrap();
    let mut deeper = reply0.payload().to_bytes().to_vec();
    let depth_at = lumen_proto::wire::CONTACTS_HEADER_BYTES + std::mem::offset_of!(lumen_proto::Contact, depth);
    deeper[depth_at..depth_at + 4].copy_from_slice(&(-50.0f32).to_le_bytes());
    raw.put(s.info().contacts.clone(), deeper).attachment(reply0_tag).wait().unwrap();
    // A close without the proof, or with another secret's, is refused and changes nothing.
    let wrong = Secret::from_bytes([7; 32]);
    for proof in [String::new(), wrong.close_proof(id), "x".repeat(64)] {
        match stranger.request(&ControlRequest::Close { session: id, proof }) {
            Err(lumen_client::Error::Refused(e)) => assert_eq!(e.code, ErrorCode::NotOwner, "{}", e.message),
            other => panic!("a stranger's close: {other:?}"),
        }
    }
    // The session's secret is in no describe and no status.
    match stranger.request(&ControlRequest::Describe { session: id }) {
        Ok(ControlReply::Described(info)) => assert!(info.secret.is_empty()),
        other => panic!("{other:?}"),
    }
    // Frames on the owner's key: the one that once ended the owner's run (frame 2^62), untagged
    // and with a wrong tag, and a good frame's bytes tagged under another secret.
    let floats = s.layout().floats;
    let mut garbage = Vec::new();
    encode_frame(&FrameHeader::new(id, 1 << 62, 0, floats, 2), &scene.state(3), &mut garbage);
    let mut short = Vec::new();
    encode_frame(&FrameHeader::new(id, 1 << 62, 0, 10, 2), &scene.state(3)[..10], &mut short);
    let frame_key = s.info().frame.clone();
    raw.put(frame_key.clone(), garbage.clone()).wait().unwrap();
    raw.put(frame_key.clone(), short.clone()).attachment(vec![0u8; 32]).wait().unwrap();
    raw.put(frame_key.clone(), garbage.clone()).attachment(wrong.tag([garbage.as_slice()]).to_vec()).wait().unwrap();
    // Forged replies on the owner's contacts key: "frame 1, no contacts", untagged and tagged
    // under another secret, published before the owner's frame 1 is answered.
    let mut forged = Vec::new();
    let mut h = ContactsHeader::reply_to(&FrameHeader::new(id, 1, 0, floats, 2));
    encode_contacts(&mut h, &[], &mut forged);
    let contacts_key = s.info().contacts.clone();
    std::thread::sleep(Duration::from_millis(200)); // the stranger's puts reach the daemon first
    raw.put(contacts_key.clone(), forged.clone()).wait().unwrap();
    raw.put(contacts_key.clone(), forged.clone()).attachment(wrong.tag([forged.as_slice()]).to_vec()).wait().unwrap();
    std::thread::sleep(Duration::from_millis(200));
    // The owner is answered, frame by frame, with the daemon's contacts only.
    let mut total = 0;
    for k in 1..20 {
        let got = round_trip(&mut s, k);
        assert!(same_bits(&got, reference.detect(&scene.state(k)).unwrap()), "frame {k}");
        total += got.len();
    }
    assert!(total > 0, "the scene's contacts are what the forged replies would have hidden");
    assert_eq!(s.forged_replies(), 3, "the two forged replies and the replayed one were seen and dropped");
    // The daemon counted the five frames, answered none of them, and the session lives on.
    let status = || owner.status().ok().and_then(|st| st.sessions.into_iter().find(|x| x.session == id));
    assert!(lumen_e2e::eventually(WAIT, || status().is_some_and(|x| x.frames == 20)));
    let st = status().unwrap();
    assert_eq!((st.frames, st.bad_frames, st.forged), (20, 0, 5));
    assert!(s.try_contacts().unwrap().is_none(), "nothing answered the stranger's frames");
    // A stranger flooding the frame key while the owner runs cannot push its frames out.
    let stop = std::sync::atomic::AtomicBool::new(false);
    std::thread::scope(|scope| {
        scope.spawn(|| {
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                raw.put(frame_key.clone(), garbage.clone()).wait().unwrap();
            }
        });
        for k in 20..60 {
            let got = round_trip(&mut s, k);
            assert!(same_bits(&got, reference.detect(&scene.state(k)).unwrap()), "frame {k} under the flood");
        }
        stop.store(true, std::sync::atomic::Ordering::Relaxed);
    });
    assert!(lumen_e2e::eventually(WAIT, || status().is_some_and(|x| x.frames == 60 && x.forged > 3)));
    // The owner's own proof, from any connection, closes it.
    assert_eq!(stranger.request(&s.close_request()).unwrap(), ControlReply::Closed { session: id });
    assert_eq!(d.terminate().map(|s| s.success()), Some(true));
}

#[test]
fn a_strangers_token_does_not_keep_a_dead_clients_session() {
    // Before: a token held on a dead client's liveliness key kept its session alive. The key
    // is now named by the session's secret, so a stranger who knows all that is public (the id,
    // describe, status) can hold tokens only on keys near it, and the daemon counts only a
    // token on exactly the owner's key.
    let d = daemon("ztok");
    let endpoint = d.endpoint();
    let mut victim = lumen_e2e::spawn_client_role("child_role", &[("LUMEN_E2E_ENDPOINT", endpoint.as_str())]);
    let id = victim.session_id();
    assert!(victim.line_starting("ok ", WAIT).is_some());
    let status = Client::zenoh(&endpoint).unwrap();
    let described = match status.request(&ControlRequest::Describe { session: id }) {
        Ok(ControlReply::Described(info)) => info,
        other => panic!("{other:?}"),
    };
    assert_eq!((described.alive.as_str(), described.secret.as_str()), ("", ""), "describe names neither the key nor the secret");
    let raw = zenoh::open(lumen_transport::net::config("client", &[], std::slice::from_ref(&endpoint)).unwrap()).wait().unwrap();
    let keys = [format!("lumen/session/{id}/client"), format!("lumen/session/{id}/client/*"), format!("lumen/session/{id}/client/**"), format!("lumen/session/{id}/**")];
    let _tokens: Vec<_> = keys.iter().map(|k| raw.liveliness().declare_token(k.clone()).wait().unwrap_or_else(|e| panic!("token on {k}: {e}"))).collect();
    std::thread::sleep(Duration::from_millis(300)); // the tokens reach the daemon before the kill
    let noticed = lumen_e2e::kill9_and_time_freeing(&mut victim, &status, id).unwrap_or_else(|last| panic!("the stranger's tokens kept the dead client's session {id}: {last}"));
    assert!(noticed < Duration::from_millis(1500), "freed after {noticed:?}");
}

#[test]
fn an_idle_connection_flood_leaves_room_for_clients() {
    // Before: 101 TCP connections that never handshake filled zenoh's pending-accept slots
    // (100 by default) and every new client was closed for about 10 s. The daemon now allows
    // `[zenoh] accept_pending` (1024) of them for `accept_timeout_ms` (2 s) each.
    let flood = |port: u16, n: usize| -> Vec<std::net::TcpStream> { (0..n).map(|_| std::net::TcpStream::connect(("127.0.0.1", port)).expect("a flood connection")).collect() };
    let d = daemon("zflood");
    let port: u16 = d.endpoint().rsplit(':').next().unwrap().parse().unwrap();
    let held = flood(port, 300);
    std::thread::sleep(Duration::from_millis(200));
    let client = Client::zenoh(&d.endpoint()).expect("a client beside 300 idle connections");
    let scene = TestScene::new(30, 8, 16);
    let mut s = client.open_session(&scene.spec).expect("opens");
    s.submit_state(&scene.state(0)).unwrap();
    assert_eq!(s.contacts(WAIT).unwrap().result(), Ok(()));
    drop(held);
    // The same flood against zenoh's own defaults locks a client out: what the setting buys.
    let dir = std::env::temp_dir().join(format!("lumen_flood_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cfg = dir.join("zenoh_defaults.toml");
    std::fs::write(&cfg, "[zenoh]\naccept_pending = 100\naccept_timeout_ms = 10000\n").unwrap();
    let old = Daemon::start(Path::new(LUMEN), &unique_prefix("zflood0"), Some(free_port()), &["--config", cfg.to_str().unwrap()]);
    let port: u16 = old.endpoint().rsplit(':').next().unwrap().parse().unwrap();
    let held = flood(port, 101);
    std::thread::sleep(Duration::from_millis(200));
    let locked = Client::zenoh(&old.endpoint()).and_then(|c| c.status());
    assert!(locked.is_err(), "zenoh's defaults let a client through 101 idle connections: {locked:?}");
    drop(held);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn opens_land_on_exactly_one_of_two_daemons_behind_a_router() {
    // A lab runs a zenoh router and a daemon per machine. Every daemon answered an
    // open on `lumen/control`, so one open made a session on each. Now a client asks every
    // daemon's load (hello) and opens on the least loaded by name, or on the one it names.
    let router_endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let router = lumen_e2e::ChildProcess::spawn({
        let mut c = std::process::Command::new(LUMEN);
        c.args(["router", "--listen", &router_endpoint, "--log", "warn"]);
        c
    });
    assert!(router.line_starting("lumen router: ready", Duration::from_secs(30)).is_some(), "the router did not get ready");
    let serve = |name: &str| Daemon::start(Path::new(LUMEN), &unique_prefix(name), None, &["--zenoh-connect", &router_endpoint, "--zenoh-name", name, "--zenoh-status", "sessions"]);
    let a = serve("lab-a");
    let mut b = serve("lab-b");
    let client = Client::zenoh(&router_endpoint).unwrap();
    assert!(lumen_e2e::eventually(Duration::from_secs(10), || client.daemons().is_ok_and(|d| d.len() == 2)), "both daemons answer through the router");
    let names: Vec<String> = client.daemons().unwrap().into_iter().map(|d| d.daemon).collect();
    assert!(names.contains(&"lab-a".into()) && names.contains(&"lab-b".into()), "{names:?}");
    // A second daemon of a name already on the network refuses to start.
    let twin = std::process::Command::new(LUMEN).args(["serve", "--prefix", &unique_prefix("lab-a2"), "--zenoh-connect", &router_endpoint, "--zenoh-name", "lab-a"]).output().unwrap();
    assert!(!twin.status.success() && String::from_utf8_lossy(&twin.stderr).contains("already serves"), "{}", String::from_utf8_lossy(&twin.stderr));
    // A foreign client that follows proto/README (a plain get on lumen/control) gets one reply:
    // the daemons' control queryables are complete, so zenoh routes its query to one daemon.
    let raw = zenoh::open(lumen_transport::net::config("client", &[], std::slice::from_ref(&router_endpoint)).unwrap()).wait().unwrap();
    let scene = TestScene::new(30, 8, 16);
    let open = serde_json::to_vec(&ControlRequest::Open { version: lumen_proto::wire::PROTOCOL_VERSION, spec: scene.spec.clone(), client: "raw".into(), echo: false, alive: String::new() }).unwrap();
    // (Every reply counted: zenoh's default consolidation would show one of several.)
    let replies: Vec<_> = raw.get("lumen/control").consolidation(zenoh::query::ConsolidationMode::None).payload(open).timeout(WAIT).wait().unwrap().iter().collect();
    assert_eq!(replies.len(), 1, "an unnamed open is answered by exactly one daemon");
    let total = |reports: &[lumen_client::StatusReport]| reports.iter().map(|r| r.sessions.len()).sum::<usize>();
    assert!(lumen_e2e::eventually(WAIT, || client.status_all().is_ok_and(|r| total(&r) == 1)), "one session for the one open");
    let Ok(ControlReply::Opened(info)) = serde_json::from_slice::<ControlReply>(&replies[0].result().unwrap().payload().to_bytes()) else { panic!("not opened") };
    let proof = Secret::parse(&info.secret).unwrap().close_proof(info.session);
    assert_eq!(client.request(&ControlRequest::Close { session: info.session, proof }).unwrap(), ControlReply::Closed { session: info.session }, "closed on the daemon that has it");
    assert_eq!(client.status_all().map(|r| total(&r)).unwrap(), 0);
    // Eight opens: each on exactly one daemon, the least loaded, so both are used.
    let mut reference = Detector::new(&scene.spec.validate().unwrap());
    let mut sessions: Vec<lumen_client::Session> = (0..8).map(|k| client.open_session(&scene.spec).unwrap_or_else(|e| panic!("open {k}: {e}"))).collect();
    let reports = client.status_all().unwrap();
    assert_eq!(reports.iter().map(|r| r.daemon.as_str()).collect::<Vec<_>>(), ["lab-a", "lab-b"]);
    for s in &sessions {
        let holders: Vec<&str> = reports.iter().filter(|r| r.sessions.iter().any(|x| x.session == s.id())).map(|r| r.daemon.as_str()).collect();
        assert_eq!(holders, [s.info().daemon.as_str()], "session {} on exactly the daemon its info names", s.id());
    }
    let on = |name: &str| sessions.iter().filter(|s| s.info().daemon == name).count();
    assert_eq!((on("lab-a"), on("lab-b")), (4, 4), "the opens went to the least loaded daemon each time (the raw one is on one of them)");
    for s in sessions.iter_mut() {
        s.submit_state(&scene.state(0)).unwrap();
        assert!(same_bits(s.contacts(WAIT).unwrap().contacts(), reference.detect(&scene.state(0)).unwrap()));
    }
    // A client may name its daemon.
    let named = Client::zenoh(&router_endpoint).unwrap().on_daemon("lab-b").open_session(&scene.spec).unwrap();
    assert_eq!(named.info().daemon, "lab-b");
    named.close().unwrap();
    // Killing one daemon leaves the other's sessions untouched.
    let a_ids: Vec<u64> = sessions.iter().filter(|s| s.info().daemon == "lab-a").map(|s| s.id()).collect();
    b.process.kill9();
    for k in 1..20 {
        for s in sessions.iter_mut().filter(|s| s.info().daemon == "lab-a") {
            s.submit_state(&scene.state(k)).unwrap();
            let id = s.id();
            let r = s.contacts(WAIT).unwrap_or_else(|e| panic!("frame {k} of session {id} on lab-a: {e}"));
            assert!(same_bits(r.contacts(), reference.detect(&scene.state(k)).unwrap()), "frame {k}");
        }
    }
    assert!(lumen_e2e::eventually(Duration::from_secs(5), || client.status_all().is_ok_and(|r| r.len() == 1)), "lab-b is gone from status");
    let left = client.status_all().unwrap();
    assert_eq!(left[0].daemon, "lab-a");
    assert!(a_ids.iter().all(|id| left[0].sessions.iter().any(|x| x.session == *id && x.frames == 20)), "lab-a's sessions, every frame answered");
    drop(sessions);
    drop(a);
}

#[test]
fn status_shows_an_unidentified_zenoh_client_only_how_many_sessions_there_are() {
    // Before: status listed every session's id, client and figures to anyone on the network.
    // By default ([zenoh] status = "counts") a zenoh client no certificate grant identifies
    // learns how many sessions there are; iceoryx2 (this machine, the daemon's account) and
    // `--zenoh-status sessions` list them.
    let prefix = unique_prefix("zcounts");
    let d = Daemon::start(Path::new(LUMEN), &prefix, Some(free_port()), &[]);
    let scene = TestScene::new(30, 8, 16);
    let owner = Client::zenoh(&d.endpoint()).unwrap();
    let mut s = owner.open_session(&scene.spec).unwrap();
    s.submit_state(&scene.state(0)).unwrap();
    s.contacts(WAIT).unwrap();
    let stranger = Client::zenoh(&d.endpoint()).unwrap();
    let st = stranger.status().unwrap();
    assert_eq!((st.sessions.len(), st.hidden), (0, 1), "a count, no session");
    let out = std::process::Command::new(LUMEN).args(["status", "--zenoh", &d.endpoint(), "--json"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && text.contains("\"hidden\": 1") && !text.contains(&s.id().to_string()), "{text}");
    let table = std::process::Command::new(LUMEN).args(["status", "--zenoh", &d.endpoint()]).output().unwrap();
    assert!(String::from_utf8_lossy(&table.stdout).contains("1 session(s) not listed"), "{}", String::from_utf8_lossy(&table.stdout));
    let local = Client::local_with(lumen_client::LocalOptions { prefix: Some(prefix.clone()), name: None }).unwrap().status().unwrap();
    assert_eq!((local.sessions.iter().map(|x| x.session).collect::<Vec<_>>(), local.hidden), (vec![s.id()], 0), "listed over iceoryx2");
    let listing = Daemon::start(Path::new(LUMEN), &unique_prefix("zlist"), Some(free_port()), &["--zenoh-status", "sessions"]);
    let mut t = Client::zenoh(&listing.endpoint()).unwrap().open_session(&scene.spec).unwrap();
    t.submit_state(&scene.state(0)).unwrap();
    t.contacts(WAIT).unwrap();
    let st = Client::zenoh(&listing.endpoint()).unwrap().status().unwrap();
    assert_eq!((st.sessions.iter().map(|x| x.session).collect::<Vec<_>>(), st.hidden), (vec![t.id()], 0), "listed under --zenoh-status sessions");
}

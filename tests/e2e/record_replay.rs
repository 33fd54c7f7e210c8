//! `lumen record` and `lumen replay` as real processes against a real `lumen serve`: a recorded
//! run replays to the same contacts bit for bit, the file is valid MCAP holding the spec and
//! every frame, a tampered recording fails `--check`, Ctrl-C finishes the file, and damaged
//! files are refused with a clear error.

use lumen_cli::recording::{self, Missed, Recording, RecordingError, Writer};
use lumen_client::{Client, LocalOptions};
use lumen_e2e::{free_port, shm_files, unique_prefix, ChildProcess, Daemon, TestScene};
use lumen_proto::wire::{self, ContactsHeader, FrameHeader};
use lumen_proto::Contact;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

const LUMEN: &str = env!("CARGO_BIN_EXE_lumen");
const WAIT: Duration = Duration::from_secs(5);

fn scene() -> TestScene {
    TestScene::new(40, 16, 24)
}

fn client(prefix: &str) -> Client {
    Client::local_with(LocalOptions { prefix: Some(prefix.into()), name: Some("record-test".into()) }).expect("local client")
}

fn temp(prefix: &str, name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("{prefix}{name}"))
}

/// `lumen record SESSION -o PATH` as a child; returns once it observes.
fn start_recorder(prefix: &str, session: u64, path: &Path) -> ChildProcess {
    let mut cmd = Command::new(LUMEN);
    cmd.args(["record", &session.to_string(), "-o", path.to_str().unwrap(), "--prefix", prefix, "--log", "warn"]);
    let rec = ChildProcess::spawn(cmd);
    assert!(rec.line_starting("lumen record: recording session", WAIT).is_some(), "the recorder did not start");
    rec
}

/// Drives `frames` frames like a physics client: each waits for its reply, then a pause that
/// leaves the recorder time to see frame and reply. Returns each reply's contacts.
fn drive(session: &mut lumen_client::Session, scene: &TestScene, frames: u64) -> Vec<Vec<Contact>> {
    (0..frames)
        .map(|k| {
            session.submit_state(&scene.state(k)).unwrap();
            let r = session.contacts(WAIT).unwrap();
            assert_eq!(r.frame(), k);
            let c = r.contacts().to_vec();
            std::thread::sleep(Duration::from_millis(20));
            c
        })
        .collect()
}

fn replay(prefix: &str, path: &Path, extra: &[&str]) -> std::process::Output {
    Command::new(LUMEN).args(["replay", path.to_str().unwrap(), "--prefix", prefix, "--log", "warn"]).args(extra).output().unwrap()
}

/// The number after `label` in `text` (e.g. "12 matched" -> 12 for label "matched").
fn count_before(text: &str, label: &str) -> Option<u64> {
    let words: Vec<&str> = text.split_whitespace().collect();
    words.windows(2).find(|w| w[1].trim_end_matches(',') == label).and_then(|w| w[0].parse().ok())
}

#[test]
fn a_recorded_run_replays_bit_for_bit() {
    const FRAMES: u64 = 30;
    let prefix = unique_prefix("rec");
    let daemon = Daemon::start(Path::new(LUMEN), &prefix, Some(free_port()), &[]);
    let scene = scene();
    let path = temp(&prefix, "run.mcap");
    let sent = {
        let client = client(&prefix);
        let mut session = client.open_session(&scene.spec).unwrap();
        let mut recorder = start_recorder(&prefix, session.id(), &path);
        let sent = drive(&mut session, &scene, FRAMES);
        std::thread::sleep(Duration::from_millis(200)); // the last reply reaches the recorder
        drop(session);
        // The session ended: the recorder finishes the file and exits by itself.
        assert!(recorder.wait_exit(Duration::from_secs(10)).is_some_and(|s| s.success()), "the recorder did not end with the session");
        let summary = recorder.line_starting("lumen record: session ended", WAIT).expect("a summary line");
        println!("{summary}");
        assert_eq!(count_before(&summary, "frames"), Some(FRAMES), "{summary}");
        assert!(summary.contains("missed 0 frames and 0 replies"), "{summary}");
        sent
    };
    assert!(sent.iter().any(|c| !c.is_empty()), "the scene makes contacts");

    // The file through the project's reader: every frame, the spec, the replies as received.
    let rec = Recording::open(&path).unwrap();
    assert_eq!(rec.frames, FRAMES);
    assert_eq!(rec.spec, scene.spec);
    assert_eq!(rec.replies.len() as u64, FRAMES);
    assert_eq!(rec.missed, Some(Missed::default()));
    for (k, contacts) in sent.iter().enumerate() {
        assert!(lumen_e2e::same_bits(&rec.replies[&(k as u64)].contacts, contacts), "frame {k}'s recorded contacts");
    }
    let frames: Vec<_> = rec.frames().unwrap().collect::<Result<_, _>>().unwrap();
    assert_eq!(frames.iter().map(|f| f.header.frame).collect::<Vec<_>>(), (0..FRAMES).collect::<Vec<_>>());
    assert_eq!(frames[7].state, scene.state(7));

    // The file through the mcap crate alone: valid, indexed, three channels as documented.
    let bytes = std::fs::read(&path).unwrap();
    let summary = mcap::read::Summary::read(&bytes).unwrap().expect("a summary section");
    let stats = summary.stats.expect("statistics");
    let count_of = |topic: &str| {
        let id = summary.channels.values().find(|c| c.topic == topic).unwrap_or_else(|| panic!("channel {topic}")).id;
        stats.channel_message_counts[&id]
    };
    assert_eq!(count_of(recording::FRAMES_TOPIC), FRAMES);
    assert_eq!(count_of(recording::CONTACTS_TOPIC), FRAMES);
    assert_eq!(count_of(recording::SPEC_TOPIC), 1);
    // The Foxglove scene (on by default): one update per frame and one per reply.
    assert_eq!(count_of(recording::SCENE_TOPIC), 2 * FRAMES);
    let mut spec_seen = false;
    let (mut frame_messages, mut frame_bytes) = (0u64, 0usize);
    let full = wire::FRAME_HEADER_BYTES + 4 + 4 * scene.state(0).len();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        if m.channel.topic == recording::SPEC_TOPIC {
            let spec: lumen_proto::SceneSpec = serde_json::from_slice(&m.data).unwrap();
            assert_eq!(spec, scene.spec);
            spec_seen = true;
        } else if m.channel.topic == recording::FRAMES_TOPIC {
            assert_eq!(m.channel.message_encoding, recording::FRAME_ENCODING);
            // The first is a key frame (every float), the others carry what changed.
            if frame_messages == 0 {
                assert_eq!(m.data.len(), full);
            }
            assert!(m.data.len() <= full);
            frame_messages += 1;
            frame_bytes += m.data.len();
            let h = FrameHeader::read(&m.data).unwrap();
            if h.client_time_ns != 0 {
                assert_eq!(m.log_time, h.client_time_ns, "log_time is the client's timestamp");
            }
        }
    }
    assert!(spec_seen);
    // The scope moves, the colon mostly does not: deltas are a small part of a whole frame.
    assert!(frame_bytes < full * 2 + (frame_messages as usize) * full / 4, "{frame_bytes} bytes for {frame_messages} frames of {full}");

    // Replayed back to back against the same daemon (a fresh session): identical contacts.
    let out = replay(&prefix, &path, &["--speed", "max", "--check"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}\n{}", String::from_utf8_lossy(&out.stderr));
    println!("{text}"); // the figures, with --nocapture
    assert_eq!(count_before(&text, "frames"), Some(FRAMES), "{text}");
    assert_eq!(count_before(&text, "matched"), Some(FRAMES), "{text}");
    assert_eq!(count_before(&text, "differed"), Some(0), "{text}");

    // The same over zenoh (the transport is a flag; the contacts do not depend on it).
    let out = replay(&prefix, &path, &["--speed", "max", "--check", "--zenoh", &daemon.endpoint()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}\n{}", String::from_utf8_lossy(&out.stderr));
    println!("{text}");
    assert_eq!(count_before(&text, "matched"), Some(FRAMES), "{text}");

    // A recording whose one reply was changed by one bit fails --check, naming that frame.
    let tampered = temp(&prefix, "tampered.mcap");
    let victim = (0..FRAMES).find(|k| !rec.replies[k].contacts.is_empty()).unwrap();
    {
        let mut w = Writer::create(&tampered, &rec.spec, rec.session, "iceoryx2").unwrap();
        for f in rec.frames().unwrap() {
            let f = f.unwrap();
            w.frame(&f.header, &f.state, 0).unwrap();
            let r = &rec.replies[&f.header.frame];
            let mut contacts = r.contacts.clone();
            if f.header.frame == victim {
                contacts[0].depth = f32::from_bits(contacts[0].depth.to_bits() ^ 1);
            }
            w.contacts(&r.header, &contacts, 0).unwrap();
        }
        w.finish(Missed::default()).unwrap();
    }
    let out = replay(&prefix, &tampered, &["--speed", "max", "--check"]);
    let (text, err) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(!out.status.success(), "{text}");
    assert_eq!(count_before(&text, "differed"), Some(1), "{text}");
    assert!(err.contains(&format!("first at frame {victim}")), "{err}");
    // Without --check the same difference is reported, and the exit is 0.
    let out = replay(&prefix, &tampered, &["--speed", "max"]);
    assert!(out.status.success());

    // At --speed 1 the replay follows the recorded pace: 30 frames 20+ ms apart take >= 0.5 s.
    let out = replay(&prefix, &path, &["--speed", "1", "--check"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    let seconds: f64 = text.split(" frames in ").nth(1).and_then(|s| s.split(' ').next()).and_then(|s| s.parse().ok()).expect("a duration");
    assert!(seconds >= 0.5, "paced replay took {seconds} s");

    drop(daemon);
    for p in [&path, &tampered] {
        let _ = std::fs::remove_file(p);
    }
    assert!(shm_files(&prefix).is_empty(), "left in /dev/shm: {:?}", shm_files(&prefix));
}

#[test]
fn ctrl_c_finishes_the_file() {
    let prefix = unique_prefix("sig");
    let daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let scene = scene();
    let path = temp(&prefix, "sigint.mcap");
    let client = client(&prefix);
    let mut session = client.open_session(&scene.spec).unwrap();
    let mut recorder = start_recorder(&prefix, session.id(), &path);
    drive(&mut session, &scene, 10);
    std::thread::sleep(Duration::from_millis(200));
    recorder.signal(libc::SIGINT);
    assert!(recorder.wait_exit(Duration::from_secs(10)).is_some_and(|s| s.success()), "the recorder did not stop cleanly on SIGINT");
    let summary = recorder.line_starting("lumen record: signal", WAIT).expect("a summary line");
    assert_eq!(count_before(&summary, "frames"), Some(10), "{summary}");
    // The session is still open; the file is complete and holds what was buffered.
    let rec = Recording::open(&path).unwrap();
    assert_eq!((rec.frames, rec.replies.len()), (10, 10));
    assert!(mcap::read::Summary::read(&std::fs::read(&path).unwrap()).unwrap().is_some());
    drop(session);
    drop(daemon);
    let _ = std::fs::remove_file(&path);
}

/// A small recording written in-process (no daemon needed).
fn write_recording(path: &Path, frames: u64) {
    let scene = scene();
    let mut w = Writer::create(path, &scene.spec, 7, "iceoryx2").unwrap();
    for k in 0..frames {
        let state = scene.state(k);
        let h = FrameHeader::new(7, k, 1_000 + k, state.len(), 2);
        w.frame(&h, &state, 0).unwrap();
        let mut reply = ContactsHeader::reply_to(&h);
        reply.count = 1;
        w.contacts(&reply, &[Contact { sample: k as u32, depth: 0.5, ..Contact::default() }], 0).unwrap();
    }
    w.finish(Missed::default()).unwrap();
}

#[test]
fn damaged_files_are_refused_clearly() {
    let prefix = unique_prefix("bad");
    let good = temp(&prefix, "good.mcap");
    write_recording(&good, 50);
    assert_eq!(Recording::open(&good).unwrap().frames, 50);
    let bytes = std::fs::read(&good).unwrap();

    let garbage = temp(&prefix, "garbage.mcap");
    std::fs::write(&garbage, b"this is not an mcap file at all, just some words").unwrap();
    let empty = temp(&prefix, "empty.mcap");
    std::fs::write(&empty, b"").unwrap();
    let cut = temp(&prefix, "cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let foreign = temp(&prefix, "foreign.mcap");
    {
        let mut w = mcap::Writer::new(std::io::BufWriter::new(std::fs::File::create(&foreign).unwrap())).unwrap();
        let ch = w.add_channel(0, "/camera", "raw", &Default::default()).unwrap();
        w.write_to_known_channel(&mcap::records::MessageHeader { channel_id: ch, sequence: 0, log_time: 1, publish_time: 1 }, &[1, 2, 3]).unwrap();
        w.finish().unwrap();
    }

    assert!(matches!(Recording::open(&garbage), Err(RecordingError::NotMcap { .. })), "{:?}", Recording::open(&garbage));
    assert!(matches!(Recording::open(&empty), Err(RecordingError::NotMcap { .. })), "{:?}", Recording::open(&empty));
    assert!(matches!(Recording::open(&cut), Err(RecordingError::Truncated { .. })), "{:?}", Recording::open(&cut));
    assert!(matches!(Recording::open(&foreign), Err(RecordingError::NotLumen { .. })), "{:?}", Recording::open(&foreign));

    // The command line says the same, names the file, and does not panic (no daemon needed:
    // the file is checked before connecting).
    for (file, says) in [(&garbage, "is not a readable MCAP file"), (&empty, "is not a readable MCAP file"), (&cut, "is cut short or damaged"), (&foreign, "no /lumen/spec message")] {
        let out = replay(&prefix, file, &["--speed", "max"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{}: {err}", file.display());
        assert!(err.contains(says) && err.contains(file.to_str().unwrap()), "{}: {err}", file.display());
        assert!(!err.contains("panicked"), "{err}");
    }
    let out = replay(&prefix, &temp(&prefix, "missing.mcap"), &[]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("missing.mcap"));
    let out = replay(&prefix, &good, &["--speed", "0"]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("positive number"));
    for p in [good, garbage, empty, cut, foreign] {
        let _ = std::fs::remove_file(p);
    }
}

/// At the real scale (the generated colonoscopy: 124,230 floats, 485 KiB per frame) driven at
/// a physics client's pace, the recorder keeps every frame and the replay matches.
#[test]
fn a_colon_sized_run_records_whole_and_replays() {
    const FRAMES: usize = 24;
    let prefix = unique_prefix("col");
    let daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let (spec, states) = lumen_scene::frames::generated(FRAMES);
    let path = temp(&prefix, "colon.mcap");
    {
        let client = client(&prefix);
        let mut session = client.open_session(&spec).unwrap();
        let mut recorder = start_recorder(&prefix, session.id(), &path);
        for (k, state) in states.iter().enumerate() {
            session.submit_state(state).unwrap();
            assert_eq!(session.contacts(WAIT).unwrap().frame(), k as u64);
            // The first frame carries the whole colon to the scene channel (3 MB of JSON, far
            // slower in a debug build than a frame's 60 ms): the pace leaves it that time. At
            // 20 ms a frame the recorder, writing each frame's scene update beside the frame,
            // fell one frame behind once in a CI run on this 2-core machine (its tests share
            // the cores): 60 ms is still a physics client's pace, with room for the recorder.
            std::thread::sleep(Duration::from_millis(if k == 0 { 1500 } else { 60 }));
        }
        std::thread::sleep(Duration::from_millis(200));
        drop(session);
        assert!(recorder.wait_exit(Duration::from_secs(10)).is_some_and(|s| s.success()));
        let summary = recorder.line_starting("lumen record: session ended", WAIT).expect("a summary line");
        println!("{summary}");
        assert!(summary.contains("missed 0 frames and 0 replies"), "{summary}");
    }
    let rec = Recording::open(&path).unwrap();
    assert_eq!((rec.frames, rec.replies.len()), (FRAMES as u64, FRAMES));
    assert_eq!(rec.spec, spec);
    let out = replay(&prefix, &path, &["--speed", "max", "--check"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}\n{}", String::from_utf8_lossy(&out.stderr));
    println!("{text}");
    assert_eq!(count_before(&text, "matched"), Some(FRAMES as u64), "{text}");
    drop(daemon);
    let _ = std::fs::remove_file(&path);
}

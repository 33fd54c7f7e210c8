//! Delta frames end to end (`proto/README.md`, section 2, "Delta frames"): the real daemon as a
//! child process, the Rust client sending deltas by itself over zenoh, raw messages for what a
//! client written from the page may get wrong, and a raw iceoryx2 client sending deltas.

use lumen_client::{Client, Observed};
use lumen_detect::Detector;
use lumen_e2e::{free_port, same_bits, unique_prefix, Daemon, TestScene};
use lumen_proto::auth::Secret;
use lumen_proto::wire::{encode_frame, FrameHeader, Status, FLAG_DELTA, FLAG_KEEP, FLAG_SCALED, FRAME_HEADER_BYTES};
use lumen_transport::delta::Encoder;
use std::path::Path;
use std::time::{Duration, Instant};
use zenoh::Wait;

const LUMEN: &str = env!("CARGO_BIN_EXE_lumen");
const WAIT: Duration = Duration::from_secs(3);

fn daemon(tag: &str) -> Daemon {
    Daemon::start(Path::new(LUMEN), &unique_prefix(tag), Some(free_port()), &[])
}

/// Frame `k` of a scope moving through a tube whose wall gives where the scope passes: the test
/// scene's rod, and the spokes of the rings around its tip pushed out a little, differently
/// each frame (as the colonoscopy's wall moves: a few rows change, most do not).
fn state(scene: &TestScene, rings: usize, spokes: usize, k: u64) -> Vec<f32> {
    let mut s = scene.state(k);
    let at = (k as usize / 3) % (rings - 6);
    for i in at..at + 6 {
        for j in 0..spokes {
            let o = (i * (spokes + 1) + 1 + j) * 3;
            let push = 1.0 + 0.01 * ((k as f32) * 0.3 + j as f32).sin();
            for c in 0..3 {
                s[o + c] *= push;
            }
        }
    }
    s
}

/// Over zenoh the client sends deltas by itself: every reply of a 400-frame run is bit for bit
/// the reply to the same frames sent whole, and an in-process detector's; the frames that went
/// as deltas are a small fraction of the whole frame's bytes; an observer sees them whole.
#[test]
fn deltas_over_zenoh_are_answered_bit_for_bit_as_whole_frames() {
    let d = daemon("dbits");
    let (rings, spokes) = (60, 16);
    let scene = TestScene::new(rings, spokes, 20);
    let client = Client::zenoh(&d.endpoint()).unwrap();
    let mut deltas = client.open_session(&scene.spec).unwrap();
    let mut whole = client.open_session(&scene.spec).unwrap();
    whole.set_deltas(false);
    let mut observer = client.observe(deltas.id()).unwrap();
    let mut reference = Detector::new(&scene.spec.validate().unwrap());
    let full_bytes = (FRAME_HEADER_BYTES + 4 * deltas.layout().floats) as u64;
    let mut delta_bytes = Vec::new();
    let mut observed = 0;
    let mut sent: Vec<Vec<f32>> = Vec::new();
    for k in 0..400 {
        let s = state(&scene, rings, spokes, k);
        let n = deltas.submit_state(&s).unwrap();
        let before = deltas.frame_counts();
        let got = deltas.contacts(WAIT).unwrap_or_else(|e| panic!("frame {k}: {e}"));
        assert_eq!((got.frame(), got.result()), (n, Ok(())), "frame {k}");
        let got = got.contacts().to_vec();
        if before.delta > 0 && before.last_bytes < full_bytes {
            delta_bytes.push(before.last_bytes);
        }
        whole.submit_state(&s).unwrap();
        let want = whole.contacts(WAIT).unwrap();
        assert!(same_bits(&got, want.contacts()), "frame {k}: the delta's reply differs from the whole frame's");
        assert!(same_bits(&got, reference.detect(&s).unwrap()), "frame {k}: differs from the in-process detector");
        sent.push(s);
        // The observer's frame, when it has one, is whole and the client's own.
        if let Ok(Observed::Frame { header, state }) = observer.next(Duration::from_millis(2)) {
            assert_eq!(header.flags & FLAG_DELTA, 0);
            let mine = &sent[header.frame as usize];
            assert!(state.iter().zip(mine).all(|(a, b)| a.to_bits() == b.to_bits()), "frame {}: the observer's state", header.frame);
            observed += 1;
        }
    }
    let counts = deltas.frame_counts();
    assert_eq!((counts.full, counts.delta), (1, 399), "the first frame whole, then deltas: {counts:?}");
    assert_eq!(whole.frame_counts().delta, 0);
    delta_bytes.sort_unstable();
    let median = delta_bytes[delta_bytes.len() / 2];
    assert!(median * 10 < full_bytes, "a delta's median {median} bytes against {full_bytes} whole");
    assert!(observed > 0, "the observer saw none of the client's frames");
}

/// A raw client of the page: the frame key, its tag, and a sender that numbers frames upward.
struct Raw {
    z: zenoh::Session,
    key: String,
    secret: Secret,
    session: u64,
    floats: usize,
    next: u64,
}

impl Raw {
    /// Sends `body` after a header flagged `flags`; returns the frame's number.
    fn send(&mut self, flags: u16, body: &[u8]) -> u64 {
        self.next += 1;
        let header = FrameHeader { flags, ..FrameHeader::new(self.session, self.next, 0, self.floats, 2) };
        let mut msg = header.to_bytes().to_vec();
        msg.extend_from_slice(body);
        let tag = self.secret.message_tag(&msg[..FRAME_HEADER_BYTES], msg.len());
        self.z.put(self.key.clone(), msg).attachment(tag.to_vec()).wait().unwrap();
        self.next
    }

    fn whole(&mut self, flags: u16, state: &[f32]) -> u64 {
        let mut msg = Vec::new();
        encode_frame(&FrameHeader::new(0, 0, 0, 0, 0), state, &mut msg);
        self.send(flags, &msg[FRAME_HEADER_BYTES..])
    }
}

/// A delta against a base the daemon never saw, against one it replaced, cut short or
/// corrupted: each is answered with its status and no contacts, and leaves the base as it was:
/// the next good delta is answered as its whole frame.
#[test]
fn deltas_against_unknown_bases_and_damaged_deltas_get_their_status_and_change_nothing() {
    let d = daemon("dbad");
    let scene = TestScene::new(30, 8, 12);
    let client = Client::zenoh(&d.endpoint()).unwrap();
    let mut session = client.open_session(&scene.spec).unwrap();
    // The client's own frames first (numbers 0 and 1), then raw ones numbered above them.
    for k in 0..2 {
        session.submit_state(&scene.state(k)).unwrap();
        session.contacts(WAIT).unwrap();
    }
    let info = session.info().clone();
    let z = zenoh::open(lumen_transport::net::config("client", &[], &[d.endpoint()]).unwrap()).wait().unwrap();
    let mut raw = Raw { z, key: info.frame.clone(), secret: Secret::parse(&info.secret).unwrap(), session: info.session, floats: info.floats as usize, next: 10 };
    let mut reference = Detector::new(&scene.spec.validate().unwrap());
    let mut enc = Encoder::new().unwrap();
    let delta = |enc: &mut Encoder, base_frame: u64, base: &[f32], new: &[f32]| {
        let mut out = Vec::new();
        enc.encode(base_frame, base, new, &mut out).unwrap();
        out
    };
    let expect = |session: &mut lumen_client::Session, n: u64, status: Status, says: &str| {
        let r = session.contacts(WAIT).unwrap_or_else(|e| panic!("frame {n}: {e}"));
        assert_eq!(r.frame(), n);
        match r.result() {
            Ok(()) => assert_eq!(status, Status::Ok, "frame {n}"),
            Err((got, message)) => {
                assert_eq!(got, status, "frame {n}: {message}");
                assert!(message.contains(says), "frame {n}: {message}");
                assert!(r.contacts().is_empty());
            }
        }
        r.contacts().to_vec()
    };
    let (s2, s3, s4) = (scene.state(2), scene.state(3), scene.state(4));
    // The client's frames were kept by the client's own deltas; a base numbered 5 never was.
    let n = raw.send(FLAG_DELTA | FLAG_SCALED | FLAG_KEEP, &delta(&mut enc, 5, &s2, &s3));
    expect(&mut session, n, Status::NoBase, "delta against frame 5; the session's base is frame 1");
    // A raw whole frame kept: the base.
    let base = raw.whole(FLAG_KEEP, &s2);
    let got = expect(&mut session, base, Status::Ok, "");
    assert!(same_bits(&got, reference.detect(&s2).unwrap()));
    // Cut short, corrupted, a wrong count: refused, the base as it was.
    let good = delta(&mut enc, base, &s2, &s3);
    let n = raw.send(FLAG_DELTA | FLAG_SCALED | FLAG_KEEP, &good[..good.len() - 5]);
    expect(&mut session, n, Status::BadDelta, "coded bytes but");
    let mut junk = good.clone();
    for b in &mut junk[16..] {
        *b = b.wrapping_mul(31).wrapping_add(7);
    }
    let n = raw.send(FLAG_DELTA | FLAG_SCALED | FLAG_KEEP, &junk);
    expect(&mut session, n, Status::BadDelta, "zstd");
    let n = raw.send(FLAG_DELTA | FLAG_SCALED | FLAG_KEEP, &good[..7]);
    expect(&mut session, n, Status::BadDelta, "shorter than its 16-byte delta header");
    // A scaled delta flagged as a plain one: its rows are not the size a plain delta's are.
    let n = raw.send(FLAG_DELTA | FLAG_KEEP, &good);
    expect(&mut session, n, Status::BadDelta, "decompress");
    let n = raw.send(FLAG_DELTA | FLAG_SCALED, &good);
    let got = expect(&mut session, n, Status::Ok, "");
    assert!(same_bits(&got, reference.detect(&s3).unwrap()));
    // Not kept: the next delta is still against the raw base, and kept it replaces the base.
    let kept = raw.send(FLAG_DELTA | FLAG_SCALED | FLAG_KEEP, &delta(&mut enc, base, &s2, &s4));
    let got = expect(&mut session, kept, Status::Ok, "");
    assert!(same_bits(&got, reference.detect(&s4).unwrap()));
    // A delta against the replaced base: refused, naming the base held.
    let n = raw.send(FLAG_DELTA | FLAG_SCALED, &delta(&mut enc, base, &s2, &s3));
    expect(&mut session, n, Status::NoBase, &format!("the session's base is frame {kept}"));
    let n = raw.send(FLAG_DELTA | FLAG_SCALED, &delta(&mut enc, kept, &s4, &s3));
    let got = expect(&mut session, n, Status::Ok, "");
    assert!(same_bits(&got, reference.detect(&s3).unwrap()));
}

/// A daemon restarted mid-run: the client's session reopens on the new daemon, which holds no
/// base; the client's first frame there goes whole and every reply stays right.
#[test]
fn after_a_daemon_restart_the_clients_deltas_start_again_from_a_whole_frame() {
    let prefix = unique_prefix("drestart");
    let port = free_port();
    let d = Daemon::start(Path::new(LUMEN), &prefix, Some(port), &[]);
    let scene = TestScene::new(30, 8, 12);
    let client = Client::zenoh(&d.endpoint()).unwrap();
    let mut session = client.open_session(&scene.spec).unwrap();
    let mut reference = Detector::new(&scene.spec.validate().unwrap());
    for k in 0..20 {
        session.submit_state(&scene.state(k)).unwrap();
        assert!(same_bits(session.contacts(WAIT).unwrap().contacts(), reference.detect(&scene.state(k)).unwrap()));
    }
    let before = session.frame_counts();
    assert_eq!((before.full, before.delta), (1, 19));
    d.terminate();
    let d = Daemon::start(Path::new(LUMEN), &prefix, Some(port), &[]);
    let mut answered = 0;
    let deadline = std::time::Instant::now() + Duration::from_secs(20);
    for k in 20.. {
        if answered == 10 || std::time::Instant::now() > deadline {
            break;
        }
        // Refused (`Disconnected`) until the client reaches the new daemon and reopens.
        if session.submit_state(&scene.state(k)).is_err() {
            std::thread::sleep(Duration::from_millis(100));
            continue;
        }
        if let Ok(r) = session.contacts(WAIT) {
            assert_eq!(r.result(), Ok(()), "frame {k}");
            let fresh = Detector::new(&scene.spec.validate().unwrap()).detect(&scene.state(k)).unwrap().to_vec();
            assert!(same_bits(r.contacts(), &fresh), "frame {k} after the restart");
            answered += 1;
        }
    }
    assert_eq!(answered, 10, "the session never came back");
    let after = session.frame_counts();
    assert_eq!(session.reconnects(), 1);
    assert!(after.full > before.full && after.delta >= before.delta + 8, "{before:?} then {after:?}");
    drop(d);
}

/// Over iceoryx2 a delta travels in the frame's `f32` slice, padded to whole floats: a raw client
/// written from the page opens a session on its node, keeps a whole frame, then sends 30 deltas,
/// each against the frame before it and kept; every reply is the whole frame's, bit for bit.
#[test]
fn deltas_over_iceoryx2_are_answered_as_whole_frames() {
    use iceoryx2::prelude::*;
    use lumen_proto::session::{ControlReply, ControlRequest};
    use lumen_proto::wire::{ContactsHeader, DELTA_HEADER_BYTES};
    use lumen_proto::Contact;
    let d = daemon("dshm");
    let scene = TestScene::new(30, 8, 12);
    let node = NodeBuilder::new().config(&lumen_transport::shm::config(Some(&d.prefix)).unwrap()).create::<lumen_transport::shm::Svc>().unwrap();
    // The open request from this node (the daemon answers only its publisher's frames).
    let request = serde_json::to_vec(&ControlRequest::Open { version: 1, spec: scene.spec.clone(), client: "raw".into(), echo: false, alive: String::new() }).unwrap();
    let control: ServiceName = "lumen/control".try_into().unwrap();
    let service = node.service_builder(&control).request_response::<[u8], [u8]>().open().unwrap();
    let wake = node.service_builder(&control).event().open().unwrap();
    let port = service.client_builder().initial_max_slice_len(request.len()).create().unwrap();
    let pending = port.loan_slice_uninit(request.len()).unwrap().write_from_slice(&request).send().unwrap();
    wake.notifier_builder().create().unwrap().notify_with_custom_event_id(EventId::new(0)).unwrap();
    let start = Instant::now();
    let info = loop {
        if let Some(reply) = pending.receive().unwrap() {
            match serde_json::from_slice(reply.payload()).unwrap() {
                ControlReply::Opened(info) => break info,
                other => panic!("{other:?}"),
            }
        }
        assert!(start.elapsed() < WAIT, "no open reply");
        std::thread::sleep(Duration::from_micros(200));
    };
    let floats = info.floats as usize;
    let (frames, frame_event) = lumen_transport::shm::open_frame(&node, &info.frame).unwrap();
    let publisher = frames.publisher_builder().initial_max_slice_len(floats).create().unwrap();
    let notifier = frame_event.notifier_builder().create().unwrap();
    let (contacts, _) = lumen_transport::shm::open_contacts(&node, &info.contacts).unwrap();
    let subscriber = contacts.subscriber_builder().create().unwrap();
    let send = |header: FrameHeader, payload: &[f32]| {
        let mut sample = publisher.loan_slice_uninit(payload.len()).unwrap().write_from_slice(payload);
        *sample.user_header_mut() = header;
        sample.send().unwrap();
        notifier.notify_with_custom_event_id(EventId::new(0)).unwrap();
    };
    let reply = |n: u64| -> (ContactsHeader, Vec<Contact>) {
        let start = Instant::now();
        loop {
            if let Some(s) = subscriber.receive().unwrap() {
                if s.user_header().frame == n {
                    return (*s.user_header(), s.payload().to_vec());
                }
            }
            assert!(start.elapsed() < WAIT, "no reply to frame {n}");
            std::thread::sleep(Duration::from_micros(200));
        }
    };
    let header = |n: u64, flags: u16| FrameHeader { flags, ..FrameHeader::new(info.session, n, 0, floats, 2) };
    send(header(0, FLAG_KEEP), &scene.state(0));
    let (h, _) = reply(0);
    assert_eq!(h.status, 0, "{}", h.message());
    let mut enc = Encoder::new().unwrap();
    let mut deltas = 0;
    for k in 1..=30u64 {
        let mut bytes = Vec::new();
        enc.encode(k - 1, &scene.state(k - 1), &scene.state(k), &mut bytes).unwrap();
        assert!(bytes.len() > DELTA_HEADER_BYTES);
        // Whole floats: up to 3 bytes of padding after the zstd frame.
        bytes.resize(bytes.len().div_ceil(4) * 4, 0);
        let payload: Vec<f32> = bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        assert!(payload.len() < floats / 4, "a delta of {} floats for a frame of {floats}", payload.len());
        send(header(k, enc.rows().flags() | FLAG_KEEP), &payload);
        let (h, got) = reply(k);
        assert_eq!(h.status, 0, "frame {k}: {}", h.message());
        let want = Detector::new(&scene.spec.validate().unwrap()).detect(&scene.state(k)).unwrap().to_vec();
        assert!(same_bits(&got, &want), "frame {k}: the delta's reply differs from the whole frame's");
        deltas += 1;
    }
    assert_eq!(deltas, 30);
}

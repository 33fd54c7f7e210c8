//! What `proto/README.md` tells a client written from it alone, checked against the real daemon
//! on both transports with raw requests: codes and messages for bad specs, the size limit, the
//! reserved header flags, the end of a session seen by an iceoryx2 observer, and `lumen status
//! --json` as the raw reply.

use iceoryx2::prelude::*;
use lumen_client::{Client, LocalOptions};
use lumen_e2e::{eventually, free_port, unique_prefix, Daemon, TestScene};
use lumen_proto::wire::Status;
use serde_json::Value;
use std::path::Path;
use std::time::Duration;
use zenoh::Wait;

const LUMEN: &str = env!("CARGO_BIN_EXE_lumen");
const WAIT: Duration = Duration::from_secs(3);

/// A daemon serving both transports, with `extra` flags.
fn daemon(tag: &str, extra: &[&str]) -> Daemon {
    Daemon::start(Path::new(LUMEN), &unique_prefix(tag), Some(free_port()), extra)
}

/// A client of `d` on each transport, shown as `name`.
fn both_clients(d: &Daemon, name: &str) -> [Client; 2] {
    [Client::local_with(LocalOptions { prefix: Some(d.prefix.clone()), name: Some(name.into()) }).unwrap(), Client::zenoh(&d.endpoint()).unwrap()]
}

/// One raw JSON request over iceoryx2 (request-response on `lumen/control`, then the event), as
/// section 1 describes; the reply parsed.
fn ask_iceoryx2(prefix: &str, json: &str) -> Value {
    let node = NodeBuilder::new().config(&lumen_transport::shm::config(Some(prefix)).unwrap()).create::<lumen_transport::shm::Svc>().unwrap();
    let name: ServiceName = "lumen/control".try_into().unwrap();
    let service = node.service_builder(&name).request_response::<[u8], [u8]>().open().unwrap();
    let wake = node.service_builder(&name).event().open().unwrap();
    let client = service.client_builder().initial_max_slice_len(json.len()).create().unwrap();
    let pending = client.loan_slice_uninit(json.len()).unwrap().write_from_slice(json.as_bytes()).send().unwrap();
    wake.notifier_builder().create().unwrap().notify_with_custom_event_id(EventId::new(0)).unwrap();
    let start = std::time::Instant::now();
    loop {
        if let Some(reply) = pending.receive().unwrap() {
            return serde_json::from_slice(reply.payload()).unwrap();
        }
        assert!(start.elapsed() < WAIT, "no reply over iceoryx2 to {json}");
        std::thread::sleep(Duration::from_micros(200));
    }
}

/// One raw JSON request over zenoh (`get` on `lumen/control`); the reply parsed.
fn ask_zenoh(endpoint: &str, json: &str) -> Value {
    let z = zenoh::open(lumen_transport::net::config("client", &[], &[endpoint.to_owned()]).unwrap()).wait().unwrap();
    let reply = z.get("lumen/control").payload(json.to_owned()).timeout(WAIT).wait().unwrap().recv().unwrap_or_else(|_| panic!("no reply over zenoh to {json}"));
    serde_json::from_slice(&reply.result().unwrap().payload().to_bytes()).unwrap()
}

/// Both transports' replies to `json`.
fn ask_both(d: &Daemon, json: &str) -> [(&'static str, Value); 2] {
    [("iceoryx2", ask_iceoryx2(&d.prefix, json)), ("zenoh", ask_zenoh(&d.endpoint(), json))]
}

/// An open request whose spec is the README's example with `edit` applied to it.
fn open_with(edit: impl FnOnce(&mut Value)) -> String {
    let mut spec = serde_json::json!({
        "bodies": [{"name": "colon", "shape": {"tube": {"rings": 20, "spokes": 8}}},
                   {"name": "scope", "shape": {"rod": {"points": 10, "radius": [2.0]}}}],
        "pairs": [{"a": "scope", "b": "colon", "kind": "interior"}],
        "precision": 4});
    edit(&mut spec);
    serde_json::json!({"op": "open", "version": 1, "client": "protocol-test", "spec": spec}).to_string()
}

#[test]
fn a_spec_field_of_the_wrong_type_or_value_is_code_spec_naming_it_on_both_transports() {
    let d = daemon("pspec", &[]);
    let set = |path: &'static str, to: Value| move |s: &mut Value| *s.pointer_mut(path).unwrap() = to;
    let cases: Vec<(String, &str)> = vec![
        (open_with(set("/pairs/0/kind", "inside".into())), "pair #0 (\"scope\", \"colon\"): unknown variant `inside`"),
        (open_with(|s| s["method"] = "fast".into()), "method: unknown variant `fast`"),
        (open_with(|s| s["nearest"] = "yes".into()), "nearest: invalid type: string \"yes\""),
        (open_with(set("/bodies/0/shape/tube/rings", (-1).into())), "body \"colon\": invalid value: integer `-1`"),
        (open_with(set("/bodies/0/shape/tube/rings", 20.5.into())), "body \"colon\": invalid type: floating point `20.5`"),
        (open_with(set("/bodies/0/shape/tube/rings", "20".into())), "body \"colon\": invalid type: string \"20\""),
        (open_with(|s| s["precision"] = 2.5.into()), "precision: invalid type: floating point `2.5`"),
        (open_with(set("/bodies/1/shape", serde_json::json!({"sphere": {"radius": 1.0}}))), "body \"scope\": unknown variant `sphere`"),
        // Numbers in range of their type but beyond the spec table's bounds.
        (open_with(set("/bodies/1/shape/rod/radius", serde_json::json!([1e30]))), "body \"scope\": rod radius #0 is 1000000000000000000000000000000"),
        (open_with(|s| s["margin"] = 2e9.into()), "margin = 2000000000"),
        (open_with(|s| s["precision"] = 65.into()), "precision x = 65"),
        (open_with(|s| s["colour"] = "red".into()), "unknown field \"colour\""),
    ];
    for (json, expected) in &cases {
        for (transport, reply) in ask_both(&d, json) {
            assert_eq!((reply["reply"].as_str(), reply["code"].as_str()), (Some("error"), Some("spec")), "{transport}: {json} -> {reply}");
            let message = reply["message"].as_str().unwrap();
            assert!(message.starts_with(&format!("invalid scene spec: {expected}")), "{transport}: {json} -> {message:?}, expected {expected:?}");
        }
    }
    // The request around the spec: its own errors are `bad_request`; `client` may be left out
    // and `method: "default"` is the default method's other name.
    for (transport, reply) in ask_both(&d, &open_with(|_| {}).replace("\"client\"", "\"colour\"")) {
        assert_eq!(reply["code"], "bad_request", "{transport}: {reply}");
    }
    let plain = serde_json::json!({"op": "open", "version": 1, "spec": serde_json::from_str::<Value>(&open_with(|s| s["method"] = "default".into())).unwrap()["spec"]}).to_string();
    for (transport, reply) in ask_both(&d, &plain) {
        assert_eq!(reply["reply"], "opened", "{transport}: {reply}");
        assert_eq!(reply["spec"]["method"], "signed", "{transport}: {reply}");
    }
}

#[test]
fn the_session_size_limit_holds_on_both_transports() {
    let cfg = std::env::temp_dir().join(format!("{}lumen.toml", unique_prefix("plimit")));
    std::fs::write(&cfg, "[limits]\nmax_session_mib = 2\n").unwrap();
    let d = daemon("plimit", &["--config", cfg.to_str().unwrap()]);
    // 3,000 rings of 64 spokes: 585,000 floats, a 2.2 MiB frame: beyond 2 MiB on both.
    let big = open_with(|s| s["bodies"][0]["shape"]["tube"] = serde_json::json!({"rings": 3000, "spokes": 64}));
    for (transport, reply) in ask_both(&d, &big) {
        assert_eq!(reply["code"], "limit", "{transport}: {reply}");
        assert!(reply["message"].as_str().unwrap().contains("the daemon allows 2 MiB"), "{transport}: {reply}");
    }
    // 20 rings of 8 spokes fit (1.4 MiB over iceoryx2: every subscriber's 16 frames and replies).
    for (transport, reply) in ask_both(&d, &open_with(|_| {})) {
        assert_eq!(reply["reply"], "opened", "{transport}: {reply}");
    }
}

/// On each transport: a frame whose header `edit` spoils is answered with status 1 (the reply
/// numbered `numbered(sent)`, its message containing `says`), and the next three frames are
/// answered as usual, each with its own number and contacts.
fn malformed_then_answered(tag: &str, edit: impl Fn(&mut lumen_proto::wire::FrameHeader), numbered: impl Fn(u64) -> u64, says: &str) {
    let d = daemon(tag, &[]);
    let scene = TestScene::new(20, 8, 10);
    for client in both_clients(&d, tag) {
        let mut s = client.open_session(&scene.spec).unwrap();
        s.frame().unwrap().copy_from_slice(&scene.state(0));
        let sent = s.submit_with(&edit).unwrap();
        let reply = s.contacts(WAIT).unwrap();
        assert_eq!(reply.frame(), numbered(sent));
        let (status, message) = reply.result().unwrap_err();
        assert_eq!(status, Status::Malformed, "{message}");
        assert!(message.contains(says), "{message}");
        assert_eq!(reply.contacts().len(), 0);
        for k in 1..4 {
            s.frame().unwrap().copy_from_slice(&scene.state(k));
            let sent = s.submit().unwrap();
            let reply = s.contacts(WAIT).unwrap_or_else(|e| panic!("{:?}: frame {sent} after the malformed one: {e}", client.transport()));
            assert_eq!(reply.frame(), sent);
            assert!(reply.result().is_ok(), "{:?}", reply.result());
            assert!(!reply.contacts().is_empty(), "the test scene touches the wall");
        }
    }
}

#[test]
fn a_frame_with_reserved_flags_is_answered_malformed_and_the_session_goes_on() {
    malformed_then_answered("pflags", |h| h.flags = 8, |sent| sent, "frame flags are 0x0008; version 1 defines only bit 0 (delta), bit 1 (keep) and bit 2 (scaled, with delta only)");
}

#[test]
fn an_iceoryx2_observer_sees_the_session_end_as_its_contacts_service_losing_its_publisher() {
    let d = daemon("pend", &[]);
    let scene = TestScene::new(20, 8, 10);
    let client = Client::local_with(LocalOptions { prefix: Some(d.prefix.clone()), name: Some("owner".into()) }).unwrap();
    let mut s = client.open_session(&scene.spec).unwrap();
    s.frame().unwrap().copy_from_slice(&scene.state(0));
    s.submit().unwrap();
    s.contacts(WAIT).unwrap();
    // An observer of its own, with iceoryx2 alone, as section 4 says.
    let node = NodeBuilder::new().config(&lumen_transport::shm::config(Some(&d.prefix)).unwrap()).create::<lumen_transport::shm::Svc>().unwrap();
    let name: ServiceName = s.info().contacts.as_str().try_into().unwrap();
    let contacts = node.service_builder(&name).publish_subscribe::<[lumen_proto::Contact]>().user_header::<lumen_proto::wire::ContactsHeader>().open().unwrap();
    let publishers = || contacts.dynamic_config().number_of_publishers();
    assert_eq!(publishers(), 1, "the daemon's publisher while the session is open");
    s.close().unwrap();
    assert!(
        eventually(WAIT, || {
            node.try_cleanup_dead_nodes();
            publishers() == 0
        }),
        "the session ended but its contacts service still has {} publishers",
        publishers()
    );
}

#[test]
fn status_json_prints_the_daemons_raw_reply() {
    let d = daemon("pstatus", &[]);
    let out = std::process::Command::new(LUMEN).args(["status", "--json", "--prefix", &d.prefix]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let printed: Value = serde_json::from_slice(&out.stdout).unwrap();
    let raw = ask_iceoryx2(&d.prefix, r#"{"op":"status"}"#);
    assert_eq!(printed["reply"], "status", "{printed}");
    let keys = |v: &Value| v.as_object().unwrap().keys().cloned().collect::<Vec<_>>();
    assert_eq!(keys(&printed), keys(&raw), "lumen status --json and the raw reply have other fields");
}

#[test]
fn a_frame_numbered_beyond_2_pow_53_is_answered_malformed_and_later_frames_go_on() {
    malformed_then_answered("pnumber", |h| h.frame = u64::MAX, |_| u64::MAX, "frame number 18446744073709551615 is beyond 9007199254740991");
}

/// A frame never outlives itself in the daemon either: a colonoscopy's session sent a frame
/// whose colon is all zeros (a physics engine that sends its state before it wrote the colon),
/// then genuine frames, gets for each what a fresh detector gives, bit for bit, on both
/// transports. (`scene/tests/glitch.rs` tries every kind of glitch on the detector itself.)
#[test]
fn after_a_frame_of_zeros_the_daemon_answers_as_a_fresh_session() {
    let d = daemon("pglitch", &[]);
    let colon = lumen_scene::generate(&lumen_scene::ColonParams::seeded(1));
    let insertion = lumen_scene::Insertion { escapes: false, ..Default::default() };
    let states: Vec<Vec<f32>> = insertion
        .frames(&colon, 6, 400.0, 1.0, 1)
        .map(|f| lumen_detect::Scene::new().tube("colon", f.colon).rod("scope", f.scope).pair("scope", "colon", lumen_detect::ContactKind::Interior).state())
        .collect();
    let spec = {
        let f = insertion.frame(&colon, 400.0);
        lumen_detect::Scene::new().tube("colon", f.colon).rod("scope", f.scope).pair("scope", "colon", lumen_detect::ContactKind::Interior).spec()
    };
    let scene = spec.validate().unwrap();
    let tube_floats = scene.layout().bodies[0].floats();
    let clients = both_clients(&d, "glitch");
    for client in clients {
        let mut s = client.open_session(&spec).unwrap();
        let mut send = |state: &[f32]| {
            s.submit_state(state).unwrap();
            let r = s.contacts(WAIT).unwrap();
            assert!(r.result().is_ok(), "{:?}", r.result());
            r.contacts().to_vec()
        };
        send(&states[0]);
        let mut zeros = states[1].clone();
        zeros[..tube_floats].fill(0.0);
        send(&zeros);
        for (k, state) in states.iter().enumerate().skip(1) {
            let got = send(state);
            let fresh = lumen_detect::Detector::new(&scene).detect(state).unwrap().to_vec();
            assert!(lumen_e2e::same_bits(&got, &fresh), "{:?}: frame {k} after a frame of zeros: {} contacts, a fresh session {}", client.transport(), got.len(), fresh.len());
        }
    }
}

/// A wait that timed out never makes the next one return that frame's late reply: on both
/// transports a reply is the newest frame's, and the late one is dropped and counted.
#[test]
fn a_reply_after_a_timed_out_wait_is_never_taken_for_the_next_frames() {
    let d = daemon("pstale", &[]);
    let scene = TestScene::new(20, 8, 10);
    for client in both_clients(&d, "stale") {
        let mut s = client.open_session(&scene.spec).unwrap();
        s.submit_state(&scene.state(0)).unwrap();
        assert_eq!(s.contacts(WAIT).unwrap().frame(), 0);
        // A frame whose wait gives up at once while its reply is still on the way. On a busy
        // machine the reply can beat the zero wait: that frame is then answered as usual and
        // the next one tries again.
        let late = (1..50)
            .find(|&k| {
                let frame = s.submit_state(&scene.state(k)).unwrap();
                match s.contacts(Duration::ZERO) {
                    Err(lumen_client::Error::Timeout(_)) => true,
                    Ok(r) => {
                        assert_eq!(r.frame(), frame, "{:?}", client.transport());
                        false
                    }
                    Err(e) => panic!("{:?}: {e}", client.transport()),
                }
            })
            .expect("a zero wait gave up on one of 49 frames");
        std::thread::sleep(Duration::from_millis(300));
        let next = s.submit_state(&scene.state(late + 1)).unwrap();
        let r = s.contacts(WAIT).unwrap();
        assert_eq!((next, r.frame()), (late + 1, late + 1), "{:?}: the wait for frame {} returned frame {}'s reply", client.transport(), late + 1, r.frame());
        assert!(lumen_e2e::same_bits(r.contacts(), lumen_detect::Detector::new(&scene.spec.validate().unwrap()).detect(&scene.state(late + 1)).unwrap()));
        assert_eq!(s.stale_replies(), 1, "{:?}", client.transport());
        // The same through try_contacts.
        s.submit_state(&scene.state(late + 2)).unwrap();
        std::thread::sleep(Duration::from_millis(300));
        s.submit_state(&scene.state(late + 3)).unwrap();
        let r = (0..300).find_map(|_| {
            let got = s.try_contacts().unwrap().map(|r| r.frame());
            if got.is_none() {
                std::thread::sleep(Duration::from_millis(10));
            }
            got
        });
        assert_eq!((r, s.stale_replies()), (Some(late + 3), 2), "{:?}", client.transport());
    }
}

/// `lumen bench sessions` against `d` with `args`: per printed line, the cycles done, the
/// daemon's and the bench's resident memory (KiB).
fn session_cycles(d: &Daemon, args: &[&str]) -> Vec<(u64, u64, u64)> {
    let out = std::process::Command::new(LUMEN).args(["bench", "sessions"]).args(args).env("LUMEN_IOX2_PREFIX", &d.prefix).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "lumen bench sessions {args:?}: {}\n{text}", String::from_utf8_lossy(&out.stderr));
    eprintln!("lumen bench sessions {args:?}:\n{text}");
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[0].parse().unwrap(), f[1].parse().unwrap(), f[2].parse().unwrap())
        })
        .collect()
}

/// The growth from the line at `from` cycles to the last: (daemon, client), KiB.
fn growth(lines: &[(u64, u64, u64)], from: u64) -> (i64, i64) {
    let base = lines.iter().find(|l| l.0 == from).expect("a line at `from`");
    let last = lines.last().unwrap();
    (last.1 as i64 - base.1 as i64, last.2 as i64 - base.2 as i64)
}

/// Sessions opened, sent a frame and closed back to back leave the daemon's and the client's
/// memory where it was: 10,000 zenoh cycles by four connections at once, each a client of its
/// own, keep both within 2 MiB of where they were after 500 (a fresh key for every session once
/// grew the daemon by about 6 KiB and the client by 4 KiB a cycle, as zenoh keeps each key a
/// connection saw), and iceoryx2 cycles as well, 1,000 of them (each costs some 0.2 s of the
/// daemon's time in a debug build).
#[test]
fn session_cycles_leave_the_daemons_and_the_clients_memory_flat() {
    let d = daemon("pcycles", &[]);
    let zenoh = session_cycles(&d, &["--zenoh", &d.endpoint(), "--cycles", "10000", "--every", "500", "--clients", "4"]);
    assert_eq!(zenoh.last().unwrap().0, 10_000);
    let (daemon_kib, client_kib) = growth(&zenoh, 500);
    assert!(daemon_kib <= 2048 && client_kib <= 2048, "zenoh, from 500 to 10,000 cycles: the daemon grew by {daemon_kib} KiB, the client by {client_kib}");
    let iceoryx2 = session_cycles(&d, &["--transport", "iceoryx2", "--cycles", "1000", "--every", "500"]);
    assert_eq!(iceoryx2.last().unwrap().0, 1_000);
    let (daemon_kib, client_kib) = growth(&iceoryx2, 500);
    assert!(daemon_kib <= 2048 && client_kib <= 2048, "iceoryx2, from 500 to 1,000 cycles: the daemon grew by {daemon_kib} KiB, the client by {client_kib}");
}

//! The server as a page sees it: the page over HTTP, then the scene and frames on the socket,
//! one frame per "ready", the newest one, never a queue.

use lumen_proto::{BodySpec, ContactKind, PairSpec, SceneSpec, Shape};
use lumen_view::{SceneInfo, Snapshot, Source, Stats, Viewer};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};
use tungstenite::Message;

fn scene() -> SceneInfo {
    let spec = SceneSpec::new(
        vec![BodySpec { name: "colon".into(), shape: Shape::Tube { rings: 10, spokes: 4 } }, BodySpec { name: "scope".into(), shape: Shape::Rod { points: 3, radius: vec![1.0] } }],
        vec![PairSpec { a: "scope".into(), b: "colon".into(), kind: ContactKind::Interior }],
    );
    SceneInfo::new(&spec, 42, Source::Live, 2, 0, "test")
}

fn snapshot(frame: u64) -> Snapshot {
    let mut state = Vec::new();
    for i in 0..10 {
        state.extend_from_slice(&[i as f32 * 2.0 + frame as f32 * 0.01, 0.0, 0.0]);
        for k in 0..4 {
            let a = k as f32 * std::f32::consts::FRAC_PI_2;
            state.extend_from_slice(&[0.0, 3.0 * a.cos(), 3.0 * a.sin()]);
        }
    }
    state.extend_from_slice(&[0.0; 9]);
    Snapshot { state, contacts: Vec::new(), stats: Stats { frame, ..Default::default() } }
}

fn get(addr: std::net::SocketAddr, path: &str) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    write!(s, "GET {path} HTTP/1.1\r\nHost: x\r\n\r\n").unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    out
}

fn frame_number(m: &Message) -> u64 {
    let Message::Binary(b) = m else { panic!("expected a frame, got {m:?}") };
    let n = u32::from_le_bytes(b[4..8].try_into().unwrap()) as usize;
    let v: serde_json::Value = serde_json::from_slice(&b[8..8 + n]).unwrap();
    v["stats"]["frame"].as_u64().unwrap()
}

#[test]
fn a_page_gets_the_scene_then_the_newest_frame_per_ready() {
    let viewer = Viewer::start("127.0.0.1:0", scene()).unwrap();
    let page = get(viewer.addr(), "/");
    assert!(page.starts_with("HTTP/1.1 200") && page.contains("<canvas id=\"gl\">"), "{page}");
    assert!(get(viewer.addr(), "/view.js").contains("webgl2"));
    assert!(get(viewer.addr(), "/nothing").starts_with("HTTP/1.1 404"));
    assert!(get(viewer.addr(), "/scene.json").contains("\"session\":42"));

    let stream = TcpStream::connect(viewer.addr()).unwrap();
    let (mut ws, _) = tungstenite::client(format!("ws://{}/ws", viewer.addr()), stream).unwrap();
    let Message::Text(t) = ws.read().unwrap() else { panic!("the scene comes first, as text") };
    assert!(t.as_str().contains("\"type\":\"scene\""));
    viewer.publish(snapshot(0));
    assert_eq!(frame_number(&ws.read().unwrap()), 0);
    // Without "ready" the page is sent nothing more, however many frames come: publishing
    // never waits for it.
    let t0 = Instant::now();
    for f in 1..=500 {
        viewer.publish(snapshot(f));
    }
    assert!(t0.elapsed() < Duration::from_secs(2), "publishing waited for the page");
    ws.get_ref().set_read_timeout(Some(Duration::from_millis(300))).unwrap();
    assert!(ws.read().is_err(), "a frame came without ready");
    ws.get_ref().set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    ws.send(Message::text(r#"{"op":"ready"}"#)).unwrap();
    let m = ws.read().unwrap();
    assert_eq!(frame_number(&m), 500, "the newest frame, not the next in line");
    let Message::Binary(b) = &m else { unreachable!() };
    let n = u32::from_le_bytes(b[4..8].try_into().unwrap()) as usize;
    let v: serde_json::Value = serde_json::from_slice(&b[8..8 + n]).unwrap();
    assert_eq!(v["dropped"], 499);
    assert_eq!(viewer.counters().messages, 2);
    assert_eq!(viewer.counters().pages, 1);
    // Controls reach the player.
    ws.send(Message::text(r#"{"op":"seek","index":7}"#)).unwrap();
    let c = viewer.control_timeout(Duration::from_secs(5));
    assert_eq!(c, Some(lumen_view::Control::Seek(7)));
}

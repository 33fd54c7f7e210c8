//! `lumen view` end to end: the real daemon, a session driven by this test (and `lumen demo
//! --view`, the physics), the real `lumen view`, and its page in headless Chromium. The page is
//! held on a frame (its "hold" box), then its numbers are checked against the replies the
//! session got and its pixels against where that frame puts the scope, the wall and the
//! contacts (projected through the page's own view-projection matrix).
//!
//! `LUMEN_VIEW_SHOTS=DIR` keeps the screenshots there (the README's picture comes from it).

use lumen_cli::recording::Recording;
use lumen_client::{Client, LocalOptions};
use lumen_e2e::browser::{Browser, Image, Page};
use lumen_e2e::{free_port, unique_prefix, ChildProcess, Daemon, TestScene};
use lumen_proto::Contact;
use serde_json::Value;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc, Mutex};
use std::time::Duration;

const LUMEN: &str = env!("CARGO_BIN_EXE_lumen");
const WAIT: Duration = Duration::from_secs(30);
/// The page's size in CSS pixels (the screenshot's, at a device scale of 1).
const SIZE: (u32, u32) = (960, 640);
/// The page's clear colour (`gl.clearColor(0.078, 0.086, 0.118)`).
const BACKGROUND: [u8; 3] = [20, 22, 30];

fn scene() -> TestScene {
    TestScene::new(40, 16, 24)
}

/// `lumen view ARGS --listen 127.0.0.1:0`; returns it and the address it serves.
fn start_view(args: &[&str]) -> (ChildProcess, String) {
    let mut cmd = Command::new(LUMEN);
    cmd.arg("view").args(args).args(["--listen", "127.0.0.1:0", "--log", "warn"]);
    let view = ChildProcess::spawn(cmd);
    let line = view.line_starting("lumen view: serving ", WAIT).expect("lumen view did not say where it serves");
    let url = line.trim_start_matches("lumen view: serving ").trim().to_owned();
    (view, url)
}

fn open(browser: &Browser, url: &str) -> Page {
    let mut page = browser.new_page("about:blank").expect("a page");
    page.set_viewport(SIZE.0, SIZE.1).expect("viewport");
    page.navigate(url).expect("the view's page loads");
    page.wait_for("window.lumenView && lumenView.frames > 0", WAIT).expect("the page drew no frame");
    page
}

/// Holds the page on its current frame and returns what it shows, once nothing more arrives.
fn hold(page: &mut Page) -> Value {
    page.eval("document.getElementById('hold').checked = true; true").unwrap();
    let mut last = -1.0;
    for _ in 0..50 {
        std::thread::sleep(Duration::from_millis(100));
        let n = page.eval("lumenView.frames").unwrap().as_f64().unwrap();
        if n == last {
            break;
        }
        last = n;
    }
    shown(page)
}

/// The page's state: stats, matrices, tip, contacts, and the panel's texts.
fn shown(page: &mut Page) -> Value {
    page.eval(
        "(() => { const t = (id) => document.getElementById(id).textContent;
          const r = (id) => { const b = document.getElementById(id).getBoundingClientRect(); return [b.left, b.top, b.right, b.bottom]; };
          return { frames: lumenView.frames, stats: lumenView.stats, viewProj: lumenView.viewProj, width: lumenView.width, height: lumenView.height,
            tip: lumenView.tip, contacts: lumenView.contacts, error: lumenView.error,
            panel: { session: t('session'), frame: t('frame'), turnaround: t('turnaround'), contacts: t('contacts'), maxpen: t('maxpen'), detect: t('detect'), fps: t('fps'),
                     escaped: t('escaped'), index: t('index') },
            covered: [r('panel'), r('legend'), r('enter-vr')] }; })()",
    )
    .unwrap()
}

/// Moves a recording's scrubber to `index` as a person drags it, and waits for that frame.
fn scrub(page: &mut Page, index: impl std::fmt::Display, what: &str) {
    page.eval(&format!("(() => {{ const s = document.getElementById('scrub'); s.value = '{index}'; s.dispatchEvent(new Event('input')); return true; }})()")).unwrap();
    page.wait_for(&format!("lumenView.stats.index === {index}"), WAIT).expect(what);
}

/// Draws once more with the wall shown or hidden and takes a screenshot.
fn screenshot(page: &mut Page, wall: bool, name: &str) -> Image {
    page.eval(&format!("(() => {{ const w = document.getElementById('wall'); w.checked = {wall}; w.dispatchEvent(new Event('change')); return true; }})()")).unwrap();
    std::thread::sleep(Duration::from_millis(200));
    let img = page.screenshot().expect("a screenshot");
    if let Some(dir) = std::env::var_os("LUMEN_VIEW_SHOTS") {
        let _ = std::fs::create_dir_all(&dir);
        img.save_png(Path::new(&dir).join(format!("{name}.png"))).unwrap();
    }
    img
}

fn f32s(v: &Value) -> Vec<f32> {
    v.as_array().expect("an array").iter().map(|x| x.as_f64().expect("a number") as f32).collect()
}

/// `p` in screen pixels through the page's column-major view-projection matrix; `None` behind
/// the eye or off the page.
fn project(s: &Value, p: [f32; 3]) -> Option<(u32, u32)> {
    let m: Vec<f64> = s["viewProj"].as_array()?.iter().map(|x| x.as_f64().unwrap()).collect();
    let (w, h) = (s["width"].as_f64()?, s["height"].as_f64()?);
    let c = |r: usize| m[r] * p[0] as f64 + m[4 + r] * p[1] as f64 + m[8 + r] * p[2] as f64 + m[12 + r];
    let (x, y, cw) = (c(0), c(1), c(3));
    if cw <= 0.0 {
        return None;
    }
    let (sx, sy) = ((x / cw + 1.0) * 0.5 * w, (1.0 - y / cw) * 0.5 * h);
    (sx >= 2.0 && sy >= 2.0 && sx < w - 2.0 && sy < h - 2.0).then_some((sx as u32, sy as u32))
}

/// Whether `(x, y)` lies under the panel, the legend or the VR button (HTML over the canvas).
fn covered(s: &Value, (x, y): (u32, u32)) -> bool {
    s["covered"].as_array().unwrap().iter().any(|r| {
        let r = f32s(r);
        r[2] > r[0] && (x as f32) >= r[0] - 3.0 && (x as f32) <= r[2] + 3.0 && (y as f32) >= r[1] - 3.0 && (y as f32) <= r[3] + 3.0
    })
}

/// Whether some pixel within 2 px of `at` satisfies `f`.
fn near(img: &Image, (x, y): (u32, u32), f: impl Fn([u8; 4]) -> bool) -> bool {
    (x.saturating_sub(2)..=x + 2).any(|i| (y.saturating_sub(2)..=y + 2).any(|j| i < img.width && j < img.height && f(img.pixel(i, j))))
}

fn is_background(p: [u8; 4]) -> bool {
    (0..3).all(|k| (p[k] as i32 - BACKGROUND[k] as i32).abs() <= 6)
}
/// The scope with the wall hidden: its blue (0.24, 0.5, 1.0), lit.
fn is_scope(p: [u8; 4]) -> bool {
    p[2] as i32 > p[0] as i32 + 40 && p[2] > 70
}
/// A contact marker: yellow to red by depth, or magenta outside the wall; unlit, over all.
fn is_marker(p: [u8; 4]) -> bool {
    p[0] > 200 && ((p[1] < 240 && p[2] < 60) || (p[1] < 60 && p[2] > 200))
}

/// Every check of one held frame: the panel against the reply, the tip against the state, the
/// scope, wall and markers in the pixels. `truth`: the frame's state, its contacts, detect ns.
fn check_frame(page: &mut Page, s: &Value, spec: &lumen_proto::SceneSpec, state: &[f32], contacts: &[Contact], detect_ns: u32, name: &str) {
    assert!(s["error"].is_null(), "the page reported {}", s["error"]);
    let panel = &s["panel"];
    assert_eq!(panel["frame"].as_str().unwrap(), s["stats"]["frame"].as_u64().unwrap().to_string());
    assert_eq!(panel["contacts"].as_str().unwrap(), contacts.len().to_string(), "contacts on the panel");
    let deepest = contacts.iter().map(|c| c.depth).fold(0.0f32, f32::max);
    let maxpen: f64 = panel["maxpen"].as_str().unwrap().parse().unwrap();
    assert!((maxpen - deepest as f64).abs() <= 0.0005 + 1e-6, "max penetration {maxpen} on the panel, {deepest} in the reply");
    let detect: f64 = panel["detect"].as_str().unwrap().parse().unwrap();
    assert!((detect - detect_ns as f64 / 1e3).abs() <= 0.5 + 1e-6, "detection {detect} us on the panel, {detect_ns} ns in the reply");
    let outside = contacts.iter().filter(|c| c.flags & lumen_proto::contact::FLAG_OUTSIDE != 0).count();
    assert_eq!(panel["escaped"].as_str().unwrap(), outside.to_string());

    // The bodies as the frame has them: the tube's rings and spokes, the rod's points.
    let (rings, spokes, rod) = match (&spec.bodies[0].shape, &spec.bodies[1].shape) {
        (lumen_proto::Shape::Tube { rings, spokes }, lumen_proto::Shape::Rod { points, .. }) => (*rings, *spokes, *points),
        _ => panic!("a tube then a rod"),
    };
    let at = |i: usize| [state[3 * i], state[3 * i + 1], state[3 * i + 2]];
    let rod0 = rings * (spokes + 1);
    let tip = at(rod0 + rod - 1);
    assert_eq!(f32s(&s["tip"]), tip.to_vec(), "the page's tip is the frame's last rod point");
    let shown: Vec<Vec<f32>> = s["contacts"].as_array().unwrap().iter().map(|c| f32s(&c["point"])).collect();
    let sent: Vec<Vec<f32>> = contacts.iter().map(|c| c.point_b.to_vec()).collect();
    assert_eq!(shown, sent, "the page's contacts are the reply's wall points, in order");

    // Wall hidden: the scope is where the frame puts it (the middle of each rod segment).
    let img = screenshot(page, false, &format!("{name}-scope"));
    let mids: Vec<(u32, u32)> = (0..rod - 1)
        .filter_map(|j| {
            let (a, b) = (at(rod0 + j), at(rod0 + j + 1));
            project(s, [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0, (a[2] + b[2]) / 2.0])
        })
        .filter(|&p| !covered(s, p))
        .collect();
    // (The colonoscope's outer end runs off the page: the points on it are what is checked.)
    assert!(mids.len() >= 10.min(rod - 1), "the scope is on the page ({} of {} points)", mids.len(), rod - 1);
    let on = mids.iter().filter(|&&p| near(&img, p, |px| is_scope(px) || is_marker(px))).count();
    assert!(on * 10 >= mids.len() * 9, "the scope is drawn at {on} of {} of its projected points", mids.len());
    // Contacts: a marker at every wall point that is not under the panel.
    let marks: Vec<(u32, u32)> = contacts.iter().filter_map(|c| project(s, c.point_b)).filter(|&p| !covered(s, p)).collect();
    let hit = marks.iter().filter(|&&p| near(&img, p, is_marker)).count();
    assert_eq!(hit, marks.len(), "contact markers drawn at {hit} of {} projected wall points", marks.len());
    // The fitted camera leaves a margin around the scene: the top right corner is background.
    assert!(is_background(img.pixel(img.width - 4, 4)), "the background where nothing is");

    // Wall shown: every tip of the middle rings is covered by the wall's surface.
    let img = screenshot(page, true, name);
    let tips: Vec<(u32, u32)> = (rings / 4..3 * rings / 4)
        .flat_map(|i| (0..spokes).map(move |k| (i, k)))
        .filter_map(|(i, k)| {
            let (c, r) = (at(i * (spokes + 1)), at(i * (spokes + 1) + 1 + k));
            project(s, [c[0] + r[0] * 0.98, c[1] + r[1] * 0.98, c[2] + r[2] * 0.98])
        })
        .filter(|&p| !covered(s, p))
        .collect();
    assert!(tips.len() > 20, "the wall is on the page");
    let drawn = tips.iter().filter(|&&p| near(&img, p, |px| !is_background(px))).count();
    assert!(drawn * 20 >= tips.len() * 19, "the wall is drawn at {drawn} of {} projected wall points", tips.len());
}

/// One reply as the test's client got it.
#[derive(Clone)]
struct Reply {
    contacts: Vec<Contact>,
    detect_ns: u32,
}

#[test]
fn a_live_session_is_drawn_where_its_frame_puts_it() {
    let prefix = unique_prefix("view");
    let _daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let scene = Arc::new(scene());
    let replies: Arc<Mutex<HashMap<u64, Reply>>> = Arc::default();
    let stop = Arc::new(AtomicBool::new(false));
    let (id_tx, id_rx) = mpsc::channel();
    let driver = {
        let (scene, replies, stop, prefix) = (scene.clone(), replies.clone(), stop.clone(), prefix.clone());
        std::thread::spawn(move || {
            let client = Client::local_with(LocalOptions { prefix: Some(prefix), name: Some("view-test".into()) }).expect("a client");
            let mut session = client.open_session(&scene.spec).expect("a session");
            id_tx.send(session.id()).unwrap();
            let mut k = 0u64;
            while !stop.load(Ordering::Relaxed) {
                session.submit_state(&scene.state(k)).unwrap();
                let r = session.contacts(WAIT).unwrap();
                assert_eq!(r.frame(), k);
                replies.lock().unwrap().insert(k, Reply { contacts: r.contacts().to_vec(), detect_ns: r.header().detect_ns });
                k += 1;
                std::thread::sleep(Duration::from_millis(4));
            }
        })
    };
    let id = id_rx.recv_timeout(WAIT).expect("the session opened");
    let (view, url) = start_view(&[&id.to_string(), "--prefix", &prefix]);
    assert!(view.line_starting(&format!("lumen view: session {id}"), WAIT).is_some());
    let browser = Browser::launch().expect("headless Chromium (Debian's chromium package)");
    let mut page = open(&browser, &url);
    page.wait_for("lumenView.frames >= 5 && lumenView.stats.turnaround_us > 0", WAIT).expect("frames keep coming, with the daemon's turnaround");
    let s = hold(&mut page);
    assert_eq!(s["panel"]["session"].as_str().unwrap(), id.to_string());
    let frame = s["stats"]["frame"].as_u64().unwrap();
    let fps: f64 = s["panel"]["fps"].as_str().unwrap().parse().unwrap();
    assert!(fps > 10.0 && fps < 1000.0, "the session's frame rate on the panel: {fps}");
    let turnaround: f64 = s["panel"]["turnaround"].as_str().unwrap().parse().unwrap();
    assert!(turnaround > 0.0, "the daemon's turnaround on the panel");
    let truth = replies.lock().unwrap().get(&frame).cloned().expect("the shown frame was answered");
    check_frame(&mut page, &s, &scene.spec, &scene.state(frame), &truth.contacts, truth.detect_ns, "live");
    assert!(!truth.contacts.is_empty(), "the frame shown has contacts to draw");
    // Held, the page gets nothing more while the session goes on; released, it catches up.
    let n = page.eval("lumenView.frames").unwrap().as_u64().unwrap();
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(page.eval("lumenView.frames").unwrap().as_u64().unwrap(), n, "a held page is sent nothing");
    page.eval("(() => { const h = document.getElementById('hold'); h.checked = false; h.dispatchEvent(new Event('change')); return true; })()").unwrap();
    page.wait_for(&format!("lumenView.stats.frame > {frame} + 20"), WAIT).expect("a released page shows newer frames");
    stop.store(true, Ordering::Relaxed);
    driver.join().expect("the driver");
}

#[test]
fn without_a_session_the_view_follows_the_first_then_the_next_to_open() {
    let prefix = unique_prefix("viewnext");
    let _daemon = Daemon::start(Path::new(LUMEN), &prefix, None, &[]);
    let scene = scene();
    let client = Client::local_with(LocalOptions { prefix: Some(prefix.clone()), name: Some("view-test".into()) }).expect("a client");
    let first = client.open_session(&scene.spec).unwrap();
    let (view, url) = start_view(&["--prefix", &prefix]);
    assert!(view.line_starting(&format!("lumen view: session {}", first.id()), WAIT).is_some(), "the view follows the session that is open");
    let got = |url: &str| std::net::TcpStream::connect(url.trim_start_matches("http://").trim_end_matches('/')).is_ok();
    assert!(got(&url));
    drop(first);
    // The first session ended; the view waits for the next one and follows it on the same page.
    std::thread::sleep(Duration::from_millis(300));
    let second = client.open_session(&scene.spec).unwrap();
    assert!(view.line_starting(&format!("lumen view: session {}", second.id()), WAIT).is_some(), "the view follows the next session to open");
    assert!(got(&url), "the same address serves on");
}

#[test]
fn a_zenoh_session_streams_to_a_page_socket() {
    // No browser: a WebSocket client reads what a page would, over a session on zenoh.
    let prefix = unique_prefix("viewz");
    let daemon = Daemon::start(Path::new(LUMEN), &prefix, Some(free_port()), &[]);
    let scene = scene();
    let client = Client::zenoh(&daemon.endpoint()).expect("a zenoh client");
    let mut session = client.open_session(&scene.spec).unwrap();
    let (_view, url) = start_view(&[&session.id().to_string(), "--zenoh", &daemon.endpoint()]);
    let addr = url.trim_start_matches("http://").trim_end_matches('/');
    let (mut ws, _) = tungstenite::connect(format!("ws://{addr}/ws")).expect("the page socket");
    let first = ws.read().unwrap();
    if let tungstenite::stream::MaybeTlsStream::Plain(t) = ws.get_mut() {
        t.set_read_timeout(Some(Duration::from_millis(20))).unwrap();
    }
    let scene_msg: Value = serde_json::from_str(first.to_text().unwrap()).unwrap();
    assert_eq!((scene_msg["type"].as_str(), scene_msg["session"].as_u64()), (Some("scene"), Some(session.id())));
    let mut shown = None;
    for k in 0..400u64 {
        session.submit_state(&scene.state(k)).unwrap();
        session.contacts(WAIT).unwrap();
        if let Ok(tungstenite::Message::Binary(b)) = ws.read() {
            let n = u32::from_le_bytes(b[4..8].try_into().unwrap()) as usize;
            assert_eq!(u32::from_le_bytes(b[0..4].try_into().unwrap()), 0x5756_4D4C, "LMVW");
            let json: Value = serde_json::from_slice(&b[8..8 + n]).unwrap();
            shown = Some(json["stats"]["frame"].as_u64().unwrap());
            break;
        }
    }
    let frame = shown.expect("a frame reached the socket");
    assert!(frame < 400);
}

/// Records `frames` frames of the test scene through the real daemon and `lumen record`.
fn record(prefix: &str, path: &Path, frames: u64) {
    let _daemon = Daemon::start(Path::new(LUMEN), prefix, None, &[]);
    let scene = scene();
    let client = Client::local_with(LocalOptions { prefix: Some(prefix.into()), name: Some("view-test".into()) }).expect("a client");
    let mut session = client.open_session(&scene.spec).unwrap();
    let mut cmd = Command::new(LUMEN);
    cmd.args(["record", &session.id().to_string(), "-o", path.to_str().unwrap(), "--prefix", prefix, "--log", "warn"]);
    let mut rec = ChildProcess::spawn(cmd);
    assert!(rec.line_starting("lumen record: recording session", WAIT).is_some());
    for k in 0..frames {
        session.submit_state(&scene.state(k)).unwrap();
        session.contacts(WAIT).unwrap();
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(Duration::from_millis(200));
    drop(session);
    assert!(rec.wait_exit(Duration::from_secs(10)).is_some_and(|s| s.success()), "the recorder ended with the session");
}

#[test]
fn a_recording_plays_and_the_scrubber_moves_it_to_a_chosen_frame() {
    let prefix = unique_prefix("viewrec");
    let path: PathBuf = std::env::temp_dir().join(format!("{prefix}run.mcap"));
    record(&prefix, &path, 150);
    let rec = Recording::open(&path).unwrap();
    // A loaded machine may make the recorder miss a frame or a reply (it counts them): the
    // checks take the file as it is, at its first frame from index 97 on that has its reply.
    let frames: Vec<_> = rec.frames().unwrap().map(Result::unwrap).collect();
    let n = frames.len() as u64;
    assert!(n >= 120, "the recorder kept {n} of 150 frames");
    let chosen = (97..n - 10).find(|&i| rec.replies.contains_key(&frames[i as usize].header.frame)).expect("a recorded reply");

    let (_view, url) = start_view(&[path.to_str().unwrap(), "--paused"]);
    let browser = Browser::launch().expect("headless Chromium (Debian's chromium package)");
    let mut page = open(&browser, &url);
    let s = shown(&mut page);
    assert_eq!(s["stats"]["index"].as_u64(), Some(0), "paused at the first frame");
    assert_eq!(page.eval("getComputedStyle(document.getElementById('playback')).display").unwrap(), "block", "the playback controls show");
    assert_eq!(page.eval("document.getElementById('scrub').max").unwrap(), (n - 1).to_string());

    // The scrubber, moved as a person drags it.
    scrub(&mut page, chosen, "the scrubber moved the recording");
    let s = shown(&mut page);
    assert_eq!(s["panel"]["index"].as_str().unwrap(), chosen.to_string());
    assert_eq!(s["panel"]["session"].as_str().unwrap(), rec.session.to_string());
    let f = &frames[chosen as usize];
    assert_eq!(s["stats"]["frame"].as_u64(), Some(f.header.frame));
    let reply = &rec.replies[&f.header.frame];
    check_frame(&mut page, &s, &rec.spec, &f.state, &reply.contacts, reply.header.detect_ns, "recording");

    // Step, then play: the index moves on; pause: it stays.
    page.eval("document.getElementById('step').click(); true").unwrap();
    page.wait_for(&format!("lumenView.stats.index === {}", chosen + 1), WAIT).expect("step shows the next frame");
    page.eval("document.getElementById('play').click(); true").unwrap();
    page.wait_for(&format!("lumenView.stats.index > {} && lumenView.stats.playing", chosen + 5), WAIT).expect("play moves on");
    page.eval("document.getElementById('pause').click(); true").unwrap();
    page.wait_for("lumenView.stats.playing === false", WAIT).expect("pause");
    let at = page.eval("lumenView.stats.index").unwrap();
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(page.eval("lumenView.stats.index").unwrap(), at, "paused, the index stays");
    let _ = std::fs::remove_file(&path);
}

/// A WebXR test double: `navigator.xr` saying immersive VR is supported, recording the session
/// modes asked for.
const FAKE_XR: &str = "Object.defineProperty(navigator, 'xr', { configurable: true, value: {
    asked: [], isSessionSupported(mode) { return Promise.resolve(mode === 'immersive-vr'); },
    requestSession(mode) { this.asked.push(mode); return Promise.reject(new Error('test double: no headset')); } } });";

#[test]
fn enter_vr_shows_only_when_the_browser_offers_an_immersive_session() {
    let prefix = unique_prefix("viewxr");
    let path: PathBuf = std::env::temp_dir().join(format!("{prefix}run.mcap"));
    record(&prefix, &path, 5);
    let (_view, url) = start_view(&[path.to_str().unwrap(), "--paused"]);
    let browser = Browser::launch().expect("headless Chromium (Debian's chromium package)");
    let display = "getComputedStyle(document.getElementById('enter-vr')).display";

    let mut plain = open(&browser, &url);
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(plain.eval(display).unwrap(), "none", "no Enter VR without an immersive session");

    let mut page = browser.new_page("about:blank").unwrap();
    page.add_init_script(FAKE_XR).unwrap();
    page.navigate(&url).unwrap();
    page.wait_for("lumenView.frames > 0 && lumenView.xr === true", WAIT).expect("the page asked the double");
    assert_eq!(page.eval(display).unwrap(), "block", "Enter VR shows");
    page.eval("document.getElementById('enter-vr').click(); true").unwrap();
    page.wait_for("navigator.xr.asked.length === 1", WAIT).unwrap();
    assert_eq!(page.eval("navigator.xr.asked[0]").unwrap(), "immersive-vr");
    page.wait_for("lumenView.error !== null", WAIT).expect("a refused session is reported");
    let _ = std::fs::remove_file(&path);
}

/// A WebXR test double that runs: `navigator.xr` offers an immersive session whose frames
/// come every 30 ms with one view, a viewer 3 m in front of the room's centre at 1.4 m eye
/// height looking at it (90 degree field of view), drawing into the page's own canvas.
const FAKE_XR_SESSION: &str = "(() => {
    const W = innerWidth, H = innerHeight, f = 1, n = 0.1, fa = 100;
    const proj = new Float32Array([f / (W / H), 0, 0, 0, 0, f, 0, 0, 0, 0, (fa + n) / (n - fa), -1, 0, 0, 2 * fa * n / (n - fa), 0]);
    const view = new Float32Array([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -1.4, -3, 1]);
    const frame = { getViewerPose: () => ({ views: [{ eye: 'none', projectionMatrix: proj, transform: { inverse: { matrix: view } } }] }) };
    class Session { constructor() { this.renderState = {}; }
      updateRenderState(s) { Object.assign(this.renderState, s); }
      requestReferenceSpace() { return Promise.resolve({}); }
      addEventListener() {}
      requestAnimationFrame(cb) { return setTimeout(() => cb(performance.now(), frame), 30); } }
    window.XRWebGLLayer = class { constructor() { this.framebuffer = null; } getViewport() { return { x: 0, y: 0, width: W, height: H }; } };
    WebGL2RenderingContext.prototype.makeXRCompatible = () => Promise.resolve();
    window.xrTest = { proj: Array.from(proj), view: Array.from(view) };
    Object.defineProperty(navigator, 'xr', { configurable: true, value: {
      isSessionSupported: (m) => Promise.resolve(m === 'immersive-vr'),
      requestSession: () => Promise.resolve(new Session()) } });
  })();";

/// `a * b`, 4x4 column-major.
fn mat4mul(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut m = vec![0.0; 16];
    for c in 0..4 {
        for r in 0..4 {
            m[c * 4 + r] = (0..4).map(|k| a[k * 4 + r] * b[c * 4 + k]).sum();
        }
    }
    m
}

#[test]
fn in_vr_the_colon_is_at_room_scale_with_the_same_contacts() {
    let prefix = unique_prefix("viewvr");
    let path: PathBuf = std::env::temp_dir().join(format!("{prefix}run.mcap"));
    record(&prefix, &path, 5);
    let rec = Recording::open(&path).unwrap();
    // The first frame the recorder kept with its reply (it may miss one on a loaded machine).
    let frames: Vec<_> = rec.frames().unwrap().map(Result::unwrap).collect();
    let at = frames.iter().position(|f| rec.replies.contains_key(&f.header.frame)).expect("a frame with its reply");
    let contacts = rec.replies[&frames[at].header.frame].contacts.clone();
    assert!(!contacts.is_empty());
    let (_view, url) = start_view(&[path.to_str().unwrap(), "--paused"]);
    let browser = Browser::launch().expect("headless Chromium (Debian's chromium package)");
    let mut page = browser.new_page("about:blank").unwrap();
    page.set_viewport(SIZE.0, SIZE.1).unwrap();
    page.add_init_script(FAKE_XR_SESSION).unwrap();
    page.navigate(&url).unwrap();
    page.wait_for("lumenView.frames > 0 && lumenView.xr === true", WAIT).expect("the page offers VR");
    scrub(&mut page, at, "the frame with its reply");
    page.eval("document.getElementById('enter-vr').click(); true").unwrap();
    page.wait_for("lumenView.xrFrames > 3", WAIT).expect("the page draws in VR");
    let s = shown(&mut page);
    let v = page.eval("({ model: lumenView.xrModel, bounds: lumenView.bounds, t: xrTest })").unwrap();
    assert!(s["error"].is_null(), "{}", s["error"]);
    let nums = |x: &Value| -> Vec<f64> { x.as_array().unwrap().iter().map(|n| n.as_f64().unwrap()).collect() };
    let (model, lo, hi) = (nums(&v["model"]), nums(&v["bounds"][0]), nums(&v["bounds"][1]));
    // Room scale: the bounds' diagonal is 4 m, their centre at eye height (y up) at the viewer's
    // origin; z up in the scene is y up in the room.
    let apply = |m: &[f64], p: [f64; 3]| [0, 1, 2, 3].map(|r| m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]);
    let (a, b) = (apply(&model, [lo[0], lo[1], lo[2]]), apply(&model, [hi[0], hi[1], hi[2]]));
    let diagonal = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    assert!((diagonal - 4.0).abs() < 1e-3, "the colon is {diagonal} m across");
    let centre = [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0, (a[2] + b[2]) / 2.0];
    assert!(centre[0].abs() < 1e-4 && (centre[1] - 1.4).abs() < 1e-4 && centre[2].abs() < 1e-4, "centred at eye height: {centre:?}");
    let up = apply(&model, [lo[0], lo[1], lo[2] + 1.0]);
    assert!((up[1] - a[1]) > 0.0 && (up[0] - a[0]).abs() < 1e-9 && (up[2] - a[2]).abs() < 1e-9, "z up is y up");
    // The same contacts, drawn where the headset's view puts them.
    let clip = mat4mul(&mat4mul(&nums(&v["t"]["proj"]), &nums(&v["t"]["view"])), &model);
    let xr = serde_json::json!({ "viewProj": clip, "width": s["width"], "height": s["height"] });
    let img = screenshot(&mut page, true, "vr");
    let marks: Vec<(u32, u32)> = contacts.iter().filter_map(|c| project(&xr, c.point_b)).filter(|&p| !covered(&s, p)).collect();
    assert!(!marks.is_empty(), "contacts in the headset's view");
    let hit = marks.iter().filter(|&&p| near(&img, p, is_marker)).count();
    assert_eq!(hit, marks.len(), "contact markers drawn in VR at {hit} of {} projected wall points", marks.len());
    let _ = std::fs::remove_file(&path);
}

#[test]
fn the_demo_with_view_shows_the_colonoscopy_live() {
    let out = std::env::temp_dir().join(format!("lumen-view-demo-{}-{}", std::process::id(), fastrand::u64(..)));
    let prefix = unique_prefix("viewdemo");
    let port = free_port();
    let browser = Browser::launch().expect("headless Chromium (Debian's chromium package)");
    let mut cmd = Command::new(LUMEN);
    cmd.args(["demo", "--frames", "3000", "--view", "--view-listen", &format!("127.0.0.1:{port}"), "--prefix", &prefix, "--out"]).arg(&out);
    let demo = ChildProcess::spawn(cmd);
    let session = demo.line_starting("lumen demo: session ", Duration::from_secs(180)).expect("the demo's session").trim_start_matches("lumen demo: session ").trim().to_owned();
    let line = demo.line_starting("lumen view: serving ", WAIT).expect("the demo says where its view is");
    let url = format!("http://127.0.0.1:{port}/");
    assert!(line.contains(&url), "{line}");
    let mut page = open(&browser, &url);
    page.wait_for("lumenView.frames >= 1", WAIT).expect("the colonoscopy's frames reach the page");
    let s = hold(&mut page);
    assert_eq!(s["panel"]["session"].as_str().unwrap(), session);
    let b = &s["stats"];
    assert!(b["frame"].as_u64().is_some() && b["fps"].as_f64().unwrap() > 0.0, "{b}");
    assert_eq!(s["contacts"].as_array().unwrap().len() as u64, b["contacts"].as_u64().unwrap());
    // The scope is where its tip says, the wall around it: the colon's scene, not the test's.
    let tip = f32s(&s["tip"]);
    let img = screenshot(&mut page, true, "demo");
    let p = project(&s, [tip[0], tip[1], tip[2]]).expect("the tip is on the page");
    assert!(!covered(&s, p) && near(&img, p, |px| !is_background(px)), "something is drawn at the scope's tip");
    // The run ends (its view with it); its recording, viewed, is drawn where its frames put the
    // colon, the scope and the contacts.
    let mut demo = demo;
    assert!(demo.wait_exit(Duration::from_secs(300)).is_some_and(|s| s.success()), "the demo ran sound to its end");
    let path = out.join("run.mcap");
    let rec = Recording::open(&path).unwrap();
    let frames: Vec<_> = rec.frames().unwrap().map(Result::unwrap).collect();
    let at = (frames.len() / 2..frames.len()).find(|&i| rec.replies.get(&frames[i].header.frame).is_some_and(|r| r.contacts.len() >= 5)).expect("a recorded frame with contacts");
    let (_view, url) = start_view(&[path.to_str().unwrap(), "--paused"]);
    let mut page = open(&browser, &url);
    scrub(&mut page, at, "the scrubber moved the recording");
    let s = shown(&mut page);
    let reply = &rec.replies[&frames[at].header.frame];
    check_frame(&mut page, &s, &rec.spec, &frames[at].state, &reply.contacts, reply.header.detect_ns, "demo-recording");
    let _ = std::fs::remove_dir_all(&out);
}

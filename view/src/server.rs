//! The view's server: the page over HTTP and a WebSocket per page, on loopback.
//!
//! The observer hands every frame to [`Viewer::publish`], which only swaps the newest
//! [`Snapshot`] in (newest wins) and never waits for a page. Each page has its own thread and
//! [`Encoder`]; it is sent a frame only after it says it drew the one before (`{"op":"ready"}`),
//! so a page gets frames at its display rate, and a slow or stalled page gets fewer, never a
//! queue, and never slows the session.
//!
//! Hand-written over std's `TcpListener` (with `httparse` for the request head and
//! `tungstenite` for the socket): the server has three routes and one socket kind, and a web
//! framework would bring an async runtime into the observer.

use crate::page;
use crate::stream::{Encoder, SceneInfo, Snapshot};
use crate::ViewError;
use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tungstenite::protocol::Role;
use tungstenite::{Message, WebSocket};

/// Pages served at once; one more is answered 503.
pub const MAX_PAGES: usize = 16;
/// How long a page thread waits on its socket before looking for a newer frame.
const POLL: Duration = Duration::from_millis(5);
/// A page that takes this long to take one message is dropped (its thread only).
const WRITE_TIMEOUT: Duration = Duration::from_secs(5);
/// The longest request head read.
const MAX_HEAD: usize = 16 * 1024;
/// The longest message a page may send (controls are a few bytes).
const MAX_PAGE_MESSAGE: usize = 4096;

/// What a page asked of a recording's playback.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Control {
    Play,
    Pause,
    /// Frames forward (negative: back), pausing.
    Step(i64),
    /// Playback speed, times real time (clamped by the player).
    Speed(f64),
    /// Jump to the frame at this index of the file.
    Seek(u64),
}

impl Control {
    /// A page's control message (`{"op":"play"}`, `{"op":"step","by":-1}`, ...), or `None`.
    fn parse(v: &serde_json::Value) -> Option<Self> {
        let num = |k: &str| v.get(k).and_then(serde_json::Value::as_f64).filter(|x| x.is_finite());
        match v.get("op")?.as_str()? {
            "play" => Some(Control::Play),
            "pause" => Some(Control::Pause),
            "step" => Some(Control::Step(num("by").unwrap_or(1.0).clamp(-1e6, 1e6) as i64)),
            "speed" => Some(Control::Speed(num("speed")?)),
            "seek" => Some(Control::Seek(num("index")?.max(0.0) as u64)),
            _ => None,
        }
    }
}

/// Totals over every page since the start.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Pages connected now.
    pub pages: usize,
    /// Frame messages sent.
    pub messages: u64,
    /// Bytes of frame messages sent.
    pub bytes: u64,
}

struct Latest {
    version: u64,
    snap: Option<Arc<Snapshot>>,
    scene_version: u64,
    scene: Arc<SceneInfo>,
}

struct Shared {
    latest: Mutex<Latest>,
    stop: AtomicBool,
    pages: AtomicUsize,
    messages: AtomicU64,
    bytes: AtomicU64,
    controls: Mutex<Sender<Control>>,
}

impl Shared {
    fn lock(&self) -> std::sync::MutexGuard<'_, Latest> {
        // A page thread that panicked while holding the lock leaves a usable value behind.
        self.latest.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// A running view server; stops when dropped.
pub struct Viewer {
    addr: SocketAddr,
    started: std::time::Instant,
    shared: Arc<Shared>,
    controls: Receiver<Control>,
}

impl Viewer {
    /// Serves the page on `addr` (`127.0.0.1:0` picks a free port) for `scene`.
    pub fn start(addr: &str, scene: SceneInfo) -> Result<Self, ViewError> {
        let listener = TcpListener::bind(addr).map_err(|source| ViewError::Bind { addr: addr.to_owned(), source })?;
        let local = listener.local_addr().map_err(|source| ViewError::Bind { addr: addr.to_owned(), source })?;
        listener.set_nonblocking(true).map_err(|source| ViewError::Bind { addr: addr.to_owned(), source })?;
        let (tx, controls) = mpsc::channel();
        let shared = Arc::new(Shared {
            latest: Mutex::new(Latest { version: 0, snap: None, scene_version: 1, scene: Arc::new(scene) }),
            stop: AtomicBool::new(false),
            pages: AtomicUsize::new(0),
            messages: AtomicU64::new(0),
            bytes: AtomicU64::new(0),
            controls: Mutex::new(tx),
        });
        let s = shared.clone();
        std::thread::Builder::new().name("lumen-view-accept".into()).spawn(move || accept(listener, s)).map_err(ViewError::Thread)?;
        Ok(Self { addr: local, started: std::time::Instant::now(), shared, controls })
    }

    /// The page's address, `http://127.0.0.1:PORT/`.
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }

    /// The address served on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Makes `snap` the newest frame; pages that are ready get it, the others get a newer one
    /// later. Never waits for a page.
    pub fn publish(&self, snap: Snapshot) {
        let snap = Arc::new(snap);
        let mut l = self.shared.lock();
        l.version += 1;
        l.snap = Some(snap);
    }

    /// Replaces the scene (another session followed): every page is sent the new scene and a
    /// key frame.
    pub fn set_scene(&self, scene: SceneInfo) {
        let mut l = self.shared.lock();
        l.scene_version += 1;
        l.scene = Arc::new(scene);
        l.snap = None;
    }

    /// The next control a page sent, if any (recordings: play, pause, step, speed, seek).
    pub fn try_control(&self) -> Option<Control> {
        self.controls.try_recv().ok()
    }

    /// The next control, waiting up to `timeout`.
    pub fn control_timeout(&self, timeout: Duration) -> Option<Control> {
        self.controls.recv_timeout(timeout).ok()
    }

    /// How long the server has run.
    pub fn uptime(&self) -> Duration {
        self.started.elapsed()
    }

    /// What has been sent so far.
    pub fn counters(&self) -> Counters {
        Counters { pages: self.shared.pages.load(Ordering::Relaxed), messages: self.shared.messages.load(Ordering::Relaxed), bytes: self.shared.bytes.load(Ordering::Relaxed) }
    }
}

impl Drop for Viewer {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Relaxed);
    }
}

fn accept(listener: TcpListener, shared: Arc<Shared>) {
    while !shared.stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((stream, _)) => {
                let s = shared.clone();
                let spawned = std::thread::Builder::new().name("lumen-view-page".into()).spawn(move || {
                    if let Err(e) = connection(stream, &s) {
                        tracing::debug!("view connection: {e}");
                    }
                });
                if let Err(e) = spawned {
                    tracing::warn!("view: no thread for a connection: {e}");
                }
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => {
                tracing::warn!("view: accept failed: {e}");
                std::thread::sleep(Duration::from_millis(100));
            }
        }
    }
}

/// A request's method, path and WebSocket key, from its head.
struct Request {
    method: String,
    path: String,
    ws_key: Option<String>,
}

fn read_head(stream: &mut TcpStream) -> std::io::Result<Option<Request>> {
    stream.set_read_timeout(Some(Duration::from_secs(5)))?;
    let mut buf = Vec::with_capacity(1024);
    let mut chunk = [0u8; 1024];
    while !buf.windows(4).any(|w| w == b"\r\n\r\n") {
        if buf.len() > MAX_HEAD {
            return Ok(None);
        }
        // One byte at a time past the first read would be slow; requests are small and the
        // client sends nothing after the head until it is answered.
        let n = stream.read(&mut chunk)?;
        if n == 0 {
            return Ok(None);
        }
        buf.extend_from_slice(&chunk[..n]);
    }
    let mut headers = [httparse::EMPTY_HEADER; 48];
    let mut req = httparse::Request::new(&mut headers);
    if !matches!(req.parse(&buf), Ok(httparse::Status::Complete(_))) {
        return Ok(None);
    }
    let header = |name: &str| req.headers.iter().find(|h| h.name.eq_ignore_ascii_case(name)).map(|h| String::from_utf8_lossy(h.value).into_owned());
    let upgrade = header("upgrade").is_some_and(|u| u.eq_ignore_ascii_case("websocket"));
    let ws_key = if upgrade { header("sec-websocket-key") } else { None };
    Ok(Some(Request { method: req.method.unwrap_or("").to_owned(), path: req.path.unwrap_or("/").to_owned(), ws_key }))
}

fn respond(stream: &mut TcpStream, status: &str, kind: &str, body: &[u8]) -> std::io::Result<()> {
    let head = format!("HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n", body.len());
    stream.write_all(head.as_bytes())?;
    stream.write_all(body)?;
    stream.flush()
}

fn connection(mut stream: TcpStream, shared: &Shared) -> std::io::Result<()> {
    let Some(req) = read_head(&mut stream)? else {
        return respond(&mut stream, "400 Bad Request", "text/plain", b"bad request\n");
    };
    if req.method != "GET" {
        return respond(&mut stream, "405 Method Not Allowed", "text/plain", b"only GET\n");
    }
    let path = req.path.split('?').next().unwrap_or("/");
    match (path, req.ws_key) {
        ("/ws", Some(key)) => {
            if shared.pages.fetch_add(1, Ordering::Relaxed) >= MAX_PAGES {
                shared.pages.fetch_sub(1, Ordering::Relaxed);
                return respond(&mut stream, "503 Service Unavailable", "text/plain", format!("at most {MAX_PAGES} pages at once\n").as_bytes());
            }
            let accept = tungstenite::handshake::derive_accept_key(key.trim().as_bytes());
            let head = format!("HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Accept: {accept}\r\n\r\n");
            let result = stream.write_all(head.as_bytes()).and_then(|()| page_loop(stream, shared));
            shared.pages.fetch_sub(1, Ordering::Relaxed);
            result
        }
        ("/" | "/index.html", _) => respond(&mut stream, "200 OK", "text/html; charset=utf-8", page::INDEX_HTML.as_bytes()),
        ("/view.js", _) => respond(&mut stream, "200 OK", "text/javascript; charset=utf-8", page::VIEW_JS.as_bytes()),
        ("/scene.json", _) => {
            let scene = shared.lock().scene.clone();
            respond(&mut stream, "200 OK", "application/json", scene.to_json().as_bytes())
        }
        _ => respond(&mut stream, "404 Not Found", "text/plain", b"not found\n"),
    }
}

fn io_of(e: tungstenite::Error) -> std::io::Error {
    match e {
        tungstenite::Error::Io(e) => e,
        other => std::io::Error::other(other.to_string()),
    }
}

/// One page: the scene, then a frame each time the page is ready and a newer one exists.
fn page_loop(stream: TcpStream, shared: &Shared) -> std::io::Result<()> {
    stream.set_read_timeout(Some(POLL))?;
    stream.set_write_timeout(Some(WRITE_TIMEOUT))?;
    stream.set_nodelay(true)?;
    let config = tungstenite::protocol::WebSocketConfig::default().max_message_size(Some(MAX_PAGE_MESSAGE)).max_frame_size(Some(MAX_PAGE_MESSAGE));
    let mut ws = WebSocket::from_raw_socket(stream, Role::Server, Some(config));
    let (mut scene_sent, mut frame_sent) = (0u64, 0u64);
    let mut encoder = Encoder::new();
    let mut ready = true;
    let mut buf = Vec::new();
    while !shared.stop.load(Ordering::Relaxed) {
        let (scene_version, scene, newer) = {
            let l = shared.lock();
            let newer = l.snap.as_ref().filter(|_| l.version != frame_sent).map(|s| (l.version, s.clone()));
            (l.scene_version, l.scene.clone(), newer)
        };
        if scene_version != scene_sent {
            ws.send(Message::text(scene.to_json())).map_err(io_of)?;
            (scene_sent, frame_sent, encoder, ready) = (scene_version, 0, Encoder::new(), true);
            continue;
        }
        if let (true, Some((version, snap))) = (ready, newer) {
            encoder.encode(&scene, &snap, false, &mut buf);
            shared.messages.fetch_add(1, Ordering::Relaxed);
            shared.bytes.fetch_add(buf.len() as u64, Ordering::Relaxed);
            ws.send(Message::binary(std::mem::take(&mut buf))).map_err(io_of)?;
            (frame_sent, ready) = (version, false);
        }
        match ws.read() {
            Ok(Message::Text(t)) => {
                let Ok(v) = serde_json::from_str::<serde_json::Value>(t.as_str()) else { continue };
                if v.get("op").and_then(|o| o.as_str()) == Some("ready") {
                    ready = true;
                } else if let Some(c) = Control::parse(&v) {
                    let _ = shared.controls.lock().unwrap_or_else(|e| e.into_inner()).send(c);
                }
            }
            Ok(Message::Close(_)) => return Ok(()),
            Ok(_) => {}
            Err(tungstenite::Error::Io(e)) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(tungstenite::Error::ConnectionClosed | tungstenite::Error::AlreadyClosed) => return Ok(()),
            Err(e) => return Err(io_of(e)),
        }
    }
    let _ = ws.close(None);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn controls_parse_and_refuse_junk() {
        let p = |s: &str| Control::parse(&serde_json::from_str(s).unwrap());
        assert_eq!(p(r#"{"op":"play"}"#), Some(Control::Play));
        assert_eq!(p(r#"{"op":"step","by":-3}"#), Some(Control::Step(-3)));
        assert_eq!(p(r#"{"op":"step"}"#), Some(Control::Step(1)));
        assert_eq!(p(r#"{"op":"seek","index":120}"#), Some(Control::Seek(120)));
        assert_eq!(p(r#"{"op":"seek","index":-5}"#), Some(Control::Seek(0)));
        assert_eq!(p(r#"{"op":"speed","speed":2.5}"#), Some(Control::Speed(2.5)));
        assert_eq!(p(r#"{"op":"speed"}"#), None);
        assert_eq!(p(r#"{"op":"format_disk"}"#), None);
        assert_eq!(p(r#"[1,2]"#), None);
    }
}

//! A small Chrome DevTools Protocol (CDP) driver for headless Chromium, so tests can load the
//! live view's page, run JavaScript in it and look at its pixels (WebGL2 on SwiftShader, no GPU).
//!
//! - [`Browser`]: a headless Chromium child on a fresh profile, killed (with its helpers) and the
//!   profile removed when dropped.
//! - [`Page`]: one tab over its own websocket: [`Page::navigate`], [`Page::eval`],
//!   [`Page::wait_for`], [`Page::screenshot`], [`Page::set_viewport`], [`Page::add_init_script`]
//!   and what the page logged, [`Page::console`].
//! - [`Image`]: a screenshot as RGBA8, [`data_url`]: an HTML document as a `data:` URL.
//!
//! Everything is blocking (tungstenite over std's `TcpStream` with read timeouts), and every
//! wait is bounded ([`DEFAULT_WAIT`] unless said otherwise) so a broken page fails a test
//! rather than hanging it.

use base64::Engine as _;
use serde_json::{json, Value};
use std::collections::HashSet;
use std::io::{self, BufRead, BufReader, Read};
use std::net::TcpStream;
use std::os::unix::process::CommandExt as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::Mutex;
use std::time::{Duration, Instant};
use tungstenite::protocol::WebSocketConfig;
use tungstenite::{Message, WebSocket};

/// How long any single wait (launch, a CDP reply, a page load) may take by default.
pub const DEFAULT_WAIT: Duration = Duration::from_secs(30);

/// The browser window's size in CSS pixels; [`Page::set_viewport`] picks another per page.
pub const WINDOW_SIZE: (u32, u32) = (1280, 800);

/// What Chromium needs to run headless in a container with WebGL2 on the CPU: no sandbox
/// (no user namespaces), SwiftShader through ANGLE (`--enable-unsafe-swiftshader` since the GPU
/// blocklist refuses it otherwise), and none of the background traffic a fresh profile starts.
const FLAGS: &[&str] = &[
    "--headless=new",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-default-apps",
    "--mute-audio",
    "--enable-unsafe-swiftshader",
    "--use-angle=swiftshader",
    "--enable-webgl",
    "--ignore-gpu-blocklist",
    "--remote-debugging-port=0",
];

/// The binaries looked for on `PATH` when `LUMEN_CHROMIUM` is not set, in order.
const CANDIDATES: &[&str] = &["chromium", "chromium-browser", "google-chrome"];

/// When a wait ends, and how long it was given (for the error that says so).
#[derive(Clone, Copy, Debug)]
struct Deadline {
    at: Instant,
    limit: Duration,
}

impl Deadline {
    /// A deadline `limit` from now.
    fn after(limit: Duration) -> Deadline {
        Deadline { at: Instant::now() + limit, limit }
    }

    /// What is left of it (zero once passed).
    fn left(&self) -> Duration {
        self.at.saturating_duration_since(Instant::now())
    }

    /// The timeout error for waiting on `what`.
    fn expired(&self, what: &str) -> BrowserError {
        BrowserError::Timeout { what: what.to_owned(), limit: self.limit }
    }
}

/// What can go wrong driving the browser; each says what was being done.
#[derive(Debug, thiserror::Error)]
pub enum BrowserError {
    #[error("no Chromium found: tried {tried} (install chromium or set LUMEN_CHROMIUM to its path)")]
    NotFound { tried: String },
    #[error("starting {binary}")]
    Spawn {
        binary: String,
        #[source]
        source: io::Error,
    },
    #[error("Chromium ({binary}) ended before it printed its DevTools address; its stderr:\n{stderr}")]
    NoDevTools { binary: String, stderr: String },
    #[error("timed out after {limit:?} waiting for {what}")]
    Timeout { what: String, limit: Duration },
    #[error("{what}")]
    Io {
        what: String,
        #[source]
        source: io::Error,
    },
    #[error("websocket to {url}: handshake failed")]
    Handshake {
        url: String,
        #[source]
        source: Box<tungstenite::Error>,
    },
    #[error("websocket {what}")]
    WebSocket {
        what: String,
        #[source]
        source: Box<tungstenite::Error>,
    },
    #[error("the DevTools connection closed while waiting for {what}")]
    Closed { what: String },
    #[error("CDP {method} failed: {message} (code {code})")]
    Cdp { method: String, code: i64, message: String },
    #[error("CDP {method}: unexpected reply {reply}")]
    Protocol { method: String, reply: String },
    #[error("navigating to {url}: {error}")]
    Navigation { url: String, error: String },
    #[error("the page threw: {0}")]
    Exception(String),
    #[error("`{condition}` not truthy after {limit:?}; last value: {last}")]
    WaitFor { condition: String, limit: Duration, last: String },
    #[error("decoding the screenshot's base64")]
    Base64(#[from] base64::DecodeError),
    #[error("decoding the screenshot's PNG")]
    PngDecode(#[source] Box<png::DecodingError>),
    #[error("encoding a PNG")]
    PngEncode(#[source] Box<png::EncodingError>),
}

type Result<T> = std::result::Result<T, BrowserError>;

/// A headless Chromium child with a fresh profile in a temporary folder; dropped, it is killed
/// with its helper processes (its own process group) and the folder removed.
pub struct Browser {
    child: Child,
    profile: PathBuf,
    port: u16,
    /// The browser-wide DevTools connection, for `Target.createTarget`.
    cdp: Mutex<Cdp>,
}

impl Browser {
    /// Finds Chromium ([`find_chromium`]), starts it headless on a fresh profile and connects to
    /// its DevTools websocket. Fails (never skips) when there is no Chromium.
    pub fn launch() -> Result<Browser> {
        let binary = find_chromium()?;
        // Until `Browser` owns them, a failure must still kill the child and remove the profile.
        let mut guard = Launching { child: None, profile: fresh_profile_dir()? };
        let mut child = spawn(&binary, &guard.profile)?;
        let stderr = child.stderr.take().expect("stderr is piped");
        guard.child = Some(child);
        let ws_url = wait_for_devtools_line(drain_lines(stderr), &binary, &mut guard)?;
        let port = port_of(&ws_url)?;
        let cdp = Cdp::connect(&ws_url)?;
        let (child, profile) = guard.into_parts();
        Ok(Browser { child, profile, port, cdp: Mutex::new(cdp) })
    }

    /// The port Chromium's DevTools server listens on (loopback).
    pub fn port(&self) -> u16 {
        self.port
    }

    /// Opens a new tab, connects to its own websocket, enables the `Page` and `Runtime` domains
    /// (so console messages and load events arrive) and loads `url`, waiting for its load event.
    pub fn new_page(&self, url: &str) -> Result<Page> {
        let reply = self.cdp.lock().unwrap_or_else(|e| e.into_inner()).call("Target.createTarget", json!({ "url": "about:blank" }))?;
        let target = reply["targetId"].as_str().ok_or_else(|| BrowserError::Protocol { method: "Target.createTarget".into(), reply: reply.to_string() })?;
        let mut page = Page { cdp: Cdp::connect(&format!("ws://127.0.0.1:{}/devtools/page/{target}", self.port))? };
        page.cdp.call("Page.enable", json!({}))?;
        page.cdp.call("Page.setLifecycleEventsEnabled", json!({ "enabled": true }))?;
        page.cdp.call("Runtime.enable", json!({}))?;
        page.navigate(url)?;
        Ok(page)
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        kill_group(&mut self.child);
        remove_dir_patiently(&self.profile);
    }
}

/// Kills a child's whole process group (Chromium's renderer, GPU and zygote helpers share it)
/// and reaps the child.
fn kill_group(child: &mut Child) {
    // SAFETY: kill(2) with a negative pid signals the group the child leads (see `spawn`).
    unsafe {
        libc::kill(-(child.id() as libc::pid_t), libc::SIGKILL);
    }
    let _ = child.kill();
    let _ = child.wait();
}

/// Removes a folder, retrying briefly: helpers killed a moment ago may still be closing files
/// in it.
fn remove_dir_patiently(dir: &Path) {
    for _ in 0..50 {
        if std::fs::remove_dir_all(dir).is_ok() || !dir.exists() {
            return;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A launch in progress: on an early return it kills the child (if started) and removes the
/// profile.
struct Launching {
    child: Option<Child>,
    profile: PathBuf,
}

impl Launching {
    /// The child and profile, handed on to a [`Browser`] that cleans them up instead.
    fn into_parts(mut self) -> (Child, PathBuf) {
        let child = self.child.take().expect("the child was started");
        (child, std::mem::take(&mut self.profile))
    }
}

impl Drop for Launching {
    fn drop(&mut self) {
        if let Some(mut child) = self.child.take() {
            kill_group(&mut child);
        }
        if !self.profile.as_os_str().is_empty() {
            remove_dir_patiently(&self.profile);
        }
    }
}

/// The Chromium binary: `LUMEN_CHROMIUM` if set, else the first of `chromium`,
/// `chromium-browser`, `google-chrome` on `PATH`; the error names everything tried.
pub fn find_chromium() -> Result<PathBuf> {
    if let Some(path) = std::env::var_os("LUMEN_CHROMIUM").filter(|p| !p.is_empty()) {
        let path = PathBuf::from(path);
        return if is_executable(&path) { Ok(path) } else { Err(BrowserError::NotFound { tried: format!("LUMEN_CHROMIUM={} (not an executable file)", path.display()) }) };
    }
    let dirs: Vec<PathBuf> = std::env::var_os("PATH").map(|p| std::env::split_paths(&p).collect()).unwrap_or_default();
    let found = CANDIDATES.iter().flat_map(|name| dirs.iter().map(move |d| d.join(name))).find(|p| is_executable(p));
    found.ok_or_else(|| BrowserError::NotFound { tried: format!("LUMEN_CHROMIUM (unset), then {} on PATH", CANDIDATES.join(", ")) })
}

/// Whether `path` is a file someone may execute.
fn is_executable(path: &Path) -> bool {
    use std::os::unix::fs::PermissionsExt as _;
    std::fs::metadata(path).map(|m| m.is_file() && m.permissions().mode() & 0o111 != 0).unwrap_or(false)
}

/// A new empty folder under the temp dir for Chromium's profile, unique to this process and call.
fn fresh_profile_dir() -> Result<PathBuf> {
    static N: AtomicUsize = AtomicUsize::new(0);
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.subsec_nanos()).unwrap_or(0);
    let dir = std::env::temp_dir().join(format!("lumen-chromium-{}-{}-{nanos}", std::process::id(), N.fetch_add(1, Ordering::Relaxed)));
    std::fs::create_dir_all(&dir).map_err(|source| BrowserError::Io { what: format!("creating the profile folder {}", dir.display()), source })?;
    Ok(dir)
}

/// Starts Chromium with [`FLAGS`], the profile and the window size, in its own process group
/// so that dropping the browser can kill its helpers too; stderr is piped for the DevTools line.
fn spawn(binary: &Path, profile: &Path) -> Result<Child> {
    let mut cmd = Command::new(binary);
    cmd.args(FLAGS).arg(format!("--user-data-dir={}", profile.display())).arg(format!("--window-size={},{}", WINDOW_SIZE.0, WINDOW_SIZE.1)).arg("about:blank");
    cmd.stdin(Stdio::null()).stdout(Stdio::null()).stderr(Stdio::piped()).process_group(0);
    cmd.spawn().map_err(|source| BrowserError::Spawn { binary: binary.display().to_string(), source })
}

/// The lines of `stream` on a channel, read by a thread that keeps draining after the receiver
/// is gone (a full stderr pipe would block Chromium).
fn drain_lines(stream: impl Read + Send + 'static) -> Receiver<String> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stream).lines() {
            let Ok(line) = line else { break };
            let _ = tx.send(line);
        }
    });
    rx
}

/// Reads Chromium's stderr until `DevTools listening on ws://...`; returns that address.
fn wait_for_devtools_line(lines: Receiver<String>, binary: &Path, guard: &mut Launching) -> Result<String> {
    let deadline = Deadline::after(DEFAULT_WAIT);
    let mut seen = Vec::new();
    loop {
        match lines.recv_timeout(deadline.left()) {
            Ok(line) => {
                if let Some(at) = line.find("DevTools listening on ") {
                    return Ok(line[at + "DevTools listening on ".len()..].trim().to_owned());
                }
                seen.push(line);
            }
            Err(RecvTimeoutError::Timeout) => return Err(deadline.expired(&format!("Chromium's DevTools line (stderr so far:\n{})", seen.join("\n")))),
            Err(RecvTimeoutError::Disconnected) => {
                std::thread::sleep(Duration::from_millis(100));
                let status = guard.child.as_mut().and_then(|c| c.try_wait().ok().flatten()).map_or("still running".to_owned(), |s| s.to_string());
                return Err(BrowserError::NoDevTools { binary: binary.display().to_string(), stderr: format!("{}\n({status})", seen.join("\n")) });
            }
        }
    }
}

/// The port of a `ws://127.0.0.1:PORT/...` address.
fn port_of(ws_url: &str) -> Result<u16> {
    let bad = || BrowserError::Protocol { method: "the DevTools line".into(), reply: ws_url.to_owned() };
    let rest = ws_url.strip_prefix("ws://").ok_or_else(bad)?;
    let host_port = rest.split('/').next().unwrap_or_default();
    host_port.rsplit(':').next().and_then(|p| p.parse().ok()).ok_or_else(bad)
}

/// One DevTools websocket: numbered calls, and the events that arrive meanwhile (console
/// messages and exceptions kept, load events noted, the rest dropped).
struct Cdp {
    socket: WebSocket<TcpStream>,
    next_id: u64,
    console: Vec<String>,
    /// Loader ids whose document fired its `load` lifecycle event.
    loaded: HashSet<String>,
}

impl Cdp {
    /// Connects to a DevTools websocket (`ws://127.0.0.1:PORT/devtools/...`), the handshake
    /// bounded by [`DEFAULT_WAIT`].
    fn connect(url: &str) -> Result<Cdp> {
        let addr = url.strip_prefix("ws://").and_then(|r| r.split('/').next()).unwrap_or_default();
        let stream = TcpStream::connect(addr).map_err(|source| BrowserError::Io { what: format!("connecting to {addr}"), source })?;
        stream.set_read_timeout(Some(DEFAULT_WAIT)).and_then(|_| stream.set_write_timeout(Some(DEFAULT_WAIT))).map_err(|source| BrowserError::Io { what: "setting socket timeouts".into(), source })?;
        // Screenshots come as one big text message; let them be larger than the defaults.
        let config = WebSocketConfig::default().max_message_size(Some(1 << 30)).max_frame_size(Some(1 << 30));
        let (socket, _) = tungstenite::client::client_with_config(url, stream, Some(config)).map_err(|e| BrowserError::Handshake { url: url.to_owned(), source: Box::new(handshake_error(e)) })?;
        Ok(Cdp { socket, next_id: 0, console: Vec::new(), loaded: HashSet::new() })
    }

    /// Calls `method` and waits up to [`DEFAULT_WAIT`] for its reply's `result`.
    fn call(&mut self, method: &str, params: Value) -> Result<Value> {
        self.call_until(method, params, Deadline::after(DEFAULT_WAIT))
    }

    /// Calls `method` and waits until `deadline` for its reply; a CDP error names the method.
    fn call_until(&mut self, method: &str, params: Value, deadline: Deadline) -> Result<Value> {
        self.next_id += 1;
        let id = self.next_id;
        let text = json!({ "id": id, "method": method, "params": params }).to_string();
        self.socket.send(Message::text(text)).map_err(|e| BrowserError::WebSocket { what: format!("sending {method}"), source: Box::new(e) })?;
        let what = format!("the reply to {method}");
        loop {
            let msg = self.next_message(&what, deadline)?;
            if msg["id"].as_u64() != Some(id) {
                self.handle_event(&msg);
                continue;
            }
            if let Some(err) = msg.get("error") {
                return Err(BrowserError::Cdp { method: method.to_owned(), code: err["code"].as_i64().unwrap_or(0), message: err["message"].as_str().unwrap_or_default().to_owned() });
            }
            return Ok(msg.get("result").cloned().unwrap_or(Value::Null));
        }
    }

    /// Reads events until `done` holds for this connection, or `deadline` passes.
    fn pump_until(&mut self, what: &str, deadline: Deadline, done: impl Fn(&Cdp) -> bool) -> Result<()> {
        while !done(self) {
            let msg = self.next_message(what, deadline)?;
            self.handle_event(&msg);
        }
        Ok(())
    }

    /// The next JSON message, read with the socket's timeout set to what is left until `deadline`.
    fn next_message(&mut self, what: &str, deadline: Deadline) -> Result<Value> {
        loop {
            let left = deadline.left();
            if left.is_zero() {
                return Err(deadline.expired(what));
            }
            let _ = self.socket.get_ref().set_read_timeout(Some(left));
            match self.socket.read() {
                Ok(Message::Text(text)) => return serde_json::from_str(text.as_str()).map_err(|e| BrowserError::Protocol { method: what.to_owned(), reply: format!("{e}: {}", text.as_str()) }),
                Ok(Message::Close(_)) | Err(tungstenite::Error::ConnectionClosed | tungstenite::Error::AlreadyClosed) => return Err(BrowserError::Closed { what: what.to_owned() }),
                Ok(_) => continue,
                Err(tungstenite::Error::Io(e)) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => continue,
                Err(e) => return Err(BrowserError::WebSocket { what: format!("reading {what}"), source: Box::new(e) }),
            }
        }
    }

    /// Keeps what an event says that the driver needs: console lines, exceptions, loads.
    fn handle_event(&mut self, msg: &Value) {
        let params = &msg["params"];
        match msg["method"].as_str() {
            Some("Runtime.consoleAPICalled") => {
                let args: Vec<String> = params["args"].as_array().into_iter().flatten().map(remote_object_text).collect();
                self.console.push(format!("[{}] {}", params["type"].as_str().unwrap_or("log"), args.join(" ")));
            }
            Some("Runtime.exceptionThrown") => self.console.push(format!("[exception] {}", exception_text(&params["exceptionDetails"]))),
            Some("Inspector.targetCrashed") => self.console.push("[crashed] the page's renderer crashed".into()),
            Some("Page.lifecycleEvent") if params["name"] == "load" => {
                self.loaded.insert(params["loaderId"].as_str().unwrap_or_default().to_owned());
            }
            _ => {}
        }
    }
}

/// A tungstenite handshake error as the underlying error (an interrupted handshake is a timeout).
fn handshake_error(e: tungstenite::HandshakeError<tungstenite::ClientHandshake<TcpStream>>) -> tungstenite::Error {
    match e {
        tungstenite::HandshakeError::Failure(e) => e,
        tungstenite::HandshakeError::Interrupted(_) => tungstenite::Error::Io(io::Error::new(io::ErrorKind::TimedOut, "the handshake timed out")),
    }
}

/// A console argument as text: its value if it has one, else its description (objects, errors).
fn remote_object_text(obj: &Value) -> String {
    match obj.get("value") {
        Some(Value::String(s)) => s.clone(),
        Some(v) => v.to_string(),
        None => obj["unserializableValue"].as_str().or(obj["description"].as_str()).unwrap_or_else(|| obj["type"].as_str().unwrap_or("?")).to_owned(),
    }
}

/// What an `exceptionDetails` says: the exception's description (message and stack) if there is
/// one, else its text.
fn exception_text(details: &Value) -> String {
    details["exception"]["description"].as_str().or(details["exception"]["value"].as_str()).or(details["text"].as_str()).unwrap_or("an exception without text").to_owned()
}

/// Whether a value is truthy as JavaScript sees it (`null`, `false`, `0`, `""` are not).
fn truthy(v: &Value) -> bool {
    match v {
        Value::Null => false,
        Value::Bool(b) => *b,
        Value::Number(n) => n.as_f64().is_some_and(|f| f != 0.0),
        Value::String(s) => !s.is_empty(),
        Value::Array(_) | Value::Object(_) => true,
    }
}

/// One tab, over its own DevTools websocket (see [`Browser::new_page`]).
pub struct Page {
    cdp: Cdp,
}

impl Page {
    /// Loads `url` in this tab and waits (up to [`DEFAULT_WAIT`]) for its `load` event; a
    /// failed load (e.g. `net::ERR_CONNECTION_REFUSED`) is an error.
    pub fn navigate(&mut self, url: &str) -> Result<()> {
        let deadline = Deadline::after(DEFAULT_WAIT);
        let reply = self.cdp.call_until("Page.navigate", json!({ "url": url }), deadline)?;
        if let Some(error) = reply["errorText"].as_str().filter(|e| !e.is_empty()) {
            return Err(BrowserError::Navigation { url: short(url), error: error.to_owned() });
        }
        // A navigation within the document (only the fragment changes) has no new loader.
        let Some(loader) = reply["loaderId"].as_str().map(str::to_owned) else { return Ok(()) };
        self.cdp.pump_until(&format!("the load event of {}", short(url)), deadline, |c| c.loaded.contains(&loader))
    }

    /// Evaluates `js` in the page (promises awaited) and returns its value as JSON (`undefined`
    /// is `null`; `NaN`, `Infinity`, `-0` and bigints come as their text); a throw is
    /// [`BrowserError::Exception`] with its message.
    pub fn eval(&mut self, js: &str) -> Result<Value> {
        self.eval_until(js, Deadline::after(DEFAULT_WAIT))
    }

    /// [`Page::eval`] with its reply awaited until `deadline`.
    fn eval_until(&mut self, js: &str, deadline: Deadline) -> Result<Value> {
        let reply = self.cdp.call_until("Runtime.evaluate", json!({ "expression": js, "returnByValue": true, "awaitPromise": true }), deadline)?;
        if let Some(details) = reply.get("exceptionDetails") {
            return Err(BrowserError::Exception(exception_text(details)));
        }
        let result = &reply["result"];
        Ok(match result.get("value") {
            Some(v) => v.clone(),
            None => result["unserializableValue"].as_str().map_or(Value::Null, |s| Value::String(s.to_owned())),
        })
    }

    /// Evaluates `js_condition` every 50 ms until its value is truthy and returns that value;
    /// throws count as "not yet". After `limit`, an error with the last value (or throw).
    pub fn wait_for(&mut self, js_condition: &str, limit: Duration) -> Result<Value> {
        let deadline = Deadline::after(limit);
        let mut last = None;
        while !deadline.left().is_zero() {
            last = Some(match self.eval_until(js_condition, deadline) {
                Ok(v) if truthy(&v) => return Ok(v),
                Ok(v) => v.to_string(),
                Err(BrowserError::Exception(text)) => format!("threw {text}"),
                // The limit ran out during this evaluation: the one before is the last value.
                Err(BrowserError::Timeout { .. }) => break,
                Err(e) => return Err(e),
            });
            std::thread::sleep(Duration::from_millis(50).min(deadline.left()));
        }
        Err(BrowserError::WaitFor { condition: js_condition.to_owned(), limit, last: last.unwrap_or_else(|| "none (no evaluation finished)".to_owned()) })
    }

    /// The visible viewport as an RGBA8 image (`Page.captureScreenshot`, PNG); after
    /// [`Page::set_viewport`] its size is the viewport's in CSS pixels.
    pub fn screenshot(&mut self) -> Result<Image> {
        let reply = self.cdp.call("Page.captureScreenshot", json!({ "format": "png" }))?;
        let data = reply["data"].as_str().ok_or_else(|| BrowserError::Protocol { method: "Page.captureScreenshot".into(), reply: short(&reply.to_string()) })?;
        Image::from_png(&base64::engine::general_purpose::STANDARD.decode(data)?)
    }

    /// Sets the viewport to `width` x `height` CSS pixels at device scale 1, so screenshot
    /// pixels are CSS pixels.
    pub fn set_viewport(&mut self, width: u32, height: u32) -> Result<()> {
        self.cdp.call("Emulation.setDeviceMetricsOverride", json!({ "width": width, "height": height, "deviceScaleFactor": 1, "mobile": false }))?;
        Ok(())
    }

    /// Installs `js` to run in every document this tab loads from now on, before the page's own
    /// scripts (e.g. a fake `navigator.xr`); it applies from the next [`Page::navigate`].
    pub fn add_init_script(&mut self, js: &str) -> Result<()> {
        self.cdp.call("Page.addScriptToEvaluateOnNewDocument", json!({ "source": js }))?;
        Ok(())
    }

    /// What the page logged (`[log] ...`, `[error] ...`) and threw uncaught (`[exception] ...`),
    /// in order, as far as the driver has read: messages arrive with the replies to calls.
    pub fn console(&self) -> Vec<String> {
        self.cdp.console.clone()
    }
}

impl Drop for Page {
    /// Closes the tab (best effort, no reply awaited) so a long test does not pile them up.
    fn drop(&mut self) {
        self.cdp.next_id += 1;
        let _ = self.cdp.socket.send(Message::text(json!({ "id": self.cdp.next_id, "method": "Page.close", "params": {} }).to_string()));
    }
}

/// The first 200 characters of `s` (data URLs and replies can be long in error messages).
fn short(s: &str) -> String {
    match s.char_indices().nth(200) {
        Some((at, _)) => format!("{}...", &s[..at]),
        None => s.to_owned(),
    }
}

/// An HTML document as a `data:text/html` URL, percent-encoded so `#`, `%` and spaces survive.
pub fn data_url(html: &str) -> String {
    let mut url = String::from("data:text/html;charset=utf-8,");
    for b in html.bytes() {
        if b.is_ascii_alphanumeric() || b"-_.~".contains(&b) {
            url.push(b as char);
        } else {
            url.push_str(&format!("%{b:02X}"));
        }
    }
    url
}

/// A screenshot: `width` x `height` pixels, RGBA8, rows top to bottom.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<u8>,
}

impl Image {
    /// Decodes a PNG of any colour type and depth to RGBA8.
    pub fn from_png(bytes: &[u8]) -> Result<Image> {
        let decode = |e| BrowserError::PngDecode(Box::new(e));
        let mut decoder = png::Decoder::new(io::Cursor::new(bytes));
        decoder.set_transformations(png::Transformations::normalize_to_color8());
        let mut reader = decoder.read_info().map_err(decode)?;
        let mut buf = vec![0; reader.output_buffer_size().unwrap_or(0)];
        let info = reader.next_frame(&mut buf).map_err(decode)?;
        buf.truncate(info.buffer_size());
        let rgba = match info.color_type {
            png::ColorType::Rgba => buf,
            png::ColorType::Rgb => buf.chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 255]).collect(),
            png::ColorType::GrayscaleAlpha => buf.chunks_exact(2).flat_map(|p| [p[0], p[0], p[0], p[1]]).collect(),
            png::ColorType::Grayscale => buf.iter().flat_map(|&g| [g, g, g, 255]).collect(),
            png::ColorType::Indexed => unreachable!("normalize_to_color8 expands palettes"),
        };
        Ok(Image { width: info.width, height: info.height, rgba })
    }

    /// The pixel at column `x`, row `y` (from the top left) as `[r, g, b, a]`; panics outside.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 4] {
        assert!(x < self.width && y < self.height, "pixel ({x}, {y}) outside a {}x{} image", self.width, self.height);
        let at = (y as usize * self.width as usize + x as usize) * 4;
        [self.rgba[at], self.rgba[at + 1], self.rgba[at + 2], self.rgba[at + 3]]
    }

    /// Writes the image as an RGBA8 PNG (so a test can keep what it saw).
    pub fn save_png(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let file = std::fs::File::create(path).map_err(|source| BrowserError::Io { what: format!("creating {}", path.display()), source })?;
        let encode = |e| BrowserError::PngEncode(Box::new(e));
        let mut encoder = png::Encoder::new(io::BufWriter::new(file), self.width, self.height);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(encode)?;
        writer.write_image_data(&self.rgba).map_err(encode)?;
        writer.finish().map_err(encode)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A page with a WebGL2 canvas cleared to rgb(10,200,30) at (0,0)-(200,100) and a red div at
    /// (300,50)-(400,150) on white; `window.gl2` says whether WebGL2 came up.
    const SCENE: &str = r#"<!doctype html><html><body style="margin:0;background:#ffffff">
<canvas id="c" width="200" height="100" style="position:absolute;left:0;top:0;width:200px;height:100px"></canvas>
<div style="position:absolute;left:300px;top:50px;width:100px;height:100px;background:rgb(255,0,0)"></div>
<script>
const gl = document.getElementById('c').getContext('webgl2', { preserveDrawingBuffer: true });
window.gl2 = gl instanceof WebGL2RenderingContext;
const info = gl && gl.getExtension('WEBGL_debug_renderer_info');
window.renderer = gl ? gl.getParameter(gl.VERSION) + ' / ' + gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER) : 'none';
if (gl) { gl.clearColor(10 / 255, 200 / 255, 30 / 255, 1); gl.clear(gl.COLOR_BUFFER_BIT); }
</script></body></html>"#;

    /// Whether two colours agree within `tol` on every channel.
    fn close_to(got: [u8; 4], want: [u8; 4], tol: u8) -> bool {
        got.iter().zip(want).all(|(g, w)| g.abs_diff(w) <= tol)
    }

    #[test]
    fn webgl2_canvas_and_a_div_show_in_the_screenshot() {
        let browser = Browser::launch().expect("headless Chromium (install chromium or set LUMEN_CHROMIUM)");
        let mut page = browser.new_page("about:blank").unwrap();
        page.set_viewport(640, 360).unwrap();
        page.navigate(&data_url(SCENE)).unwrap();
        assert_eq!(page.eval("window.gl2").unwrap(), json!(true), "no WebGL2 on the software renderer ({}); console: {:?}", page.eval("window.renderer").unwrap(), page.console());
        // Two frames, so the cleared canvas is composited before the capture.
        page.eval("new Promise(r => requestAnimationFrame(() => requestAnimationFrame(() => r(0))))").unwrap();
        let shot = page.screenshot().unwrap();
        let keep = std::env::temp_dir().join(format!("lumen-browser-selftest-{}.png", std::process::id()));
        shot.save_png(&keep).unwrap();
        assert_eq!((shot.width, shot.height), (640, 360), "the viewport's size in CSS px");
        for (x, y, want, what) in [
            (100, 50, [10, 200, 30, 255], "the WebGL2 clear colour"),
            (350, 100, [255, 0, 0, 255], "the red div"),
            (250, 50, [255, 255, 255, 255], "the white page"),
            (600, 300, [255, 255, 255, 255], "the white page"),
        ] {
            let got = shot.pixel(x, y);
            assert!(close_to(got, want, 2), "{what} at ({x}, {y}): {got:?}, want {want:?} (screenshot kept at {})", keep.display());
        }
        // The PNG written reads back the same; kept only when something above failed.
        let again = Image::from_png(&std::fs::read(&keep).unwrap()).unwrap();
        std::fs::remove_file(&keep).unwrap();
        assert_eq!(again, shot);
    }

    #[test]
    fn eval_returns_values_and_throws_become_errors() {
        let browser = Browser::launch().expect("headless Chromium (install chromium or set LUMEN_CHROMIUM)");
        let mut page = browser.new_page(&data_url("<p>hi</p>")).unwrap();
        assert_eq!(page.eval("1+2").unwrap(), json!(3));
        assert_eq!(page.eval("document.querySelector('p').textContent").unwrap(), json!("hi"));
        assert_eq!(page.eval("Promise.resolve({a: [1, 'b']})").unwrap(), json!({ "a": [1, "b"] }));
        assert_eq!(page.eval("undefined").unwrap(), Value::Null);
        match page.eval("throw new Error('boom')") {
            Err(BrowserError::Exception(text)) => assert!(text.contains("boom"), "{text}"),
            other => panic!("a throw should be an Exception error, got {other:?}"),
        }
        assert!(matches!(page.eval("Promise.reject(new Error('nope'))"), Err(BrowserError::Exception(t)) if t.contains("nope")));
        let cdp_err = page.cdp.call("No.suchMethod", json!({})).unwrap_err();
        assert!(matches!(&cdp_err, BrowserError::Cdp { method, .. } if method == "No.suchMethod"), "{cdp_err}");
    }

    #[test]
    fn wait_for_polls_until_truthy_and_times_out_with_the_last_value() {
        let browser = Browser::launch().expect("headless Chromium (install chromium or set LUMEN_CHROMIUM)");
        let mut page = browser.new_page(&data_url("<script>setTimeout(() => { window.ready = 'yes'; }, 300);</script>")).unwrap();
        assert_eq!(page.wait_for("window.ready", Duration::from_secs(10)).unwrap(), json!("yes"));
        let started = Instant::now();
        match page.wait_for("window.never || 0", Duration::from_millis(400)) {
            Err(BrowserError::WaitFor { last, .. }) => assert_eq!(last, "0"),
            other => panic!("expected a WaitFor timeout, got {other:?}"),
        }
        assert!(started.elapsed() < Duration::from_secs(5), "the wait is bounded by its limit");
        assert!(matches!(page.wait_for("notDefined.x", Duration::from_millis(200)), Err(BrowserError::WaitFor { last, .. }) if last.contains("notDefined")));
    }

    #[test]
    fn init_scripts_run_first_and_the_console_is_collected() {
        let browser = Browser::launch().expect("headless Chromium (install chromium or set LUMEN_CHROMIUM)");
        let mut page = browser.new_page("about:blank").unwrap();
        page.add_init_script("window.fakeThing = 42;").unwrap();
        page.navigate(&data_url("<script>window.seen = window.fakeThing; console.log('seen', window.seen); setTimeout(() => { throw new Error('late boom'); }, 0);</script>")).unwrap();
        assert_eq!(page.eval("window.seen").unwrap(), json!(42), "the init script ran before the page's script");
        page.wait_for("new Promise(r => setTimeout(() => r(true), 100))", Duration::from_secs(5)).unwrap();
        let console = page.console();
        assert!(console.iter().any(|l| l == "[log] seen 42"), "{console:?}");
        assert!(console.iter().any(|l| l.starts_with("[exception]") && l.contains("late boom")), "{console:?}");
    }

    #[test]
    fn dropping_the_browser_kills_it_and_removes_its_profile() {
        let browser = Browser::launch().expect("headless Chromium (install chromium or set LUMEN_CHROMIUM)");
        let (pid, profile) = (browser.child.id() as libc::pid_t, browser.profile.clone());
        assert!(profile.is_dir());
        assert!(!group_members(pid).is_empty(), "Chromium runs in its own process group");
        drop(browser);
        assert!(!profile.exists(), "{} left behind", profile.display());
        // SIGKILL lands a moment later for the helpers; zombies awaiting a reaper do not count.
        assert!(crate::eventually(Duration::from_secs(5), || group_members(pid).is_empty()), "Chromium's process group {pid} outlived the browser: {:?}", group_members(pid));
    }

    /// The live (not zombie) processes in process group `pgid`, from `/proc/*/stat`.
    fn group_members(pgid: libc::pid_t) -> Vec<String> {
        let stats = std::fs::read_dir("/proc").into_iter().flatten().filter_map(|e| std::fs::read_to_string(e.ok()?.path().join("stat")).ok());
        // After the command's closing parenthesis: state, ppid, pgrp, ...
        stats.filter(|s| s.rsplit_once(')').map(|(_, rest)| rest.split_whitespace().collect::<Vec<_>>()).is_some_and(|f| f.len() > 2 && f[0] != "Z" && f[2] == pgid.to_string())).collect()
    }

    #[test]
    fn data_urls_escape_what_would_end_them() {
        assert_eq!(data_url("a b#%"), "data:text/html;charset=utf-8,a%20b%23%25");
    }
}

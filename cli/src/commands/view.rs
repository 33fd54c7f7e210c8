//! `lumen view [SESSION | FILE.mcap]`: a session in the browser. It observes a running session
//! (the same transport flags as `lumen status`; without a SESSION it follows the first session
//! the daemon lists, then each next one to open) or plays a recording, and serves the page of
//! `lumen-view` on loopback.
//!
//! stdout, for scripts: first `lumen view: serving http://ADDR/`, then `lumen view: session N`
//! each time a session is followed (or `lumen view: playing FILE, F frames, session N`).
//!
//! The observer never waits for a page: it hands the newest frame with its reply to the server
//! (at most [`PUBLISH_HZ`] a second; a page draws at its own rate anyway) and goes back to the
//! session. SIGINT / SIGTERM end it.

use super::transport::TransportArgs;
use crate::commands::{CliError, CliResult};
use crate::playback::{Cursor, Playback};
use clap::Args;
use lumen_client::{Client, Error, Observed};
use lumen_service::daemon::{block_termination_signals, wait_signal};
use lumen_view::{Control, SceneInfo, Snapshot, Source, Stats, Viewer};
use std::collections::{HashSet, VecDeque};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Snapshots handed to the server per second at most, live (a page draws at its display rate).
pub const PUBLISH_HZ: f64 = 120.0;
/// How often the loops look for a signal, a control or a new session.
const POLL: Duration = Duration::from_millis(20);
/// How often the daemon's figures of the session (its turnaround) are asked for.
const STATUS_EVERY: Duration = Duration::from_secs(1);
/// Frame rates are counted over this window.
const RATE_WINDOW: Duration = Duration::from_secs(1);

#[derive(Debug, Args)]
pub struct ViewArgs {
    /// A session id (as `lumen status` lists it), or a recording (`run.mcap`). Without it: the
    /// first session the daemon lists, then each next one to open.
    pub target: Option<String>,
    /// Address the page is served on (loopback by default; port 0 picks a free one).
    #[arg(long, default_value = "127.0.0.1:7480", value_name = "ADDR")]
    pub listen: String,
    /// Wall rows drawn per ring segment, 1 to 16 (1: a row per ring, enough where rings are a
    /// millimetre or two apart, as in the generated and the GCA colons).
    #[arg(long, default_value_t = 1)]
    pub steps: usize,
    /// Open the page in the system's browser (`xdg-open`, or `open` on macOS).
    #[arg(long)]
    pub open: bool,
    /// A recording: start paused at the first frame (else it plays at once, in real time).
    #[arg(long)]
    pub paused: bool,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// What the positional argument names.
#[derive(Debug, PartialEq)]
enum Target {
    Follow,
    Session(u64),
    Recording(PathBuf),
}

fn target(arg: Option<&str>) -> CliResult<Target> {
    let Some(t) = arg else { return Ok(Target::Follow) };
    if let Ok(id) = t.parse::<u64>() {
        return Ok(Target::Session(id));
    }
    let path = Path::new(t);
    if path.is_file() {
        return Ok(Target::Recording(path.to_owned()));
    }
    Err(CliError::bad_flag("TARGET", t, "a session id or a recording file (run.mcap) that exists"))
}

pub fn run(args: ViewArgs) -> CliResult {
    block_termination_signals();
    if !(1..=16).contains(&args.steps) {
        return Err(CliError::bad_flag("--steps", args.steps, "1 to 16"));
    }
    match target(args.target.as_deref())? {
        Target::Recording(path) => play(&args, &path),
        t => live(
            &args,
            match t {
                Target::Session(id) => Some(id),
                _ => None,
            },
        ),
    }
}

/// Starts the server on the first scene and says where.
fn serve(args: &ViewArgs, scene: SceneInfo) -> CliResult<Viewer> {
    let viewer = Viewer::start(&args.listen, scene)?;
    say(&format!("lumen view: serving {}", viewer.url()));
    if args.open {
        open_browser(&viewer.url());
    }
    Ok(viewer)
}

/// The last line: what the pages were sent.
fn bye(viewer: &Viewer) {
    let c = viewer.counters();
    let s = viewer.uptime().as_secs_f64().max(1e-3);
    say(&format!("lumen view: sent {} frames, {} bytes in {s:.1} s ({:.0} frames/s, {:.0} KB/s)", c.messages, c.bytes, c.messages as f64 / s, c.bytes as f64 / s / 1e3));
}

fn say(line: &str) {
    println!("{line}");
    let _ = std::io::stdout().flush();
}

fn open_browser(url: &str) {
    let opener = if cfg!(target_os = "macos") { "open" } else { "xdg-open" };
    if let Err(e) = std::process::Command::new(opener).arg(url).spawn() {
        eprintln!("lumen view: could not start {opener} ({e}); open {url} yourself");
    }
}

// ---- live -----------------------------------------------------------------------------------

fn live(args: &ViewArgs, only: Option<u64>) -> CliResult {
    let client = args.transport.client("lumen view")?;
    let mut viewer: Option<Viewer> = None;
    let mut seen = HashSet::new();
    loop {
        let id = match only {
            Some(id) => id,
            None => match next_session(&client, &seen)? {
                Some(id) => id,
                None => {
                    if let Some(v) = &viewer {
                        bye(v);
                    }
                    return Ok(());
                }
            },
        };
        seen.insert(id);
        let mut observer = match client.observe(id) {
            Ok(o) => o,
            // A session that ended between the listing and here: look for the next.
            Err(Error::SessionEnded(_) | Error::Refused(_)) if only.is_none() => continue,
            Err(e) => return Err(e.into()),
        };
        let info = observer.info().clone();
        let scene = SceneInfo::new(&info.spec, id, Source::Live, args.steps, 0, &info.transport.to_string());
        match &viewer {
            Some(v) => v.set_scene(scene),
            None => viewer = Some(serve(args, scene)?),
        }
        say(&format!("lumen view: session {id}"));
        let v = viewer.as_ref().expect("started above");
        match follow(&client, &mut observer, v)? {
            Ended::Session => eprintln!("lumen view: session {id} ended"),
            Ended::Signal => {
                bye(v);
                return Ok(());
            }
        }
        if only.is_some() {
            bye(v);
            return Ok(());
        }
    }
}

enum Ended {
    Session,
    Signal,
}

/// The first session on this client's transport not followed yet; `None` on a signal.
fn next_session(client: &Client, seen: &HashSet<u64>) -> CliResult<Option<u64>> {
    let mut said = false;
    loop {
        let report = client.status()?;
        if !said && !report.sessions.is_empty() {
            eprint!("{}", super::status::table(&report));
        }
        if let Some(s) = report.sessions.iter().find(|s| s.transport == client.transport() && !seen.contains(&s.session)) {
            return Ok(Some(s.session));
        }
        if !said {
            if report.hidden > 0 {
                eprintln!("lumen view: the daemon serves {} session(s) it does not list to this client ([zenoh] status policy): give the SESSION id", report.hidden);
            }
            eprintln!("lumen view: waiting for a session on {}", client.transport());
            said = true;
        }
        if wait_signal(Duration::from_millis(250)).is_some() {
            return Ok(None);
        }
    }
}

/// The last two frames seen (a reply may come after the next frame).
#[derive(Default)]
struct Held {
    frames: [Option<(u64, Vec<f32>)>; 2],
    next: usize,
}

impl Held {
    fn put(&mut self, frame: u64, state: &[f32]) {
        let slot = &mut self.frames[self.next];
        self.next ^= 1;
        let buf = match slot.take() {
            Some((_, mut v)) => {
                v.clear();
                v.extend_from_slice(state);
                v
            }
            None => state.to_vec(),
        };
        *slot = Some((frame, buf));
    }

    fn get(&self, frame: u64) -> Option<&(u64, Vec<f32>)> {
        self.frames.iter().flatten().find(|f| f.0 == frame)
    }
}

/// Frames per second from frame numbers over the last [`RATE_WINDOW`].
#[derive(Default)]
struct Rate(VecDeque<(u64, Instant)>);

impl Rate {
    fn push(&mut self, frame: u64, at: Instant) {
        if self.0.back().is_some_and(|b| frame < b.0) {
            self.0.clear(); // the client restarted its count
        }
        self.0.push_back((frame, at));
        while self.0.front().is_some_and(|f| at.duration_since(f.1) > RATE_WINDOW) {
            self.0.pop_front();
        }
    }

    fn fps(&self) -> f64 {
        match (self.0.front(), self.0.back()) {
            (Some(a), Some(b)) if b.1 > a.1 => (b.0 - a.0) as f64 / b.1.duration_since(a.1).as_secs_f64(),
            _ => 0.0,
        }
    }
}

/// The daemon's turnaround of `session` (frame in to reply out, p50 over its last seconds, us)
/// from its status report: an observer cannot time the client's own round trip (the client's
/// timestamps are on the client's clock).
fn turnaround(client: &Client, session: u64) -> Option<f64> {
    let report = client.status().ok()?;
    report.sessions.iter().find(|s| s.session == session).map(|s| s.service.p50_us).filter(|t| *t > 0.0)
}

fn follow(client: &Client, observer: &mut lumen_client::Observer, viewer: &Viewer) -> CliResult<Ended> {
    let (mut held, mut rate) = (Held::default(), Rate::default());
    let gap = Duration::from_secs_f64(1.0 / PUBLISH_HZ);
    let session = observer.info().session;
    let mut last_publish: Option<Instant> = None;
    let (mut service_us, mut last_status) = (None, Instant::now() - STATUS_EVERY);
    loop {
        if wait_signal(Duration::ZERO).is_some() {
            return Ok(Ended::Signal);
        }
        if last_status.elapsed() >= STATUS_EVERY {
            last_status = Instant::now();
            service_us = turnaround(client, session).or(service_us);
        }
        match observer.next(POLL) {
            Ok(Observed::Frame { header, state }) => {
                rate.push(header.frame, Instant::now());
                held.put(header.frame, state);
            }
            Ok(Observed::Contacts(reply)) => {
                let now = Instant::now();
                if last_publish.is_some_and(|t| now.duration_since(t) < gap) {
                    continue;
                }
                let Some((frame, state)) = held.get(reply.frame()) else { continue };
                let h = reply.header();
                let stats =
                    Stats { frame: *frame, fps: rate.fps(), turnaround_us: service_us, detect_us: h.detect_ns as f64 / 1e3, status: h.status, ..Stats::default() }.of_contacts(reply.contacts());
                viewer.publish(Snapshot { state: state.clone(), contacts: reply.contacts().to_vec(), stats });
                last_publish = Some(now);
            }
            Err(Error::Timeout(_)) => {}
            Err(Error::SessionEnded(_)) => return Ok(Ended::Session),
            Err(e) => return Err(e.into()),
        }
    }
}

// ---- recordings -----------------------------------------------------------------------------

/// The fastest and slowest playback, times real time.
const SPEEDS: (f64, f64) = (1.0 / 64.0, 64.0);
/// A gap in the recording's clock longer than this plays as this (a paused client).
const LONGEST_STEP: Duration = Duration::from_millis(250);

fn play(args: &ViewArgs, path: &Path) -> CliResult {
    let pb = Playback::load(path)?;
    let label = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
    let scene = SceneInfo::new(&pb.recording.spec, pb.recording.session, Source::Recording, args.steps, pb.len() as u64, &label);
    let viewer = serve(args, scene)?;
    say(&format!("lumen view: playing {}, {} frames, session {}", path.display(), pb.len(), pb.recording.session));
    if pb.is_empty() {
        eprintln!("lumen view: {} holds no frame", path.display());
    }
    let mut p = Player { pb: &pb, cursor: Cursor::default(), playing: !args.paused, speed: 1.0, clock: Instant::now() };
    p.show(&viewer, 0)?;
    loop {
        if wait_signal(Duration::ZERO).is_some() {
            bye(&viewer);
            return Ok(());
        }
        let wait = p.due().map_or(POLL, |d| d.min(POLL));
        match viewer.control_timeout(wait) {
            Some(c) => p.control(&viewer, c)?,
            None => p.advance(&viewer)?,
        }
    }
}

/// A recording's playback state.
struct Player<'a> {
    pb: &'a Playback,
    cursor: Cursor,
    playing: bool,
    speed: f64,
    /// When the frame shown was due.
    clock: Instant,
}

impl Player<'_> {
    fn index(&self) -> usize {
        self.cursor.index().unwrap_or(0)
    }

    /// The recording's time from the frame shown to the next, at the playback speed.
    fn step(&self) -> Option<Duration> {
        self.step_from(self.index())
    }

    /// How long until the next frame is due, playing.
    fn due(&self) -> Option<Duration> {
        if !self.playing {
            return None;
        }
        let next = self.clock + self.step()?;
        Some(next.saturating_duration_since(Instant::now()))
    }

    /// Plays on: the frame due now (frames that are late are skipped, as a live view drops them).
    fn advance(&mut self, viewer: &Viewer) -> CliResult {
        if !self.playing {
            return Ok(());
        }
        let (start, mut i) = (self.index(), self.index());
        while let Some(step) = self.step_from(i) {
            if self.clock + step > Instant::now() {
                break;
            }
            self.clock += step;
            i += 1;
        }
        if i + 1 >= self.pb.len() {
            self.playing = false; // the end: paused on the last frame
        }
        if i != start || !self.playing {
            self.show(viewer, i)?;
        }
        Ok(())
    }

    /// The same from frame `i`.
    fn step_from(&self, i: usize) -> Option<Duration> {
        let (a, b) = (self.pb.log_time_ns(i)?, self.pb.log_time_ns(i + 1)?);
        Some(Duration::from_nanos(b.saturating_sub(a)).min(LONGEST_STEP).div_f64(self.speed))
    }

    fn control(&mut self, viewer: &Viewer, c: Control) -> CliResult {
        let i = self.index();
        match c {
            Control::Play => {
                if i + 1 >= self.pb.len() {
                    self.show(viewer, 0)?; // play again from the start
                }
                self.playing = true;
                self.clock = Instant::now();
            }
            Control::Pause => self.playing = false,
            Control::Step(by) => {
                self.playing = false;
                self.show(viewer, (i as i64 + by).max(0) as usize)?;
                return Ok(());
            }
            Control::Speed(s) => {
                self.speed = s.clamp(SPEEDS.0, SPEEDS.1);
                self.clock = Instant::now();
            }
            Control::Seek(k) => {
                self.show(viewer, usize::try_from(k).unwrap_or(usize::MAX))?;
                self.clock = Instant::now();
                return Ok(());
            }
        }
        self.show(viewer, self.index())
    }

    /// Decodes frame `index` with its recorded reply and hands it to the server.
    fn show(&mut self, viewer: &Viewer, index: usize) -> CliResult {
        if self.pb.is_empty() {
            return Ok(());
        }
        self.pb.seek(&mut self.cursor, index)?;
        let i = self.index();
        let header = self.cursor.header.expect("a frame was decoded");
        let reply = self.pb.reply(header.frame);
        let mut stats = Stats { frame: header.frame, fps: self.recorded_fps(i), index: Some(i as u64), playing: Some(self.playing), speed: Some(self.speed), ..Stats::default() };
        if let Some(r) = reply {
            stats.detect_us = r.header.detect_ns as f64 / 1e3;
            stats.status = r.header.status;
            stats = stats.of_contacts(&r.contacts);
        }
        viewer.publish(Snapshot { state: self.cursor.state.clone(), contacts: reply.map(|r| r.contacts.clone()).unwrap_or_default(), stats });
        Ok(())
    }

    /// The recorded client's frame rate around frame `i` (over up to 30 frames of its clock).
    fn recorded_fps(&self, i: usize) -> f64 {
        let a = i.saturating_sub(30);
        let b = if a == i { (i + 30).min(self.pb.len().saturating_sub(1)) } else { i };
        match (self.pb.log_time_ns(a), self.pb.log_time_ns(b)) {
            (Some(ta), Some(tb)) if tb > ta => (b - a) as f64 / ((tb - ta) as f64 / 1e9),
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_target_is_a_session_a_file_or_nothing() {
        assert_eq!(target(None).unwrap(), Target::Follow);
        assert_eq!(target(Some("4503599627370495")).unwrap(), Target::Session(4_503_599_627_370_495));
        let here = std::env::current_exe().unwrap();
        assert_eq!(target(Some(here.to_str().unwrap())).unwrap(), Target::Recording(here));
        let e = target(Some("/no/such/run.mcap")).unwrap_err().to_string();
        assert!(e.contains("/no/such/run.mcap") && e.contains("session id or a recording"), "{e}");
    }

    #[test]
    fn the_rate_counts_frame_numbers_over_the_window_and_restarts() {
        let t0 = Instant::now();
        let mut r = Rate::default();
        for k in 0..=100u64 {
            r.push(k * 2, t0 + Duration::from_millis(5 * k)); // 2 frames per 5 ms: 400/s
        }
        assert!((r.fps() - 400.0).abs() < 1e-6, "{}", r.fps());
        r.push(0, t0 + Duration::from_millis(600));
        assert_eq!(r.fps(), 0.0);
    }

    #[test]
    fn held_frames_keep_the_last_two() {
        let mut h = Held::default();
        h.put(1, &[1.0]);
        h.put(2, &[2.0]);
        h.put(3, &[3.0]);
        assert!(h.get(1).is_none());
        assert_eq!(h.get(2).unwrap().1, vec![2.0]);
        assert_eq!(h.get(3).unwrap().1, vec![3.0]);
    }
}

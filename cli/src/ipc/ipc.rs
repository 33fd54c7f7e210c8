//! `lumen bench ipc`: round trip (frame submitted -> contacts received) on the colon-sized
//! scene, on each transport, back to back, paced at 1 kHz and with four paced sessions at once;
//! each against a bare echo of the same payload over the same transport (no detection),
//! measured in the same run in alternating blocks of frames, so both see the same machine.
//! Over zenoh each mode runs with whole frames and with delta frames, and paced at 1 kHz
//! behind an emulated 1 Gbit/s link too (`Session::emulate_link`).
//!
//! The daemon is the real `lumen serve`, started as a child process with a private iceoryx2
//! prefix and zenoh port; the clients are threads of this process.

use super::ownership::{self, Ownership};
use super::quantile_us;
use super::wake::{self, Wake};
use crate::error::{CliError, CliResult};
use lumen_client::{now_ns, Client, Error as ClientError, LocalOptions, Session, Transport};
use lumen_proto::{SceneSpec, StateLayout};
use lumen_scene::frames as scene;
use serde::Serialize;
use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// One measured configuration.
#[derive(Debug, Clone, Serialize)]
pub struct IpcRun {
    pub transport: String,
    /// `back-to-back`, `paced-1khz` or `4-sessions`.
    pub mode: String,
    pub p50_us: f64,
    pub p99_us: f64,
    pub p999_us: f64,
    /// p50 of the bare echo, same transport, mode and payload.
    pub echo_p50_us: f64,
    /// p99 of the bare echo: the transport's and the scheduler's own tail, with no detection.
    pub echo_p99_us: f64,
    /// Largest detection time the daemon reported on an echo reply: 0, since the echo detects nothing.
    pub echo_detect_max_us: f64,
    /// Median detection time reported by the daemon.
    pub detect_us: f64,
    /// p99 of the detection time: how much of the round trip's p99 detection alone explains.
    pub detect_p99_us: f64,
    /// Daemon-side p50 from seeing the frame to having sent the reply (detection included):
    /// what the round trip adds beyond this is transport and wake-ups.
    pub daemon_p50_us: f64,
    /// Frames measured (after warm-up; all sessions).
    pub frames: u64,
    /// Frames without their own reply (timed out, skipped or refused).
    pub lost_frames: u64,
    /// `whole` or `delta`: how frames went (iceoryx2: whole, in shared memory).
    pub frame: String,
    /// Median bytes of a frame's message on the wire (0 over iceoryx2: nothing is copied).
    pub wire_bytes_p50: f64,
    /// The client loop's frames a second over the measured frames (the detecting and the echo
    /// session's together; paced, 1,000 when the loop holds 1 kHz).
    pub rate_hz: f64,
}

/// Everything `ipc.json` holds.
#[derive(Debug, Clone, Serialize)]
pub struct IpcReport {
    pub scene: String,
    pub floats_per_frame: usize,
    pub quick: bool,
    /// Microseconds the client works between a reply and its next frame, back to back.
    pub think_us: u64,
    pub cores: usize,
    pub runs: Vec<IpcRun>,
    /// The machine's floor: a one-byte round trip between two threads ([`super::wake`]).
    pub wake: Vec<Wake>,
    /// What session ownership costs a zenoh round trip, in this process ([`super::ownership`]).
    pub ownership: Ownership,
}

impl IpcReport {
    /// The table of `ipc.md` (and the README).
    pub fn markdown(&self) -> String {
        let mut s = format!(
            "# lumen bench ipc\n\nScene: {} ({} floats = {:.0} KiB per frame). {} cores{}{}.\nRound trip = frame submitted -> contacts received, in microseconds; echo = same transport and payload, no detection, alternating with the detection in blocks of {BLOCK} frames.\n\n",
            self.scene,
            self.floats_per_frame,
            self.floats_per_frame as f64 * 4.0 / 1024.0,
            self.cores,
            if self.quick { ", --quick" } else { "" },
            if self.think_us > 0 { format!(", the client working {} us between a reply and its next frame back to back", self.think_us) } else { String::new() }
        );
        s += "| transport | mode | frame | KiB on the wire | rate Hz | p50 | p99 | p99.9 | echo p50 | echo p99 | detect | detect p99 | daemon p50 | p50 - echo - detect | frames | lost |\n|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
        for r in &self.runs {
            s += &format!(
                "| {} | {} | {} | {} | {:.0} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {} | {} |\n",
                r.transport,
                r.mode,
                r.frame,
                if r.wire_bytes_p50 > 0.0 { format!("{:.1}", r.wire_bytes_p50 / 1024.0) } else { "shared memory".into() },
                r.rate_hz,
                r.p50_us,
                r.p99_us,
                r.p999_us,
                r.echo_p50_us,
                r.echo_p99_us,
                r.detect_us,
                r.detect_p99_us,
                r.daemon_p50_us,
                r.p50_us - r.echo_p50_us - r.detect_us,
                r.frames,
                r.lost_frames
            );
        }
        s += "\nThe machine's floor under every round trip, measured in the same run: one byte there and back between two threads over a Unix socket pair (no payload, no IPC library, no detection), the threads pinned to two cores or to one.\n\n| mode | threads on | p50 | p99 | p99.9 | round trips |\n|---|---|---:|---:|---:|---:|\n";
        for w in &self.wake {
            s += &format!("| {} | {} | {:.1} | {:.1} | {:.1} | {} |\n", w.mode, w.cores, w.p50_us, w.p99_us, w.p999_us, w.round_trips);
        }
        let o = &self.ownership;
        s += &format!(
            "\nSession ownership over zenoh (proto/README.md, section 6), timed in this process on this run's frame: the client's tag of its {} KiB frame, the daemon's gate, the daemon's tag of a {}-byte reply and the client's gate cost {:.3} us a round trip at p50 ({:.3} at p99; {} batches of 1000). Over iceoryx2 ownership is one comparison a frame.\n",
            o.frame_bytes / 1024,
            o.reply_bytes,
            o.p50_us,
            o.p99_us,
            o.batches
        );
        s
    }
}

/// Mode of one measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    BackToBack,
    Paced1kHz,
}

/// How a measurement's frames travel over zenoh.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Wire {
    /// Delta frames (else whole).
    pub deltas: bool,
    /// An emulated link's rate, bytes a second (`None`: loopback as it is).
    pub link: Option<u64>,
}

/// 1 Gbit/s in bytes a second.
const GIGABIT: u64 = 125_000_000;

/// The benchmark's plan.
pub struct IpcBench {
    quick: bool,
    /// Use the analytic stand-in instead of lumen-scene's generated colonoscopy.
    pub stand_in: bool,
    /// Frames per measurement instead of 1,500 (`--quick`) or 10,000.
    pub frames: Option<usize>,
    /// Back to back, how long the client works (spins) between a reply and its next frame, as
    /// a physics step would; zero: it submits at once.
    pub think: Duration,
    transports: Vec<Transport>,
    /// The iceoryx2 `global.prefix` of the daemon it starts.
    pub prefix: String,
    /// The zenoh endpoint that daemon listens on and the clients connect to.
    pub endpoint: String,
}

/// Round trips and detection times of one measurement.
#[derive(Debug, Default)]
struct Samples {
    rtt_ns: Vec<u64>,
    detect_ns: Vec<u64>,
    lost: u64,
    /// Daemon-side service-time p50 of each session measured, us.
    daemon_p50_us: Vec<f64>,
    /// Bytes of each measured frame's message on the wire (zenoh).
    wire_bytes: Vec<u64>,
    /// Frames measured a second, per session.
    rate_hz: Vec<f64>,
}

impl Samples {
    fn merge(&mut self, o: Samples) {
        self.rtt_ns.extend(o.rtt_ns);
        self.detect_ns.extend(o.detect_ns);
        self.lost += o.lost;
        self.daemon_p50_us.extend(o.daemon_p50_us);
        self.wire_bytes.extend(o.wire_bytes);
        self.rate_hz.extend(o.rate_hz);
    }
}

/// The `lumen serve` child of the benchmark; stopped with SIGTERM when dropped.
pub struct DaemonChild {
    child: Child,
}

impl DaemonChild {
    /// Starts `exe serve ARGS...` and waits for its "ready" line.
    pub fn spawn(exe: &std::path::Path, args: &[String]) -> CliResult<Self> {
        let mut child = Command::new(exe).arg("serve").args(args).stdout(Stdio::piped()).stderr(Stdio::inherit()).spawn().map_err(|source| CliError::StartDaemon { exe: exe.to_owned(), source })?;
        let stdout = child.stdout.take().expect("piped");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if line.contains("ready") {
                    let _ = tx.send(());
                }
            }
        });
        let mut me = Self { child };
        let limit = Duration::from_secs(20);
        if rx.recv_timeout(limit).is_err() {
            let _ = me.child.kill();
            return Err(CliError::DaemonNotReady { limit });
        }
        Ok(me)
    }
}

impl Drop for DaemonChild {
    fn drop(&mut self) {
        // SAFETY: signalling our own child by its pid.
        unsafe { libc::kill(self.child.id() as i32, libc::SIGTERM) };
        let deadline = Instant::now() + Duration::from_secs(5);
        while Instant::now() < deadline {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A free TCP port on loopback.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).map(|a| a.port()).unwrap_or(17447)
}

impl IpcBench {
    /// A plan; `only` restricts it to `iceoryx2` or `zenoh`.
    pub fn new(quick: bool, only: Option<&str>) -> CliResult<Self> {
        let transports = match only {
            None => vec![Transport::Iceoryx2, Transport::Zenoh],
            Some("iceoryx2") => vec![Transport::Iceoryx2],
            Some("zenoh") => vec![Transport::Zenoh],
            Some(o) => return Err(CliError::UnknownTransport { name: o.to_owned() }),
        };
        let prefix = format!("lumen_bench_{}_", std::process::id());
        Ok(Self { quick, stand_in: false, frames: None, think: Duration::ZERO, transports, prefix, endpoint: format!("tcp/127.0.0.1:{}", free_port()) })
    }

    fn client(&self, t: Transport) -> Result<Client, ClientError> {
        match t {
            Transport::Iceoryx2 => Client::local_with(LocalOptions { prefix: Some(self.prefix.clone()), name: Some("bench".into()) }),
            // The bench's own daemon, wherever it was told to listen.
            Transport::Zenoh => Client::zenoh_insecure(&self.endpoint),
        }
    }

    /// Runs every measurement against a fresh daemon.
    pub fn run(&self) -> CliResult<IpcReport> {
        let exe = std::env::current_exe().map_err(CliError::CurrentExe)?;
        // Status lists the sessions to the bench's own zenoh client too (not only counts): it
        // reads each session's daemon-side time from there.
        let mut args: Vec<String> = ["--prefix", &self.prefix, "--zenoh-listen", &self.endpoint, "--zenoh-status", "sessions", "--log", "warn"].iter().map(|s| s.to_string()).collect();
        if !lumen_transport::net::is_loopback(&self.endpoint) {
            args.push("--insecure".into()); // told to listen beyond loopback, for a measurement
        }
        let _daemon = DaemonChild::spawn(&exe, &args)?;
        let (spec, states) = if self.stand_in { scene::stand_in(FRAMES) } else { colonoscopy(FRAMES)? };
        let layout = StateLayout::of(&spec);
        let scene_name = if self.stand_in {
            format!("stand-in colon: tube {} rings x {} spokes + rod of {} points", scene::RINGS, scene::SPOKES, scene::ROD_POINTS)
        } else {
            format!(
                "`lumen demo`'s colonoscopy (generated colon, seed 1: {} rings x 32 spokes, the scripted scope of 160 points, a wall that gives), frames {} to {}",
                spec.bodies[0].points(),
                COLONOSCOPY_FROM,
                COLONOSCOPY_FROM + FRAMES as u64 - 1
            )
        };
        let states = Arc::new(states);
        let n = self.frames.unwrap_or(if self.quick { 1500 } else { 10_000 });
        let mut runs = Vec::new();
        let plan = |t: Transport| -> Vec<(&'static str, Mode, Wire)> {
            let whole = Wire::default();
            let delta = Wire { deltas: true, link: None };
            match t {
                Transport::Iceoryx2 => vec![("back-to-back", Mode::BackToBack, whole), ("paced-1khz", Mode::Paced1kHz, whole)],
                Transport::Zenoh => vec![
                    ("back-to-back", Mode::BackToBack, whole),
                    ("back-to-back", Mode::BackToBack, delta),
                    ("paced-1khz", Mode::Paced1kHz, whole),
                    ("paced-1khz", Mode::Paced1kHz, delta),
                    ("paced-1khz, 1 Gbit/s link", Mode::Paced1kHz, Wire { link: Some(GIGABIT), ..whole }),
                    ("paced-1khz, 1 Gbit/s link", Mode::Paced1kHz, Wire { link: Some(GIGABIT), ..delta }),
                ],
            }
        };
        let total: usize = self.transports.iter().map(|&t| plan(t).len() + 1).sum();
        let bar = indicatif::ProgressBar::new((total * 2) as u64);
        bar.set_style(indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} {msg}").expect("template"));
        for &t in &self.transports {
            for (name, mode, wire) in plan(t) {
                bar.set_message(format!("{t} {name}{}", if wire.deltas { " delta" } else { "" }));
                let client = self.client(t)?;
                let think = if mode == Mode::BackToBack { self.think } else { Duration::ZERO };
                let (det, echo) = measure(&client, &spec, &states, mode, n, think, wire)?;
                bar.inc(2);
                runs.push(summarise(t, name, wire, det, echo));
            }
            // Four sessions as a client uses them by default: deltas over zenoh.
            let wire = Wire { deltas: t == Transport::Zenoh, link: None };
            bar.set_message(format!("{t} 4 sessions"));
            let (det, echo) = self.sessions(t, 4, &spec, &states, n / 2, wire)?;
            bar.inc(2);
            runs.push(summarise(t, "4-sessions", wire, det, echo));
        }
        bar.set_message("the machine's wake-up");
        let wake = wake::floor(n).map_err(CliError::WakeFloor)?;
        bar.set_message("ownership's work");
        // A reply of one contact a scope point (the scene's rod: its last body).
        let ownership = ownership::measure(&states[0], spec.bodies.len(), spec.bodies.last().map_or(0, |b| b.points()), n.min(1000));
        bar.finish_and_clear();
        drop(_daemon); // SIGTERM: it releases its shared memory
                       // The private prefix's node counter (iceoryx2 never removes it) and anything left.
        lumen_transport::shm::remove_prefix(&self.prefix);
        Ok(IpcReport {
            scene: format!("{scene_name}, interior contacts, precision 4"),
            floats_per_frame: layout.floats,
            quick: self.quick,
            think_us: self.think.as_micros() as u64,
            cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            runs,
            wake,
            ownership,
        })
    }

    /// `k` sessions at 1 kHz each at once, one client thread per session, each alternating
    /// with an echo session of its own in the same blocks ([`BLOCK`]): the detection and the echo
    /// of all `k` take turns together. Returns (detection, echo).
    fn sessions(&self, t: Transport, k: usize, spec: &SceneSpec, states: &Arc<Vec<Vec<f32>>>, frames: usize, wire: Wire) -> CliResult<(Samples, Samples)> {
        let start = Instant::now() + Duration::from_millis(300);
        let handles: Vec<_> = (0..k)
            .map(|_| {
                let (spec, states) = (spec.clone(), states.clone());
                let (prefix, endpoint) = (self.prefix.clone(), self.endpoint.clone());
                std::thread::spawn(move || -> Result<(Samples, Samples), ClientError> {
                    let me = IpcBench { quick: true, stand_in: false, frames: None, think: Duration::ZERO, transports: vec![], prefix, endpoint };
                    let client = me.client(t)?;
                    std::thread::sleep(start.saturating_duration_since(Instant::now()));
                    measure(&client, &spec, &states, Mode::Paced1kHz, frames, Duration::ZERO, wire)
                })
            })
            .collect();
        let (mut det, mut echo) = (Samples::default(), Samples::default());
        for h in handles {
            let (d, e) = h.join().map_err(|_| CliError::SessionThreadPanicked)??;
            det.merge(d);
            echo.merge(e);
        }
        Ok((det, echo))
    }
}

fn summarise(t: Transport, mode: &str, wire: Wire, mut det: Samples, mut echo: Samples) -> IpcRun {
    let mut bytes: Vec<u64> = std::mem::take(&mut det.wire_bytes);
    bytes.sort_unstable();
    IpcRun {
        frame: if wire.deltas { "delta" } else { "whole" }.into(),
        wire_bytes_p50: bytes.get(bytes.len() / 2).copied().unwrap_or(0) as f64,
        rate_hz: det.rate_hz.iter().fold(0.0, |a, b| a + b) / det.rate_hz.len().max(1) as f64,
        transport: t.to_string(),
        mode: mode.into(),
        p50_us: quantile_us(&mut det.rtt_ns, 0.5),
        p99_us: quantile_us(&mut det.rtt_ns, 0.99),
        p999_us: quantile_us(&mut det.rtt_ns, 0.999),
        echo_p50_us: quantile_us(&mut echo.rtt_ns, 0.5),
        echo_p99_us: quantile_us(&mut echo.rtt_ns, 0.99),
        echo_detect_max_us: echo.detect_ns.iter().copied().max().unwrap_or(0) as f64 / 1e3,
        detect_us: quantile_us(&mut det.detect_ns, 0.5),
        detect_p99_us: quantile_us(&mut det.detect_ns, 0.99),
        // Summed from 0.0: an empty float sum is -0.0, which the table would print as such.
        daemon_p50_us: det.daemon_p50_us.iter().fold(0.0, |a, b| a + b) / det.daemon_p50_us.len().max(1) as f64,
        frames: det.rtt_ns.len() as u64 + det.lost,
        lost_frames: det.lost,
    }
}

/// Frames precomputed; played forwards then backwards so the motion stays continuous.
const FRAMES: usize = 64;

/// The first frame of the colonoscopy the bench plays: mid-procedure, the scope deep in the
/// sigmoid and pressing the wall.
const COLONOSCOPY_FROM: u64 = 1500;

/// Frames `COLONOSCOPY_FROM ..` of `lumen demo`'s colonoscopy (the generated colon, the
/// scripted scope, the wall that gives), run in this process with the default detection.
fn colonoscopy(frames: usize) -> CliResult<(SceneSpec, Vec<Vec<f32>>)> {
    let colon = lumen_sim::setup::colon(lumen_scene::ColonKind::Generated, 1, None).map_err(|source| CliError::Colon { scene: "generated", source })?;
    let mut world = lumen_sim::World::in_process(&colon, lumen_sim::SimConfig::default())?;
    for _ in 1..COLONOSCOPY_FROM {
        world.step()?;
    }
    let mut states = Vec::with_capacity(frames);
    for _ in 0..frames {
        world.step()?;
        states.push(world.source().state().to_vec());
    }
    Ok((world.spec().clone(), states))
}

fn state_index(k: usize) -> usize {
    let p = k % (2 * FRAMES - 2);
    if p < FRAMES {
        p
    } else {
        2 * FRAMES - 2 - p
    }
}

/// Frames one session submits before the other takes its turn: the detection and the bare echo
/// are measured in alternating blocks of this many frames, so a change in the machine's load
/// (a shared VM's medians move by tens of percent from one minute to the next) falls on both alike and
/// `p50 - echo - detect` compares like with like.
const BLOCK: usize = 100;

/// Submits `frames` frames to a detecting session and as many to an echo session of the same
/// spec, in alternating blocks after a warm-up of each, waiting for each reply; paced, one frame
/// per millisecond whichever session it goes to; `think` spent busy before each frame.
/// Returns (detection, echo).
fn measure(client: &Client, spec: &SceneSpec, states: &[Vec<f32>], mode: Mode, frames: usize, think: Duration, wire: Wire) -> Result<(Samples, Samples), ClientError> {
    let mut sessions: [Session; 2] = [client.open_session(spec)?, client.open_echo_session(spec)?];
    for s in &mut sessions {
        s.set_deltas(wire.deltas);
        s.emulate_link(wire.link);
    }
    let mut measured_from: [Option<Instant>; 2] = [None; 2];
    let warm = (frames / 10).max(50);
    let mut out: [Samples; 2] = std::array::from_fn(|_| Samples { rtt_ns: Vec::with_capacity(frames), detect_ns: Vec::with_capacity(frames), ..Samples::default() });
    // Frames each session has submitted: its own sequence, so its scope moves continuously.
    let mut sent = [0usize; 2];
    let start = Instant::now();
    for tick in 0..2 * (warm + frames) {
        // Both warm up first; then blocks take turns, and whichever still has frames goes on.
        let turn = if tick < 2 * warm { tick / warm } else { (tick - 2 * warm) / BLOCK % 2 };
        let which = if sent[turn] < warm + frames { turn } else { 1 - turn };
        // Busy, as a physics step is: a sleep would measure the scheduler's wake-up instead.
        let worked = Instant::now();
        while worked.elapsed() < think {
            std::hint::spin_loop();
        }
        if mode == Mode::Paced1kHz {
            let due = start + Duration::from_micros(1000 * tick as u64);
            std::thread::sleep(due.saturating_duration_since(Instant::now()));
        }
        let (session, out, k) = (&mut sessions[which], &mut out[which], sent[which]);
        sent[which] += 1;
        session.frame()?.copy_from_slice(&states[state_index(k)]);
        let n = session.submit()?;
        let measured = k >= warm;
        if measured {
            measured_from[which].get_or_insert_with(Instant::now);
            out.wire_bytes.push(session.frame_counts().last_bytes);
        }
        loop {
            match session.contacts(Duration::from_secs(1)) {
                Ok(reply) if reply.frame() < n => continue, // a late answer to an earlier frame
                Ok(reply) => {
                    if !measured {
                        break;
                    }
                    if reply.frame() != n || reply.result().is_err() {
                        out.lost += 1;
                    } else {
                        out.rtt_ns.push(now_ns().saturating_sub(reply.header().client_time_ns));
                        out.detect_ns.push(reply.header().detect_ns as u64);
                        out.lost += reply.header().skipped as u64;
                    }
                    break;
                }
                Err(ClientError::Timeout(_)) => {
                    out.lost += measured as u64;
                    break;
                }
                Err(e) => return Err(e),
            }
        }
    }
    // The loop's rate over the measured frames of both sessions (they take turns on its
    // ticks): paced, 1,000 a second when the loop holds 1 kHz.
    if let Some(from) = measured_from.iter().flatten().min() {
        out[0].rate_hz.push((2 * frames) as f64 / from.elapsed().as_secs_f64().max(1e-9));
    }
    // The daemon keeps its last 1024 service times: all of them from the measured frames.
    let status = client.status()?;
    for (session, out) in sessions.iter().zip(out.iter_mut()) {
        if let Some(me) = status.sessions.iter().find(|x| x.session == session.id()) {
            out.daemon_p50_us.push(me.service.p50_us);
        }
    }
    let [det, echo] = out;
    Ok((det, echo))
}

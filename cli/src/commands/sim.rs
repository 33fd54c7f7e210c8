//! `lumen sim`: the colonoscopy physics (lumen-sim) as a separate process that gets its
//! contacts from the daemon, the way a lab's own engine would.
//!
//! stdout, for scripts (`lumen demo` reads it): first `session <id>` (so a recorder can
//! attach), then one JSON object per line: `{"type":"progress",...}` every `--progress-every`
//! frames and a final `{"type":"summary",...,"error":null}` ([`crate::figures::SimLine`]).
//! People's messages go to stderr. `--figures FILE` gets one JSON line per frame
//! ([`crate::figures::FrameRow`]).
//!
//! SIGINT / SIGTERM end the run after the current frame: the summary is printed, the session
//! closed, and the exit status is 130.

use super::transport::TransportArgs;
use crate::commands::{CliError, CliResult};
use crate::figures::{FrameRow, SimLine, Tally};
use clap::Args;
use lumen_scene::ColonKind;
use lumen_service::daemon::{block_termination_signals, wait_signal};
use lumen_sim::daemon::DaemonSource;
use lumen_sim::{setup, SimConfig, SimError, World};
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// The run's length and its colon: the same flags for `lumen sim` and `lumen demo`.
#[derive(Debug, Clone, Args)]
pub struct RunArgs {
    /// Frames to run (1 ms of simulated time each; the default script is 3,000).
    #[arg(long, default_value_t = 3000)]
    pub frames: u64,
    /// The colon: generated, its hard variants narrow (below the scope's diameter in the anal
    /// canal and the sigmoid), collapsed (a collapsed sigmoid segment), loop (a sigmoid that
    /// winds once around) and tight-bend (bends tighter than the lumen), gca, or insufflated (a
    /// generated surface whose lumen is wider than its bends, imported: `lumen generate`).
    #[arg(long, default_value = "generated")]
    pub scene: ColonKind,
    /// Directory of the GCA colon's files (default ../shared/data/colon-gca00090).
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Inflation of the GCA colon (`--scene gca`): its scan is collapsed; 1 is as scanned
    /// (narrower than the scope in places), 2 the default, 4 a lumen far wider than its flexures.
    #[arg(long, default_value_t = lumen_sim::setup::GCA_INFLATE)]
    pub inflate: f32,
    /// A colon model written by `lumen import` (native, or the text format when it ends in
    /// `.txt`), in mm; replaces --scene.
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// The scope's radius, mm (a 13 mm adult colonoscope: 6.5).
    #[arg(long, default_value_t = 6.5)]
    pub scope_radius: f64,
    /// The scope's insertion tube length, mm.
    #[arg(long, default_value_t = 1600.0)]
    pub scope_length: f64,
    /// The scope's flexural rigidity EI, N m^2 (adult colonoscopes: about 0.1 to 0.3).
    #[arg(long, default_value_t = 0.15)]
    pub scope_stiffness: f64,
}

impl RunArgs {
    /// What the run's colon is called in messages and reports: the scene, or the model file.
    pub fn colon_name(&self) -> String {
        match &self.model {
            Some(p) => format!("model {}", p.display()),
            None if self.scene == ColonKind::Gca && self.inflate != lumen_sim::setup::GCA_INFLATE => format!("gca inflated x{}", self.inflate),
            None => self.scene.name().into(),
        }
    }

    /// The colon: the model file when one is given (the error names it), else the scene.
    pub fn colon(&self, seed: u64) -> CliResult<lumen_detect::Tube> {
        if let Some(path) = &self.model {
            return setup::model_colon(path).map_err(|e| match e {
                setup::ModelFileError::Read(source) => CliError::FlagPath { flag: "--model", path: path.clone(), source },
                e => CliError::Model { path: path.clone(), message: e.to_string() },
            });
        }
        let colon = setup::colon_inflated(self.scene, seed, self.data.as_deref(), self.inflate).map_err(|source| CliError::Colon { scene: self.scene.name(), source })?;
        if self.scene == ColonKind::Gca {
            eprintln!("data: {}", lumen_scene::gca::attribution());
        }
        Ok(colon)
    }

    /// The simulation's configuration with the scope of the flags; each flag is checked.
    pub fn config(&self) -> CliResult<SimConfig> {
        for (flag, v) in [("--scope-radius", self.scope_radius), ("--scope-length", self.scope_length), ("--scope-stiffness", self.scope_stiffness)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(CliError::bad_flag(flag, v, "a positive number"));
            }
        }
        let mut c = SimConfig::default();
        c.rod.radius_mm = self.scope_radius;
        c.rod.length_mm = self.scope_length;
        c.rod.flexural_rigidity_nm2 = self.scope_stiffness;
        Ok(c)
    }

    /// The flags to give a `lumen sim` child for the same run (the colon and the scope).
    pub fn child_args(&self) -> Vec<std::ffi::OsString> {
        let mut a: Vec<std::ffi::OsString> = vec!["--scene".into(), self.scene.name().into()];
        a.extend(["--inflate".into(), self.inflate.to_string().into()]);
        if let Some(d) = &self.data {
            a.extend(["--data".into(), d.into()]);
        }
        if let Some(m) = &self.model {
            a.extend(["--model".into(), m.into()]);
        }
        for (flag, v) in [("--scope-radius", self.scope_radius), ("--scope-length", self.scope_length), ("--scope-stiffness", self.scope_stiffness)] {
            a.extend([flag.into(), v.to_string().into()]);
        }
        a
    }
}

/// Says where the lumen is narrower than the scope (the scope pushes the wall open there).
fn say_fit(colon: &lumen_detect::Tube, radius: f64) {
    let n = lumen_import::fit::narrowings(colon, radius);
    if n.is_empty() {
        return;
    }
    let shown: Vec<String> = n.iter().take(8).map(|x| format!("rings {}-{} (smallest spoke {:.1} mm)", x.rings.start(), x.rings.end(), x.smallest)).collect();
    let more = if n.len() > 8 { format!(" and {} more runs", n.len() - 8) } else { String::new() };
    eprintln!("lumen sim: the lumen is narrower than the scope (radius {radius} mm) at {}{more}; the scope pushes the wall open there", shown.join(", "));
}

#[derive(Debug, Args)]
pub struct SimArgs {
    #[command(flatten)]
    pub run: RunArgs,
    /// Seed of the generated colon.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[command(flatten)]
    pub transport: TransportArgs,
    /// Write each frame's figures here (JSON lines).
    #[arg(long, value_name = "FILE")]
    pub figures: Option<PathBuf>,
    /// A progress line on stdout every this many frames (0: none).
    #[arg(long, default_value_t = 100)]
    pub progress_every: u64,
    /// After the session line, wait for a line (or the end) on stdin before the first
    /// detection, so that a recorder can attach before anything is sent.
    #[arg(long)]
    pub hold: bool,
    /// Seconds to wait for each reply of the daemon.
    #[arg(long, default_value_t = 5.0)]
    pub reply_timeout: f64,
}

/// Exit status after SIGINT / SIGTERM (128 + SIGINT, as shells report it).
pub const INTERRUPTED: u8 = 130;

pub fn run(args: SimArgs) -> CliResult<std::process::ExitCode> {
    // Signals are taken between frames, so the session closes and the summary is printed.
    block_termination_signals();
    if !(args.reply_timeout > 0.0 && args.reply_timeout.is_finite()) {
        return Err(CliError::bad_flag("--reply-timeout", args.reply_timeout, "a positive number of seconds"));
    }
    let t0 = Instant::now();
    let config = args.run.config()?;
    let colon = args.run.colon(args.seed)?;
    eprintln!("lumen sim: {} colon, {} rings x {} spokes, built in {:.2?}", args.run.colon_name(), colon.rings(), colon.spokes, t0.elapsed());
    say_fit(&colon, config.rod.radius_mm);
    let spec = setup::scene_spec(&colon, &config.rod, &config.sim);
    let client = args.transport.client("lumen sim")?;
    let session = client.open_session(&spec)?;
    let mut out = std::io::stdout().lock();
    writeln!(out, "session {}", session.id()).and_then(|()| out.flush()).map_err(CliError::Stdout)?;
    if args.hold && !wait_for_go() {
        eprintln!("lumen sim: interrupted before the first frame");
        return Ok(std::process::ExitCode::from(INTERRUPTED));
    }
    let mut source = DaemonSource::new(session);
    source.timeout = Duration::from_secs_f64(args.reply_timeout);
    // A signal also ends a wait for the daemon (a reply, or a daemon that is away), not only
    // the loop between frames.
    source.interrupt = Some(|| wait_signal(Duration::ZERO));
    let mut world = World::new(&colon, config, source)?;
    eprintln!("lumen sim: scope fitted in {} detections; running {} frames over {}", world.fit_iterations(), args.run.frames, args.transport.transport());
    let figures_error = |source| CliError::FlagPath { flag: "--figures", path: args.figures.clone().unwrap_or_default(), source };
    let mut figures = match &args.figures {
        Some(p) => Some(BufWriter::new(std::fs::File::create(p).map_err(|source| CliError::FlagPath { flag: "--figures", path: p.clone(), source })?)),
        None => None,
    };
    let mut tally = Tally::new(args.run.frames);
    // The failure, or the signal's message; the summary line carries it as text.
    let mut failure: Option<CliError> = None;
    let mut interrupted: Option<String> = None;
    let start = Instant::now();
    for _ in 0..args.run.frames {
        if let Some(sig) = wait_signal(Duration::ZERO) {
            interrupted = Some(format!("interrupted by signal {sig} after {} frames", world.frame()));
            break;
        }
        let row = match world.step().cloned() {
            Ok(r) => FrameRow {
                frame: r.frame,
                physics_us: r.physics_s * 1e6,
                rtt_us: world.source().last_round_trip_us() as f64,
                detect_us: world.source().last_detect_us(),
                contacts: r.contacts,
                max_penetration_mm: r.max_penetration_mm,
                escaped: r.escaped,
                nan: false,
                wire_bytes: world.source().session().frame_counts().last_bytes,
            },
            Err(SimError::NonFinite { frame }) => {
                failure = Some(CliError::NonFinite { frame });
                FrameRow { frame, nan: true, ..FrameRow::default() }
            }
            Err(e) => {
                match world.source().interrupted() {
                    Some(sig) => interrupted = Some(format!("interrupted by signal {sig} after {} frames", world.frame())),
                    None => failure = Some(e.into()),
                }
                break;
            }
        };
        tally.add(&row);
        if let Some(f) = figures.as_mut() {
            serde_json::to_writer(&mut *f, &row)?;
            f.write_all(b"\n").map_err(figures_error)?;
        }
        if row.nan {
            break;
        }
        if args.progress_every > 0 && row.frame % args.progress_every == 0 {
            let line = serde_json::to_string(&SimLine::Progress(tally.figures(start.elapsed().as_secs_f64())))?;
            writeln!(out, "{line}").and_then(|()| out.flush()).map_err(CliError::Stdout)?;
        }
    }
    let wall_s = start.elapsed().as_secs_f64();
    if let Some(mut f) = figures {
        f.flush().map_err(figures_error)?;
    }
    let figures = tally.figures(wall_s);
    let error = interrupted.clone().or_else(|| failure.as_ref().map(ToString::to_string));
    let line = serde_json::to_string(&SimLine::Summary { figures: figures.clone(), error })?;
    writeln!(out, "{line}").and_then(|()| out.flush()).map_err(CliError::Stdout)?;
    eprintln!(
        "lumen sim: {} frames, {:.0} frames/s, round trip p50 {:.0} us p99 {:.0} us, contacts at most {}, max penetration {:.3} mm, escaped samples at most {}, NaN frames {}",
        figures.frames, figures.physics_fps, figures.rtt_p50_us, figures.rtt_p99_us, figures.contacts_max, figures.max_penetration_mm, figures.escaped_samples_max, figures.nan_frames
    );
    let sent = world.source().session().frame_counts();
    if sent.bytes > 0 {
        eprintln!(
            "lumen sim: frames on the wire: median {:.1} KiB, most {:.1} KiB ({} whole, {} as deltas)",
            figures.wire_bytes_p50 / 1024.0,
            figures.wire_bytes_max as f64 / 1024.0,
            sent.full,
            sent.delta
        );
    }
    match (interrupted, failure) {
        (Some(why), _) => {
            eprintln!("lumen sim: {why}");
            Ok(std::process::ExitCode::from(INTERRUPTED))
        }
        (None, Some(e)) => Err(e),
        (None, None) => Ok(std::process::ExitCode::SUCCESS),
    }
}

/// Waits for a line or the end of stdin, watching for SIGINT / SIGTERM; false if one came.
fn wait_for_go() -> bool {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = std::io::stdin().read_line(&mut line);
        let _ = tx.send(());
    });
    loop {
        if wait_signal(Duration::ZERO).is_some() {
            return false;
        }
        match rx.recv_timeout(Duration::from_millis(20)) {
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
            _ => return true,
        }
    }
}

//! `lumen demo`: the whole loop in one command. It starts the daemon (`lumen serve`, on a
//! fresh iceoryx2 prefix of its own), the physics client (`lumen sim`) and the recorder
//! (`lumen record`, into `run.mcap`) as separate processes of this same binary, shows the run's
//! progress, and writes a report: `report.md`, `summary.json`, `frames.jsonl` and SVG plots in
//! `--out`. The sim holds its first frame until the recorder observes its session, so the
//! recording starts with the run.
//!
//! The run is sound when no scope sample is outside the wall at the end of any frame, the
//! deepest penetration is at most [`MAX_PENETRATION_MM`] and no frame produced a NaN; the exit
//! status is 0 only then (the physics rate is reported, not judged).
//!
//! SIGINT / SIGTERM at any point are forwarded to the children, which are waited for; then
//! whatever the prefix left in /dev/shm is removed, and the exit status is 130.

use super::sim::RunArgs;
use super::transport::TransportArg;
use crate::commands::{CliError, CliResult};
use crate::demo_report::{self, Summary};
use crate::figures::{FrameRow, RunFigures, SimLine};
use crate::procs::{Next, Proc};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use lumen_service::daemon::{block_termination_signals, wait_signal};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::{Duration, Instant};

/// The deepest penetration a sound run may have, mm.
pub const MAX_PENETRATION_MM: f32 = 1.0;

#[derive(Debug, Args)]
pub struct DemoArgs {
    #[command(flatten)]
    pub run: RunArgs,
    /// How the physics talks to the daemon.
    #[arg(long, value_enum, default_value = "iceoryx2")]
    pub transport: TransportArg,
    /// Where the report goes.
    #[arg(long, default_value = "demo")]
    pub out: PathBuf,
    /// iceoryx2 prefix of the run (default: lumen_demo_<pid>_, which nothing else uses).
    #[arg(long)]
    pub prefix: Option<String>,
    /// Do not record the run (a recording holds every frame, as what changed since the one
    /// before: about 100 KB per frame for the scripted colonoscopy).
    #[arg(long)]
    pub no_record: bool,
    /// Record without the Foxglove scene channel (`lumen record --no-scene`).
    #[arg(long)]
    pub no_scene: bool,
    /// Watch the run in the browser: `lumen view` attached to the session (its address is
    /// printed before the run starts).
    #[arg(long)]
    pub view: bool,
    /// Where `--view` serves its page.
    #[arg(long, default_value = "127.0.0.1:7480", value_name = "ADDR")]
    pub view_listen: String,
    /// With `--view`: open the page in the system's browser.
    #[arg(long)]
    pub open: bool,
}

/// Why the demo stopped before its report.
enum Stop {
    Signal(i32),
    Failed(CliError),
}

impl From<CliError> for Stop {
    fn from(e: CliError) -> Self {
        Stop::Failed(e)
    }
}

pub fn run(args: DemoArgs) -> CliResult<ExitCode> {
    // Before any thread exists, so every thread has them blocked and they arrive in the loop.
    block_termination_signals();
    if args.run.frames == 0 {
        return Err(CliError::bad_flag("--frames", args.run.frames, "at least 1"));
    }
    // The scope's flags and a model file are checked here, before any process starts.
    args.run.config()?;
    if args.run.model.is_some() {
        args.run.colon(0)?;
    }
    std::fs::create_dir_all(&args.out).map_err(|source| CliError::FlagPath { flag: "--out", path: args.out.clone(), source })?;
    let prefix = args.prefix.clone().unwrap_or_else(|| format!("lumen_demo_{}_", std::process::id()));
    if !lumen_transport::shm::shm_files(&prefix).is_empty() {
        return Err(CliError::PrefixInUse { prefix });
    }
    println!("lumen demo: prefix {prefix}, pid {}, report in {}", std::process::id(), args.out.display());
    let mut run = Run { args: &args, prefix: &prefix, procs: Vec::new() };
    let outcome = run.go();
    // Children first (clients before the daemon), then the prefix's shared memory.
    let signal = match &outcome {
        Err(Stop::Signal(s)) => *s,
        _ => libc::SIGTERM,
    };
    for p in run.procs.iter_mut().rev() {
        p.stop(if p.name == "daemon" { libc::SIGTERM } else { signal }, Duration::from_secs(10));
    }
    run.procs.clear();
    let left = lumen_transport::shm::remove_prefix(&prefix);
    if !left.is_empty() {
        eprintln!("lumen demo: could not remove {}", left.join(", "));
    }
    match outcome {
        Ok(code) => Ok(code),
        Err(Stop::Signal(sig)) => {
            eprintln!("lumen demo: interrupted (signal {sig}); children stopped, prefix {prefix} cleaned");
            Ok(ExitCode::from(super::sim::INTERRUPTED))
        }
        Err(Stop::Failed(e)) => Err(e),
    }
}

struct Run<'a> {
    args: &'a DemoArgs,
    prefix: &'a str,
    /// Started in order: daemon, sim, then the recorder and the view when asked for.
    procs: Vec<Proc>,
}

impl Run<'_> {
    fn go(&mut self) -> Result<ExitCode, Stop> {
        let exe = std::env::current_exe().map_err(CliError::CurrentExe)?;
        let zenoh = (self.args.transport == TransportArg::Zenoh).then(|| format!("tcp/127.0.0.1:{}", crate::ipc::ipc::free_port()));

        let mut serve = Command::new(&exe);
        serve.args(["serve", "--log", "warn", "--prefix", self.prefix]);
        if let Some(ep) = &zenoh {
            serve.args(["--zenoh-listen", ep]);
        }
        self.procs.push(Proc::spawn("daemon", serve)?);
        self.expect_line(0, "lumen serve: ready", Duration::from_secs(30))?;

        let figures_path = self.args.out.join("frames.jsonl");
        let every = (self.args.run.frames / 50).clamp(1, 100);
        let mut sim = Command::new(&exe);
        sim.args(["sim", "--log", "warn", "--hold", "--prefix", self.prefix]).args(self.args.run.child_args());
        sim.arg("--frames").arg(self.args.run.frames.to_string()).arg("--progress-every").arg(every.to_string()).arg("--figures").arg(&figures_path);
        match &zenoh {
            Some(ep) => sim.args(["--transport", "zenoh", "--zenoh", ep]),
            None => sim.args(["--transport", "iceoryx2"]),
        };
        self.procs.push(Proc::spawn("sim", sim)?);
        // Building the GCA colon and fitting the scope take a while before the session opens.
        let session = self.expect_line(1, "session ", Duration::from_secs(180))?;
        let session = session.trim_start_matches("session ").trim().to_owned();
        println!("lumen demo: session {session}");
        if !self.args.no_record {
            let mut record = Command::new(&exe);
            record.args(["record", &session, "--log", "warn", "--prefix", self.prefix, "-o"]).arg(self.args.out.join("run.mcap"));
            if self.args.no_scene {
                record.arg("--no-scene");
            }
            if let Some(ep) = &zenoh {
                record.args(["--zenoh", ep]);
            }
            self.procs.push(Proc::spawn("recorder", record)?);
            self.expect_line(self.procs.len() - 1, "lumen record: recording session", Duration::from_secs(30))?;
        }
        if self.args.view {
            let mut view = Command::new(&exe);
            view.args(["view", &session, "--log", "warn", "--prefix", self.prefix, "--listen", &self.args.view_listen]);
            if let Some(ep) = &zenoh {
                view.args(["--zenoh", ep]);
            }
            if self.args.open {
                view.arg("--open");
            }
            self.procs.push(Proc::spawn("view", view)?);
            let line = self.expect_line(self.procs.len() - 1, "lumen view: serving", Duration::from_secs(30))?;
            println!("{line} (the run, live)");
        }
        // Released: the run starts.
        self.procs[1].send_line("go")?;

        let t0 = Instant::now();
        let (last, sim_status) = self.follow_sim()?;
        let wall_s = t0.elapsed().as_secs_f64();
        let (figures, error) = match last {
            Some(SimLine::Summary { figures, error }) => (figures, error),
            _ => (RunFigures::default(), Some(format!("lumen sim ended ({}) without a summary", sim_status.map_or("killed".into(), |s| s.to_string())))),
        };
        self.finish(&figures, error, &figures_path, wall_s)
    }

    /// Waits for a stdout line of child `i` starting with `start`, watching for signals and
    /// for the child's end.
    fn expect_line(&mut self, i: usize, start: &str, limit: Duration) -> Result<String, Stop> {
        let end = Instant::now() + limit;
        loop {
            if let Some(sig) = wait_signal(Duration::ZERO) {
                return Err(Stop::Signal(sig));
            }
            let p = &mut self.procs[i];
            match p.line(Duration::from_millis(50)) {
                Next::Line(l) if l.starts_with(start) => return Ok(l),
                Next::Line(_) | Next::Waiting => {}
                Next::Closed => {
                    let status = p.wait(Duration::from_secs(5)).map_or("killed".into(), |s| s.to_string());
                    return Err(Stop::Failed(CliError::ChildEnded { name: p.name, status, expected: start.to_owned() }));
                }
            }
            if Instant::now() > end {
                return Err(Stop::Failed(CliError::ChildSilent { name: self.procs[i].name, expected: start.to_owned(), limit }));
            }
        }
    }

    /// Shows the sim's progress until it ends; returns its last line and exit status.
    fn follow_sim(&mut self) -> Result<(Option<SimLine>, Option<std::process::ExitStatus>), Stop> {
        let bar = ProgressBar::new(self.args.run.frames);
        bar.set_style(ProgressStyle::with_template("{bar:30} {pos}/{len} frames {msg}").expect("template"));
        let mut last = None;
        loop {
            if let Some(sig) = wait_signal(Duration::ZERO) {
                bar.abandon();
                return Err(Stop::Signal(sig));
            }
            match self.procs[1].line(Duration::from_millis(50)) {
                Next::Line(l) => match serde_json::from_str::<SimLine>(&l) {
                    Ok(SimLine::Progress(f)) => {
                        bar.set_position(f.frames);
                        bar.set_message(progress_message(&f));
                    }
                    Ok(s @ SimLine::Summary { .. }) => last = Some(s),
                    Err(_) => eprintln!("lumen sim: {l}"),
                },
                Next::Waiting => {}
                Next::Closed => break,
            }
        }
        if let Some(SimLine::Summary { figures, .. }) = &last {
            bar.set_position(figures.frames);
            bar.set_message(progress_message(figures));
        }
        bar.finish();
        let status = self.procs[1].wait(Duration::from_secs(10));
        Ok((last, status))
    }

    /// Waits for the recorder to finish (it ends with the session), stops the daemon, writes
    /// the report, judges the run.
    fn finish(&mut self, figures: &RunFigures, error: Option<String>, figures_path: &Path, wall_s: f64) -> Result<ExitCode, Stop> {
        let recording = self.finish_recorder();
        for p in self.procs.iter_mut().rev() {
            p.stop(libc::SIGTERM, Duration::from_secs(10));
        }
        let rows = read_rows(figures_path)?;
        let mut summary = Summary::new(&self.args.run.colon_name(), self.args.transport, figures, error, wall_s, MAX_PENETRATION_MM);
        summary.recording = recording;
        demo_report::write(&self.args.out, &summary, &rows).map_err(|e| CliError::Report { dir: self.args.out.clone(), source: Box::new(e) })?;
        println!("{}", summary.text());
        println!("lumen demo: report in {}", self.args.out.join("report.md").display());
        if summary.failures.is_empty() {
            Ok(ExitCode::SUCCESS)
        } else {
            eprintln!("lumen demo: the run was not sound: {}", summary.failures.join("; "));
            Ok(ExitCode::FAILURE)
        }
    }
}

impl Run<'_> {
    /// The recorder's last line once it has finished its file (it ends when the session does;
    /// SIGINT after 10 s); `None` without a recorder.
    fn finish_recorder(&mut self) -> Option<String> {
        let rec = self.procs.iter_mut().find(|p| p.name == "recorder")?;
        let start = Instant::now();
        let (mut last, mut signalled) = (None, false);
        loop {
            match rec.line(Duration::from_millis(50)) {
                Next::Line(l) => last = Some(l),
                Next::Closed => break,
                Next::Waiting => {
                    let t = start.elapsed();
                    if t > Duration::from_secs(10) && !signalled {
                        rec.signal(libc::SIGINT);
                        signalled = true;
                    }
                    if t > Duration::from_secs(20) {
                        break;
                    }
                }
            }
        }
        let status = rec.wait(Duration::from_secs(10));
        match (last, status) {
            (Some(l), Some(s)) if s.success() => Some(l.trim_start_matches("lumen record: ").to_owned()),
            (l, s) => Some(format!("the recorder failed ({}){}", s.map_or("killed".into(), |s| s.to_string()), l.map_or(String::new(), |l| format!(": {l}")))),
        }
    }
}

fn progress_message(f: &RunFigures) -> String {
    format!(
        "| {:.0} frames/s | rtt p50 {:.0} us p99 {:.0} us | contacts {} | max pen {:.3} mm | escaped {}",
        f.physics_fps, f.rtt_p50_us, f.rtt_p99_us, f.contacts, f.max_penetration_mm, f.escaped_samples_max
    )
}

/// The per-frame figures `lumen sim` wrote.
fn read_rows(path: &Path) -> CliResult<Vec<FrameRow>> {
    let text = std::fs::read_to_string(path).map_err(|source| CliError::Read { path: path.to_owned(), source })?;
    text.lines().enumerate().map(|(i, l)| serde_json::from_str(l).map_err(|source| CliError::FigureLine { path: path.to_owned(), line: i + 1, source })).collect()
}

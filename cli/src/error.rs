//! The `lumen` command line's one error type: what stopped a subcommand, for people, with its
//! source kept.

use crate::recording::{RecordingError, ReplyDifference};
use std::path::PathBuf;
use std::time::Duration;

/// An error of any subcommand.
pub type CliResult<T = ()> = Result<T, CliError>;

/// Why a subcommand stopped. The errors of the crates below are kept whole (their text is
/// shown as it is); what only the command line knows names what was wrong.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// A flag's value is not allowed.
    #[error("{flag} {value}: expected {expected}")]
    BadFlag { flag: String, value: String, expected: String },
    /// `lumen bench ipc --only` names no transport.
    #[error("unknown transport {name:?}: use iceoryx2 or zenoh")]
    UnknownTransport { name: String },
    /// The daemon's configuration.
    #[error(transparent)]
    Config(#[from] lumen_service::config::ConfigError),
    /// The daemon could not run.
    #[error(transparent)]
    Daemon(#[from] lumen_service::DaemonError),
    /// zenoh, outside a daemon or a client (`lumen router`).
    #[error(transparent)]
    Transport(#[from] lumen_transport::TransportError),
    /// Talking to the daemon.
    #[error(transparent)]
    Client(#[from] lumen_client::Error),
    /// Reading a surface or a midline, or building a tube.
    #[error(transparent)]
    Import(#[from] lumen_import::ImportError),
    /// `lumen import` built a model that is not a usable tube (the problems were printed).
    #[error("{}: not a usable tube ({problems} problem(s) above); nothing written (--force writes it anyway)", mesh.display())]
    ImportRefused { mesh: PathBuf, problems: usize },
    /// A model file given with --model could not be read as a colon.
    #[error("--model {}: {message}", path.display())]
    Model { path: PathBuf, message: String },
    /// The colon of `lumen sim` could not be had.
    #[error("the {scene} colon: {source}")]
    Colon { scene: &'static str, source: lumen_scene::gca::GcaError },
    /// The physics failed.
    #[error(transparent)]
    Sim(#[from] lumen_sim::SimError),
    /// A frame of the physics produced a NaN.
    #[error("frame {frame} produced a non-finite value (NaN)")]
    NonFinite { frame: u64 },
    /// `lumen bench detect`.
    #[error(transparent)]
    Bench(#[from] lumen_bench::Error),
    /// Writing or reading a recording.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// The live view's server.
    #[error(transparent)]
    View(#[from] lumen_view::ViewError),
    /// Writing JSON.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// A file or folder named by a flag could not be created or written.
    #[error("{flag} {}: {source}", path.display())]
    FlagPath { flag: &'static str, path: PathBuf, source: std::io::Error },
    /// A file could not be written.
    #[error("{}: {source}", path.display())]
    Write { path: PathBuf, source: std::io::Error },
    /// A file could not be read.
    #[error("reading {}: {source}", path.display())]
    Read { path: PathBuf, source: std::io::Error },
    /// A line of a per-frame figures file is not a frame's figures.
    #[error("{} line {line}: {source}", path.display())]
    FigureLine { path: PathBuf, line: usize, source: serde_json::Error },
    /// stdout is gone (a closed pipe).
    #[error("writing to stdout: {0}")]
    Stdout(#[source] std::io::Error),
    /// The iceoryx2 prefix of a demo is taken.
    #[error("iceoryx2 prefix {prefix:?} is in use (files in /dev/shm); choose another --prefix")]
    PrefixInUse { prefix: String },
    /// This binary's own path (to start its children).
    #[error("finding this executable: {0}")]
    CurrentExe(#[source] std::io::Error),
    /// A child process could not be started.
    #[error("starting the {name}: {source}")]
    Spawn { name: &'static str, source: std::io::Error },
    /// A child's stdin is closed.
    #[error("the {name}'s stdin is closed")]
    StdinClosed { name: &'static str },
    /// Writing to a child's stdin.
    #[error("writing to the {name}: {source}")]
    ChildStdin { name: &'static str, source: std::io::Error },
    /// A child ended before the line it was waited on for.
    #[error("the {name} ended ({status}) before saying {expected:?}; its messages are above")]
    ChildEnded { name: &'static str, status: String, expected: String },
    /// A child did not say a line in time.
    #[error("the {name} did not say {expected:?} within {limit:?}")]
    ChildSilent { name: &'static str, expected: String, limit: Duration },
    /// The daemon of `lumen bench ipc` could not be started.
    #[error("starting {}: {source}", exe.display())]
    StartDaemon { exe: PathBuf, source: std::io::Error },
    /// The daemon of `lumen bench ipc` did not say it was ready.
    #[error("the daemon did not get ready within {} s", limit.as_secs())]
    DaemonNotReady { limit: Duration },
    /// A thread of this process could not be started.
    #[error("starting the {name} thread: {source}")]
    ThreadSpawn { name: &'static str, source: std::io::Error },
    /// A thread of this process panicked (its message is above).
    #[error("the {name} thread panicked")]
    ThreadPanicked { name: &'static str },
    /// A client thread of `lumen bench ipc` panicked.
    #[error("a session thread panicked")]
    SessionThreadPanicked,
    /// Measuring the machine's wake-up floor.
    #[error("measuring the wake-up floor: {0}")]
    WakeFloor(#[source] std::io::Error),
    /// Drawing a plot of `lumen demo`.
    #[error("plotting {plot}: {source}")]
    Plot { plot: &'static str, source: plotters::drawing::DrawingAreaErrorKind<std::io::Error> },
    /// `lumen demo`'s report could not be written.
    #[error("writing the report in {}: {source}", dir.display())]
    Report { dir: PathBuf, source: Box<CliError> },
    /// The daemon did not answer a replayed frame.
    #[error("no reply to frame {frame} within {timeout:?}")]
    NoReply { frame: u64, timeout: Duration },
    /// `lumen replay --check`: replies differ from the recorded ones.
    #[error("{differed} of {frames} replies differ from {} (first at frame {frame}: {source})", path.display())]
    RepliesDiffer { differed: u64, frames: u64, path: PathBuf, frame: u64, source: ReplyDifference },
}

impl CliError {
    /// A flag's value that is not allowed, and what would be.
    pub fn bad_flag(flag: impl Into<String>, value: impl ToString, expected: impl Into<String>) -> Self {
        CliError::BadFlag { flag: flag.into(), value: value.to_string(), expected: expected.into() }
    }
}

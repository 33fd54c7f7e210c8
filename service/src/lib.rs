//! The Lumen daemon (`lumen serve`) and the `lumen` command line.
//!
//! - [`config`]: the TOML configuration and its limits.
//! - [`daemon`]: starts the transports over one [`registry`], stops on SIGINT/SIGTERM.
//! - [`local`] (iceoryx2) and [`remote`] (zenoh): the transports.
//! - [`control`]: open / describe / close / status, the same on both.
//! - [`engine`]: one session's frame processing (check, detect, reply).
//! - [`stats`]: per-session figures for `lumen status`.
//! - [`bench`]: `lumen bench ipc`.
//! - [`figures`]: the per-frame and run figures `lumen sim` writes and `lumen demo` reads.
//! - [`demo_report`]: `lumen demo`'s summary, report and plots; [`procs`]: its child processes.
//! - [`recording`]: MCAP recordings of a session (`lumen record`, `lumen replay`).
//! - [`cli`]: the subcommands, one module each.

pub mod bench;
pub mod cli;
pub mod config;
pub mod control;
pub mod daemon;
pub mod demo_report;
pub mod engine;
pub mod figures;
pub mod local;
pub mod procs;
pub mod recording;
pub mod registry;
pub mod remote;
pub mod stats;

pub use config::ServeConfig;
pub use daemon::{Daemon, DaemonError, Running};

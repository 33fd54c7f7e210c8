//! The `lumen` command line over Lumen's crates: it composes the daemon (`lumen-service`), the
//! client (`lumen-client`), the physics (`lumen-sim`), the scenes and import, and the
//! benchmarks, and holds what only a person at a terminal needs: progress bars, reports,
//! plots and recordings.
//!
//! - [`commands`]: the subcommands, one module each.
//! - [`ipc`]: `lumen bench ipc` (round trips over both transports against a bare echo and the
//!   machine's own wake-up floor).
//! - [`figures`]: the per-frame and run figures `lumen sim` writes and `lumen demo` reads.
//! - [`demo_report`]: `lumen demo`'s summary, report and plots; [`procs`]: its child processes.
//! - [`error`]: [`CliError`], the one error type of every subcommand.
//! - [`foxglove`]: a recording's `/lumen/scene` channel, Foxglove's `foxglove.SceneUpdate`.
//! - [`recording`]: MCAP recordings of a session (`lumen record`, `lumen replay`);
//!   [`playback`]: a recording held for `lumen view run.mcap`, any frame in any order.

pub mod commands;
pub mod demo_report;
pub mod error;
pub mod figures;
pub mod foxglove;
pub mod ipc;
pub mod playback;
pub mod procs;
pub mod recording;

pub use error::{CliError, CliResult};

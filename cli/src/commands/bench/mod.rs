//! `lumen bench ...`: one module per benchmark.

pub mod ipc;
pub mod sessions;

use super::CliResult;
use clap::Subcommand;

#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// Speed against error of the collision methods (thesis, default, parry) over precisions,
    /// spokes and scenes; writes report.md, report.json and speed_vs_error.svg.
    // Boxed: its many flags would make every `BenchCommand` as large.
    Detect(Box<lumen_bench::cli::DetectArgs>),
    /// Round trip frame -> contacts over iceoryx2 and zenoh, against a bare echo.
    Ipc(ipc::IpcArgs),
    /// Sessions opened, sent a frame and closed, over and over: the daemon's and the client's
    /// resident memory as they go, and the cycles a second.
    Sessions(sessions::SessionsArgs),
}

impl BenchCommand {
    pub fn run(self) -> CliResult {
        match self {
            BenchCommand::Detect(a) => Ok(a.run().map(|_| ())?),
            BenchCommand::Ipc(a) => ipc::run(a),
            BenchCommand::Sessions(a) => sessions::run(a),
        }
    }
}

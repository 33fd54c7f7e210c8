//! `lumen bench ...`: one module per benchmark.

pub mod ipc;

use super::CliResult;
use clap::Subcommand;

#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// Round trip frame -> contacts over iceoryx2 and zenoh, against a bare echo.
    Ipc(ipc::IpcArgs),
}

impl BenchCommand {
    pub fn run(self) -> CliResult {
        match self {
            BenchCommand::Ipc(a) => ipc::run(a),
        }
    }
}

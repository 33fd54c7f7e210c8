//! The `lumen` command line: one module per subcommand.

pub mod bench;
pub mod certs;
pub mod demo;
pub mod generate;
pub mod import;
pub mod record;
pub mod replay;
pub mod router;
pub mod serve;
pub mod sim;
pub mod status;
pub mod transport;
pub mod view;

pub use crate::error::{CliError, CliResult};
use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Lumen: collision detection for colonoscopy simulators.
#[derive(Debug, Parser)]
#[command(name = "lumen", version, about)]
pub struct Cli {
    /// Log filter (e.g. `info`, `lumen_service=debug`); also `RUST_LOG`.
    #[arg(long, global = true, default_value = "info")]
    pub log: String,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the daemon (iceoryx2 on this machine, zenoh across machines).
    Serve(serve::ServeArgs),
    /// A zenoh router alone: daemons on several machines connect to it, clients too.
    Router(router::RouterArgs),
    /// List the daemon's sessions with frame rates, latencies and contact counts.
    Status(status::StatusArgs),
    /// Build a tube model from a triangle surface and its midline (ray casts per ring).
    Import(import::ImportArgs),
    /// Write a seeded insufflated colon (surface and midline) for `lumen import`: lumens wider
    /// than their bends, elliptical, with deep folds and a canal narrower than a scope.
    Generate(generate::GenerateArgs),
    /// Run the colonoscopy physics against the daemon, as a lab's own engine would.
    Sim(sim::SimArgs),
    /// The whole loop in one command: daemon, physics and recorder, a progress bar, a report.
    Demo(demo::DemoArgs),
    /// Record a session's frames and contacts to an MCAP file until it ends or Ctrl-C.
    Record(record::RecordArgs),
    /// Play a recording back as a new session and compare the contacts with the recorded ones.
    Replay(replay::ReplayArgs),
    /// A session (or a recording) in the browser: the wall, the scope and the contacts, live.
    View(view::ViewArgs),
    /// A lab's certificate authority and its daemons' and clients' certificates (mutual TLS).
    Certs(certs::CertsArgs),
    /// Benchmarks.
    #[command(subcommand)]
    Bench(bench::BenchCommand),
}

impl Cli {
    /// Runs the chosen subcommand.
    pub fn run(self) -> ExitCode {
        init_logging(&self.log);
        let done = |r: CliResult| r.map(|()| ExitCode::SUCCESS);
        let result = match self.command {
            Command::Serve(a) => done(serve::run(a)),
            Command::Router(a) => done(router::run(a)),
            Command::Status(a) => done(status::run(a)),
            Command::Import(a) => done(import::run(a)),
            Command::Generate(a) => done(generate::run(a)),
            Command::Sim(a) => sim::run(a),
            Command::Demo(a) => demo::run(a),
            Command::Record(a) => done(record::run(a)),
            Command::Replay(a) => done(replay::run(a)),
            Command::View(a) => done(view::run(a)),
            Command::Certs(a) => done(certs::run(a)),
            Command::Bench(b) => done(b.run()),
        };
        match result {
            Ok(code) => code,
            Err(e) => {
                eprintln!("lumen: {e}");
                ExitCode::FAILURE
            }
        }
    }
}

fn init_logging(filter: &str) {
    let filter = std::env::var("RUST_LOG").unwrap_or_else(|_| format!("{filter},zenoh=warn"));
    let _ = tracing_subscriber::fmt().with_env_filter(tracing_subscriber::EnvFilter::new(filter)).with_writer(std::io::stderr).try_init();
}

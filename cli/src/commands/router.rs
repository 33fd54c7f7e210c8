//! `lumen router`: a zenoh router alone, for a lab whose daemons run on several machines. Each
//! `lumen serve --zenoh-connect` to it, clients connect to it, and every daemon on it answers;
//! a client opens on the least loaded daemon or the one it names (`proto/README.md`, section 1).

use super::CliResult;
use clap::Args;
use lumen_service::daemon::{block_termination_signals, wait_signal};
use std::io::Write;
use std::time::Duration;

#[derive(Debug, Args)]
pub struct RouterArgs {
    /// Listen here (repeatable), e.g. tcp/0.0.0.0:7447.
    #[arg(long, value_name = "ENDPOINT", required = true)]
    pub listen: Vec<String>,
    /// Connect to other routers (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Vec<String>,
}

pub fn run(args: RouterArgs) -> CliResult {
    block_termination_signals();
    let router = lumen_transport::net::open_router(&args.listen, &args.connect)?;
    // One line on stdout when routing: scripts and tests wait for it.
    println!("lumen router: ready, pid {}, listening on {:?}", std::process::id(), args.listen);
    let _ = std::io::stdout().flush();
    while wait_signal(Duration::from_millis(500)).is_none() {}
    drop(router);
    println!("lumen router: stopped");
    Ok(())
}

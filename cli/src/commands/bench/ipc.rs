//! `lumen bench ipc [--quick] [--out DIR]`.

use crate::commands::{CliError, CliResult};
use crate::ipc::ipc::{IpcBench, IpcReport};
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct IpcArgs {
    /// Fewer frames: finishes in well under a minute.
    #[arg(long)]
    pub quick: bool,
    /// Where to write ipc.json and ipc.md.
    #[arg(long, default_value = "bench-out")]
    pub out: PathBuf,
    /// Only this transport (iceoryx2 or zenoh).
    #[arg(long)]
    pub only: Option<String>,
    /// Use the analytic colon-sized stand-in instead of lumen-scene's generated colonoscopy.
    #[arg(long)]
    pub stand_in: bool,
    /// Frames per measurement (default 1,500 with --quick, else 10,000; at least 10).
    #[arg(long, value_parser = clap::value_parser!(u32).range(10..))]
    pub frames: Option<u32>,
    /// Back to back, the client works this many microseconds (busy) between a reply and its
    /// next frame, as a physics step would (default 0: it submits at once).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u64).range(0..=100_000))]
    pub think_us: u64,
    /// The iceoryx2 `global.prefix` of the daemon the bench starts (default: one of its own,
    /// `lumen_bench_<pid>_`); its files are removed at the end, so give one no other daemon uses.
    #[arg(long)]
    pub prefix: Option<String>,
    /// The zenoh endpoint the bench's daemon listens on and its clients connect to (default: a
    /// free loopback port, `tcp/127.0.0.1:<port>`).
    #[arg(long, value_name = "ENDPOINT")]
    pub zenoh_listen: Option<String>,
}

pub fn run(args: IpcArgs) -> CliResult {
    let mut bench = IpcBench::new(args.quick, args.only.as_deref())?;
    if let Some(prefix) = args.prefix {
        bench.prefix = prefix;
    }
    if let Some(endpoint) = args.zenoh_listen {
        bench.endpoint = endpoint;
    }
    bench.stand_in = args.stand_in;
    bench.frames = args.frames.map(|n| n as usize);
    bench.think = std::time::Duration::from_micros(args.think_us);
    let report: IpcReport = bench.run()?;
    std::fs::create_dir_all(&args.out).map_err(|source| CliError::FlagPath { flag: "--out", path: args.out.clone(), source })?;
    let write = |name: &str, text: &str| std::fs::write(args.out.join(name), text).map_err(|source| CliError::Write { path: args.out.join(name), source });
    write("ipc.json", &serde_json::to_string_pretty(&report)?)?;
    let md = report.markdown();
    write("ipc.md", &md)?;
    print!("{md}");
    eprintln!("wrote {} and {}", args.out.join("ipc.json").display(), args.out.join("ipc.md").display());
    Ok(())
}

//! Standalone `lumen bench detect` (the same flags; `--help` lists them):
//!
//! ```sh
//! cargo run --release -p lumen-bench -- --quick --out bench-out
//! cargo run --release -p lumen-bench -- --scene generated --out bench-out
//! ```

use clap::Parser;
use lumen_bench::cli::DetectArgs;
use std::process::ExitCode;

/// lumen-bench: speed against error of Lumen's collision methods (thesis, default, parry).
#[derive(Parser)]
#[command(name = "lumen-bench", version, about)]
struct Cmd {
    #[command(flatten)]
    args: DetectArgs,
}

fn main() -> ExitCode {
    match Cmd::parse().args.run() {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("lumen-bench: {e}");
            ExitCode::FAILURE
        }
    }
}

use clap::Parser;
use lumen_service::cli::Cli;

fn main() -> std::process::ExitCode {
    Cli::parse().run()
}

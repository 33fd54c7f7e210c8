use clap::Parser;
use lumen_cli::commands::Cli;

fn main() -> std::process::ExitCode {
    Cli::parse().run()
}

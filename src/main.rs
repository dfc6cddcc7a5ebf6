//! `mrmm`: one command line for the central node, robot peers, the operator and the demo.

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    let filter = tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(args.default_log_filter()));
    tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).init();
    // Bounded by role, not by the cores (Zenoh reads its part when it first starts a runtime).
    let threads = args.threads();
    threads.configure_zenoh();
    let rt = match threads.runtime() {
        Ok(rt) => rt,
        Err(e) => {
            eprintln!("mrmm: cannot start the runtime: {e}");
            return ExitCode::FAILURE;
        }
    };
    match rt.block_on(cli::run(args)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("mrmm: {e:#}");
            ExitCode::FAILURE
        }
    }
}

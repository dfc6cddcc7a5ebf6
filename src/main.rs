//! `mrmm`: one command line for the central node, robot peers, the operator and the demo.
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

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
            eprintln!("mrmm: {}", one_line(&e));
            ExitCode::FAILURE
        }
    }
}

/// An error and its sources on one line (`a: b: c`), each source said once: our errors keep
/// their sources and also name them in their own message, so a source already said is skipped.
fn one_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

#[cfg(test)]
mod tests {
    use super::one_line;

    #[test]
    fn an_error_and_its_sources_are_one_line_each_said_once() {
        let io = std::io::Error::other("address in use");
        let ours = mrmm_proto::ProtoError::zenoh(io);
        assert_eq!(ours.to_string(), "zenoh: address in use");
        assert!(std::error::Error::source(&ours).is_some(), "the source is kept");
        let e = anyhow::Error::new(ours).context("central: cannot start");
        assert_eq!(one_line(&e), "central: cannot start: zenoh: address in use");
    }
}

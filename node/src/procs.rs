//! Nodes as child processes of this `mrmm` (the demo's fleet, the experiments'): spawned with
//! their logs in files, waited for until their ready line, stopped gracefully.

use std::path::Path;
use std::process::Stdio;
use std::time::Duration;

use tokio::io::{AsyncBufReadExt, BufReader};
use tokio::process::{Child, Command};

use crate::error::ProcError;

/// Spawns `mrmm <args>` with stderr to `log`; the child dies with us (PR_SET_PDEATHSIG).
pub fn spawn(args: &[String], log: &Path) -> Result<Child, ProcError> {
    let exe = std::env::current_exe().map_err(ProcError::NoExe)?;
    let log_file = std::fs::File::create(log).map_err(|source| ProcError::Log { path: log.to_path_buf(), source })?;
    let mut cmd = Command::new(exe);
    cmd.args(args).stdin(Stdio::null()).stdout(Stdio::piped()).stderr(log_file).kill_on_drop(true);
    // SAFETY: prctl is async-signal-safe; it only sets the parent-death signal of the child.
    unsafe {
        cmd.pre_exec(|| {
            libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM);
            Ok(())
        });
    }
    cmd.spawn().map_err(ProcError::Spawn)
}

/// Waits for the child's stdout line starting with `prefix` and returns it; the rest of its
/// stdout is drained in the background.
pub async fn ready_line(child: &mut Child, prefix: &str, timeout: Duration, log: &Path) -> Result<String, ProcError> {
    let out = child.stdout.take().ok_or(ProcError::NoStdout)?;
    let mut lines = BufReader::new(out).lines();
    let found = tokio::time::timeout(timeout, async {
        while let Some(line) = lines.next_line().await? {
            if line.starts_with(prefix) {
                return Ok::<_, std::io::Error>(Some(line));
            }
        }
        Ok(None)
    })
    .await;
    let tail = || std::fs::read_to_string(log).unwrap_or_default().lines().last().unwrap_or("").to_string();
    match found {
        Ok(Ok(Some(line))) => {
            drain(lines);
            Ok(line)
        }
        Ok(Ok(None)) | Ok(Err(_)) => Err(ProcError::Exited(tail())),
        Err(_) => Err(ProcError::NotReady(timeout.as_secs(), tail())),
    }
}

/// Reads the child's stdout in the background (its lines are not needed: a full pipe would
/// block it).
pub fn drain_stdout(child: &mut Child) {
    if let Some(out) = child.stdout.take() {
        drain(BufReader::new(out).lines());
    }
}

/// Reads the rest of `lines` in the background.
fn drain(mut lines: tokio::io::Lines<BufReader<tokio::process::ChildStdout>>) {
    tokio::spawn(async move { while let Ok(Some(_)) = lines.next_line().await {} });
}

/// The value of `key=` in a ready line.
pub fn field<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    line.split_whitespace().find_map(|w| w.strip_prefix(key)?.strip_prefix('='))
}

/// SIGTERM every child, then wait up to `grace` for each before killing it.
pub async fn stop_all(children: &mut [Child], grace: Duration) {
    for c in children.iter() {
        if let Some(pid) = c.id() {
            // SAFETY: sending a signal to our own child's pid.
            unsafe {
                libc::kill(pid as libc::pid_t, libc::SIGTERM);
            }
        }
    }
    for c in children.iter_mut() {
        if tokio::time::timeout(grace, c.wait()).await.is_err() {
            let _ = c.kill().await;
        }
    }
}

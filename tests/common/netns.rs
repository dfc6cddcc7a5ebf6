//! Network namespaces made by a test, and the helpers the namespace tests share: `ip`, operator
//! queries and taps run inside a namespace, and waiting on what they show.

use std::process::Command;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context};
use serde_json::Value;

use super::{start_lines, Proc, Scratch, EXE};

/// Runs `ip ARGS`; its stderr is the error.
pub fn ip(args: &[&str]) -> anyhow::Result<()> {
    let out = Command::new("ip").args(args).output().context("run ip")?;
    if !out.status.success() {
        bail!("ip {}: {}", args.join(" "), String::from_utf8_lossy(&out.stderr).trim());
    }
    Ok(())
}

/// `make()`'s namespaces, or `None` (said) where they cannot be made — a failure under `CI=true`
/// (CI runs as root and must run test `name`).
pub fn namespaces<N>(name: &str, make: impl FnOnce() -> anyhow::Result<N>) -> anyhow::Result<Option<N>> {
    match make() {
        Ok(n) => Ok(Some(n)),
        Err(e) if std::env::var("CI").is_ok_and(|v| v == "true") => {
            bail!("cannot create network namespaces under CI ({e}): CI runs as root and must run {name}")
        }
        Err(e) => {
            println!("SKIPPED {name}: cannot create network namespaces here ({e}); run as root to test partitions");
            Ok(None)
        }
    }
}

/// `mrmm op --json <what>` run in namespace `ns` against `central`.
pub fn op<T: serde::de::DeserializeOwned>(ns: &str, central: &str, what: &[&str]) -> anyhow::Result<T> {
    let out = Command::new("ip").args(["netns", "exec", ns, EXE, "op", "--connect", central, "--json", "--timeout-ms", "8000"]).args(what).output()?;
    ensure!(out.status.success(), "op {what:?}: {}", String::from_utf8_lossy(&out.stderr).trim());
    Ok(serde_json::from_slice(&out.stdout)?)
}

/// Polls `f` every 200 ms until it gives a value, or fails after `timeout`.
pub fn eventually<T>(what: &str, timeout: Duration, mut f: impl FnMut() -> Option<T>) -> anyhow::Result<T> {
    let deadline = Instant::now() + timeout;
    loop {
        if let Some(v) = f() {
            return Ok(v);
        }
        ensure!(Instant::now() < deadline, "timed out after {timeout:?} waiting for {what}");
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// The lines a tap printed so far, as JSON.
pub fn drain(tap: &Receiver<String>) -> Vec<Value> {
    tap.try_iter().filter_map(|l| serde_json::from_str(&l).ok()).collect()
}

/// Reads the tap until `done` says so (it sees every line), or fails after `timeout`.
pub fn tap_until(tap: &Receiver<String>, what: &str, timeout: Duration, mut done: impl FnMut(&Value) -> bool) -> anyhow::Result<()> {
    let deadline = Instant::now() + timeout;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        ensure!(!left.is_zero(), "timed out after {timeout:?} waiting for {what}");
        if let Ok(line) = tap.recv_timeout(left) {
            if let Ok(v) = serde_json::from_str::<Value>(&line) {
                if done(&v) {
                    return Ok(());
                }
            }
        }
    }
}

/// `mrmm tap mrmm/**` in namespace `ns`, listening on `addr`, linked to `eps`; its output lines
/// as they come.
pub fn start_tap(dir: &Scratch, ns: &str, addr: &str, eps: &[String], name: &str) -> anyhow::Result<(Proc, Receiver<String>)> {
    let mut args = vec!["tap".to_string(), mrmm_proto::Pattern::All.to_string(), "--listen".into(), format!("tcp/{addr}:0")];
    for ep in eps {
        args.extend(["--connect".to_string(), ep.clone()]);
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    start_lines(&["ip", "netns", "exec", ns], name, &args, &dir.path(&format!("{name}.log")), "{\"tap\"", Duration::from_secs(20))
}

//! A robot process's threads are bounded by its role, not by the computer's cores: one computer
//! can run hundreds of robot processes (issue 35). Tokio's default is one worker per core, and
//! Zenoh's six runtime threads come on top; `TOKIO_WORKER_THREADS` makes this 2-core machine look
//! like a 16-core one to that default.

mod common;

use std::time::Duration;

use common::{start_central, start_robot, wait_robots, Scratch};
use mrmm_net::client::Client;

/// The threads of process `pid` (Linux: `/proc/<pid>/status`).
fn threads_of(pid: i32) -> anyhow::Result<usize> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status"))?;
    let line = status.lines().find(|l| l.starts_with("Threads:")).ok_or_else(|| anyhow::anyhow!("no Threads line"))?;
    Ok(line["Threads:".len()..].trim().parse()?)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_runs_a_handful_of_threads_on_any_number_of_cores() -> anyhow::Result<()> {
    // Only this test runs in this binary: the variable reaches the processes it starts.
    std::env::set_var("TOKIO_WORKER_THREADS", "16");
    let dir = Scratch::new("threads");
    let (_central, ep) = start_central(&dir)?;
    let robot = start_robot(&dir, "r1", &ep, 0.0, 0.0)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    wait_robots(&client, 1).await?;
    let n = threads_of(robot.pid())?;
    // Main thread, 2 workers, Zenoh's 4 (2 receive, send, application) and a few blocking ones
    // (name lookups, files). Taking Tokio's default here starts 16 workers; Zenoh's, 6 threads.
    assert!(n <= 12, "robot r1 runs {n} threads");
    Ok(())
}

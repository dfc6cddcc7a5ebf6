//! The experiments' fleet: central and `n` identical simulated robots as real `mrmm` processes
//! on loopback (plain TCP: the paper's figures measure coordination, not cryptography), reused
//! by every run of an experiment.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, RobotStatus, RobotView};
use tokio::process::Child;

use mrmm_node::procs;

/// Every robot's top speed, m/s: the idleness bound is L / (n · SPEED).
pub const SPEED: f64 = 1.0;

/// Beyond this many robots the lease is longer (the keep-alives of a large clique on a small
/// machine; docs/scale.md).
const LARGE_FLEET: usize = 40;

pub struct Fleet {
    pub client: Client,
    pub ids: Vec<String>,
    /// Central first, then the robots in the order of `ids`.
    children: Vec<Child>,
    pub dir: PathBuf,
    /// Where central listens, and each robot.
    pub central: String,
    pub endpoints: Vec<String>,
    time_scale: f64,
    lease_ms: u64,
    restarts: usize,
}

impl Fleet {
    /// Starts central and `n` robots (r1…rn) in `dir` and waits until all are registered.
    pub async fn start(dir: &Path, n: usize, time_scale: f64) -> anyhow::Result<Fleet> {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let mut children = Vec::new();
        match Self::boot(dir, n, time_scale, &mut children).await {
            Ok((client, ids, central, endpoints)) => {
                Ok(Fleet { client, ids, children, dir: dir.to_path_buf(), central, endpoints, time_scale, lease_ms: lease(n), restarts: 0 })
            }
            Err(e) => {
                procs::stop_all(&mut children, Duration::from_secs(3)).await;
                Err(e.context(format!("logs in {}", dir.display())))
            }
        }
    }

    async fn boot(dir: &Path, n: usize, time_scale: f64, children: &mut Vec<Child>) -> anyhow::Result<(Client, Vec<String>, String, Vec<String>)> {
        let (central, endpoint) = start_central(dir, "tcp/127.0.0.1:0", "central.log").await?;
        children.push(central);
        let ids: Vec<String> = (1..=n).map(|i| format!("r{i}")).collect();
        for (i, id) in ids.iter().enumerate() {
            children.push(start_robot(dir, id, i, std::slice::from_ref(&endpoint), time_scale, lease(n), &format!("{id}.log"))?);
            if n > LARGE_FLEET {
                // Every robot opens a link to every robot before it: a burst starves the leases.
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        }
        let mut endpoints = Vec::new();
        for (id, child) in ids.iter().zip(children.iter_mut().skip(1)) {
            let log = dir.join(format!("{id}.log"));
            let line = procs::ready_line(child, "robot ready", Duration::from_secs(30 + n as u64), &log).await?;
            endpoints.push(procs::field(&line, "listening").unwrap_or_default().split(',').next().unwrap_or_default().to_string());
        }
        let client = Client::connect(std::slice::from_ref(&endpoint), Duration::from_secs(10)).await?;
        match all_idle(&client, n, Duration::from_secs(30 + n as u64)).await {
            Ok(()) => Ok((client, ids, endpoint, endpoints)),
            Err(idle) => Err(anyhow!("only {idle} of {n} robots registered and idle")),
        }
    }

    /// SIGKILLs central.
    pub async fn kill_central(&mut self) {
        kill(&mut self.children[0]).await;
    }

    /// Starts central again on its endpoint, with its journal.
    pub async fn restart_central(&mut self) -> anyhow::Result<()> {
        self.restarts += 1;
        let (central, _) = start_central(&self.dir, &self.central, &format!("central-{}.log", self.restarts)).await?;
        self.children[0] = central;
        Ok(())
    }

    /// SIGKILLs robot `i` (index in `ids`).
    pub async fn kill_robot(&mut self, i: usize) {
        if let Some(c) = self.children.get_mut(i + 1) {
            kill(c).await;
        }
    }

    /// Starts robot `i` again, linking to its peers first (central may be down) and central.
    pub async fn restart_robot(&mut self, i: usize) -> anyhow::Result<()> {
        self.restarts += 1;
        let id = self.ids.get(i).cloned().ok_or_else(|| anyhow!("no robot {i}"))?;
        let connect: Vec<String> = self.endpoints.iter().enumerate().filter(|(j, _)| *j != i).map(|(_, e)| e.clone()).chain([self.central.clone()]).collect();
        let log = format!("{id}-{}.log", self.restarts);
        let mut child = start_robot(&self.dir, &id, i, &connect, self.time_scale, self.lease_ms, &log)?;
        let line = procs::ready_line(&mut child, "robot ready", Duration::from_secs(30), &self.dir.join(&log)).await?;
        if let Some(e) = procs::field(&line, "listening").and_then(|l| l.split(',').next()) {
            self.endpoints[i] = e.to_string();
        }
        self.children[i + 1] = child;
        Ok(())
    }

    /// Waits until every robot is idle again (after a run's missions were terminated).
    pub async fn settle(&self, timeout: Duration) -> anyhow::Result<()> {
        all_idle(&self.client, self.ids.len(), timeout)
            .await
            .map_err(|idle| anyhow!("{idle} of {} robots idle {} s after the run", self.ids.len(), timeout.as_secs()))
    }

    pub async fn stop(mut self) {
        self.client.close().await;
        procs::stop_all(&mut self.children, Duration::from_secs(5)).await;
    }
}

fn lease(n: usize) -> u64 {
    if n > LARGE_FLEET {
        4000
    } else {
        1000
    }
}

async fn kill(child: &mut Child) {
    let _ = child.kill().await;
}

/// Starts central (wire statistics on) listening on `listen`; returns it and its TCP endpoint.
async fn start_central(dir: &Path, listen: &str, log: &str) -> anyhow::Result<(Child, String)> {
    let log = dir.join(log);
    let state = dir.join("central-state");
    let args: Vec<String> =
        ["central", "--wire-stats", "--listen", listen, "--state-dir"].iter().map(|s| s.to_string()).chain([state.display().to_string()]).collect();
    let mut central = procs::spawn(&args, &log)?;
    let line = procs::ready_line(&mut central, "central ready", Duration::from_secs(30), &log).await.context("central did not start")?;
    let endpoint = procs::field(&line, "listening")
        .and_then(|l| l.split(',').find(|e| e.starts_with("tcp/")))
        .map(String::from)
        .ok_or_else(|| anyhow!("central ready line without a TCP endpoint: {line}"))?;
    Ok((central, endpoint))
}

/// Starts robot `id` (the `i`-th) linking to `connect`, its log in `log`.
fn start_robot(dir: &Path, id: &str, i: usize, connect: &[String], time_scale: f64, lease_ms: u64, log: &str) -> anyhow::Result<Child> {
    let path = dir.join(format!("{id}.json5"));
    std::fs::write(&path, robot_config(id, i, connect, time_scale, lease_ms)).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(procs::spawn(&["robot".into(), "--config".into(), path.display().to_string()], &dir.join(log))?)
}

/// Waits until `n` robots are idle; on timeout, how many were.
async fn all_idle(client: &Client, n: usize, timeout: Duration) -> Result<(), usize> {
    let deadline = Instant::now() + timeout;
    loop {
        let views: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await.unwrap_or_default();
        let idle = views.iter().filter(|v| v.status == RobotStatus::Idle).count();
        if idle == n {
            return Ok(());
        }
        if Instant::now() > deadline {
            return Err(idle);
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
}

/// Identical ground robots on a line south of the field.
fn robot_config(id: &str, i: usize, connect: &[String], time_scale: f64, lease_ms: u64) -> String {
    let connect = serde_json::to_string(connect).unwrap_or_default();
    let x = i as f64 * 1.0;
    // Visits are seen in telemetry: samples must stay about a robot second apart (a robot is
    // within a waypoint's 1.5 m for 3 s), whatever the time scale.
    let hz = time_scale.clamp(5.0, 20.0);
    format!(
        r#"{{
  id: "{id}", type: "ground", capabilities: ["camera"],
  kinematics: {{ max_speed: {SPEED}, max_turn_rate: 3.0 }},
  start: {{ x: {x}, y: -4, theta: 1.5708 }},
  time_scale: {time_scale}, telemetry_hz: {hz},
  zenoh: {{ listen: ["tcp/127.0.0.1:0"], connect: {connect}, lease_ms: {lease_ms}, wire_stats: true }},
}}
"#
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn generated_configs_are_valid() {
        let text = super::robot_config("r1", 0, &["tcp/127.0.0.1:7447".into()], 10.0, 1000);
        let cfg = mrmm_peer::config::RobotConfig::from_json5("gen", &text).expect("valid");
        assert_eq!((cfg.time_scale, cfg.kinematics.max_speed, cfg.zenoh.wire_stats), (10.0, super::SPEED, true));
    }
}

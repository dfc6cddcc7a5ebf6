//! The stand-in ROS 2 robot (`tests/py/ros2_robot.py`, on zenoh-ros2-sdk from PyPI) driven from
//! tests and benches: its process, its commands and its JSON lines.

use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context};
use serde_json::Value;

use super::Scratch;

/// The pinned Python with the ROS 2 packages: `MRMM_PYTHON`, or the virtual environment `.ci/run`
/// makes.
pub fn python() -> Option<PathBuf> {
    if let Ok(p) = std::env::var("MRMM_PYTHON") {
        return Some(PathBuf::from(p));
    }
    let p = PathBuf::from(std::env::var_os("HOME")?).join(".cache/mrmm/venv/bin/python");
    p.exists().then_some(p)
}

pub fn python_or_skip() -> anyhow::Result<Option<PathBuf>> {
    match python() {
        Some(p) => Ok(Some(p)),
        None => {
            anyhow::ensure!(std::env::var("CI").as_deref() != Ok("true"), "no Python with zenoh-ros2-sdk under CI: .ci/run installs it");
            println!("SKIPPED: no Python with zenoh-ros2-sdk (run .ci/run once, or set MRMM_PYTHON)");
            Ok(None)
        }
    }
}

pub fn free_port() -> anyhow::Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
}

/// The stand-in robot: its process, its stdin and its JSON lines.
pub struct StandIn {
    child: Child,
    stdin: ChildStdin,
    pub lines: Receiver<Value>,
    pub port: u16,
}

impl StandIn {
    pub fn start(py: &PathBuf, dir: &Scratch) -> anyhow::Result<Self> {
        Self::start_with(py, dir, &[])
    }

    /// With extra arguments (`--nav2`: also a Nav2 navigator).
    pub fn start_with(py: &PathBuf, dir: &Scratch, extra: &[&str]) -> anyhow::Result<Self> {
        let port = free_port()?;
        let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/py/ros2_robot.py");
        let mut child = Command::new(py)
            .arg(script)
            .args(["--port", &port.to_string()])
            .args(extra)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(std::fs::File::create(dir.path("standin.log"))?)
            .spawn()
            .context("spawn the stand-in robot")?;
        let stdin = child.stdin.take().ok_or_else(|| anyhow!("no stdin"))?;
        let out = child.stdout.take().ok_or_else(|| anyhow!("no stdout"))?;
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                if let Ok(v) = serde_json::from_str::<Value>(&line) {
                    let _ = tx.send(v);
                }
            }
        });
        let mut s = StandIn { child, stdin, lines, port };
        s.wait("ready", Duration::from_secs(30), |_| true).with_context(|| std::fs::read_to_string(dir.path("standin.log")).unwrap_or_default())?;
        Ok(s)
    }

    pub fn send(&mut self, cmd: &str) -> anyhow::Result<()> {
        writeln!(self.stdin, "{cmd}")?;
        Ok(self.stdin.flush()?)
    }

    /// The next line with this `event` that `ok` accepts (others are skipped).
    pub fn wait(&mut self, event: &str, timeout: Duration, mut ok: impl FnMut(&Value) -> bool) -> anyhow::Result<Value> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(v) if v["event"] == event && ok(&v) => return Ok(v),
                Ok(_) => continue,
                Err(_) => bail!("the stand-in robot said no {event:?} within {timeout:?}"),
            }
        }
    }

    pub fn ask(&mut self, cmd: &str, event: &str) -> anyhow::Result<Value> {
        self.send(cmd)?;
        self.wait(event, Duration::from_secs(10), |_| true)
    }
}

impl Drop for StandIn {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A robot config with a `ros2` body on the stand-in's router.
pub fn ros_robot_config(dir: &Scratch, id: &str, central: &str, router_port: u16) -> anyhow::Result<PathBuf> {
    ros_robot_config_driven(dir, id, central, router_port, "cmd_vel")
}

/// [`ros_robot_config`] with `drive` `cmd_vel` or `nav2`.
pub fn ros_robot_config_driven(dir: &Scratch, id: &str, central: &str, router_port: u16, drive: &str) -> anyhow::Result<PathBuf> {
    let cfg = format!(
        r#"{{ id: "{id}", type: "ground", capabilities: ["camera"],
             kinematics: {{ max_speed: 1.0, max_turn_rate: 2.0 }},
             telemetry_hz: 10,
             body: {{ kind: "ros2", router: "tcp/127.0.0.1:{router_port}", drive: "{drive}", odom_topic: "/odom", cmd_vel_topic: "/cmd_vel", odom_timeout_ms: 500 }},
             zenoh: {{ listen: ["tcp/127.0.0.1:0"], connect: ["{central}"], lease_ms: 1000 }} }}"#
    );
    let path = dir.path(&format!("{id}.json5"));
    std::fs::write(&path, cfg)?;
    Ok(path)
}

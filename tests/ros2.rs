//! A ROS 2 robot in the fleet, against the ecosystem's own rmw_zenoh implementation: a stand-in
//! robot in Python (`tests/py/ros2_robot.py`, zenoh-ros2-sdk from PyPI, no mrmm code) with its
//! own Zenoh router, `/cmd_vel` in and `/odom` out. `mrmm robot` with a `ros2` body registers,
//! shows in the stand-in's ROS graph, drives to a goto, patrols with two simulated robots through
//! their sync points, drops malformed CDR, and stops the robot (zero twist seen on the ROS side)
//! when its fleet links are gone.

mod common;

use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context};
use common::{eventually, start, start_central, start_robot_scaled, Scratch};
use mrmm_proto::client::Client;
use mrmm_proto::{self as proto, GotoRequest, MissionCreate, MissionView, RobotView};
use serde_json::Value;

/// The pinned Python with the ROS 2 packages: `MRMM_PYTHON`, or the virtual environment `.ci/run`
/// makes.
fn python() -> Option<PathBuf> {
    if let Ok(p) = std::env::var("MRMM_PYTHON") {
        return Some(PathBuf::from(p));
    }
    let p = PathBuf::from(std::env::var_os("HOME")?).join(".cache/mrmm/venv/bin/python");
    p.exists().then_some(p)
}

fn python_or_skip() -> anyhow::Result<Option<PathBuf>> {
    match python() {
        Some(p) => Ok(Some(p)),
        None => {
            anyhow::ensure!(std::env::var("CI").as_deref() != Ok("true"), "no Python with zenoh-ros2-sdk under CI: .ci/run installs it");
            println!("SKIPPED: no Python with zenoh-ros2-sdk (run .ci/run once, or set MRMM_PYTHON)");
            Ok(None)
        }
    }
}

fn free_port() -> anyhow::Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
}

/// The stand-in robot: its process, its stdin and its JSON lines.
struct StandIn {
    child: Child,
    stdin: ChildStdin,
    lines: Receiver<Value>,
    port: u16,
}

impl StandIn {
    fn start(py: &PathBuf, dir: &Scratch) -> anyhow::Result<Self> {
        let port = free_port()?;
        let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/py/ros2_robot.py");
        let mut child = Command::new(py)
            .arg(script)
            .args(["--port", &port.to_string()])
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

    fn send(&mut self, cmd: &str) -> anyhow::Result<()> {
        writeln!(self.stdin, "{cmd}")?;
        Ok(self.stdin.flush()?)
    }

    /// The next line with this `event` that `ok` accepts (others are skipped).
    fn wait(&mut self, event: &str, timeout: Duration, mut ok: impl FnMut(&Value) -> bool) -> anyhow::Result<Value> {
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

    fn ask(&mut self, cmd: &str, event: &str) -> anyhow::Result<Value> {
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
fn ros_robot_config(dir: &Scratch, id: &str, central: &str, router_port: u16) -> anyhow::Result<PathBuf> {
    let cfg = format!(
        r#"{{ id: "{id}", type: "ground", capabilities: ["camera"],
             kinematics: {{ max_speed: 1.0, max_turn_rate: 2.0 }},
             telemetry_hz: 10,
             body: {{ kind: "ros2", router: "tcp/127.0.0.1:{router_port}", odom_topic: "/odom", cmd_vel_topic: "/cmd_vel", odom_timeout_ms: 500 }},
             zenoh: {{ listen: ["tcp/127.0.0.1:0"], connect: ["{central}"], lease_ms: 1000 }} }}"#
    );
    let path = dir.path(&format!("{id}.json5"));
    std::fs::write(&path, cfg)?;
    Ok(path)
}

#[test]
fn type_hashes_agree_with_two_independent_implementations() -> anyhow::Result<()> {
    let Some(py) = python_or_skip()? else { return Ok(()) };
    let dir = Scratch::new("ros2-hashes");
    let mut standin = StandIn::start(&py, &dir)?;
    let ours = mrmm_ros2::msgs::known_types();
    let names: Vec<&str> = ours.iter().map(|(t, _)| *t).collect();
    let got = standin.ask(&format!("hashes {}", names.join(" ")), "hashes")?;
    for (t, hash) in ours {
        assert_eq!(got["sdk"][t], hash, "zenoh-ros2-sdk's hash of {t}: {got}");
        assert_eq!(got["rosbags"][t], hash, "rosbags' Jazzy hash of {t}: {got}");
    }
    // And the stand-in's own keys are the ones mrmm builds.
    let ready = standin.ask("state", "state")?;
    assert!(ready["x"].is_number());
    Ok(())
}

async fn robot(client: &Client, id: &str) -> Option<RobotView> {
    let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await.ok()?;
    v.into_iter().find(|r| r.id == id)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_ros2_robot_drives_patrols_with_simulated_ones_and_stops_without_its_fleet() -> anyhow::Result<()> {
    let Some(py) = python_or_skip()? else { return Ok(()) };
    let dir = Scratch::new("ros2");
    let mut standin = StandIn::start(&py, &dir)?;
    let (mut central, ep) = start_central(&dir)?;
    let mut r1 = start_robot_scaled(&dir, "r1", &ep, 0.0, -1.0, 1.0)?;
    let mut r2 = start_robot_scaled(&dir, "r2", &ep, 2.0, -1.0, 1.0)?;
    let cfg = ros_robot_config(&dir, "r3", &ep, standin.port)?.display().to_string();
    let _r3 = start("r3", &["robot", "--config", &cfg], &dir.path("r3.log"), "robot ready", Duration::from_secs(20))?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 3).await?;

    // mrmm's node is in the robot's ROS graph: publisher of /cmd_vel, subscriber of /odom.
    let graph = {
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            let g = standin.ask("graph", "graph")?;
            let has = |topic: &str, side: &str| g[topic][side].as_array().is_some_and(|v| v.iter().any(|e| e["node"] == "mrmm_r3"));
            if has("cmd_vel", "publishers") && has("odom", "subscribers") {
                break g;
            }
            anyhow::ensure!(Instant::now() < deadline, "mrmm_r3 not in the ROS graph: {g}");
        }
    };
    println!("ROS graph: {graph}");

    // A goto: the robot drives (twists on /cmd_vel) and mrmm reports the pose odometry gives.
    let ack: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Goto), Some(&GotoRequest { robot: "r3".into(), x: 1.5, y: 0.5 })).await?;
    println!("goto: {ack}");
    standin.wait("moving", Duration::from_secs(10), |_| true)?;
    let at = standin.wait("zero", Duration::from_secs(30), |_| true)?;
    let (x, y) = (at["x"].as_f64().unwrap_or(f64::NAN), at["y"].as_f64().unwrap_or(f64::NAN));
    assert!((x - 1.5).hypot(y - 0.5) < 0.15, "stopped at ({x}, {y}), not at the goal");
    eventually("mrmm reporting r3 at its goal", Duration::from_secs(10), || async {
        let p = robot(&client, "r3").await?.pose?;
        ((p.x - 1.5).hypot(p.y - 0.5) < 0.15).then_some(())
    })
    .await?;

    // Malformed CDR on /odom is dropped; odometry goes on being read.
    standin.ask("garbage", "garbage_sent")?;

    // A patrol with the two simulated robots completes a round through its sync points.
    let create = MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        robots: Some(vec!["r1".into(), "r2".into(), "r3".into()]),
        params: [("waypoints".to_string(), serde_json::json!([[0, 0], [2, 0], [2, 2], [0, 2]]))].into(),
        ..Default::default()
    };
    let created: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&create)).await?;
    assert_eq!(created.robots.len(), 3, "{created:?}");
    let m = eventually("a round of the patrol with the ROS 2 robot", Duration::from_secs(90), || async {
        let m: MissionView = client.query(proto::Key::SystemMission("p".to_string()), None::<&()>).await.ok()?;
        (m.metrics.rounds >= 1 && m.metrics.sync_points_passed >= 2).then_some(m)
    })
    .await?;
    println!("patrol: rounds {}, sync points {}", m.metrics.rounds, m.metrics.sync_points_passed);
    let log = std::fs::read_to_string(dir.path("r3.log"))?;
    assert!(log.contains("dropped a malformed ROS 2 message"), "no trace of the malformed payloads in r3's log");

    // The fleet goes (central and both teammates SIGKILLed) while r3 is driving: r3 has no fleet
    // link left and stops its robot — a zero twist on /cmd_vel.
    let deadline = Instant::now() + Duration::from_secs(30);
    while standin.ask("state", "state")?["v"].as_f64().is_none_or(|v| v < 0.05) {
        anyhow::ensure!(Instant::now() < deadline, "r3 never seen driving in the patrol");
    }
    let cut = Instant::now();
    central.kill();
    r1.kill();
    r2.kill();
    // Within one lease (1 s; a SIGKILL closes the links at once, a silent link takes the lease).
    let zero = standin.wait("zero", Duration::from_millis(1500), |_| true)?;
    println!("zero twist {:.0} ms after the fleet went: {zero}", cut.elapsed().as_secs_f64() * 1000.0);
    // It stays stopped: mrmm goes on sending zero twists (ten more), and nothing else.
    let zeros = standin.ask("state", "state")?["zeros"].as_u64().unwrap_or(0);
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        standin.send("state")?;
        let st = standin.lines.recv_timeout(Duration::from_secs(5))?;
        anyhow::ensure!(st["event"] != "moving", "the robot moved again without its fleet: {st}");
        if st["event"] == "state" && st["zeros"].as_u64().unwrap_or(0) >= zeros + 10 {
            assert_eq!((st["v"].as_f64(), st["omega"].as_f64()), (Some(0.0), Some(0.0)), "{st}");
            break;
        }
        anyhow::ensure!(Instant::now() < deadline, "no zero twists kept coming: {st}");
    }
    let log = std::fs::read_to_string(dir.path("r3.log"))?;
    assert!(log.contains("FleetLost"), "r3 did not say why it stopped");
    Ok(())
}

//! What a ROS 2 body costs against a simulated one (issue 13's measurements), with real
//! processes on loopback: central, a simulated robot and a robot with a `ros2` body on the
//! stand-in ROS 2 robot (`tests/py/ros2_robot.py`, zenoh-ros2-sdk from PyPI, its own Zenoh router).
//!
//! - goal-to-motion: from sending a goto to the first telemetry of the robot moving (all bodies;
//!   telemetry at 50 Hz), for the cmd_vel ROS body to the first non-zero twist the robot
//!   receives, for the Nav2 ROS body (a second stand-in, `--nav2`) to the goal at the navigator;
//! - telemetry rate each robot publishes (configured 50 Hz);
//! - CPU of each robot process, idle and while driving back and forth.
//!
//! `cargo bench --bench ros2 -- [--trials N]` (default 20).

#[path = "../tests/common/mod.rs"]
mod common;

use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{anyhow, Context};
use common::measure::{cpu_s, quantile};
use common::standin::{python, StandIn};
use common::{start, start_central, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, GotoRequest, Key};

fn config(dir: &Scratch, id: &str, central: &str, body: &str) -> anyhow::Result<String> {
    let cfg = format!(
        r#"{{ id: "{id}", type: "ground", kinematics: {{ max_speed: 1.0, max_turn_rate: 2.0 }}, telemetry_hz: 50, {body}
             zenoh: {{ listen: ["tcp/127.0.0.1:0"], connect: ["{central}"], lease_ms: 1000 }} }}"#
    );
    let path = dir.path(&format!("{id}.json5"));
    std::fs::write(&path, cfg)?;
    Ok(path.display().to_string())
}

fn unix_s() -> f64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0.0, |d| d.as_secs_f64())
}

#[tokio::main(flavor = "multi_thread", worker_threads = 2)]
async fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let trials: usize = args.iter().position(|a| a == "--trials").and_then(|i| args.get(i + 1)?.parse().ok()).unwrap_or(20);
    let py = python().ok_or_else(|| anyhow!("no Python with zenoh-ros2-sdk: run .ci/run once, or set MRMM_PYTHON"))?;
    let dir = Scratch::new("bench-ros2");
    let mut standin = StandIn::start(&py, &dir)?;
    let (_central, ep) = start_central(&dir)?;
    let sim_cfg = config(&dir, "sim", &ep, "")?;
    let ros_cfg = config(&dir, "ros", &ep, &format!(r#"body: {{ kind: "ros2", router: "tcp/127.0.0.1:{}" }},"#, standin.port))?;
    let mut navigator = StandIn::start_with(&py, &dir, &["--nav2"])?;
    let nav_cfg = config(&dir, "nav", &ep, &format!(r#"body: {{ kind: "ros2", drive: "nav2", router: "tcp/127.0.0.1:{}" }},"#, navigator.port))?;
    let sim = start("sim", &["robot", "--config", &sim_cfg], &dir.path("sim.log"), "robot ready", Duration::from_secs(20))?;
    let ros = start("ros", &["robot", "--config", &ros_cfg], &dir.path("ros.log"), "robot ready", Duration::from_secs(20))?;
    let nav = start("nav", &["robot", "--config", &nav_cfg], &dir.path("nav.log"), "robot ready", Duration::from_secs(20))?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 3).await?;
    // A ring, not Zenoh's default FIFO: while this task waits on a stand-in, telemetry (150/s) must
    // not fill a blocking channel and stall the session's receive path (the goto replies).
    let telemetry = client
        .session()
        .declare_subscriber(Key::RobotTelemetry("*".into()).to_string())
        .with(zenoh::handlers::RingChannel::new(4096))
        .await
        .map_err(|e| anyhow!("{e}"))?;

    // Telemetry rate and idle CPU over 10 s.
    let window = Duration::from_secs(10);
    let (c_sim, c_ros, c_nav) = (cpu_s(sim.child.id()), cpu_s(ros.child.id()), cpu_s(nav.child.id()));
    let t0 = Instant::now();
    let (mut n_sim, mut n_ros, mut n_nav) = (0u32, 0u32, 0u32);
    while t0.elapsed() < window {
        let Ok(Ok(s)) = tokio::time::timeout(Duration::from_millis(200), telemetry.recv_async()).await else { continue };
        match proto::decode_telemetry(&s.payload().to_bytes()).map(|t| t.id) {
            Ok(id) if id == "sim" => n_sim += 1,
            Ok(id) if id == "ros" => n_ros += 1,
            Ok(id) if id == "nav" => n_nav += 1,
            _ => {}
        }
    }
    let secs = t0.elapsed().as_secs_f64();
    let idle = ((cpu_s(sim.child.id()) - c_sim) / secs * 100.0, (cpu_s(ros.child.id()) - c_ros) / secs * 100.0, (cpu_s(nav.child.id()) - c_nav) / secs * 100.0);
    let rate = (f64::from(n_sim) / secs, f64::from(n_ros) / secs, f64::from(n_nav) / secs);

    // Goal to motion, back and forth between two points 1.5 m apart.
    let (mut sim_lat, mut ros_lat, mut ros_twist, mut nav_lat, mut nav_goal) = (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (c_sim, c_ros, c_nav) = (cpu_s(sim.child.id()), cpu_s(ros.child.id()), cpu_s(nav.child.id()));
    let t_drive = Instant::now();
    for i in 0..trials {
        let x = if i % 2 == 0 { 1.5 } else { 0.0 };
        while telemetry.try_recv().ok().flatten().is_some() {}
        let sent_unix = unix_s();
        let sent = Instant::now();
        // The three gotos leave together, so that no body's latency includes another's.
        let goto = |robot: &'static str| {
            let client = &client;
            async move {
                client
                    .query::<serde_json::Value>(proto::Key::SystemCmd(proto::SystemCmd::Goto), Some(&GotoRequest { robot: robot.into(), x, y: 0.0, map: None }))
                    .await
                    .with_context(|| format!("trial {i}: goto {robot} ({x}, 0)"))
            }
        };
        let (a, b, c) = tokio::join!(goto("sim"), goto("ros"), goto("nav"));
        a?;
        b?;
        c?;
        let (mut s_at, mut r_at, mut n_at) = (None, None, None);
        while (s_at.is_none() || r_at.is_none() || n_at.is_none()) && sent.elapsed() < Duration::from_secs(5) {
            let Ok(Ok(s)) = tokio::time::timeout(Duration::from_millis(200), telemetry.recv_async()).await else { continue };
            let Ok(t) = proto::decode_telemetry(&s.payload().to_bytes()) else { continue };
            if t.velocity.v.abs() > 1e-3 || t.velocity.omega.abs() > 1e-3 {
                let at = Some(sent.elapsed().as_secs_f64() * 1000.0);
                match t.id.as_str() {
                    "sim" if s_at.is_none() => s_at = at,
                    "ros" if r_at.is_none() => r_at = at,
                    "nav" if n_at.is_none() => n_at = at,
                    _ => {}
                }
            }
        }
        let moving = standin.wait("moving", Duration::from_secs(5), |_| true).context("no twist reached the stand-in")?;
        ros_twist.push((moving["t"].as_f64().unwrap_or(f64::NAN) - sent_unix) * 1000.0);
        let goal = navigator.wait("goal", Duration::from_secs(5), |_| true).context("no goal reached the navigator")?;
        nav_goal.push((goal["t"].as_f64().unwrap_or(f64::NAN) - sent_unix) * 1000.0);
        sim_lat.extend(s_at);
        ros_lat.extend(r_at);
        nav_lat.extend(n_at);
        standin.wait("zero", Duration::from_secs(20), |_| true).context("the ROS robot never arrived")?;
        navigator.wait("result", Duration::from_secs(20), |r| r["status"] == 4).context("the Nav2 robot never arrived")?;
    }
    let secs = t_drive.elapsed().as_secs_f64();
    let driving =
        ((cpu_s(sim.child.id()) - c_sim) / secs * 100.0, (cpu_s(ros.child.id()) - c_ros) / secs * 100.0, (cpu_s(nav.child.id()) - c_nav) / secs * 100.0);

    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| s.lines().find_map(|l| l.strip_prefix("model name").map(|v| v.trim_start_matches([' ', '\t', ':']).to_string())))
        .unwrap_or_default();
    println!("ros2 body vs simulated body; {trials} gotos each; {} cores, {cpu}", std::thread::available_parallelism().map_or(0, |n| n.get()));
    println!("| measure | simulated body | ROS 2 body, cmd_vel | ROS 2 body, Nav2 |");
    println!("|---|---:|---:|---:|");
    let p = |v: &[f64]| format!("{:.1} / {:.1}", quantile(&mut v.to_vec(), 0.5), quantile(&mut v.to_vec(), 0.9));
    println!("| goto → telemetry shows motion, p50 / p90 ms | {} | {} | {} |", p(&sim_lat), p(&ros_lat), p(&nav_lat));
    println!("| goto → first twist / goal at the robot, p50 / p90 ms | – | {} | {} |", p(&ros_twist), p(&nav_goal));
    println!("| telemetry received, Hz (configured 50) | {:.1} | {:.1} | {:.1} |", rate.0, rate.1, rate.2);
    println!("| robot process CPU idle, % of a core | {:.1} | {:.1} | {:.1} |", idle.0, idle.1, idle.2);
    println!("| robot process CPU driving, % of a core | {:.1} | {:.1} | {:.1} |", driving.0, driving.1, driving.2);
    client.close().await;
    Ok(())
}

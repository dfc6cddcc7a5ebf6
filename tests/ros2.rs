//! A ROS 2 robot in the fleet, against the ecosystem's own rmw_zenoh implementation: a stand-in
//! robot in Python (`tests/py/ros2_robot.py`, zenoh-ros2-sdk from PyPI, no mrmm code) with its
//! own Zenoh router, `/cmd_vel` in and `/odom` out. `mrmm robot` with a `ros2` body registers,
//! shows in the stand-in's ROS graph, drives to a goto, patrols with two simulated robots through
//! their sync points, drops malformed CDR, and stops the robot (zero twist seen on the ROS side)
//! when its fleet links are gone.

mod common;

use std::time::{Duration, Instant};

use common::standin::{python_or_skip, ros_robot_config, StandIn};
use common::{eventually, start, start_central, start_robot_scaled, Scratch};
use mrmm_proto::client::Client;
use mrmm_proto::{self as proto, GotoRequest, MissionCreate, MissionView, RobotView};
use serde_json::Value;

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

    // Malformed CDR on /odom is dropped; odometry goes on being read. A node that has /odom with
    // another type hash (another distribution) is named in a warning.
    standin.ask("garbage", "garbage_sent")?;
    standin.ask("wrong_odom", "wrong_odom")?;

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
    assert!(log.contains("old_distro_odometry has /odom with type hash RIHS01_000"), "no warning about the other type hash in r3's log");

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

//! A ROS 2 robot in the fleet, against the ecosystem's own rmw_zenoh implementation: a stand-in
//! robot in Python (`tests/py/ros2_robot.py`, zenoh-ros2-sdk from PyPI, no mrmm code) with its
//! own Zenoh router, `/cmd_vel` in and `/odom` out. `mrmm robot` with a `ros2` body registers,
//! shows in the stand-in's ROS graph, drives to a goto, patrols with two simulated robots through
//! their sync points, drops malformed CDR, and stops the robot (zero twist seen on the ROS side)
//! when its fleet links are gone.

mod common;

use std::time::{Duration, Instant};

use common::standin::{python_or_skip, ros_robot_config, ros_robot_config_driven, StandIn};
use common::{eventually, start, start_central, start_robot_scaled, Scratch};
use mrmm_net::client::Client;
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

/// RIHS01 hashes from real ROS 2 builds, the ground truth for the derivation the Nav2 stand-in
/// uses (tests/py/rihs.py): AddTwoInts from rmw_zenoh's design document (its key example);
/// CancelGoal and NavigateToPose's from rosidl_generator_c output of ROS 2 Jazzy-era builds
/// (`*__description.c`; nav2_msgs with `error_code`/`error_msg` in the result and five feedback
/// fields, as Jazzy's NavigateToPose has).
const ADD_TWO_INTS: &str = "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a";
const CANCEL_GOAL: &str = "RIHS01_573d8b0a534451d7bc2ac8c5ffde8ac14b8593b7001175d0cd6516dcbeb8689a";
const NAV2_SEND_GOAL: &str = "RIHS01_a4fcb3bee1bf32e21a0e541a943b221aa0826996e2c98f079b47022b256f48b5";
const NAV2_GET_RESULT: &str = "RIHS01_c407920357d566771e8882b4ef4d1f1a84ee922d609920ccd57faa6d6e391dc5";
const NAV2_FEEDBACK: &str = "RIHS01_9d1f6fa2eb975ce733b419ac2e97b134d8ff92b6478b6559feed9a50bdfd82b3";

#[test]
fn action_hashes_derived_with_rosbags_are_those_of_a_ros_build() -> anyhow::Result<()> {
    let Some(py) = python_or_skip()? else { return Ok(()) };
    let dir = Scratch::new("ros2-rihs");
    let mut standin = StandIn::start(&py, &dir)?;
    let got = standin.ask("rihs", "rihs")?;
    assert_eq!(got["add_two_ints"], ADD_TWO_INTS, "{got}");
    assert_eq!(got["cancel_goal"], CANCEL_GOAL, "{got}");
    let nav = &got["navigate_to_pose"];
    assert_eq!((&nav["send_goal"], &nav["get_result"], &nav["feedback"]), (&NAV2_SEND_GOAL.into(), &NAV2_GET_RESULT.into(), &NAV2_FEEDBACK.into()), "{got}");
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

    // mrmm's node is in the robot's ROS graph: publisher of /cmd_vel, subscriber of /odom and
    // /battery_state.
    let graph = {
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            let g = standin.ask("graph", "graph")?;
            let has = |topic: &str, side: &str| g[topic][side].as_array().is_some_and(|v| v.iter().any(|e| e["node"] == "mrmm_r3"));
            if has("cmd_vel", "publishers") && has("odom", "subscribers") && has("battery_state", "subscribers") {
                break g;
            }
            anyhow::ensure!(Instant::now() < deadline, "mrmm_r3 not in the ROS graph: {g}");
        }
    };
    println!("ROS graph: {graph}");

    // A goto: the robot drives (twists on /cmd_vel) and mrmm reports the pose odometry gives.
    let ack: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Goto), Some(&GotoRequest { map: None, robot: "r3".into(), x: 1.5, y: 0.5 })).await?;
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

    // The robot's battery, as its driver publishes it (sensor_msgs/BatteryState), is the fleet's:
    // its charge, and whether it charges; a percentage out of 0–1 is dropped and logged.
    standin.ask("battery 0.63 2", "battery")?;
    let b = eventually("r3's battery at 63 %", Duration::from_secs(10), || async {
        robot(&client, "r3").await?.battery.filter(|b| (b.charge - 0.63).abs() < 1e-6)
    })
    .await?;
    assert!(!b.charging && b.reach_m.is_none(), "{b:?}");
    standin.ask("battery 87 1", "battery")?;
    standin.ask("battery 0.64 1", "battery")?;
    eventually("r3 charging", Duration::from_secs(10), || async {
        robot(&client, "r3").await?.battery.filter(|b| b.charging && (b.charge - 0.64).abs() < 1e-6)
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
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.metrics.rounds >= 1 && m.metrics.sync_points_passed >= 2).then_some(m)
    })
    .await?;
    println!("patrol: rounds {}, sync points {}", m.metrics.rounds, m.metrics.sync_points_passed);
    let log = std::fs::read_to_string(dir.path("r3.log"))?;
    assert!(log.contains("dropped a malformed ROS 2 message"), "no trace of the malformed payloads in r3's log");
    assert!(log.contains("old_distro_odometry has /odom with type hash RIHS01_000"), "no warning about the other type hash in r3's log");
    assert!(log.contains("percentage 87 is not within 0–1"), "no trace of the battery's bad percentage in r3's log");

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

async fn mission(client: &Client, name: &str) -> Option<MissionView> {
    client.query(proto::Key::SystemMission(name.into()), None::<&()>).await.ok()
}

/// The graph tokens of the stand-in's router whose key contains `part`.
fn tokens_with(standin: &mut StandIn, part: &str) -> anyhow::Result<Vec<String>> {
    let t = standin.ask("tokens", "tokens")?;
    Ok(t["keys"].as_array().into_iter().flatten().filter_map(Value::as_str).filter(|k| k.contains(part)).map(String::from).collect())
}

/// The last chunk but one of a graph token: the type hash.
fn hash_of(token: &str) -> &str {
    token.rsplit('/').nth(1).unwrap_or_default()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn nav2_gets_goals_cancels_them_on_replan_and_fleet_loss_and_refusals_and_recoveries_are_reported() -> anyhow::Result<()> {
    let Some(py) = python_or_skip()? else { return Ok(()) };
    let dir = Scratch::new("ros2-nav2");
    let mut standin = StandIn::start_with(&py, &dir, &["--nav2"])?;
    let (mut central, ep) = start_central(&dir)?;
    let cfg = ros_robot_config_driven(&dir, "r3", &ep, standin.port, "nav2")?.display().to_string();
    let _r3 = start("r3", &["robot", "--config", &cfg], &dir.path("r3.log"), "robot ready", Duration::from_secs(20))?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 1).await?;

    // mrmm_r3's three action clients and its feedback subscriber are in the graph, with the
    // hashes the server announces: Jazzy's (mrmm compiles none in; it follows the server).
    let deadline = Instant::now() + Duration::from_secs(10);
    for (service, server_kind, client_kind, jazzy) in [
        ("send_goal", "/SS/", "/SC/", NAV2_SEND_GOAL),
        ("get_result", "/SS/", "/SC/", NAV2_GET_RESULT),
        ("cancel_goal", "/SS/", "/SC/", CANCEL_GOAL),
        ("feedback", "/MP/", "/MS/", NAV2_FEEDBACK),
    ] {
        let part = format!("%navigate_to_pose%_action%{service}/");
        loop {
            let toks = tokens_with(&mut standin, &part)?;
            let server = toks.iter().find(|k| k.contains(server_kind));
            let client = toks.iter().find(|k| k.contains(client_kind) && k.contains("/mrmm_r3/"));
            if let (Some(s), Some(c)) = (server, client) {
                assert_eq!((hash_of(s), hash_of(c)), (jazzy, jazzy), "{service}: server {s}, client {c}");
                break;
            }
            anyhow::ensure!(Instant::now() < deadline, "no client of {service} from mrmm_r3: {toks:?}");
        }
    }

    // A goto is a goal in the map frame; Nav2 drives there and mrmm reports the robot there.
    let goto = |x: f64, y: f64| {
        let client = &client;
        async move { client.query::<Value>(proto::Key::SystemCmd(proto::SystemCmd::Goto), Some(&GotoRequest { map: None, robot: "r3".into(), x, y })).await }
    };
    goto(1.5, 0.5).await?;
    let g = standin.wait("goal", Duration::from_secs(10), |_| true)?;
    assert_eq!((g["accepted"].as_bool(), g["x"].as_f64(), g["y"].as_f64(), g["frame"].as_str()), (Some(true), Some(1.5), Some(0.5), Some("map")), "{g}");
    let r = standin.wait("result", Duration::from_secs(30), |_| true)?;
    assert_eq!(r["status"], 4, "{r}");
    eventually("mrmm reporting r3 at its goal, not stuck", Duration::from_secs(10), || async {
        let v = robot(&client, "r3").await?;
        let p = v.pose?;
        ((p.x - 1.5).hypot(p.y - 0.5) < 0.2 && v.stuck.is_none() && v.behaviour.as_deref() == Some("hold")).then_some(())
    })
    .await?;

    // A new goto while driving: the running goal is cancelled and the new one sent.
    goto(4.0, 0.5).await?;
    standin.wait("goal", Duration::from_secs(10), |g| g["x"] == 4.0)?;
    goto(0.0, 2.0).await?;
    // The cancel and the new goal go out together: whichever the navigator takes first, the old
    // goal ends cancelled (by the cancel, or preempted by the new goal, then the cancel finds it
    // over: code 3) and the new one is driven.
    let (mut cancelled, mut ended, mut sent) = (false, false, false);
    let deadline = Instant::now() + Duration::from_secs(10);
    while !(cancelled && ended && sent) {
        let e = standin.lines.recv_timeout(deadline.saturating_duration_since(Instant::now()))?;
        cancelled |= e["event"] == "cancel" && (e["code"] == 0 || e["code"] == 3);
        ended |= e["event"] == "result" && e["status"] == 5;
        sent |= e["event"] == "goal" && e["x"] == 0.0 && e["y"] == 2.0;
    }
    standin.wait("result", Duration::from_secs(40), |r| r["status"] == 4)?;

    // In a mission (a one-robot patrol), a rejected goal and an aborted one are reported — the
    // robot says why, in its view and in its mission's — and tried again.
    standin.ask("nav2 reject", "nav2_mode")?;
    let create = MissionCreate {
        name: "n".into(),
        recipe: "patrol".into(),
        robots: Some(vec!["r3".into()]),
        params: [("waypoints".to_string(), serde_json::json!([[1, 1], [2, 1]]))].into(),
        ..Default::default()
    };
    let _: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&create)).await?;
    standin.wait("goal", Duration::from_secs(15), |g| g["accepted"] == false)?;
    let why =
        eventually("r3 reported stuck: rejected", Duration::from_secs(10), || async { robot(&client, "r3").await?.stuck.filter(|s| s.contains("rejected")) })
            .await?;
    println!("stuck: {why}");
    eventually("mission n shows r3 stuck", Duration::from_secs(10), || async {
        mission(&client, "n").await?.stuck.get("r3").filter(|s| s.contains("rejected")).cloned()
    })
    .await?;
    standin.ask("nav2 abort", "nav2_mode")?;
    standin.wait("result", Duration::from_secs(15), |r| r["status"] == 6)?;
    eventually("r3 reported stuck: aborted", Duration::from_secs(10), || async { robot(&client, "r3").await?.stuck.filter(|s| s.contains("aborted")) }).await?;
    standin.ask("nav2 ok", "nav2_mode")?;
    standin.wait("result", Duration::from_secs(30), |r| r["status"] == 4)?;
    eventually("r3 no longer stuck", Duration::from_secs(10), || async { robot(&client, "r3").await.filter(|v| v.stuck.is_none()).map(|_| ()) }).await?;
    eventually("mission n without stuck members", Duration::from_secs(10), || async { mission(&client, "n").await.filter(|m| m.stuck.is_empty()).map(|_| ()) })
        .await?;
    let _: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Terminate), Some(&proto::MissionTerminate { name: "n".into() })).await?;
    eventually("r3 free again", Duration::from_secs(10), || async { robot(&client, "r3").await.filter(|v| v.mission.is_none()).map(|_| ()) }).await?;

    // Nav2 recovering again and again (a blocked path) is reported before any abort, from its
    // feedback, and the report goes once the goal is reached.
    standin.ask("nav2 recover", "nav2_mode")?;
    goto(3.0, 3.0).await?;
    standin.wait("goal", Duration::from_secs(10), |g| g["x"] == 3.0)?;
    let why =
        eventually("r3 reported recovering", Duration::from_secs(10), || async { robot(&client, "r3").await?.stuck.filter(|s| s.contains("recovering")) })
            .await?;
    println!("stuck: {why}");
    standin.ask("nav2 ok", "nav2_mode")?;
    standin.wait("result", Duration::from_secs(30), |r| r["status"] == 4)?;
    eventually("r3 no longer stuck", Duration::from_secs(10), || async { robot(&client, "r3").await.filter(|v| v.stuck.is_none()).map(|_| ()) }).await?;

    // The fleet goes while Nav2 drives: the goal is cancelled (the robot stops) within a lease.
    goto(6.0, 6.0).await?;
    standin.wait("goal", Duration::from_secs(10), |g| g["x"] == 6.0)?;
    let deadline = Instant::now() + Duration::from_secs(10);
    while standin.ask("state", "state")?["v"].as_f64().is_none_or(|v| v < 0.05) {
        anyhow::ensure!(Instant::now() < deadline, "the robot never drove to (6, 6)");
    }
    let cut = Instant::now();
    central.kill();
    let c = standin.wait("cancel", Duration::from_millis(1500), |_| true)?;
    println!("goal cancelled {:.0} ms after the fleet went: {c}", cut.elapsed().as_secs_f64() * 1000.0);
    let st = standin.ask("state", "state")?;
    assert_eq!((st["v"].as_f64(), st["omega"].as_f64()), (Some(0.0), Some(0.0)), "{st}");
    Ok(())
}

//! Capabilities that change at runtime, with real processes: central + 4 robots (r4 without a
//! camera); a patrol whose recipe file requires a camera refuses r4; the operator says r2's
//! camera broke (`mrmm op capabilities`): r2 leaves the patrol, which replans and goes on, and
//! the agent says so; r4 gets a camera and joins; r3 restarts with a config without one and is
//! taken out as it comes back.

mod common;

use std::path::Path;
use std::time::Duration;

use common::{eventually, robot_config, start, start_central, Scratch, EXE};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, MissionView, RobotView};

async fn mission(c: &Client) -> Option<MissionView> {
    c.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()
}

async fn robot(c: &Client, id: &str) -> Option<RobotView> {
    c.query(proto::Key::SystemRobot(id.into()), None::<&()>).await.ok()
}

/// `mrmm op --connect <central> <args>`: (success, stdout, stderr).
fn op(central: &str, args: &[&str]) -> anyhow::Result<(bool, String, String)> {
    let out = std::process::Command::new(EXE).args(["op", "--connect", central]).args(args).output()?;
    Ok((out.status.success(), String::from_utf8_lossy(&out.stdout).into_owned(), String::from_utf8_lossy(&out.stderr).into_owned()))
}

/// Robot `id`'s config with `caps` for capabilities, started.
fn start_robot_with_caps(dir: &Scratch, id: &str, central: &str, x: f64, caps: &str) -> anyhow::Result<common::Proc> {
    let path = robot_config(dir, id, &[central.to_string()], x, -3.0, 10.0)?;
    let cfg = std::fs::read_to_string(&path)?.replace(r#"capabilities: ["camera"]"#, &format!("capabilities: {caps}"));
    std::fs::write(&path, cfg)?;
    start(id, &["robot", "--config", &path.display().to_string()], &dir.path(&format!("{id}.log")), "robot ready", Duration::from_secs(20))
}

fn camera_recipe(path: &Path) -> anyhow::Result<String> {
    let xml = mrmm_planner::recipe::bank("patrol").ok_or_else(|| anyhow::anyhow!("no patrol"))?;
    std::fs::write(path, xml.replace("  <params>", "  <requires capability=\"camera\"/>\n  <params>"))?;
    Ok(path.display().to_string())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_that_loses_what_its_mission_requires_leaves_it_and_the_mission_goes_on() -> anyhow::Result<()> {
    let dir = Scratch::new("capabilities");
    let (_central, ep) = start_central(&dir)?;
    let mut robots = Vec::new();
    for i in 1..=3 {
        robots.push(start_robot_with_caps(&dir, &format!("r{i}"), &ep, i as f64 * 2.0, r#"["camera"]"#)?);
    }
    robots.push(start_robot_with_caps(&dir, "r4", &ep, 8.0, r#"["lidar"]"#)?);
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    let live = client.session().declare_subscriber(proto::Key::AgentAdviceLive.to_string()).await.map_err(|e| anyhow::anyhow!("{e}"))?;
    common::wait_robots(&client, 4).await?;
    let recipe = camera_recipe(&dir.path("inspect.xml"))?;
    let square = "[[0,0],[10,0],[10,10],[0,10]]";

    // r4 has no camera: refused in words, nothing created.
    let (ok, _, err) = op(&ep, &["mission", "create", "p", "--recipe", &recipe, "--robots", "r1,r4", "--waypoints", square])?;
    assert!(!ok && err.contains("robot \"r4\" lacks camera (mission p requires camera)"), "{err}");
    assert!(mission(&client).await.is_none());
    let (ok, out, err) = op(&ep, &["mission", "create", "p", "--recipe", &recipe, "--robots", "r1,r2,r3", "--waypoints", square])?;
    assert!(ok, "{out}{err}");
    assert_eq!(mission(&client).await.map(|m| m.requires), Some(vec!["camera".to_string()]));
    let passed = |n: u32| {
        let client = &client;
        move || async move { mission(client).await.filter(|m| m.metrics.sync_points_passed >= n) }
    };
    let before = eventually("the patrol passing its first sync points", Duration::from_secs(30), passed(2)).await?.metrics.sync_points_passed;

    // r2's camera broke: it leaves p at once (the answer says so), and p replans without it.
    while live.try_recv().ok().flatten().is_some() {}
    let (ok, out, err) = op(&ep, &["capabilities", "r2", "--remove", "camera"])?;
    assert!(ok, "{err}");
    assert!(out.contains("r2: no capabilities") && out.contains("r2 left mission p"), "{out}");
    eventually("p without r2, and r2 idle without a camera", Duration::from_secs(10), || async {
        let m = mission(&client).await?;
        let r2 = robot(&client, "r2").await?;
        (m.robots == ["r1", "r3"] && r2.mission.is_none() && r2.capabilities.is_empty() && r2.behaviour.as_deref() == Some("hold")).then_some(())
    })
    .await?;
    // Not critical: it waits out the operator's busy window (10 s after their last command).
    let advice = common::wait_raised(&live, "capability/r2", Duration::from_secs(20)).await?;
    assert!(advice.reason.starts_with("robot r2 no longer has camera, which mission p requires: it left the mission"), "{}", advice.reason);
    // The patrol goes on with two.
    eventually("p passing sync points with r1 and r3", Duration::from_secs(30), passed(before + 3)).await?;

    // r4 is fitted with a camera: it may join now.
    let (ok, out, err) = op(&ep, &["capabilities", "r4", "--add", "camera"])?;
    assert!(ok && out.contains("r4: camera, lidar"), "{out}{err}");
    let (ok, out, err) = op(&ep, &["move", "r4", "p"])?;
    assert!(ok, "{out}{err}");
    eventually("r4 in p", Duration::from_secs(15), || async { mission(&client).await.filter(|m| m.robots == ["r1", "r3", "r4"]) }).await?;
    // A bad name is refused by central, naming the problem.
    let (ok, _, err) = op(&ep, &["capabilities", "r1", "--add", "night vision"])?;
    assert!(!ok && err.contains("bad capability \"night vision\""), "{err}");

    // r3 restarts with a config without a camera: as it registers again, it leaves p.
    robots[2].kill();
    eventually("r3 lost", Duration::from_secs(10), || async { robot(&client, "r3").await.filter(|r| r.status == proto::RobotStatus::Lost) }).await?;
    robots[2] = start_robot_with_caps(&dir, "r3", &ep, 6.0, "[]")?;
    let m = eventually("p without r3", Duration::from_secs(15), || async {
        let r3 = robot(&client, "r3").await?;
        let m = mission(&client).await?;
        (r3.status != proto::RobotStatus::Lost && r3.mission.is_none() && m.robots == ["r1", "r4"]).then_some(m)
    })
    .await?;
    eventually("p passing sync points with r1 and r4", Duration::from_secs(30), passed(m.metrics.sync_points_passed + 3)).await?;

    // The journal says who did what.
    let journal = common::journal(&client).await?;
    let text: Vec<String> = journal.iter().map(|e| serde_json::to_string(&e.event).unwrap_or_default()).collect();
    assert!(text.iter().any(|t| t.contains("robot capabilities") && t.contains("\"operator\"")), "{text:?}");
    assert!(text.iter().any(|t| t.contains("\"central\"") && t.contains("robot \\\"r3\\\" lacks camera")), "{text:?}");
    client.close().await;
    Ok(())
}

/// A robot with a state dir keeps its changed capabilities across a power cycle (SIGKILL and a
/// restart), until its config's list changes.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn changed_capabilities_survive_a_restart_with_a_state_dir() -> anyhow::Result<()> {
    let dir = Scratch::new("capabilities-kept");
    let (_central, ep) = start_central(&dir)?;
    let state = dir.path("r1-state");
    std::fs::create_dir_all(&state)?;
    let config = robot_config(&dir, "r1", std::slice::from_ref(&ep), 0.0, -3.0, 10.0)?;
    let config_s = config.display().to_string();
    let state_s = state.display().to_string();
    let start_r1 = || start("r1", &["robot", "--config", &config_s, "--state-dir", &state_s], &dir.path("r1.log"), "robot ready", Duration::from_secs(20));
    let mut r1 = start_r1()?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 1).await?;
    let caps = |want: Vec<&'static str>| {
        let client = &client;
        move || {
            let want = want.clone();
            async move { robot(client, "r1").await.filter(|r| r.status != proto::RobotStatus::Lost && r.capabilities == want) }
        }
    };
    let (ok, out, err) = op(&ep, &["capabilities", "r1", "--remove", "camera", "--add", "thermal"])?;
    assert!(ok && out.contains("r1: thermal"), "{out}{err}");
    r1.kill();
    eventually("r1 lost", Duration::from_secs(10), || async { robot(&client, "r1").await.filter(|r| r.status == proto::RobotStatus::Lost) }).await?;
    r1 = start_r1()?;
    eventually("r1 back with what it was left with", Duration::from_secs(15), caps(vec!["thermal"])).await?;
    // Its config now says something else (the camera was repaired): the config wins.
    r1.kill();
    eventually("r1 lost again", Duration::from_secs(10), || async { robot(&client, "r1").await.filter(|r| r.status == proto::RobotStatus::Lost) }).await?;
    std::fs::write(&config, std::fs::read_to_string(&config)?.replace(r#"capabilities: ["camera"]"#, r#"capabilities: ["camera", "gripper"]"#))?;
    let _r1 = start_r1()?;
    eventually("r1 back with its config's capabilities", Duration::from_secs(15), caps(vec!["camera", "gripper"])).await?;
    client.close().await;
    Ok(())
}

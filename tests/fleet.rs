//! The walking skeleton with real processes: central + 3 robots on loopback; registration,
//! commands, loss by SIGKILL and by freezing, recovery, and bad input.

mod common;

use std::time::{Duration, Instant};

use common::{eventually, start_central, start_robot, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, GotoRequest, RobotStatus, RobotView, SystemStatus};
use serde_json::Value;

async fn robots(c: &Client) -> Vec<RobotView> {
    c.query(proto::Key::SystemRobots, None::<&()>).await.unwrap_or_default()
}

async fn status_of(c: &Client, id: &str) -> Option<RobotStatus> {
    c.query::<RobotView>(proto::Key::SystemRobot(id.into()), None::<&()>).await.ok().map(|v| v.status)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fleet_registers_moves_and_detects_loss() -> anyhow::Result<()> {
    let dir = Scratch::new("fleet");
    let (_central, ep) = start_central(&dir)?;
    let t0 = Instant::now();
    let mut r1 = start_robot(&dir, "r1", &ep, 0.0, 0.0)?;
    let r2 = start_robot(&dir, "r2", &ep, 2.0, 0.0)?;
    let mut r3 = start_robot(&dir, "r3", &ep, 4.0, 0.0)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(2)).await?;

    // Registration through the operator API.
    let views = eventually("3 registered robots with telemetry", Duration::from_secs(15), || async {
        let v = robots(&client).await;
        (v.len() == 3 && v.iter().all(|r| r.status == RobotStatus::Idle && r.pose.is_some())).then_some(v)
    })
    .await?;
    println!("registration: 3 robots visible {:?} after spawn", t0.elapsed());
    assert_eq!(views.iter().map(|v| v.id.as_str()).collect::<Vec<_>>(), ["r1", "r2", "r3"]);
    assert_eq!(views[1].robot_type, "ground");
    assert_eq!(views[1].capabilities, ["camera"]);
    let st: SystemStatus = client.query(proto::Key::SystemStatus, None::<&()>).await?;
    assert_eq!((st.robots_total, st.idle, st.lost), (3, 3, 0));

    // goto: the pose arrives.
    let ack: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Goto), Some(&GotoRequest { robot: "r1".into(), x: 3.0, y: 4.0, map: None })).await?;
    assert_eq!(ack["ok"], true);
    eventually("r1 at (3, 4) and idle", Duration::from_secs(20), || async {
        let v: RobotView = client.query(proto::Key::SystemRobot("r1".into()), None::<&()>).await.ok()?;
        let p = v.pose?;
        let near = ((p.x - 3.0).powi(2) + (p.y - 4.0).powi(2)).sqrt() < 0.1;
        (near && v.status == RobotStatus::Idle).then_some(())
    })
    .await?;

    // Bad input: unknown robot, garbage request, garbage telemetry; central keeps answering.
    let e = client
        .query::<Value>(proto::Key::SystemCmd(proto::SystemCmd::Goto), Some(&GotoRequest { robot: "nope".into(), x: 0.0, y: 0.0, map: None }))
        .await
        .expect_err("unknown robot");
    assert!(e.to_string().contains("unknown robot \"nope\""), "{e}");
    let e = client.query::<Value>(proto::Key::SystemCmd(proto::SystemCmd::Goto), Some(&"hello")).await.expect_err("garbage");
    assert!(e.to_string().contains("goto request"), "{e}");
    let e = client.query::<Value>(proto::Key::SystemRobot("nope".into()), None::<&()>).await.expect_err("unknown");
    assert!(e.to_string().contains("unknown robot"), "{e}");
    client.session().put(proto::Key::RobotTelemetry("r2".into()).to_string(), b"\xff\x00garbage".to_vec()).await.map_err(|e| anyhow::anyhow!("{e}"))?;
    client.session().put(proto::Key::RobotTelemetry("r2".into()).to_string(), b"MRM1\x05\x05".to_vec()).await.map_err(|e| anyhow::anyhow!("{e}"))?;
    assert_eq!(robots(&client).await.len(), 3, "central still answers after garbage");

    // SIGKILL: lost.
    let killed = Instant::now();
    r3.kill();
    eventually("r3 lost", Duration::from_secs(10), || async { (status_of(&client, "r3").await == Some(RobotStatus::Lost)).then_some(()) }).await?;
    println!("loss detection after SIGKILL: {:?}", killed.elapsed());

    // SIGSTOP: lost after the lease; SIGCONT: back, re-registered.
    let frozen = Instant::now();
    r2.signal("STOP")?;
    eventually("r2 lost while frozen", Duration::from_secs(10), || async { (status_of(&client, "r2").await == Some(RobotStatus::Lost)).then_some(()) }).await?;
    println!("loss detection after SIGSTOP: {:?}", frozen.elapsed());
    r2.signal("CONT")?;
    let thawed = Instant::now();
    eventually("r2 back after SIGCONT", Duration::from_secs(20), || async { (status_of(&client, "r2").await == Some(RobotStatus::Idle)).then_some(()) })
        .await?;
    println!("re-registration after SIGCONT: {:?}", thawed.elapsed());

    // A goto to a lost robot is refused.
    let e = client
        .query::<Value>(proto::Key::SystemCmd(proto::SystemCmd::Goto), Some(&GotoRequest { robot: "r3".into(), x: 0.0, y: 0.0, map: None }))
        .await
        .expect_err("lost");
    assert!(e.to_string().contains("lost"), "{e}");
    let st: SystemStatus = client.query(proto::Key::SystemStatus, None::<&()>).await?;
    assert_eq!((st.robots_total, st.lost), (3, 1));

    r1.kill();
    client.close().await;
    Ok(())
}

#[test]
fn bad_config_stops_start_up_with_one_line() -> anyhow::Result<()> {
    let dir = Scratch::new("badcfg");
    let path = dir.path("bad.json5");
    std::fs::write(&path, r#"{ id: "r1", type: "ground", kinematics: { max_speed: -2, max_turn_rate: 1 } }"#)?;
    let out = std::process::Command::new(common::EXE).args(["robot", "--config"]).arg(&path).output()?;
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "one line: {err}");
    assert!(lines[0].contains("bad.json5: kinematics.max_speed: must be"), "{err}");

    let out = std::process::Command::new(common::EXE).args(["robot", "--config", "/nonexistent/robot.json5"]).output()?;
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/robot.json5: cannot read"));

    let central = dir.path("central.json5");
    std::fs::write(&central, r#"{ agent: { autonomy: "yolo" } }"#)?;
    let out = std::process::Command::new(common::EXE).args(["central", "--config"]).arg(&central).output()?;
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("central.json5: agent.autonomy: unknown variant `yolo`"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");

    let out = std::process::Command::new(common::EXE).args(["central", "--listen", "udp/127.0.0.1:1"]).output()?;
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("listen[0]"));
    Ok(())
}

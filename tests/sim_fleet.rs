//! `mrmm sim-fleet`: many robots in one process, each its own peer. They register one by one, run
//! a mission, and are crashed and started again one at a time from stdin: the crashed robot is
//! lost (its mission replans without it), the others are not, and it comes back.

mod common;

use std::io::Write;
use std::time::Duration;

use common::{eventually, start_central, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, JournalEvent, MissionView, RobotStatus, RobotView};

async fn status_of(client: &Client, id: &str) -> Option<RobotStatus> {
    let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await.ok()?;
    v.into_iter().find(|r| r.id == id).map(|r| r.status)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn robots_of_one_process_are_peers_of_their_own_and_crash_one_by_one() -> anyhow::Result<()> {
    let dir = Scratch::new("sim-fleet");
    let (_central, ep) = start_central(&dir)?;
    let template = dir.path("r.json5");
    std::fs::write(
        &template,
        format!(
            r#"{{ id: "r", type: "ground", capabilities: ["camera"], kinematics: {{ max_speed: 1.0, max_turn_rate: 1.5 }},
                 start: {{ x: 0, y: -3 }}, time_scale: 10, zenoh: {{ listen: ["tcp/127.0.0.1:0"], connect: ["{ep}"] }} }}"#
        ),
    )?;
    let template = template.display().to_string();
    let (mut fleet, mut stdin, lines) = common::start_piped(
        "sim-fleet",
        &["sim-fleet", "--config", &template, "--robots", "5", "--spacing", "2", "--rate", "0"],
        &dir.path("fleet.log"),
        "sim-fleet ready",
        Duration::from_secs(60),
    )?;
    assert_eq!(fleet.ready, "sim-fleet ready robots=5");
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    let views = common::wait_robots(&client, 5).await?;
    let mut ids: Vec<&str> = views.iter().map(|v| v.id.as_str()).collect();
    ids.sort();
    assert_eq!(ids, ["r1", "r2", "r3", "r4", "r5"]);
    // Each its own start pose on the template's grid (3 wide, 2 m).
    let r4 = views.iter().find(|v| v.id == "r4").and_then(|v| v.pose).expect("r4 pose");
    assert!((r4.x - 0.0).abs() < 0.5 && (r4.y - -1.0).abs() < 0.5, "r4 starts on the grid's second row: {r4:?}");

    // A patrol of three of them; every robot is also a mission host (the chain lives among them).
    let _: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&common::square_patrol(3, None))).await?;
    let before = eventually("the patrol passing sync points", Duration::from_secs(40), || async {
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.metrics.sync_points_passed >= 1).then_some(m)
    })
    .await?;
    let victim = before.robots[1].clone();

    // Crash one member from stdin: it is lost, its mission plans for the two left.
    writeln!(stdin, "kill {victim}")?;
    let killed = lines.recv_timeout(Duration::from_secs(10))?;
    assert_eq!(killed, format!("robot killed id={victim}"));
    eventually("the crashed robot lost", Duration::from_secs(10), || async {
        (status_of(&client, victim.as_str()).await == Some(RobotStatus::Lost)).then_some(())
    })
    .await?;
    eventually("the patrol planned without it", Duration::from_secs(30), || async {
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.plans.as_ref().is_some_and(|p| p.len() == 2 && p.iter().all(|r| r.robot != victim)) && m.manager.epoch > before.manager.epoch).then_some(())
    })
    .await?;

    // Started again: it registers anew; nobody else was ever lost.
    writeln!(stdin, "start {victim}")?;
    let again = lines.recv_timeout(Duration::from_secs(20))?;
    assert!(again.starts_with(&format!("robot ready id={victim} ")), "{again}");
    eventually("the robot back", Duration::from_secs(15), || async {
        status_of(&client, victim.as_str()).await.is_some_and(|s| s != RobotStatus::Lost).then_some(())
    })
    .await?;
    let lost: Vec<String> = common::journal(&client)
        .await?
        .into_iter()
        .filter_map(|e| match e.event {
            JournalEvent::RobotLost { robot } => Some(robot.to_string()),
            _ => None,
        })
        .collect();
    assert_eq!(lost, vec![victim.clone()], "only the crashed robot was ever lost");

    // Crashed from the operator API (through central): it answers, then stops; it is lost and
    // the process runs on without it.
    let other = ["r1", "r2", "r3", "r4", "r5"].into_iter().find(|r| !before.robots.iter().any(|m| m == r)).expect("a robot outside the patrol");
    let ack: proto::CommandAck = client.query(proto::Key::SystemCmd(proto::SystemCmd::Crash), Some(&proto::CrashRequest { robot: other.into() })).await?;
    assert_eq!(ack.robot, other);
    assert_eq!(lines.recv_timeout(Duration::from_secs(10))?, format!("robot crashed id={other}"));
    eventually("the robot crashed by the operator lost", Duration::from_secs(10), || async {
        (status_of(&client, other).await == Some(RobotStatus::Lost)).then_some(())
    })
    .await?;
    writeln!(stdin, "list")?;
    let running = lines.recv_timeout(Duration::from_secs(10))?;
    assert!(running.starts_with("running ids=") && !running.contains(other) && running.split(',').count() == 4, "{running}");
    writeln!(stdin, "start {other}")?;
    assert!(lines.recv_timeout(Duration::from_secs(20))?.starts_with(&format!("robot ready id={other} ")));

    // `list` names the robots running; SIGTERM stops them all and the process.
    writeln!(stdin, "list")?;
    assert_eq!(lines.recv_timeout(Duration::from_secs(10))?, "running ids=r1,r2,r3,r4,r5");
    fleet.signal("TERM")?;
    let status = common::wait_exit(&mut fleet, Duration::from_secs(20)).await?;
    assert!(status.success(), "sim-fleet exit status {status}");
    client.close().await;
    Ok(())
}

/// A secure fleet: the template has QUIC endpoints and no `security` section; `--pki` gives each
/// robot its own certificate, and central admits each under its own id.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn secure_robots_of_one_process_each_prove_their_own_id() -> anyhow::Result<()> {
    let dir = Scratch::new("sim-fleet-secure");
    let pki = common::fleet_pki(&dir, 3)?;
    let (_central, ep) = common::start_secure_central(&dir, &pki)?;
    let template = dir.path("r.json5");
    std::fs::write(
        &template,
        format!(
            r#"{{ id: "r", type: "ground", kinematics: {{ max_speed: 1.0, max_turn_rate: 1.5 }},
                 zenoh: {{ listen: ["quic/127.0.0.1:0"], connect: ["{ep}"] }} }}"#
        ),
    )?;
    let (template, pki_arg) = (template.display().to_string(), pki.display().to_string());
    let (mut fleet, _stdin, _lines) = common::start_piped(
        "sim-fleet",
        &["sim-fleet", "--config", &template, "--robots", "3", "--rate", "0", "--pki", &pki_arg],
        &dir.path("fleet.log"),
        "sim-fleet ready",
        Duration::from_secs(60),
    )?;
    let op = Client::connect_with(std::slice::from_ref(&ep), Some(proto::SecuritySection::from_dir(&pki, "op")), Duration::from_secs(5)).await?;
    let views = common::wait_robots(&op, 3).await?;
    let mut ids: Vec<&str> = views.iter().map(|v| v.id.as_str()).collect();
    ids.sort();
    assert_eq!(ids, ["r1", "r2", "r3"]);
    fleet.signal("TERM")?;
    assert!(common::wait_exit(&mut fleet, Duration::from_secs(20)).await?.success());
    op.close().await;
    Ok(())
}

#[test]
fn a_bad_sim_fleet_command_line_stops_start_up_with_one_line() -> anyhow::Result<()> {
    let dir = Scratch::new("sim-fleet-bad");
    let robot = |id: &str, port: u16| {
        format!(
            r#"{{ id: "{id}", type: "ground", kinematics: {{ max_speed: 1, max_turn_rate: 1 }}, zenoh: {{ listen: ["tcp/127.0.0.1:{port}"], connect: ["tcp/127.0.0.1:9"] }} }}"#
        )
    };
    let (a, b, c) = (dir.path("a.json5"), dir.path("b.json5"), dir.path("c.json5"));
    std::fs::write(&a, robot("same", 0))?;
    std::fs::write(&b, robot("same", 0))?;
    std::fs::write(&c, robot("fixed", 7599))?;
    let (a, b, c) = (a.display().to_string(), b.display().to_string(), c.display().to_string());
    // A bad value is named with its file, no override claimed when there is none.
    let d = dir.path("d.json5");
    std::fs::write(&d, r#"{ id: "slow", type: "ground", kinematics: { max_speed: -1, max_turn_rate: 1 } }"#)?;
    let d = d.display().to_string();
    let bad_speed = format!("{d}: robot slow: kinematics.max_speed: must be a number in [0.01, 1000] (got -1)");
    for (args, wanted) in [
        (vec!["--config", &d], bad_speed.as_str()),
        (vec!["--config", &a, "--config", &b], "robot same: two configs give this id; every robot needs its own"),
        (vec!["--config", &a, "--config", &b, "--robots", "3"], "--robots takes one --config, the template (got 2)"),
        (vec!["--config", &a, "--robots", "3", "--spacing", "0"], "--spacing: must be a positive number of metres (got 0)"),
        (vec!["--config", &c, "--robots", "2"], "robot fixed2: zenoh.listen tcp/127.0.0.1:7599 is robot fixed1's too: give each robot its own port, or port 0"),
    ] {
        let out = std::process::Command::new(common::EXE).arg("sim-fleet").args(&args).output()?;
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} started");
        assert_eq!(err.trim(), format!("mrmm: {wanted}"), "{args:?}");
    }
    Ok(())
}

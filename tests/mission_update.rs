//! A running mission updated, paused and resumed by the operator (issue 33, items 4-5): new
//! waypoints are replanned as the next epoch for the same members (a new, longer tour); paused,
//! every member holds where it is (no barrier passes); the pause survives a SIGKILL and restart of
//! central (its journal holds it); resumed, the team forms again and its barriers pass.

mod common;

use std::collections::BTreeMap;
use std::time::Duration;

use common::{eventually, start, Proc, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, MissionCreate, MissionPause, MissionStatus, MissionUpdate, MissionView, PlanSummary, RobotView};
use serde_json::{json, Value};

fn free_port() -> anyhow::Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
}

fn central(dir: &Scratch, ep: &str, log: &str) -> anyhow::Result<Proc> {
    let state = dir.path("central-state").display().to_string();
    start("central", &["central", "--listen", ep, "--state-dir", &state], &dir.path(log), "central ready", Duration::from_secs(20))
}

async fn mission(c: &Client) -> Option<MissionView> {
    c.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()
}

fn tour_length(m: &MissionView) -> f64 {
    match &m.summary {
        Some(PlanSummary::Patrol(p)) => p.length,
        _ => 0.0,
    }
}

/// Where each robot is, as central says.
async fn poses(c: &Client) -> BTreeMap<String, (f64, f64, String)> {
    let rs: Vec<RobotView> = c.query(proto::Key::SystemRobots, None::<&()>).await.unwrap_or_default();
    rs.into_iter().filter_map(|r| Some((r.id.to_string(), (r.pose?.x, r.pose?.y, r.behaviour.unwrap_or_default())))).collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn update_pause_restart_and_resume() -> anyhow::Result<()> {
    let dir = Scratch::new("update");
    let ep = format!("tcp/127.0.0.1:{}", free_port()?);
    let mut c = central(&dir, &ep, "central.log")?;
    let _robots = common::start_robots(&dir, &ep, 3)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 3).await?;
    let cmd = |c| proto::Key::SystemCmd(c);
    let create = MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        robots: Some(vec!["r1".into(), "r2".into(), "r3".into()]),
        params: [("waypoints".to_string(), json!([[0, 0], [10, 0], [10, 10], [0, 10]]))].into(),
        ..Default::default()
    };
    let _: MissionView = client.query(cmd(proto::SystemCmd::Create), Some(&create)).await?;
    let before = eventually("the patrol past its first barriers", Duration::from_secs(30), || async {
        mission(&client).await.filter(|m| m.metrics.sync_points_passed >= 2)
    })
    .await?;
    assert!((tour_length(&before) - 40.0).abs() < 1e-6);

    // New waypoints: the same members, the next epoch, the new tour.
    let update =
        MissionUpdate { name: "p".into(), params: [("waypoints".to_string(), json!([[0, 0], [20, 0], [20, 20], [0, 20]]))].into(), ..Default::default() };
    let v: Value = client.query(cmd(proto::SystemCmd::Update), Some(&update)).await?;
    assert_eq!(v["changed"], true, "{v}");
    let updated = eventually("the new tour planned", Duration::from_secs(20), || async {
        mission(&client).await.filter(|m| (tour_length(m) - 80.0).abs() < 1e-6 && m.manager.epoch > before.manager.epoch)
    })
    .await?;
    assert_eq!(updated.robots, before.robots, "no robot released");
    assert_eq!(updated.params["waypoints"], "[[0,0],[20,0],[20,20],[0,20]]");
    // A bad update is refused in words and changes nothing.
    let bad = MissionUpdate { name: "p".into(), params: [("waypoints".to_string(), json!([[0, 0]]))].into(), ..Default::default() };
    let e = client.query::<Value>(cmd(proto::SystemCmd::Update), Some(&bad)).await.expect_err("one waypoint");
    assert!(e.to_string().contains("at least 2 points"), "{e}");

    // Pause: every member holds where it is.
    let _: Value = client.query(cmd(proto::SystemCmd::Pause), Some(&MissionPause { name: "p".into() })).await?;
    let paused =
        eventually("the mission paused", Duration::from_secs(20), || async { mission(&client).await.filter(|m| m.status == MissionStatus::Paused) }).await?;
    // Holding, and still: the same poses over ten polls in a row (the status says paused as soon
    // as the head decided; the hold plans reach the robots a moment later).
    let last = std::cell::RefCell::new((BTreeMap::new(), 0u32));
    let held = eventually("every member holding still", Duration::from_secs(10), || async {
        let p = poses(&client).await;
        let mut l = last.borrow_mut();
        let same = p.len() == 3
            && p.values().all(|(_, _, b)| b.ends_with("hold"))
            && p.iter().all(|(id, (x, y, _))| l.0.get(id).is_some_and(|(a, b, _): &(f64, f64, String)| (a - x).hypot(b - y) < 0.01));
        l.1 = if same { l.1 + 1 } else { 0 };
        l.0 = p.clone();
        (l.1 >= 10).then_some(p)
    })
    .await?;
    // Central dies and comes back from its journal: the mission is still paused.
    c.kill();
    c = central(&dir, &ep, "central2.log")?;
    let _ = &c;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    let after = eventually("the paused mission back after central's restart", Duration::from_secs(30), || async {
        mission(&client).await.filter(|m| m.status == MissionStatus::Paused && m.robots.len() == 3)
    })
    .await?;
    assert!(
        after.metrics.sync_points_passed <= paused.metrics.sync_points_passed + 3,
        "no barrier while paused: {} then {}",
        paused.metrics.sync_points_passed,
        after.metrics.sync_points_passed
    );
    let still = poses(&client).await;
    for (id, (x, y, b)) in &held {
        let (x2, y2, b2) = &still[id];
        assert!((x - x2).hypot(y - y2) < 0.2 && b2.ends_with("hold") && b.ends_with("hold"), "{id} moved while paused: ({x}, {y}) → ({x2}, {y2}) {b2}");
    }

    // Resumed: the team forms again and passes barriers.
    let _: Value = client.query(cmd(proto::SystemCmd::Resume), Some(&MissionPause { name: "p".into() })).await?;
    let resumed =
        eventually("the mission running again", Duration::from_secs(20), || async { mission(&client).await.filter(|m| m.status == MissionStatus::Running) })
            .await?;
    eventually("barriers passing again", Duration::from_secs(30), || async {
        mission(&client).await.filter(|m| m.metrics.sync_points_passed >= 2 && m.manager.epoch > resumed.manager.epoch - 1)
    })
    .await?;
    let journal = common::journal(&client).await?;
    let commands: Vec<String> =
        journal.iter().filter_map(|e| if let proto::JournalEvent::Command { command, .. } = &e.event { Some(command.clone()) } else { None }).collect();
    for want in ["mission update", "mission pause", "mission resume"] {
        assert!(commands.iter().any(|c| c == want), "{want} journaled: {commands:?}");
    }
    client.close().await;
    Ok(())
}

//! Missions end to end with real processes, observed through the operator API only: central +
//! 6 robots; a patrol of 4 and a coverage of 2; the patrol completes a round with sync; a robot
//! moves to the coverage (both replan); a patrol robot is killed (the rest go on without it); the
//! coverage is terminated (its robots are idle again).

mod common;

use std::time::{Duration, Instant};

use common::{eventually, start_central, start_robot_scaled, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, MissionCreate, MissionTerminate, MissionView, RobotMove, RobotStatus, RobotView};
use serde_json::{json, Value};

async fn mission(c: &Client, name: &str) -> Option<MissionView> {
    c.query(proto::Key::SystemMission(name.into()), None::<&()>).await.ok()
}

async fn robots(c: &Client) -> Vec<RobotView> {
    c.query(proto::Key::SystemRobots, None::<&()>).await.unwrap_or_default()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_missions_repartitioned_live() -> anyhow::Result<()> {
    let dir = Scratch::new("missions");
    let (_central, ep) = start_central(&dir)?;
    let mut procs = Vec::new();
    for i in 1..=6 {
        procs.push(start_robot_scaled(&dir, &format!("r{i}"), &ep, i as f64 * 2.0, -4.0, 10.0)?);
    }
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    eventually("6 idle robots", Duration::from_secs(15), || async {
        let v = robots(&client).await;
        (v.len() == 6 && v.iter().all(|r| r.status == RobotStatus::Idle && r.pose.is_some())).then_some(())
    })
    .await?;

    // Create: a patrol of 4 on a 10 m square, a coverage of 2.
    let t_create = Instant::now();
    let patrol = MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        robots: Some(vec!["r1".into(), "r2".into(), "r3".into(), "r4".into()]),
        params: [("waypoints".to_string(), json!([[0, 0], [10, 0], [10, 10], [0, 10]]))].into(),
        ..MissionCreate::default()
    };
    let created: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&patrol)).await?;
    assert_eq!(created.robots, ["r1", "r2", "r3", "r4"]);
    eventually("all patrol robots moving", Duration::from_secs(10), || async {
        let v = robots(&client).await;
        let moving = v
            .iter()
            .filter(|r| r.mission.as_ref().map(|x| x.as_str()) == Some("p") && r.behaviour.as_deref().is_some_and(|b| b.contains("goto") || b.contains("sync")))
            .count();
        (moving == 4).then_some(())
    })
    .await?;
    println!("create → all 4 robots executing their plans: {:?}", t_create.elapsed());
    let coverage = MissionCreate {
        name: "c".into(),
        recipe: "coverage".into(),
        robots: Some(vec!["r5".into(), "r6".into()]),
        params: [("region".to_string(), json!([[-30, -30], [-10, -30], [-10, -10], [-30, -10]]))].into(),
        ..MissionCreate::default()
    };
    let c: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&coverage)).await?;
    assert_eq!(c.summary.as_ref().and_then(|s| s.coverage()).map(|c| c.points.len()), Some(2));

    // The patrol completes a round with sync: start barrier + 4 per round.
    let p = eventually("a full patrol round with its sync points", Duration::from_secs(40), || async {
        let m = mission(&client, "p").await?;
        (m.metrics.rounds >= 1 && m.metrics.sync_points_passed >= 5).then_some(m)
    })
    .await?;
    assert_eq!(p.manager.epoch, 1);
    assert!(p.metrics.visits.iter().all(|&v| v >= 1), "every waypoint visited: {:?}", p.metrics.visits);
    assert!(p.metrics.messages["sync"] >= 20, "{:?}", p.metrics.messages);
    let predicted = p.summary.as_ref().and_then(|s| s.patrol()).map_or(0.0, |p| p.predicted_worst_idleness);
    println!("patrol round: worst idleness {:?} s, average {:?} s, predicted {predicted} s", p.metrics.worst_idleness, p.metrics.avg_idleness);

    // Move r4 to the coverage: patrol replanned to 3 evenly spaced, coverage to 3 points.
    let moved: Value =
        client.query(proto::Key::SystemCmd(proto::SystemCmd::Move), Some(&RobotMove { robot: "r4".into(), to: Some("c".into()), replaces: None })).await?;
    assert_eq!(moved["from"], "p");
    let p = eventually("patrol replanned for 3", Duration::from_secs(10), || async {
        let m = mission(&client, "p").await?;
        (m.robots.len() == 3 && m.manager.epoch == 2 && m.plans.as_ref().is_some_and(|p| p.len() == 3)).then_some(m)
    })
    .await?;
    let summary = p.summary.as_ref().and_then(|s| s.patrol()).cloned().ok_or_else(|| anyhow::anyhow!("no patrol summary"))?;
    // Spaced a third of a round apart in time: 40 m and four right-angle corners rounded at the
    // robots' 2 rad/s (the robots say their turn rate when they register; the planner counts
    // each corner's arc, less the legs' ends it cuts).
    let (length, spacing) = (summary.length, summary.spacing);
    let corner = mrmm_planner::corner::Blend::through(std::f64::consts::FRAC_PI_2, 5.0, 5.0, (1.0, 1.0), 2.0).expect("rounded");
    let round = 40.0 + 4.0 * (corner.seconds() - 2.0 * corner.tangent);
    assert!((length - 40.0).abs() < 1e-6 && (spacing - round / 3.0).abs() < 1e-6, "L {length}, spacing {spacing}");
    assert!((summary.predicted_worst_idleness - round / 3.0).abs() < 1e-6, "{}", summary.predicted_worst_idleness);
    let c = eventually("coverage replanned for 3", Duration::from_secs(10), || async {
        let m = mission(&client, "c").await?;
        (m.robots == ["r4", "r5", "r6"] && m.summary.as_ref().and_then(|s| s.coverage()).map(|c| c.points.len()) == Some(3)).then_some(m)
    })
    .await?;
    assert_eq!(c.manager.epoch, 2);
    eventually("r4 executing the coverage plan", Duration::from_secs(10), || async {
        let v: RobotView = client.query(proto::Key::SystemRobot("r4".into()), None::<&()>).await.ok()?;
        (v.mission.as_ref().map(|x| x.as_str()) == Some("c") && v.behaviour.as_deref().is_some_and(|b| b.starts_with("step"))).then_some(())
    })
    .await?;

    // Kill a patrol robot: replanned to 2, and the two go on through their barriers.
    let killed = Instant::now();
    procs[0].kill();
    eventually("patrol replanned for 2 after the loss", Duration::from_secs(10), || async {
        let m = mission(&client, "p").await?;
        (m.robots == ["r2", "r3"] && m.manager.epoch == 3 && m.plans.as_ref().is_some_and(|p| p.len() == 2)).then_some(())
    })
    .await?;
    println!("robot SIGKILL → patrol replanned for the other 2: {:?}", killed.elapsed());
    eventually("the 2 survivors pass barriers of the new plan", Duration::from_secs(40), || async {
        let m = mission(&client, "p").await?;
        (m.metrics.sync_points_passed >= 3).then_some(())
    })
    .await?;

    // Terminate the coverage: its robots are idle again.
    let t: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Terminate), Some(&MissionTerminate { name: "c".into() })).await?;
    assert_eq!(t["robots"], json!(["r4", "r5", "r6"]));
    eventually("coverage robots idle", Duration::from_secs(10), || async {
        let v = robots(&client).await;
        let idle = v.iter().filter(|r| ["r4", "r5", "r6"].contains(&r.id.as_str()) && r.status == RobotStatus::Idle && r.mission.is_none()).count();
        (idle == 3).then_some(())
    })
    .await?;
    let missions: Vec<MissionView> = client.query(proto::Key::SystemMissions, None::<&()>).await?;
    assert_eq!(missions.iter().map(|m| m.name.as_str()).collect::<Vec<_>>(), ["p"]);
    // The end reached the coverage's replicas: none of them takes the dead mission over (a
    // replica that never heard of the end would stand after 3 s of silence).
    let statuses = client.session().declare_subscriber(proto::Key::MissionStatus("c".into()).to_string()).await.map_err(|e| anyhow::anyhow!("{e}"))?;
    let zombie = tokio::time::timeout(Duration::from_secs(5), statuses.recv_async()).await;
    assert!(zombie.is_err(), "a terminated mission came back: {zombie:?}");
    client.close().await;
    Ok(())
}

//! A mission managed on another node: `mrmm mission-host --name h2` in its own process runs the
//! mission's manager (plans, barriers, metrics, marginal benefit). Its state is replicated on two
//! of its robots: when h2 is SIGKILLed, the first replica takes over with a higher chain epoch,
//! the robots go on, and the operator reaches the manager on its new node.

mod common;

use std::time::Duration;

use common::{eventually, start, start_central, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, Marginal, MissionStatus, MissionView, RobotView};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_mission_hosted_by_another_process() -> anyhow::Result<()> {
    let dir = Scratch::new("host");
    let (_central, ep) = start_central(&dir)?;
    let mut host = common::start_host(&dir, "h2", &ep)?;
    let _robots = common::start_robots(&dir, &ep, 3)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 3).await?;
    let create = common::square_patrol(3, Some("h2"));
    // The system manager learns of h2 through its liveliness token.
    let created = eventually("the mission created on h2", Duration::from_secs(15), || async {
        client.query::<MissionView>(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&create)).await.ok()
    })
    .await?;
    assert_eq!(created.manager.node, "h2");
    eventually("the team passing barriers under h2's manager", Duration::from_secs(30), || async {
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.metrics.sync_points_passed >= 2 && m.plans.as_ref().is_some_and(|p| p.len() == 3)).then_some(())
    })
    .await?;
    let g: Marginal = client.query(proto::keys::marginal_selector("p", 1), None::<&()>).await?;
    assert_eq!((g.robots, g.with_robots), (3, 4));
    assert!(g.predicted < g.current);
    let bad = client.query::<Marginal>(format!("{}?add=zero", proto::Key::MissionMarginal("p".into())), None::<&()>).await;
    assert!(bad.expect_err("bad add").to_string().contains("add=zero"));

    // Visits counted so far, then two more barriers (seconds: the metrics are checkpointed into
    // the chain once a second), so the replicas hold at least these.
    let counted = eventually("waypoints visited", Duration::from_secs(30), || async {
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        let n: u32 = m.metrics.visits.iter().sum();
        (n >= 2).then_some((n, m.metrics.sync_points_passed))
    })
    .await?;
    eventually("two more barriers", Duration::from_secs(30), || async {
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.metrics.sync_points_passed >= counted.1 + 2).then_some(())
    })
    .await?;
    let before: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await?;
    assert_eq!(before.manager.chain.len(), 3, "head and two replicas: {:?}", before.manager);
    assert_eq!(before.manager.chain[0], "h2");
    let successor = before.manager.chain[1].clone();
    // Watch the mission's status publications: the first one from another node is the takeover.
    let statuses = client.session().declare_subscriber(proto::Key::MissionStatus("p".into()).to_string()).await.map_err(|e| anyhow::anyhow!("{e}"))?;
    host.kill();
    let killed = std::time::Instant::now();
    let took_over = tokio::time::timeout(Duration::from_secs(10), async {
        loop {
            let s = statuses.recv_async().await.ok()?;
            let v: MissionView = serde_json::from_slice(&s.payload().to_bytes()).ok()?;
            if v.manager.node != "h2" {
                return Some(v);
            }
        }
    })
    .await
    .ok()
    .flatten()
    .ok_or_else(|| anyhow::anyhow!("no replica took the mission over"))?;
    println!("takeover: {} ms after SIGKILL of the head, by {}", killed.elapsed().as_millis(), took_over.manager.node);
    assert_eq!(took_over.manager.node, successor, "the first live successor takes over");
    assert!(took_over.manager.chain_epoch > before.manager.chain_epoch);
    assert_eq!(took_over.robots.len(), 3);
    assert_eq!(took_over.manager.epoch, before.manager.epoch, "same plans: the robots are not disturbed");
    let kept: u32 = took_over.metrics.visits.iter().sum();
    assert!(kept >= counted.0, "the new head counts visits afresh: {kept} < {} counted before the takeover", counted.0);
    // The operator reaches the manager on its new node; the chain is repaired to two replicas.
    let m = eventually("the system manager following the new head", Duration::from_secs(10), || async {
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.manager.node == successor && m.status == MissionStatus::Running && m.manager.chain.len() == 3).then_some(m)
    })
    .await?;
    assert!(!m.manager.chain.iter().any(|n| n == "h2"), "{:?}", m.manager);
    let g: Marginal = client.query(proto::keys::marginal_selector("p", 1), None::<&()>).await?;
    assert_eq!(g.robots, 3);
    // The robots keep executing their plans.
    let before: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await?;
    eventually("robots still moving", Duration::from_secs(10), || async {
        let now: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await.ok()?;
        let moved = now.iter().zip(&before).filter(|(a, b)| {
            let (p, q) = (a.pose.unwrap_or_default(), b.pose.unwrap_or_default());
            (p.x - q.x).hypot(p.y - q.y) > 1.0
        });
        (moved.count() == 3).then_some(())
    })
    .await?;
    client.close().await;
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_restarted_central_adopts_the_missions_of_surviving_hosts() -> anyhow::Result<()> {
    let dir = Scratch::new("restart");
    let (mut central, ep) = start_central(&dir)?;
    let _host = common::start_host(&dir, "h2", &ep)?;
    let _robots = common::start_robots(&dir, &ep, 3)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    let create = common::square_patrol(3, Some("h2"));
    eventually("the mission created on h2", Duration::from_secs(20), || async {
        client.query::<MissionView>(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&create)).await.ok()
    })
    .await?;
    client.close().await;

    // Central dies and comes back on the same endpoint.
    central.kill();
    let log = dir.path("central2.log");
    let _central = start("central2", &["central", "--listen", &ep], &log, "central ready", Duration::from_secs(20))?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    let m = eventually("the mission adopted from h2's report", Duration::from_secs(20), || async {
        let ms: Vec<MissionView> = client.query(proto::Key::SystemMissions, None::<&()>).await.ok()?;
        ms.into_iter().find(|m| m.name == "p" && m.robots.len() == 3 && m.status == MissionStatus::Running)
    })
    .await?;
    assert_eq!(m.manager.node, "h2");
    let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await?;
    assert!(v.iter().all(|r| r.mission.as_ref().map(|x| x.as_str()) == Some("p")), "{v:?}");
    let before = m.metrics.sync_points_passed;
    eventually("the team still passing barriers", Duration::from_secs(20), || async {
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.metrics.sync_points_passed > before).then_some(())
    })
    .await?;
    client.close().await;
    Ok(())
}

/// The mission's host and the one robot replicating it are SIGKILLed while central runs: its chain
/// [h2, replica] lost its majority, no manager reports it any more, and its two other robots run
/// their plans on. After `RUNNING_WAIT_S` (20 s) without a report central starts it anew, next
/// lineage, on its own host, with those two robots — and journals it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_mission_whose_chain_lost_its_majority_while_central_runs_is_started_anew() -> anyhow::Result<()> {
    let dir = Scratch::new("host-silent");
    let (_central, ep) = start_central(&dir)?;
    let mut host = common::start_host(&dir, "h2", &ep)?;
    let mut robots = common::start_robots(&dir, &ep, 3)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 3).await?;
    let create = proto::MissionCreate { replicas: Some(1), ..common::square_patrol(3, Some("h2")) };
    eventually("the mission created on h2", Duration::from_secs(15), || async {
        client.query::<MissionView>(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&create)).await.ok()
    })
    .await?;
    let before = eventually("p past a barrier under h2, one robot replicating it", Duration::from_secs(30), || async {
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.manager.node == "h2" && m.manager.chain.len() == 2 && m.metrics.sync_points_passed >= 1).then_some(m)
    })
    .await?;
    let replica = before.manager.chain[1].clone();
    let i: usize = replica.as_str().strip_prefix('r').and_then(|n| n.parse().ok()).ok_or_else(|| anyhow::anyhow!("replica {replica} is not a robot"))?;
    let mut alive: Vec<String> = ["r1", "r2", "r3"].iter().filter(|r| **r != replica).map(|r| r.to_string()).collect();
    alive.sort();
    host.kill();
    robots[i - 1].kill();
    let killed = std::time::Instant::now();
    let m = eventually("p started anew on central with the two robots left", Duration::from_secs(60), || async {
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.status == MissionStatus::Running && m.robots == alive && proto::chain::lineage_of(m.manager.chain_epoch) == 1).then_some(m)
    })
    .await?;
    let after = killed.elapsed();
    println!("h2 and replica {replica} killed → p started anew after {after:?} on {} (chain {:?})", m.manager.node, m.manager.chain);
    assert!(after >= Duration::from_secs(15), "started anew {after:?} after the kill, well before RUNNING_WAIT_S");
    let j = common::journal(&client).await?;
    assert!(
        j.iter().any(|e| matches!(&e.event, proto::JournalEvent::MissionRestarted { mission, robots } if mission == "p" && *robots == alive)),
        "the journal says p started again with {alive:?}"
    );
    eventually("p past more barriers in its new lineage", Duration::from_secs(30), || async {
        let n: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (n.metrics.sync_points_passed >= 1 && proto::chain::lineage_of(n.manager.chain_epoch) == 1).then_some(())
    })
    .await?;
    client.close().await;
    Ok(())
}

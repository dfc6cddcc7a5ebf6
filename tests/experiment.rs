//! The paper's communication-loss experiment (its section 4.3), step by step, with real processes:
//!
//! 1. four robots start and register;
//! 2. the operator defines waypoints;
//! 3. the patrol is planned (TSP tour, optimal start assignment) and runs;
//! 4. central is SIGKILLed: the patrol and its barriers go on, a robot replica takes the mission
//!    manager over;
//! 5. a robot is SIGKILLed: the team goes on without waiting for it;
//! 6. the robot restarts (connecting to its peers only, central is still down) and rejoins the
//!    mission and the team;
//! 7. central restarts and sees everything again, without fighting the mission's new manager.
//!
//! Observed from a peer attached to two robots (central's API is gone for most of the test).

mod common;

use std::collections::{BTreeMap, BTreeSet};
use std::time::{Duration, Instant};

use anyhow::{anyhow, ensure};
use common::{eventually, start, start_central, Scratch};
use mrmm_net::client::Client;
use mrmm_net::net::{self, Mode};
use mrmm_proto::{self as proto, MissionCreate, MissionStatus, MissionView, RobotView, SyncArrival};
use zenoh::handlers::{RingChannel, RingChannelHandler};
use zenoh::pubsub::Subscriber;
use zenoh::sample::Sample;

/// The observer's subscriptions drop their oldest samples when nobody reads them: a full FIFO
/// channel would block the session's receiving thread (and with it every session of this
/// process) while the test is busy elsewhere.
type Sub = Subscriber<RingChannelHandler<Sample>>;

/// Waits for a status publication of mission `p` that satisfies `pred`.
async fn status_where(sub: &Sub, what: &str, timeout: Duration, pred: impl Fn(&MissionView) -> bool) -> anyhow::Result<MissionView> {
    let deadline = Instant::now() + timeout;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        ensure!(!left.is_zero(), "timed out after {timeout:?} waiting for {what}");
        let Ok(Ok(s)) = tokio::time::timeout(left, sub.recv_async()).await else { continue };
        if let Ok(v) = serde_json::from_slice::<MissionView>(&s.payload().to_bytes()) {
            if pred(&v) {
                return Ok(v);
            }
        }
    }
}

/// Waits until each robot of `ids` has arrived at `n` more barriers of plan epoch `epoch` or later.
async fn barriers(sub: &Sub, ids: &[&str], n: usize, epoch: u64, timeout: Duration) -> anyhow::Result<Duration> {
    let t0 = Instant::now();
    while sub.try_recv().ok().flatten().is_some() {}
    let mut passed: BTreeMap<String, BTreeSet<(u32, u32)>> = BTreeMap::new();
    while ids.iter().any(|id| passed.get(*id).is_none_or(|b| b.len() < n)) {
        let left = (t0 + timeout).saturating_duration_since(Instant::now());
        ensure!(!left.is_zero(), "barriers stalled: {passed:?}");
        let Ok(Ok(s)) = tokio::time::timeout(left, sub.recv_async()).await else { continue };
        if let Ok(a) = proto::from_json::<SyncArrival>("arrival", &s.payload().to_bytes()) {
            if a.epoch >= epoch {
                passed.entry(a.robot.to_string()).or_default().insert((a.round, a.point));
            }
        }
    }
    Ok(t0.elapsed())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_papers_seven_steps() -> anyhow::Result<()> {
    let dir = Scratch::new("experiment");
    // 1. Four robots start and register.
    let (mut central, ep) = start_central(&dir)?;
    let mut robots = common::start_robots(&dir, &ep, 4)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 4).await?;

    // 2–3. The operator defines waypoints; the patrol is planned and runs.
    let create = MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        count: Some(4),
        params: [("waypoints".to_string(), serde_json::json!([[0, 0], [8, 0], [14, 6], [8, 12], [0, 12], [-4, 6]]))].into(),
        ..Default::default()
    };
    let m: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&create)).await?;
    assert_eq!(m.robots.len(), 4);
    let length = m.summary.as_ref().and_then(|s| s.patrol()).map_or(0.0, |p| p.length);
    assert!(length > 40.0, "a tour through the waypoints: {:?}", m.summary);
    let m = eventually("the patrol past its first barriers", Duration::from_secs(30), || async {
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.metrics.sync_points_passed >= 2).then_some(m)
    })
    .await?;
    assert_eq!(m.plans.as_ref().map(Vec::len), Some(4));
    assert_eq!(m.manager.node, "central");
    let plan_epoch = m.manager.epoch;
    client.close().await;

    // The observer: a peer attached to r3 and r4, and to central's endpoint (central is gone
    // soon; the observer links to it again when it comes back — a peer that lists only robots
    // never links to a router, and the router then carries some of the robots' traffic).
    let peers: Vec<String> = robots[2..].iter().filter_map(|r| r.field("listening")).collect();
    let mut connect = peers.clone();
    connect.push(ep.clone());
    let observer = net::open(net::zenoh_config(Mode::Peer, &["tcp/127.0.0.1:0".into()], &connect, 1000)?).await?;
    let zerr = |e: zenoh::Error| anyhow!("{e}");
    let arrivals = observer.declare_subscriber(proto::Pattern::TeamSync("p".to_string()).to_string()).with(RingChannel::new(4096)).await.map_err(zerr)?;
    let statuses = observer.declare_subscriber(proto::Key::MissionStatus("p".into()).to_string()).with(RingChannel::new(256)).await.map_err(zerr)?;
    // Linked to every robot (gossip): arrivals of all four come through.
    barriers(&arrivals, &["r1", "r2", "r3", "r4"], 1, plan_epoch, Duration::from_secs(20)).await?;

    // 4. Central dies: a replica takes the manager over, the patrol and its barriers go on.
    central.kill();
    let killed = Instant::now();
    let v = status_where(&statuses, "a robot managing the mission", Duration::from_secs(10), |v| v.manager.node != "central").await?;
    println!("step 4: {} took the manager over {} ms after central's SIGKILL", v.manager.node, killed.elapsed().as_millis());
    assert_eq!(v.manager.node, "r1");
    assert_eq!(v.manager.epoch, plan_epoch, "the robots keep their plans");
    let took = barriers(&arrivals, &["r1", "r2", "r3", "r4"], 2, plan_epoch, Duration::from_secs(30)).await?;
    println!("step 4: every robot passed 2 more barriers within {took:?}");

    // 5. A robot of the manager's chain dies: the team goes on without it, the chain is repaired.
    let v = status_where(&statuses, "the repaired chain", Duration::from_secs(10), |v| v.manager.chain.len() == 3).await?;
    let victim = v.manager.chain[1].clone();
    let i = robots.iter().position(|r| r.name == victim).ok_or_else(|| anyhow!("no process {victim}"))?;
    robots[i].kill();
    let killed = Instant::now();
    let v = status_where(&statuses, "the team without the dead robot", Duration::from_secs(20), |v| {
        !v.robots.iter().any(|r| *r == victim.as_str()) && v.manager.epoch > plan_epoch && v.status == MissionStatus::Running
    })
    .await?;
    println!("step 5: {victim} SIGKILLed; replanned for {:?} in {} ms", v.robots, killed.elapsed().as_millis());
    let rest: Vec<&str> = v.robots.iter().map(|r| r.as_str()).collect();
    barriers(&arrivals, &rest, 2, v.manager.epoch, Duration::from_secs(30)).await?;
    let v = status_where(&statuses, "a chain without the dead robot", Duration::from_secs(10), |v| {
        v.manager.chain.len() == 3 && !v.manager.chain.contains(&victim)
    })
    .await?;
    let short_epoch = v.manager.epoch;

    // 6. The robot restarts, connecting to its peers only (central is still down), and rejoins.
    let mut connect: Vec<String> = robots.iter().filter(|r| r.name != victim).filter_map(|r| r.field("listening")).collect();
    connect.push(ep.clone());
    robots[i] = common::start_robot_with(&dir, victim.as_str(), &connect, 3.0, -3.0, 10.0)?;
    let v = status_where(&statuses, "the robot back in the mission", Duration::from_secs(20), |v| {
        v.robots.iter().any(|r| *r == victim.as_str()) && v.manager.epoch > short_epoch && v.status == MissionStatus::Running
    })
    .await?;
    println!("step 6: {victim} restarted and rejoined: robots {:?}, plan epoch {}", v.robots, v.manager.epoch);
    barriers(&arrivals, &["r1", "r2", "r3", "r4"], 2, v.manager.epoch, Duration::from_secs(30)).await?;
    let manager = v.manager.node.clone();

    // 7. Central comes back on the same endpoint and sees everything again.
    let _central = start("central2", &["central", "--listen", &ep], &dir.path("central2.log"), "central ready", Duration::from_secs(20))?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    let m = eventually("central seeing the mission again", Duration::from_secs(20), || async {
        let ms: Vec<MissionView> = client.query(proto::Key::SystemMissions, None::<&()>).await.ok()?;
        ms.into_iter().find(|m| m.name == "p" && m.robots.len() == 4 && m.status == MissionStatus::Running)
    })
    .await?;
    assert_eq!(m.manager.node, manager, "central does not take the mission back");
    assert_eq!(m.manager.epoch, v.manager.epoch, "central's return does not disturb the running plans");
    let rv = eventually("central seeing every robot in the mission", Duration::from_secs(20), || async {
        let v: Vec<RobotView> = client.query(proto::Key::SystemRobots, None::<&()>).await.ok()?;
        (v.len() == 4 && v.iter().all(|r| r.mission.as_ref().map(|x| x.as_str()) == Some("p"))).then_some(v)
    })
    .await?;
    println!("step 7: central back; robots {:?}", rv.iter().map(|r| &r.id).collect::<Vec<_>>());
    // Still one manager: statuses published from now on (those queued before are dropped)
    // all come from the same node, for three of its status periods.
    while statuses.try_recv().ok().flatten().is_some() {}
    let drained = Instant::now();
    for _ in 0..3 {
        let v = status_where(&statuses, "a status", Duration::from_secs(5), |_| true).await?;
        println!("step 7: a status {:?} after the drain", drained.elapsed());
        assert_eq!(v.manager.node, manager, "a second manager publishes after central's return");
        assert_eq!(v.manager.epoch, m.manager.epoch, "the plans stay as they were");
    }
    client.close().await;
    let _ = observer.close().await;
    Ok(())
}

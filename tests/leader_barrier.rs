//! The paper's leader barrier with real processes: central + 4 robots on a patrol with
//! `barrier: leader`. Only members other than the leader (r1, the lowest id) publish arrivals,
//! only the leader announces releases, and the team passes its barriers. The leader is
//! SIGKILLed: the next lowest (r2) leads the replanned team, whose barriers keep passing.

mod common;

use std::collections::BTreeSet;
use std::time::Duration;

use common::{eventually, start_central, start_robots, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, MissionView, Pattern, SyncArrival, SyncRelease};
use serde_json::json;
use zenoh::handlers::RingChannel;

async fn mission(c: &Client) -> Option<MissionView> {
    c.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_leader_gathers_arrivals_announces_releases_and_is_replaced_when_it_dies() -> anyhow::Result<()> {
    let dir = Scratch::new("leader-barrier");
    let (_central, ep) = start_central(&dir)?;
    let mut robots = start_robots(&dir, &ep, 4)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 4).await?;
    let zerr = |e: zenoh::Error| anyhow::anyhow!("{e}");
    // A tap on the team's barrier traffic (one more subscriber: the leader's releases and the
    // arrivals reach it too).
    let arrivals = client.session().declare_subscriber(Pattern::TeamArrive("p".into()).to_string()).with(RingChannel::new(4096)).await.map_err(zerr)?;
    let releases = client.session().declare_subscriber(Pattern::TeamRelease("p".into()).to_string()).with(RingChannel::new(4096)).await.map_err(zerr)?;
    let mesh = client.session().declare_subscriber(Pattern::TeamSync("p".into()).to_string()).with(RingChannel::new(4096)).await.map_err(zerr)?;

    let mut create = common::square_patrol(4, None);
    create.params.insert("barrier".into(), json!("leader"));
    let _: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&create)).await?;
    eventually("a round of the leader barrier", Duration::from_secs(40), || async {
        let m = mission(&client).await?;
        (m.metrics.rounds >= 1 && m.metrics.sync_points_passed >= 5).then_some(())
    })
    .await?;

    let drain_arrivals = |epoch: u64| -> anyhow::Result<BTreeSet<String>> {
        let mut from = BTreeSet::new();
        while let Ok(Some(s)) = arrivals.try_recv() {
            let a: SyncArrival = proto::from_json("arrival", &s.payload().to_bytes())?;
            if a.epoch == epoch {
                from.insert(a.robot.to_string());
            }
        }
        Ok(from)
    };
    let drain_releases = |epoch: u64| -> anyhow::Result<Vec<SyncRelease>> {
        let mut out = Vec::new();
        while let Ok(Some(s)) = releases.try_recv() {
            let r: SyncRelease = proto::from_json("release", &s.payload().to_bytes())?;
            if r.epoch == epoch {
                out.push(r);
            }
        }
        Ok(out)
    };
    let from = drain_arrivals(1)?;
    assert_eq!(from, BTreeSet::from(["r2".to_string(), "r3".into(), "r4".into()]), "the leader r1 hears arrivals, it does not publish its own");
    let rel = drain_releases(1)?;
    assert!(rel.len() >= 5, "a release per barrier: {rel:?}");
    assert!(rel.iter().all(|r| r.leader == "r1"), "only r1 leads: {rel:?}");
    assert!(rel.windows(2).all(|w| (w[0].round, w[0].point) <= (w[1].round, w[1].point)), "releases move forward: {rel:?}");
    assert!(mesh.try_recv().ok().flatten().is_none(), "no mesh arrivals under the leader barrier");

    // The leader dies: the team is replanned for three, and r2 leads it.
    robots[0].kill();
    let m = eventually("the patrol replanned for the other three", Duration::from_secs(15), || async {
        let m = mission(&client).await?;
        (m.robots == ["r2", "r3", "r4"] && m.plans.as_ref().is_some_and(|p| p.len() == 3)).then_some(m)
    })
    .await?;
    let epoch = m.manager.epoch;
    let passed = m.metrics.sync_points_passed;
    eventually("barriers of the new plan passed", Duration::from_secs(40), || async {
        let m = mission(&client).await?;
        (m.manager.epoch == epoch && m.metrics.sync_points_passed >= passed + 4).then_some(())
    })
    .await?;
    let rel = drain_releases(epoch)?;
    assert!(!rel.is_empty() && rel.iter().all(|r| r.leader == "r2"), "r2 leads epoch {epoch}: {rel:?}");
    assert_eq!(drain_arrivals(epoch)?, BTreeSet::from(["r3".to_string(), "r4".into()]));
    Ok(())
}

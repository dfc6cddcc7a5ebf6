//! A hand-over with real processes: a robot takes a patrol member's place (`mrmm op move r3 p
//! --replacing r1`, what central's charging policy does when a spare relieves a low robot). The
//! member that stays carries its plan on — its rounds and barriers go on counting, no replan
//! sends it back to the formation — the newcomer starts on the leaver's leg in the leaver's
//! round, the team keeps passing barriers with it, the member that stays keeps its member token up
//! throughout, and the leaver is freed.

mod common;

use std::collections::BTreeMap;
use std::time::Duration;

use common::{eventually, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, MissionView, Progress, RobotView};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_takes_a_members_place_and_the_team_goes_on_without_a_replan() -> anyhow::Result<()> {
    let dir = Scratch::new("handover");
    let state = dir.path("central-state").display().to_string();
    let central = common::start(
        "central",
        &["central", "--state-dir", &state, "--listen", "tcp/127.0.0.1:0"],
        &dir.path("central.log"),
        "central ready",
        Duration::from_secs(20),
    )?;
    let ep = central.field("listening").and_then(|l| l.split(',').next().map(str::to_string)).ok_or_else(|| anyhow::anyhow!("no endpoint"))?;
    let mut robots = Vec::new();
    for (id, x, y) in [("r1", 0.0, -1.0), ("r2", 8.0, 9.0), ("r3", 1.0, -1.0)] {
        let cfg = common::robot_config(&dir, id, std::slice::from_ref(&ep), x, y, 5.0)?.display().to_string();
        robots.push(common::start(id, &["robot", "--config", &cfg], &dir.path(&format!("{id}.log")), "robot ready", Duration::from_secs(20))?);
    }
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 3).await?;
    let telemetry = client
        .session()
        .declare_subscriber(proto::Pattern::AllTelemetry.to_string())
        .with(zenoh::handlers::RingChannel::new(4096))
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    // Each robot's newest progress, as its telemetry says.
    let mut progress: BTreeMap<String, Progress> = BTreeMap::new();
    let drain = |progress: &mut BTreeMap<String, Progress>| {
        while let Ok(Some(s)) = telemetry.try_recv() {
            if let Ok(t) = proto::decode_telemetry(&s.payload().to_bytes()) {
                if let Some(p) = t.progress {
                    progress.insert(t.id.to_string(), p);
                }
            }
        }
    };
    let patrol = proto::MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        robots: Some(vec!["r1".into(), "r2".into()]),
        params: [("waypoints".to_string(), serde_json::json!([[0, 0], [8, 0], [8, 8], [0, 8]]))].into(),
        ..Default::default()
    };
    let created: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&patrol)).await?;
    let planned = created.manager.epoch;

    // The patrol is under way: r2 has passed a few barriers.
    let before = eventually("r2 past four barriers", Duration::from_secs(60), || {
        drain(&mut progress);
        let p = progress.get("r2").filter(|p| p.epoch == planned && p.syncs_passed >= 4).cloned();
        async move { p }
    })
    .await?;

    // The teammates' tokens from here on: r2's must stay up through the hand-over (a token gone
    // and back is a member gone for its teammates' barriers).
    let tokens = client
        .session()
        .liveliness()
        .declare_subscriber(proto::Pattern::TeamMembers("p".into()).to_string())
        .with(zenoh::handlers::RingChannel::new(256))
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let out = std::process::Command::new(common::EXE).args(["op", "--connect", &ep, "move", "r3", "p", "--replacing", "r1"]).output()?;
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && said.contains("r3: none → p (in place of r1)"), "{said}{}", String::from_utf8_lossy(&out.stderr));

    // r2 goes on under the next epoch from where it was: its barriers and rounds keep counting.
    let carried = eventually("r2 on the next epoch", Duration::from_secs(20), || {
        drain(&mut progress);
        let p = progress.get("r2").filter(|p| p.epoch > planned).cloned();
        async move { p }
    })
    .await?;
    assert_eq!(carried.epoch, planned + 1, "one new epoch, no replan after it");
    assert!(carried.syncs_passed >= before.syncs_passed && carried.round >= before.round, "r2 was sent back to the start: {before:?} → {carried:?}");
    let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await?;
    assert_eq!(m.robots, ["r2", "r3"]);
    assert_eq!(m.manager.epoch, planned + 1);

    // The team keeps passing barriers with r3, which started in r1's round.
    let after = eventually("r2 and r3 past two more barriers together", Duration::from_secs(60), || {
        drain(&mut progress);
        let both = match (progress.get("r2"), progress.get("r3")) {
            (Some(a), Some(b)) if a.epoch == planned + 1 && b.epoch == planned + 1 && a.syncs_passed >= carried.syncs_passed + 2 && b.syncs_passed >= 3 => {
                Some((a.clone(), b.clone()))
            }
            _ => None,
        };
        async move { both }
    })
    .await?;
    assert!(after.1.round >= before.round, "r3 started in r1's round, not the first: {:?}", after.1);
    let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await?;
    assert_eq!(m.manager.epoch, planned + 1, "still no replan");
    let mut gone = Vec::new();
    while let Ok(Some(s)) = tokens.try_recv() {
        if s.kind() == zenoh::sample::SampleKind::Delete {
            gone.push(s.key_expr().to_string());
        }
    }
    assert!(gone.iter().all(|k| !k.ends_with("/r2")), "r2's member token went down: {gone:?}");
    assert!(gone.iter().any(|k| k.ends_with("/r1")), "r1 left the team: {gone:?}");
    let r1: RobotView = client.query(proto::Key::SystemRobot("r1".into()), None::<&()>).await?;
    assert_eq!(r1.mission, None, "the leaver is freed");

    // Replacing a robot that is not a member is refused, with why.
    let out = std::process::Command::new(common::EXE).args(["op", "--connect", &ep, "move", "r1", "p", "--replacing", "r9"]).output()?;
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("is not in mission p"), "{out:?}");
    client.close().await;
    Ok(())
}

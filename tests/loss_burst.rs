//! A burst of losses costs one replan (issue 35's plain bug): three of six patrol robots
//! SIGKILLed at once, and the mission's head plans once for the three left, not once per loss.

mod common;

use std::time::Duration;

use common::{eventually, start_central, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, MissionView};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn three_robots_lost_at_once_cost_one_replan() -> anyhow::Result<()> {
    let dir = Scratch::new("burst");
    let (_central, ep) = start_central(&dir)?;
    let mut robots = common::start_robots(&dir, &ep, 6)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 6).await?;
    let _: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&common::square_patrol(6, None))).await?;
    let before = eventually("the patrol running", Duration::from_secs(30), || async {
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.metrics.sync_points_passed >= 1).then_some(m)
    })
    .await?;
    let pids: Vec<String> = robots[3..].iter().map(|r| r.pid().to_string()).collect();
    anyhow::ensure!(std::process::Command::new("kill").arg("-9").args(&pids).status()?.success(), "kill -9");
    for r in robots[3..].iter_mut() {
        r.kill();
    }
    let after = eventually("the mission planned for the three left", Duration::from_secs(20), || async {
        let m: MissionView = client.query(proto::Key::SystemMission("p".into()), None::<&()>).await.ok()?;
        (m.robots.len() == 3 && m.plans.as_ref().is_some_and(|p| p.len() == 3)).then_some(m)
    })
    .await?;
    let replans = after.manager.epoch - before.manager.epoch;
    println!("3 robots SIGKILLed at once: {replans} replan(s)");
    assert_eq!(replans, 1, "one replan for the burst, not one per robot");
    let journal = common::journal(&client).await?;
    let lost: u64 = journal.iter().map(|e| e.event.losses()).sum();
    assert_eq!(lost, 3);
    client.close().await;
    Ok(())
}

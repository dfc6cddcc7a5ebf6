//! The advising agent through the public API: central + 5 robots, a patrol held to a standard it
//! cannot meet and a coverage; a robot is killed. Critical "robot lost" advice is published live
//! within seconds, and "below standard" advice carries the marginal-benefit numbers.

mod common;

use std::time::{Duration, Instant};

use common::{eventually, start_central, start_robot_scaled, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, Advice, MissionCreate, MissionView, Priority};
use serde_json::json;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn advice_for_a_lost_robot_and_a_mission_below_standard() -> anyhow::Result<()> {
    let dir = Scratch::new("advice");
    let (_central, ep) = start_central(&dir)?;
    let mut robots: Vec<_> = (1..=5).map(|i| start_robot_scaled(&dir, &format!("r{i}"), &ep, i as f64 * 2.0, -3.0, 10.0)).collect::<Result<_, _>>()?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    let live = client.session().declare_subscriber(proto::Key::AgentAdviceLive.to_string()).await.map_err(|e| anyhow::anyhow!("{e}"))?;
    common::wait_robots(&client, 5).await?;
    let patrol = MissionCreate {
        name: "p".into(),
        recipe: "patrol".into(),
        robots: Some(vec!["r1".into(), "r2".into()]),
        params: [("waypoints".to_string(), json!([[0, 0], [30, 0], [30, 30], [0, 30]])), ("max_worst_idleness".to_string(), json!(5))].into(),
        ..MissionCreate::default()
    };
    let _: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&patrol)).await?;
    let coverage = MissionCreate {
        name: "c".into(),
        recipe: "coverage".into(),
        robots: Some(vec!["r3".into(), "r4".into(), "r5".into()]),
        params: [("region".to_string(), json!([[-30, -30], [-10, -30], [-10, -10], [-30, -10]]))].into(),
        ..MissionCreate::default()
    };
    let _: MissionView = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&coverage)).await?;

    // Below standard, with the numbers: the predicted worst idleness with one robot more.
    let below = eventually("below-standard advice", Duration::from_secs(40), || async {
        let a: Vec<Advice> = client.query(proto::Key::AgentAdvice, None::<&()>).await.ok()?;
        a.into_iter().find(|a| a.id == "standard/p")
    })
    .await?;
    assert_eq!(below.priority, Priority::Warning);
    assert!(below.reason.contains("move r5 from c to p: predicted worst idleness"), "{}", below.reason);
    assert_eq!(below.suggestion.as_deref(), Some("mrmm op move r5 p"));
    assert_eq!(below.evidence["predicted_with_one_more"], 40.0);

    // A robot is killed: critical advice, live.
    while live.try_recv().ok().flatten().is_some() {}
    let killed = Instant::now();
    robots[3].kill();
    let lost = common::wait_raised(&live, "lost/r4", Duration::from_secs(10)).await?;
    println!("robot SIGKILL → critical advice published: {:?}", killed.elapsed());
    assert_eq!(lost.priority, Priority::Critical);
    assert!(lost.reason.starts_with("robot r4 lost; mission c replanned"), "{}", lost.reason);
    client.close().await;
    Ok(())
}

//! A mission of two teams with real processes (issue 33, items 1-3, 6): three fast ground robots
//! patrol one square, two slow aerial robots (real time, half a metre a second, far from their
//! tour) another. The recipe's start barrier is the whole mission's: no fast robot starts its
//! rounds before both slow ones have reached their slots. After it each team runs its own
//! barriers: the fast team's keep passing at its own pace while the slow team's come late. The
//! mission's view lists each leaf team's members, and a robot hears no barrier of the other team.
//! A slow robot is killed: its team falls below its `min`; the mission goes on with the members
//! it has, and the advising agent says so (critical) and names the idle aerial robot that fits.

mod common;

use std::collections::{BTreeMap, BTreeSet};
use std::time::{Duration, Instant};

use common::{eventually, start, start_central, Proc, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, Key, MissionCreate, MissionView, SyncArrival};
use zenoh::handlers::RingChannel;

const RECIPE: &str = r#"<recipe name="two-paces">
  <team name="fast" type="ground" planner="patrol" min="1">
    <params>
      <param name="sync_spacing_max" value="10"/>
      <waypoints><point x="0" y="0"/><point x="10" y="0"/><point x="10" y="10"/><point x="0" y="10"/></waypoints>
    </params>
    <behaviour type="*"><stream/><navigate to="slot"/><sync point="start" scope="mission"/><loop><round/></loop></behaviour>
  </team>
  <team name="slow" type="aerial" planner="patrol" min="2">
    <params>
      <param name="sync_spacing_max" value="10"/>
      <waypoints><point x="30" y="0"/><point x="40" y="0"/><point x="40" y="10"/><point x="30" y="10"/></waypoints>
    </params>
    <behaviour type="*"><stream/><navigate to="slot"/><sync point="start" scope="mission"/><loop><round/></loop></behaviour>
  </team>
</recipe>"#;

/// A robot of `robot_type` at `at`; `pace`: its top speed (m/s) and its simulated seconds per
/// second.
fn robot(dir: &Scratch, id: &str, ep: &str, robot_type: &str, at: (f64, f64), pace: (f64, f64)) -> anyhow::Result<Proc> {
    let ((x, y), (speed, time_scale)) = (at, pace);
    let cfg = format!(
        r#"{{ id: "{id}", type: "{robot_type}", kinematics: {{ max_speed: {speed}, max_turn_rate: 2.0 }},
             start: {{ x: {x}, y: {y} }}, time_scale: {time_scale}, telemetry_hz: 10,
             zenoh: {{ listen: ["tcp/127.0.0.1:0"], connect: ["{ep}"], lease_ms: 1000 }} }}"#
    );
    let path = dir.path(&format!("{id}.json5"));
    std::fs::write(&path, cfg)?;
    start(id, &["robot", "--config", &path.display().to_string()], &dir.path(&format!("{id}.log")), "robot ready", Duration::from_secs(20))
}

/// Barrier arrivals heard on one key pattern, with when they were heard.
struct Tap {
    sub: zenoh::pubsub::Subscriber<zenoh::handlers::RingChannelHandler<zenoh::sample::Sample>>,
    heard: Vec<(Instant, SyncArrival)>,
}

impl Tap {
    async fn new(c: &Client, pattern: proto::Pattern) -> anyhow::Result<Tap> {
        let sub = c.session().declare_subscriber(pattern.to_string()).with(RingChannel::new(8192)).await.map_err(|e| anyhow::anyhow!("{e}"))?;
        Ok(Tap { sub, heard: vec![] })
    }

    fn drain(&mut self) -> anyhow::Result<()> {
        while let Ok(Some(s)) = self.sub.try_recv() {
            self.heard.push((Instant::now(), proto::from_json("arrival", &s.payload().to_bytes())?));
        }
        Ok(())
    }

    /// Barriers (round, point) every one of `members` arrived at, in the plan's epoch `epoch`.
    fn passed(&self, epoch: u64, members: &[&str]) -> usize {
        let mut by: BTreeMap<(u32, u32), BTreeSet<&str>> = BTreeMap::new();
        for (_, a) in self.heard.iter().filter(|(_, a)| a.epoch == epoch) {
            by.entry((a.round, a.point)).or_default().insert(a.robot.as_str());
        }
        by.values().filter(|who| members.iter().all(|m| who.contains(m))).count()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_teams_keep_their_own_pace_after_a_mission_wide_start() -> anyhow::Result<()> {
    let dir = Scratch::new("teams");
    let (_central, ep) = start_central(&dir)?;
    let mut procs = Vec::new();
    for (i, id) in ["r1", "r2", "r3"].iter().enumerate() {
        procs.push(robot(&dir, id, &ep, "ground", (i as f64 * 2.0, -3.0), (1.0, 10.0))?);
    }
    // Far from their tour (about 8 m to go at 0.5 m/s, in real time: some 15 s).
    for (i, id) in ["r4", "r5"].iter().enumerate() {
        procs.push(robot(&dir, id, &ep, "aerial", (32.0 + i as f64 * 4.0, -9.0), (0.5, 1.0))?);
    }
    // An idle aerial robot the mission does not take (it names its robots).
    let _spare = robot(&dir, "r6", &ep, "aerial", (50.0, -9.0), (0.5, 1.0))?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(5)).await?;
    common::wait_robots(&client, 6).await?;
    let mut mission_tap = Tap::new(&client, proto::Pattern::TeamSync("e".into())).await?;
    let mut fast_tap = Tap::new(&client, proto::Pattern::TeamSync("e/fast".into())).await?;
    let mut slow_tap = Tap::new(&client, proto::Pattern::TeamSync("e/slow".into())).await?;

    let members = ["r1", "r2", "r3", "r4", "r5"].map(String::from).to_vec();
    let create = MissionCreate { name: "e".into(), recipe: RECIPE.into(), robots: Some(members.iter().map(Into::into).collect()), ..Default::default() };
    let _: MissionView = client.query(Key::SystemCmd(proto::SystemCmd::Create), Some(&create)).await?;
    let view = eventually("both teams planned", Duration::from_secs(20), || async {
        let v: MissionView = client.query(Key::SystemMission("e".into()), None::<&()>).await.ok()?;
        (v.teams.len() == 2).then_some(v)
    })
    .await?;
    assert_eq!(view.teams["e/fast"], ["r1", "r2", "r3"], "{:?}", view.teams);
    assert_eq!(view.teams["e/slow"], ["r4", "r5"], "{:?}", view.teams);
    let epoch = view.manager.epoch;

    // The fast team passes rounds of barriers; by then the slow team has gathered at its slots.
    let fast = ["r1", "r2", "r3"];
    eventually("the fast team past six barriers of its own", Duration::from_secs(90), || {
        let ok = fast_tap.drain().is_ok() && mission_tap.drain().is_ok() && slow_tap.drain().is_ok();
        let passed = fast_tap.passed(epoch, &fast);
        async move { (ok && passed >= 6).then_some(()) }
    })
    .await?;
    // The mission's start barrier waited for everyone: no fast robot arrived at a barrier of its
    // team before the last slow robot arrived at the mission's — each slow robot's first arrival
    // there (a robot re-publishes its arrival while it waits, and echoes it to a late teammate:
    // those copies may come after the barrier passed).
    let first_start =
        |robot: &str| mission_tap.heard.iter().filter(|(_, a)| a.epoch == epoch && a.robot == robot && (a.round, a.point) == (0, 0)).map(|(t, _)| *t).min();
    let last_slow_start = ["r4", "r5"].map(first_start).into_iter().collect::<Option<Vec<_>>>().and_then(|ts| ts.into_iter().max());
    let last_slow_start = last_slow_start.expect("the slow robots arrived at the mission's start barrier");
    let first_fast = fast_tap.heard.iter().filter(|(_, a)| a.epoch == epoch).map(|(t, _)| *t).min().expect("fast arrivals");
    assert!(first_fast > last_slow_start, "a fast robot started its rounds before the slow team had gathered");
    let everyone: BTreeSet<&str> = mission_tap.heard.iter().filter(|(_, a)| a.epoch == epoch).map(|(_, a)| a.robot.as_str()).collect();
    assert_eq!(everyone, ["r1", "r2", "r3", "r4", "r5"].into_iter().collect(), "the mission's barrier is everyone's");
    // The two teams' barriers are their own: no robot of one arrives at a barrier of the other.
    assert!(fast_tap.heard.iter().all(|(_, a)| fast.contains(&a.robot.as_str())));
    assert!(slow_tap.heard.iter().all(|(_, a)| ["r4", "r5"].contains(&a.robot.as_str())));
    // The slow team is far behind (in real time at half a metre a second), yet alive and going.
    let slow_passed = slow_tap.passed(epoch, &["r4", "r5"]);
    assert!(slow_passed * 2 < fast_tap.passed(epoch, &fast), "slow {slow_passed}, fast {}", fast_tap.passed(epoch, &fast));
    eventually("the slow team past a barrier of its own", Duration::from_secs(60), || {
        let ok = slow_tap.drain().is_ok();
        let passed = slow_tap.passed(epoch, &["r4", "r5"]);
        async move { (ok && passed >= 1).then_some(()) }
    })
    .await?;
    let v: MissionView = client.query(Key::SystemMission("e".into()), None::<&()>).await?;
    assert_eq!(v.manager.epoch, epoch, "no replan: nobody was taken for lost");

    // r5 dies: the slow team has one of the two members it needs. The mission replans with the
    // four left (the fast team too), and the agent names r6, the idle robot that fits.
    procs[4].kill();
    let advice = eventually("critical advice for the short team", Duration::from_secs(30), || async {
        let a: Vec<proto::Advice> = client.query(Key::AgentAdvice, None::<&()>).await.ok()?;
        a.into_iter().find(|a| a.id == "team/e/slow")
    })
    .await?;
    assert_eq!(advice.priority, proto::Priority::Critical);
    assert!(advice.reason.contains("has 1 of the 2 members it needs: add r6"), "{}", advice.reason);
    let v = eventually("the mission replanned for the four left", Duration::from_secs(30), || async {
        let v: MissionView = client.query(Key::SystemMission("e".into()), None::<&()>).await.ok()?;
        (v.manager.epoch > epoch && v.teams.get("e/slow").is_some_and(|m| m == &["r4".to_string()])).then_some(v)
    })
    .await?;
    assert_eq!(v.status, proto::MissionStatus::Running, "{:?}", v.error);
    client.close().await;
    drop(procs);
    Ok(())
}

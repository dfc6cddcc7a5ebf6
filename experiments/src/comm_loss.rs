//! The paper's communication-loss experiment (its section 4.3) as one run on the fleet: a patrol
//! of every robot; central is SIGKILLed (a robot takes the mission manager over), a robot of the
//! manager's chain is SIGKILLed (the team goes on without it), the robot restarts linking to its
//! peers only and rejoins, central restarts from its journal. Between events the team does a
//! round. The mission's status publications, heard by a peer linked to every robot, give the
//! timeline: worst idleness and barriers passed over time, with the events marked.

use std::time::{Duration, Instant};

use anyhow::{anyhow, ensure};
use mrmm_net::client::Client;
use mrmm_net::net::{self, Mode};
use mrmm_proto::{self as proto, Key, MissionCreate, MissionStatus, MissionTerminate, MissionView};
use serde_json::json;
use zenoh::handlers::{RingChannel, RingChannelHandler};
use zenoh::pubsub::Subscriber;
use zenoh::sample::Sample;

use crate::fleet::{Fleet, SPEED};
use crate::run::{tour_length, Row, Spec, WAYPOINTS};
use crate::wire::Wire;

/// One status publication of the mission, as the timeline keeps it.
#[derive(Debug, Clone)]
pub struct Point {
    /// Robot seconds since the mission was created.
    pub t: f64,
    /// The longest a waypoint waited between visits so far (robot seconds).
    pub worst_idleness: Option<f64>,
    pub avg_idleness: Option<f64>,
    /// Barriers the team passed since the start, over every plan.
    pub barriers: u64,
    pub robots: usize,
    pub manager: String,
}

/// The run's timeline: status points and the events, as (robot seconds, what).
#[derive(Debug, Clone, Default)]
pub struct Timeline {
    pub points: Vec<Point>,
    pub events: Vec<(f64, String)>,
}

/// What the observer has heard so far.
struct Watch {
    sub: Subscriber<RingChannelHandler<Sample>>,
    t0: Instant,
    time_scale: f64,
    timeline: Timeline,
    /// Barriers passed so far, and the last count the current plan (epoch) reported: the count
    /// grows by each rise (a new plan's first report is its baseline, as it may still carry the
    /// old plan's count).
    passed: u64,
    current: (u64, u32),
}

impl Watch {
    fn now(&self) -> f64 {
        self.t0.elapsed().as_secs_f64() * self.time_scale
    }

    fn barriers(&self) -> u64 {
        self.passed
    }

    fn event(&mut self, what: &str) {
        let t = self.now();
        self.timeline.events.push((t, what.to_string()));
    }

    /// Records status publications until one satisfies `pred` (or `timeout` passes).
    async fn until(&mut self, what: &str, timeout: Duration, pred: impl Fn(&Watch, &MissionView) -> bool) -> anyhow::Result<MissionView> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            ensure!(!left.is_zero(), "comm-loss: timed out after {} s waiting for {what}", timeout.as_secs());
            let Ok(Ok(s)) = tokio::time::timeout(left, self.sub.recv_async()).await else { continue };
            let Ok(v) = proto::from_json::<MissionView>("mission status", &s.payload().to_bytes()) else { continue };
            let passed = v.metrics.sync_points_passed;
            if v.manager.epoch > self.current.0 {
                self.current = (v.manager.epoch, passed);
            } else if v.manager.epoch == self.current.0 {
                self.passed += u64::from(passed.saturating_sub(self.current.1));
                self.current.1 = passed;
            }
            let t = self.now();
            self.timeline.points.push(Point {
                t,
                worst_idleness: v.metrics.worst_idleness,
                avg_idleness: v.metrics.avg_idleness,
                barriers: self.barriers(),
                robots: v.robots.len(),
                manager: v.manager.node.to_string(),
            });
            if pred(self, &v) {
                return Ok(v);
            }
        }
    }

    /// Waits until the team passed `k` more barriers (a round's worth).
    async fn barriers_more(&mut self, k: u64, what: &str, timeout: Duration) -> anyhow::Result<MissionView> {
        let target = self.barriers() + k;
        self.until(what, timeout, |w, v| v.status == MissionStatus::Running && w.barriers() >= target).await
    }
}

/// Runs the seven steps on `fleet` (every robot in the patrol) and leaves it idle.
pub async fn run(fleet: &mut Fleet, name: &str, spec: &Spec) -> anyhow::Result<(Row, Timeline)> {
    let n = fleet.ids.len();
    ensure!(n >= 3, "comm-loss needs at least 3 robots (a chain of 3 and one to lose), got {n}");
    let started = Instant::now();
    let mut connect = fleet.endpoints.clone();
    connect.push(fleet.central.clone());
    let observer = net::open(net::zenoh_config(Mode::Peer, &["tcp/127.0.0.1:0".into()], &connect, 1000)?).await?;
    let sub =
        observer.declare_subscriber(Key::MissionStatus(name.into()).to_string()).with(RingChannel::new(1024)).await.map_err(|e| anyhow!("observer: {e}"))?;
    let result = steps(fleet, name, spec, sub).await;
    let _ = observer.close().await;
    // Whatever happened, the fleet is whole and idle again for the next run.
    let _ = fleet.client.query::<serde_json::Value>(proto::Key::SystemCmd(proto::SystemCmd::Terminate), Some(&MissionTerminate { name: name.into() })).await;
    let settled = fleet.settle(Duration::from_secs(60)).await;
    let (mut row, timeline) = result?;
    settled?;
    row.wall_s = started.elapsed().as_secs_f64();
    Ok((row, timeline))
}

async fn steps(fleet: &mut Fleet, name: &str, spec: &Spec, sub: Subscriber<RingChannelHandler<Sample>>) -> anyhow::Result<(Row, Timeline)> {
    let n = fleet.ids.len();
    let waypoints: Vec<[f64; 2]> = WAYPOINTS.iter().map(|(x, y)| [x * spec.env_scale, y * spec.env_scale]).collect();
    let round_wall = tour_length(&waypoints) / SPEED / spec.time_scale;
    // A step may take a few rounds (a takeover, a replan, the formation of a new plan).
    let patience = Duration::from_secs_f64(60.0 + round_wall * 4.0);
    let create = MissionCreate {
        name: name.into(),
        recipe: "patrol".into(),
        robots: Some(fleet.ids.iter().map(Into::into).collect()),
        params: [("waypoints".to_string(), json!(waypoints)), ("barrier".to_string(), json!(spec.barrier.as_str()))].into(),
        ..MissionCreate::default()
    };
    let mut w = Watch { sub, t0: Instant::now(), time_scale: spec.time_scale, timeline: Timeline::default(), passed: 0, current: (0, 0) };
    let created: MissionView = fleet.client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&create)).await.map_err(|e| anyhow!("create: {e}"))?;
    let patrol = created.summary.as_ref().and_then(|s| s.patrol()).cloned().ok_or_else(|| anyhow!("mission {name} has no patrol summary"))?;
    // Status publications carry no summary: the planner puts one sync point per member on the
    // tour, so a round is as many barriers as the team has members.
    let per_round = |v: &MissionView| v.robots.len().max(1) as u64;
    // 1–3. The patrol runs a round.
    let v = w.until("the patrol running", patience, |_, v| v.status == MissionStatus::Running).await?;
    let v = w.barriers_more(per_round(&v) + 1, "a first round", patience).await?;
    // 4. Central dies: a robot takes the manager over; the team does a round.
    w.event("central killed");
    fleet.kill_central().await;
    w.until("a robot managing the mission", patience, |_, v| v.manager.node != "central").await?;
    w.barriers_more(per_round(&v), "a round without central", patience).await?;
    // The chain repaired (three robots, central out of it) before the next loss: two losses in a
    // chain of two leave no majority (a liveness gap of the chain, issue 12).
    let v =
        w.until("the chain repaired without central", patience, |_, v| v.manager.chain.len() >= 3 && !v.manager.chain.iter().any(|c| c == "central")).await?;
    // 5. A robot of the manager's chain dies: the team goes on without it.
    let victim = v.manager.chain.get(1).cloned().unwrap_or_else(|| fleet.ids[n - 1].clone().into());
    let i = fleet.ids.iter().position(|id| *id == victim).ok_or_else(|| anyhow!("no robot {victim}"))?;
    w.event(&format!("{victim} killed"));
    fleet.kill_robot(i).await;
    let v = w
        .until("the team without it", patience, |_, v| {
            v.robots.len() == n - 1 && !v.robots.iter().any(|r| r == victim.as_str()) && v.status == MissionStatus::Running
        })
        .await?;
    w.barriers_more(per_round(&v), "a round of the smaller team", patience).await?;
    // 6. It restarts, linking to its peers (central is still down), and rejoins.
    w.event(&format!("{victim} back"));
    fleet.restart_robot(i).await?;
    let v = w.until("the robot back in the team", patience, |_, v| v.robots.len() == n && v.status == MissionStatus::Running).await?;
    let v = w.barriers_more(per_round(&v), "a round of the whole team again", patience).await?;
    // 7. Central comes back from its journal and sees the mission as it runs.
    w.event("central back");
    fleet.restart_central().await?;
    fleet.client = Client::connect(std::slice::from_ref(&fleet.central), Duration::from_secs(10)).await?;
    let deadline = Instant::now() + patience;
    loop {
        let seen: Option<MissionView> = fleet.client.query(Key::SystemMission(name.into()), None::<&()>).await.ok();
        if seen.is_some_and(|m| m.robots.len() == n && m.status == MissionStatus::Running) {
            break;
        }
        ensure!(Instant::now() < deadline, "comm-loss: central never saw the mission again");
        tokio::time::sleep(Duration::from_millis(250)).await;
    }
    let v = w.barriers_more(per_round(&v), "a round after central's return", patience).await?;
    let m = &v.metrics;
    let msg = |k: &str| m.messages.get(k).copied().unwrap_or(0);
    let row = Row {
        spec: spec.clone(),
        robots_after: v.robots.len(),
        tour_m: patrol.length,
        sync_per_round: patrol.sync_per_round,
        wall_s: 0.0,
        avg_idleness_s: m.avg_idleness.unwrap_or(f64::NAN),
        worst_idleness_s: w.timeline.points.iter().filter_map(|p| p.worst_idleness).fold(f64::NAN, f64::max),
        bound_s: patrol.length / (n.max(1) as f64 * SPEED),
        sync_points: u32::try_from(w.barriers()).unwrap_or(u32::MAX),
        sync_wait_per_round_s: m.sync_wait_s / (n.max(1) as f64 * f64::from(m.rounds.max(1))),
        msgs_plan: msg("plan"),
        msgs_sync: msg("sync"),
        // Central's counters restart with it: no wire counts for this run.
        wire: Wire::default(),
    };
    Ok((row, w.timeline))
}

/// `comm-loss-timeline.csv`: one line per status heard, then one per event.
pub fn timeline_csv(t: &Timeline) -> String {
    let mut out = String::from("t_s,worst_idleness_s,avg_idleness_s,barriers,robots,manager,event\n");
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.2}"));
    for p in &t.points {
        out.push_str(&format!("{:.2},{},{},{},{},{},\n", p.t, opt(p.worst_idleness), opt(p.avg_idleness), p.barriers, p.robots, p.manager));
    }
    for (at, what) in &t.events {
        out.push_str(&format!("{at:.2},,,,,,{what}\n"));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_timeline_csv_has_points_then_events() {
        let t = Timeline {
            points: vec![Point { t: 1.0, worst_idleness: Some(3.5), avg_idleness: None, barriers: 4, robots: 4, manager: "central".into() }],
            events: vec![(2.0, "central killed".into())],
        };
        assert_eq!(timeline_csv(&t), "t_s,worst_idleness_s,avg_idleness_s,barriers,robots,manager,event\n1.00,3.50,,4,4,central,\n2.00,,,,,,central killed\n");
    }
}

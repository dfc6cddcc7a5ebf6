//! The host core, scripted: starting, committing before acting, answering control queries after
//! the commit, re-delivering plans, re-asking planners, taking over, stepping down.

use std::collections::BTreeMap;

use mrmm_planner::recipe;
use mrmm_proto::{Behaviour, Member, MissionCtl, MissionSpecWire, MissionStart, Pose, Progress, RobotSpec, Telemetry, Time, Velocity};

use super::*;
use crate::at;
use crate::mission::chain::Params;

fn member(id: &str, x: f64) -> Member {
    Member {
        spec: RobotSpec { id: id.into(), robot_type: "ground".into(), x, y: 0.0, speed: 1.0, turn_rate: None, reach_m: None },
        time_scale: 1.0,
        capabilities: vec![],
    }
}

fn start(name: &str, ids: &[&str]) -> Box<MissionStart> {
    Box::new(MissionStart {
        spec: MissionSpecWire {
            name: name.into(),
            recipe_name: "patrol".into(),
            recipe_xml: recipe::bank("patrol").expect("bank").into(),
            planner: "patrol".into(),
            params: [("waypoints".to_string(), "[[0,0],[10,0],[10,10],[0,10]]".to_string())].into(),
            replicas: 2,
            map: None,
            paused: false,
        },
        members: ids.iter().enumerate().map(|(i, id)| member(id, i as f64)).collect(),
        anew: false,
        lineage: 0,
    })
}

/// The proven sender of node `name` in these scripts: central, else a mission host.
fn sender(name: &str) -> mrmm_proto::Sender {
    use mrmm_proto::{Role, Sender};
    if name == "central" {
        Sender::new(Role::Central, name)
    } else {
        Sender::new(Role::Host, name)
    }
}

fn central() -> mrmm_proto::Sender {
    sender("central")
}

/// Nodes wired together: chain messages are delivered at once, in order.
struct Mesh {
    nodes: BTreeMap<String, HostCore>,
    now: Time,
    /// Every command that is not a chain message, with the node that gave it.
    out: Vec<(String, Command)>,
}

impl Mesh {
    fn new(names: &[&str], robots: &[&str]) -> Mesh {
        let p = Params { quarantine: 0.0, ..Params::default() };
        let mut m = Mesh { nodes: names.iter().map(|n| (n.to_string(), HostCore::new(n, p, at(0.0)))).collect(), now: at(0.0), out: vec![] };
        for a in names {
            for b in names {
                m.to(a, Event::HostAlive(b.into()));
            }
            for r in robots {
                m.to(a, Event::RobotAlive(r.into()));
            }
        }
        m
    }

    fn to(&mut self, node: &str, ev: Event) -> Vec<Command> {
        let mut queue = vec![(node.to_string(), ev)];
        let mut mine = Vec::new();
        while !queue.is_empty() {
            let (at, ev) = queue.remove(0);
            let Some(core) = self.nodes.get_mut(&at) else { continue };
            for c in core.handle(self.now, ev) {
                match c {
                    Command::Chain { to, envelope } => {
                        let from = sender(&at);
                        queue.push((to.to_string(), Event::Chain { envelope, from }));
                    }
                    other => {
                        if at == node {
                            mine.push(other.clone());
                        }
                        self.out.push((at.clone(), other));
                    }
                }
            }
        }
        mine
    }

    fn tick(&mut self, dt: f64) -> Vec<(String, Command)> {
        self.now += dt;
        let names: Vec<String> = self.nodes.keys().cloned().collect();
        let from = self.out.len();
        for n in names {
            self.to(&n, Event::Tick);
        }
        self.out[from..].to_vec()
    }
}

/// Plans a request the way the planner service would.
fn planned(cmds: &[Command]) -> Option<Event> {
    cmds.iter().find_map(|c| match c {
        Command::RequestPlan { mission, epoch, kind, request, .. } => Some(Event::Planned {
            mission: mission.clone(),
            epoch: *epoch,
            result: crate::mission::planning::plan(*kind, request).map(Box::new).map_err(Failure::fatal),
        }),
        _ => None,
    })
}

fn sent_plans(cmds: &[Command]) -> Vec<(String, u64)> {
    cmds.iter()
        .filter_map(|c| match c {
            Command::SendPlan { robot, assignment, .. } => Some((robot.to_string(), assignment.epoch)),
            _ => None,
        })
        .collect()
}

fn replies(cmds: &[Command]) -> Vec<u64> {
    cmds.iter()
        .filter_map(|c| match c {
            Command::Reply { query, .. } => Some(*query),
            _ => None,
        })
        .collect()
}

fn progress(id: &str, mission: &str, epoch: u64) -> Event {
    Event::Telemetry(Box::new(Telemetry {
        id: id.into(),
        seq: 1,
        t: 0.0,
        pose: Pose::default(),
        velocity: Velocity::default(),
        behaviour: Behaviour::Hold,
        mission: Some(mission.into()),
        progress: Some(Progress {
            mission: mission.into(),
            epoch,
            step: 0,
            round: 0,
            syncs_passed: 0,
            sync_msgs: 0,
            waiting: None,
            sync_wait_s: 0.0,
            traffic_wait_s: 0.0,
            done: false,
        }),
        admitted: vec![],
        stuck: None,
        info_rev: 0,
        battery: None,
        vehicle: None,
    }))
}

/// A mission `p` of r1, r2 led by `central`, replicated on r1 and r2, planned and delivered.
fn running() -> Mesh {
    let mut m = Mesh::new(&["central", "r1", "r2"], &["r1", "r2"]);
    let cmds = m.to("central", Event::Start { query: 1, start: start("p", &["r1", "r2"]), from: central() });
    assert!(cmds.contains(&Command::Serve { mission: "p".into() }));
    assert!(matches!(cmds.iter().find(|c| matches!(c, Command::RequestPlan { .. })), Some(Command::RequestPlan { local: true, epoch: 1, .. })));
    assert!(replies(&cmds).is_empty(), "answered once planned");
    let ev = planned(&cmds).expect("a plan request");
    let cmds = m.to("central", ev);
    // The chain acknowledged synchronously: plans go out, the start is answered.
    assert_eq!(sent_plans(&cmds), [("r1".into(), 1), ("r2".into(), 1)]);
    assert_eq!(replies(&cmds), [1]);
    let v = m.nodes["central"].view(m.now, "p", false).expect("led");
    assert_eq!(v.manager.chain, ["central", "r1", "r2"]);
    m
}

#[test]
fn a_mission_starts_plans_once_committed_and_answers_the_start() {
    let m = running();
    assert!(m.nodes["r1"].replica("p").is_some_and(|r| r.state().is_some_and(|s| s.epoch == 1)));
    assert_eq!(m.nodes["central"].undelivered("p"), ["r1", "r2"]);
}

#[test]
fn plans_are_sent_again_until_the_robot_shows_them() {
    let mut m = running();
    assert!(sent_plans(&m.tick(1.0).into_iter().map(|c| c.1).collect::<Vec<_>>()).is_empty());
    m.to("central", progress("r1", "p", 1));
    // r2's plan is still on its way (its query not answered yet): not sent twice at once.
    assert!(sent_plans(&m.tick(1.1).into_iter().map(|c| c.1).collect::<Vec<_>>()).is_empty());
    // The query timed out: r1 shows its plan, r2 gets it again.
    m.to("central", Event::PlanDelivered { mission: "p".into(), robot: "r2".into(), epoch: 1, result: Err(Failure::retry("no answer")) });
    let again: Vec<Command> = m.tick(0.9).into_iter().filter(|(n, _)| n == "central").map(|c| c.1).collect();
    assert_eq!(sent_plans(&again), [("r2".into(), 1)], "r1 shows its plan; r2 gets it again");
    m.to("central", Event::PlanDelivered { mission: "p".into(), robot: "r2".into(), epoch: 1, result: Ok(()) });
    assert!(m.nodes["central"].undelivered("p").is_empty());
    assert!(sent_plans(&m.tick(3.0).into_iter().map(|c| c.1).collect::<Vec<_>>()).is_empty());
}

#[test]
fn a_control_is_answered_after_its_commit_and_dropped_by_a_non_head() {
    let mut m = running();
    // Not the head: no answer, so the system manager asks again (of the right node).
    assert_eq!(m.to("r2", Event::Ctl { query: 7, mission: "p".into(), ctl: MissionCtl::Terminate, from: central() }), vec![Command::Drop { query: 7 }]);
    // r2 stops answering: the change cannot commit, the answer waits.
    m.nodes.remove("r2");
    let cmds = m.to("central", Event::Ctl { query: 8, mission: "p".into(), ctl: MissionCtl::Joined { member: member("r3", 5.0) }, from: central() });
    assert!(replies(&cmds).is_empty(), "{cmds:?}");
    // r2 is declared gone: the chain is repaired without it and the change commits.
    m.to("central", Event::HostGone("r2".into()));
    m.to("r1", Event::HostGone("r2".into()));
    let later: Vec<Command> = (0..20).flat_map(|_| m.tick(0.1)).filter(|(n, _)| n == "central").map(|c| c.1).collect();
    assert_eq!(replies(&later), [8]);
    assert_eq!(m.nodes["central"].view(m.now, "p", false).map(|v| v.manager.chain), Some(vec!["central".into(), "r1".into()]));
}

#[test]
fn a_robot_central_takes_back_while_it_is_gone_here_is_kept_lost_until_it_is_back() {
    let mut m = running();
    let joined = |q: u64| Event::Ctl { query: q, mission: "p".into(), ctl: MissionCtl::Joined { member: member("r3", 5.0) }, from: central() };
    // Central's order came from a report older than r3's loss: r3 keeps its place as lost, and
    // the team is not replanned around a robot that would hold every barrier.
    let cmds = m.to("central", joined(8));
    assert!(!cmds.iter().any(|c| matches!(c, Command::RequestPlan { .. })), "{cmds:?}");
    assert_eq!(replies(&cmds), [8], "answered: the change is committed");
    let v = m.nodes["central"].view(m.now, "p", false).expect("led");
    assert_eq!((v.robots, v.lost), (vec!["r1".into(), "r2".into()], vec!["r3".into()]));
    // r3 is back here too late for that order: central's next order takes it in, and the team
    // is replanned with it.
    m.tick(super::head::ORDERED_BACK_S);
    m.to("central", Event::RobotAlive("r3".into()));
    m.to("central", progress("r3", "p", 1));
    assert_eq!(m.nodes["central"].view(m.now, "p", false).map(|v| v.lost), Some(vec!["r3".into()]), "an order that old no longer holds");
    let cmds = m.to("central", joined(9));
    assert!(matches!(cmds.iter().find(|c| matches!(c, Command::RequestPlan { .. })), Some(Command::RequestPlan { epoch: 2, .. })), "{cmds:?}");
    assert_eq!(m.nodes["central"].view(m.now, "p", false).map(|v| v.robots), Some(vec!["r1".into(), "r2".into(), "r3".into()]));
}

#[test]
fn a_robot_central_took_back_before_this_host_heard_it_come_back_rejoins_when_it_does() {
    let mut m = running();
    m.to("central", Event::RobotGone("r2".into()));
    assert_eq!(m.nodes["central"].view(m.now, "p", false).map(|v| v.lost), Some(vec!["r2".into()]));
    // Central heard r2 come back first (its own event, or its roll call) and ordered it back;
    // this host has not heard it yet: kept lost.
    let cmds = m.to("central", Event::Ctl { query: 8, mission: "p".into(), ctl: MissionCtl::Joined { member: member("r2", 1.0) }, from: central() });
    assert_eq!(replies(&cmds), [8]);
    assert_eq!(m.nodes["central"].view(m.now, "p", false).map(|v| v.lost), Some(vec!["r2".into()]));
    // This host hears it (event or roll call) soon after: the order holds, r2 rejoins — central
    // does not order twice.
    m.tick(1.0);
    m.to("central", Event::RobotAlive("r2".into()));
    m.to("central", progress("r2", "p", 1));
    let v = m.nodes["central"].view(m.now, "p", false).expect("led");
    assert_eq!((v.robots, v.lost), (vec!["r1".into(), "r2".into()], vec![]));
}

#[test]
fn a_planner_that_does_not_answer_is_asked_again_then_the_mission_fails() {
    let mut m = Mesh::new(&["central"], &["r1"]);
    m.to("central", Event::PlannerAlive { kind: "patrol".into(), zid: "z".into() });
    let cmds = m.to("central", Event::Start { query: 1, start: start("p", &["r1"]), from: central() });
    assert!(matches!(cmds.iter().find(|c| matches!(c, Command::RequestPlan { .. })), Some(Command::RequestPlan { local: false, .. })));
    let fail = || Event::Planned { mission: "p".into(), epoch: 1, result: Err(Failure::retry("no answer")) };
    // The service died: asked again, locally.
    m.to("central", Event::PlannerGone { kind: "patrol".into(), zid: "z".into() });
    for _ in 0..PLAN_RETRIES {
        let cmds = m.to("central", fail());
        assert!(matches!(cmds.as_slice(), [Command::RequestPlan { local: true, epoch: 1, .. }]), "{cmds:?}");
    }
    let cmds = m.to("central", fail());
    let cmds: Vec<Command> = cmds.into_iter().chain(m.tick(0.1).into_iter().map(|c| c.1)).collect();
    assert!(cmds.iter().any(|c| matches!(c, Command::Reply { query: 1, result: Err(e) } if e.error.contains("planning failed"))), "{cmds:?}");
    assert!(cmds.contains(&Command::Unserve { mission: "p".into() }));
}

#[test]
fn the_first_replica_takes_over_and_sends_the_committed_plans_again() {
    let mut m = running();
    m.nodes.remove("central");
    let cmds = m.to("r1", Event::HostGone("central".into()));
    let cmds: Vec<Command> = cmds.into_iter().chain(m.tick(0.1).into_iter().filter(|(n, _)| n == "r1").map(|c| c.1)).collect();
    assert!(cmds.contains(&Command::Serve { mission: "p".into() }), "{cmds:?}");
    let v = m.nodes["r1"].view(m.now, "p", false).expect("r1 leads");
    assert_eq!((v.manager.node.as_str(), v.manager.epoch), ("r1", 1), "same plans, no replan");
    assert!(v.manager.chain_epoch > 1);
    assert_eq!(sent_plans(&cmds), [("r1".into(), 1), ("r2".into(), 1)]);
}

#[test]
fn a_head_that_steps_down_lets_waiting_controls_go() {
    let mut m = running();
    m.nodes.remove("r2");
    m.to("central", Event::Ctl { query: 9, mission: "p".into(), ctl: MissionCtl::Left { ids: vec!["r1".into()] }, from: central() });
    // A newer head told it so: central steps down; the waiting control is not answered
    // (its asker will ask the new head).
    let state = m.nodes["r1"].replica("p").and_then(|r| r.state().cloned()).expect("r1 holds the state");
    let newer = mrmm_proto::chain::Msg::Update { config: mrmm_proto::chain::Config { epoch: 9, chain: vec!["r1".into(), "central".into()] }, seq: 3, state };
    let envelope = Box::new(mrmm_proto::ChainEnvelope { mission: "p".into(), from: "r1".into(), msg: newer });
    let cmds = m.to("central", Event::Chain { envelope, from: sender("r1") });
    assert!(cmds.contains(&Command::Drop { query: 9 }), "{cmds:?}");
    assert!(cmds.contains(&Command::Unserve { mission: "p".into() }));
}

#[test]
fn a_host_watches_the_robots_of_the_missions_it_leads_or_replicates_and_no_other() {
    use std::collections::BTreeSet;
    let mut m = Mesh::new(&["central", "r1", "r2", "h"], &["r1", "r2", "r3"]);
    let set = |v: &[&str]| v.iter().map(RobotId::from).collect::<BTreeSet<RobotId>>();
    assert!(m.nodes["central"].watched().is_empty(), "no mission: nobody to watch");
    let cmds = m.to("central", Event::Start { query: 1, start: start("p", &["r1", "r2"]), from: central() });
    let ev = planned(&cmds).expect("a plan request");
    m.to("central", ev);
    assert_eq!(m.nodes["central"].watched(), set(&["r1", "r2"]), "the head watches its members");
    assert_eq!(m.nodes["r1"].watched(), set(&["r1", "r2"]), "a replica watches them too (it may take over)");
    assert!(m.nodes["h"].watched().is_empty() && !m.nodes["h"].watches("r1"), "a host outside the mission watches nobody");
    // A lost member stays watched: its telemetry says when it may rejoin.
    m.to("central", Event::RobotGone("r2".into()));
    assert!(m.nodes["central"].watches("r2"));
    // A robot sends chain messages about a mission this node knows nothing of: held back until
    // its telemetry (now watched) says whether it runs that mission.
    let cfg = mrmm_proto::chain::Config { epoch: 1, chain: vec!["r3".into(), "h".into()] };
    let msg = mrmm_proto::chain::Msg::Beat { config: cfg, seq: 0 };
    let envelope = Box::new(mrmm_proto::ChainEnvelope { mission: "q".into(), from: "r3".into(), msg });
    let robot = mrmm_proto::Sender::new(mrmm_proto::Role::Robot, "r3");
    let cmds = m.to("h", Event::Chain { envelope: envelope.clone(), from: robot.clone() });
    assert!(cmds.is_empty() && m.nodes["h"].watches("r3"), "{cmds:?}");
    // Its telemetry says it runs another mission: refused, and h leaves the chain it was put in.
    m.to("h", progress("r3", "other", 1));
    let cmds = m.to("h", Event::Chain { envelope, from: robot.clone() });
    let refused = |c: &Command| matches!(c, Command::Refused(mrmm_proto::edge::Refused::NotEntitled { from, .. }) if *from == robot);
    assert!(cmds.iter().any(refused), "refused as its proven sender, typed: {cmds:?}");
    // Once it stops, h forgets it.
    m.tick(2.0 * UNJUDGED_S);
    m.tick(0.1);
    assert!(!m.nodes["h"].watches("r3"));
}

#[test]
fn a_head_whose_chain_restarted_blank_reports_it_cannot_commit_and_gives_the_mission_up_for_a_new_lineage() {
    let mut m = running();
    // r1 and r2 (the chain's two replicas) restart without disks while central leads; central
    // hears of it after both came back blank (a vote it asks for is refused).
    let p = Params { quarantine: 0.0, ..Params::default() };
    m.tick(1.0);
    for r in ["r1", "r2"] {
        m.nodes.insert(r.to_string(), HostCore::new(r, p, m.now));
    }
    for r in ["r1", "r2"] {
        m.to("central", Event::HostGone(r.into()));
        m.to("central", Event::RobotGone(r.into()));
    }
    for a in ["central", "r1", "r2"] {
        for b in ["central", "r1", "r2"] {
            m.to(a, Event::HostAlive(b.into()));
        }
        for r in ["r1", "r2"] {
            m.to(a, Event::RobotAlive(r.into()));
        }
    }
    let since = m.now;
    for _ in 0..250 {
        m.tick(0.1);
    }
    let v = m.nodes["central"].view(m.now, "p", false).expect("still led");
    let stuck = v.manager.uncommitted_s.expect("a head that cannot commit says so");
    assert!(stuck >= 20.0 && stuck <= m.now - since + 0.1, "{stuck} s");
    // Central starts p anew (lineage 1) on its host: the stuck head gives it up, and the new
    // lineage's chain forms with the blank nodes, its plans above every epoch of the old one.
    let mut anew = start("p", &["r1", "r2"]);
    anew.anew = true;
    anew.lineage = 1;
    let cmds = m.to("central", Event::Start { query: 9, start: anew, from: central() });
    assert!(cmds.contains(&Command::Unserve { mission: "p".into() }), "the old head stepped down: {cmds:?}");
    assert!(cmds.contains(&Command::Serve { mission: "p".into() }), "{cmds:?}");
    let ev = planned(&cmds).expect("a plan request");
    let cmds = m.to("central", ev);
    assert_eq!(replies(&cmds), [9], "{cmds:?}");
    let floor = mrmm_proto::chain::lineage_floor(1);
    assert!(sent_plans(&cmds).iter().all(|(_, e)| *e > floor) && sent_plans(&cmds).len() == 2, "{cmds:?}");
    let v = m.nodes["central"].view(m.now, "p", false).expect("led anew");
    assert_eq!((v.manager.chain, v.manager.uncommitted_s), (vec!["central".into(), "r1".into(), "r2".into()], None));
    assert!(m.nodes["r2"].replica("p").is_some_and(|r| r.state().is_some()), "the new chain holds the state");
}

#[test]
fn a_healthy_head_is_not_given_up_by_a_start_anew() {
    let mut m = running();
    let mut anew = start("p", &["r1", "r2"]);
    anew.anew = true;
    anew.lineage = 1;
    let cmds = m.to("central", Event::Start { query: 9, start: anew, from: central() });
    assert!(cmds.iter().any(|c| matches!(c, Command::Reply { query: 9, result: Err(e) } if e.error.contains("already hosted"))), "{cmds:?}");
    assert!(!cmds.contains(&Command::Unserve { mission: "p".into() }));
}

/// A robot released from a mission that ended here, but which never heard the end (lost), keeps
/// a replica and votes to stand again: it is no longer entitled to speak for the mission, and is
/// told the mission ended all the same — refused without the end, it could stand again with its
/// old team (system sim, seed 1948).
#[test]
fn a_straggler_of_an_ended_mission_is_told_so_though_no_longer_entitled() {
    let mut m = running();
    // r2 hears nothing more: the end does not reach it.
    m.nodes.remove("r2");
    let cmds = m.to("central", Event::Ctl { query: 9, mission: "p".into(), ctl: MissionCtl::Terminate, from: central() });
    assert_eq!(replies(&cmds), [9], "{cmds:?}");
    // Central's replica ends (the end's acknowledgement never comes: it retires by itself).
    for _ in 0..200 {
        m.tick(0.5);
    }
    assert!(m.nodes["central"].replica("p").is_none(), "ended here");
    let vote = chain::Msg::Vote { proposal: mrmm_proto::chain::Config { epoch: 5, chain: vec!["r2".into(), "central".into()] }, base: vec![], last: (1, 3) };
    let robot = mrmm_proto::Sender::new(mrmm_proto::Role::Robot, "r2");
    // r2 runs another mission now, as its telemetry says.
    m.to("central", progress("r2", "q", 1));
    let core = m.nodes.get_mut("central").expect("central");
    let out = core.handle(m.now, Event::Chain { envelope: Box::new(ChainEnvelope { mission: "p".into(), from: "r2".into(), msg: vote }), from: robot });
    assert!(out.iter().any(|c| matches!(c, Command::Chain { to, envelope } if to == "r2" && matches!(envelope.msg, chain::Msg::End { .. }))), "{out:?}");
    assert!(out.iter().any(|c| matches!(c, Command::Refused(_))), "and nothing it sent is taken: {out:?}");
}

/// A large team is handed its plans a window at a time: each answer lets the next plan go, the
/// tick sends what the window has room for, and every member gets its plan once.
#[test]
fn a_large_team_gets_its_plans_a_window_at_a_time() {
    let ids: Vec<String> = (1..=40).map(|i| format!("r{i}")).collect();
    let robots: Vec<&str> = ids.iter().map(String::as_str).collect();
    let mut m = Mesh::new(&["central"], &robots);
    let cmds = m.to("central", Event::Start { query: 1, start: start("p", &robots), from: central() });
    let cmds = m.to("central", planned(&cmds).expect("a plan request"));
    let first = sent_plans(&cmds);
    assert_eq!(first.len(), head::DELIVERY_WINDOW, "a window's worth at first");
    // One answer: one more plan goes out at once.
    let (done, _) = first[0].clone();
    let next = sent_plans(&m.to("central", Event::PlanDelivered { mission: "p".into(), robot: done.clone().into(), epoch: 1, result: Ok(()) }));
    assert_eq!(next.len(), 1);
    assert!(!first.contains(&next[0]), "a robot still waiting: {next:?}");
    // The rest answer: the others go out as places free up, none twice.
    let mut got: Vec<String> = first.iter().chain(&next).map(|(r, _)| r.clone()).collect();
    for (r, _) in first.iter().skip(1).chain(&next) {
        let more = m.to("central", Event::PlanDelivered { mission: "p".into(), robot: r.clone().into(), epoch: 1, result: Ok(()) });
        got.extend(sent_plans(&more).into_iter().map(|(r, _)| r));
    }
    let mut tick = sent_plans(&m.tick(0.1).into_iter().map(|c| c.1).collect::<Vec<_>>());
    got.extend(tick.drain(..).map(|(r, _)| r));
    let mut sorted = got.clone();
    sorted.sort();
    sorted.dedup();
    assert_eq!(sorted.len(), got.len(), "no plan sent twice: {got:?}");
    assert_eq!(sorted.len(), 40, "every member got its plan");
}

//! Mission manager flows, asserting the emitted commands: initiate, leave, join, lose, stale
//! plans, metrics.

use super::*;
use crate::at;
use mrmm_planner::recipe;
use mrmm_proto::{BarrierMode, Behaviour, Pose, Progress, Step, Velocity};

fn spec() -> MissionSpec {
    let xml = recipe::bank("patrol").expect("bank").to_string();
    MissionSpec {
        name: "p1".into(),
        recipe_name: "patrol".into(),
        recipe_xml: xml,
        planner: PlannerKind::Patrol,
        params: BTreeMap::from([("waypoints".to_string(), "[[0,0],[20,0],[20,20],[0,20]]".to_string())]),
        replicas: 2,
        requires: vec![],
        map: None,
        paused: false,
    }
}

fn robot(id: &str, t: &str, x: f64) -> Member {
    Member {
        spec: RobotSpec { id: id.into(), robot_type: t.into(), x, y: -2.0, speed: 1.0, turn_rate: None, reach_m: None },
        time_scale: 1.0,
        capabilities: vec![],
    }
}

/// Runs the planner as a planner service would.
fn plan_for(cmds: &[Command]) -> (u64, MissionPlan) {
    let Some(Command::RequestPlan { epoch, request, .. }) = cmds.iter().find(|c| matches!(c, Command::RequestPlan { .. })) else {
        panic!("expected a plan request in {cmds:?}");
    };
    let xml = recipe::bank(&request.recipe).unwrap_or(&request.recipe);
    let r = recipe::parse(xml).expect("recipe");
    (
        *epoch,
        recipe::build_with(
            &r,
            &request.params,
            &request.robots,
            &request.capabilities.iter().map(|(k, v)| (k.to_string(), v.clone())).collect(),
            None,
            recipe::Bounds::Relaxed,
        )
        .expect("plan")
        .to_wire(),
    )
}

fn sent_to(cmds: &[Command]) -> Vec<(String, u64, usize)> {
    cmds.iter()
        .filter_map(|c| match c {
            Command::SendPlan { robot, assignment } => Some((robot.to_string(), assignment.epoch, assignment.members.len())),
            _ => None,
        })
        .collect()
}

fn started() -> MissionManager {
    let mut m = MissionManager::new(spec(), "node".into(), vec![robot("a", "ground", 0.0), robot("b", "ground", 5.0), robot("c", "aerial", 10.0)]);
    let cmds = m.handle(at(0.0), Event::Start);
    let (epoch, plan) = plan_for(&cmds);
    assert_eq!(epoch, 1);
    let cmds = m.handle(at(0.0), Event::PlanReady { epoch, plan: Box::new(plan) });
    assert_eq!(sent_to(&cmds), [("a".into(), 1, 3), ("b".into(), 1, 3), ("c".into(), 1, 3)]);
    assert_eq!(cmds.last(), Some(&Command::Started));
    m
}

#[test]
fn initiating_builds_teams_and_sends_plans() {
    let m = started();
    let v = m.view(true);
    assert_eq!(v.status, MissionStatus::Running);
    assert_eq!(v.teams["p1/ground"], ["a", "b"]);
    assert_eq!(v.teams["p1/aerial"], ["c"]);
    assert_eq!(v.plans.as_ref().map(Vec::len), Some(3));
    let Some(PlanSummary::Patrol(p)) = &v.summary else { panic!("a patrol summary") };
    assert!((p.length - 80.0).abs() < 1e-9);
    assert!(serde_json::to_value(&v).expect("json")["summary"].get("plans").is_none());
}

#[test]
fn leaving_replans_for_the_rest_and_old_plans_are_ignored() {
    let mut m = started();
    let cmds = m.handle(at(0.0), Event::Left { ids: vec!["b".into()] });
    let (epoch, plan) = plan_for(&cmds);
    assert_eq!(epoch, 2);
    // A late plan of epoch 1 changes nothing.
    let (_, old) = plan_for(&[Command::RequestPlan {
        epoch: 1,
        kind: PlannerKind::Patrol,
        request: PlanRequest {
            recipe: spec().recipe_xml,
            params: spec().params,
            robots: vec![robot("a", "ground", 0.0).spec],
            map: None,
            capabilities: Default::default(),
            relax_bounds: true,
        },
    }]);
    assert!(m.handle(at(0.0), Event::PlanReady { epoch: 1, plan: Box::new(old) }).is_empty());
    let cmds = m.handle(at(0.0), Event::PlanReady { epoch, plan: Box::new(plan.clone()) });
    assert_eq!(sent_to(&cmds), [("a".into(), 2, 2), ("c".into(), 2, 2)]);
    assert!(!cmds.contains(&Command::Started), "started only once");
    // Two robots, evenly spaced: spacing L/2.
    let PlanSummary::Patrol(p) = plan.summary else { panic!() };
    assert!((p.spacing - 40.0).abs() < 1e-9);
    // Unknown robots leaving change nothing.
    assert!(m.handle(at(0.0), Event::Left { ids: vec!["zz".into()] }).is_empty());
}

#[test]
fn joining_replans_including_the_newcomer() {
    let mut m = started();
    let cmds = m.handle(at(0.0), Event::Joined(robot("d", "ground", 3.0)));
    let (epoch, plan) = plan_for(&cmds);
    let cmds = m.handle(at(0.0), Event::PlanReady { epoch, plan: Box::new(plan) });
    assert_eq!(sent_to(&cmds).len(), 4);
    assert_eq!(m.view(false).teams["p1/ground"], ["a", "b", "d"]);
}

/// The plans sent, by robot.
fn plans_sent(cmds: &[Command]) -> BTreeMap<String, PlanAssignment> {
    cmds.iter()
        .filter_map(|c| match c {
            Command::SendPlan { robot, assignment } => Some((robot.to_string(), (**assignment).clone())),
            _ => None,
        })
        .collect()
}

#[test]
fn a_hand_over_carries_the_plan_on_without_a_replan() {
    let mut m = started();
    let before = plans_sent(&m.current_assignments());
    m.handle(at(1.0), Event::Telemetry(Box::new(tel("a", 0.0, 0.0, 4, 2))));
    m.handle(at(1.0), Event::Telemetry(Box::new(tel("b", 5.0, 0.0, 4, 2))));
    let cmds = m.handle(at(2.0), Event::Replaced { out: "b".into(), by: robot("d", "ground", 6.0) });
    assert!(!cmds.iter().any(|c| matches!(c, Command::RequestPlan { .. })), "no planner asked: {cmds:?}");
    let sent = plans_sent(&cmds);
    assert_eq!(sent.keys().collect::<Vec<_>>(), ["a", "c", "d"]);
    let (a, d) = (&sent["a"], &sent["d"]);
    assert_eq!(a.epoch, 2);
    assert_eq!(a.plan, before["a"].plan, "the others' plans are the same");
    assert_eq!(a.members, ["a", "d", "c"], "the team has the newcomer instead");
    assert_eq!(d.plan.steps, before["b"].plan.steps, "the newcomer has the leaver's plan");
    assert_eq!((d.plan.robot.as_str(), d.plan.slot), ("d", before["b"].plan.slot));
    assert_eq!(d.handover, Some(proto::Handover { planned: 1, step: 3, round: 2 }), "from where the leaver was");
    assert_eq!(a.handover.map(|h| h.planned), Some(1));
    assert_eq!(sent["c"].handover.map(|h| (h.step, h.round)), Some((0, 0)), "c never said where it is");
    assert_eq!(m.view(false).teams["p1/ground"], ["a", "d"]);

    // A second hand-over keeps the lineage; a new head re-sends the same.
    m.handle(
        at(3.0),
        Event::Telemetry(Box::new(Telemetry {
            progress: Some(Progress { epoch: 2, ..tel("d", 6.0, 0.0, 1, 3).progress.expect("p") }),
            ..tel("d", 6.0, 0.0, 1, 3)
        })),
    );
    let cmds = m.handle(at(4.0), Event::Replaced { out: "d".into(), by: robot("e", "ground", 6.0) });
    let e = &plans_sent(&cmds)["e"];
    assert_eq!((e.epoch, e.handover), (3, Some(proto::Handover { planned: 1, step: 3, round: 3 })));
    let snap = m.snapshot();
    let again = MissionManager::restore(snap, "other".into()).expect("restore");
    assert_eq!(plans_sent(&again.current_assignments())["e"].handover, e.handover);

    // Without word from the leaver on the current plan: a leave and a join, one replan.
    let cmds = m.handle(at(5.0), Event::Replaced { out: "a".into(), by: robot("f", "ground", 1.0) });
    let (epoch, plan) = plan_for(&cmds);
    assert_eq!(epoch, 4);
    let cmds = m.handle(at(5.0), Event::PlanReady { epoch, plan: Box::new(plan) });
    assert!(plans_sent(&cmds).values().all(|a| a.handover.is_none()), "a planned plan carries nothing on");
    assert_eq!(m.view(false).teams["p1/ground"], ["e", "f"]);
}

#[test]
fn losing_everyone_stalls_and_a_failed_first_plan_fails() {
    let mut m = started();
    for id in ["a", "b"] {
        assert!(!m.handle(at(0.0), Event::Left { ids: vec![id.into()] }).is_empty());
    }
    assert!(m.handle(at(0.0), Event::Left { ids: vec!["c".into()] }).is_empty(), "no plan for nobody");
    assert_eq!(m.view(false).status, MissionStatus::Stalled);

    let mut f = MissionManager::new(spec(), "n".into(), vec![robot("a", "ground", 0.0)]);
    let cmds = f.handle(at(0.0), Event::Start);
    let (epoch, _) = plan_for(&cmds);
    assert_eq!(f.handle(at(0.0), Event::PlanFailed { epoch, error: "boom".into() }), vec![Command::Failed { error: "boom".into() }]);
    assert_eq!(f.view(false).status, MissionStatus::Failed);
}

fn tel(id: &str, x: f64, y: f64, syncs: u32, round: u32) -> Telemetry {
    Telemetry {
        id: id.into(),
        seq: 1,
        t: 0.0,
        pose: Pose { x, y, theta: 0.0 },
        velocity: Velocity::default(),
        behaviour: Behaviour::Hold,
        mission: Some("p1".into()),
        progress: Some(Progress {
            mission: "p1".into(),
            epoch: 1,
            step: 3,
            round,
            syncs_passed: syncs,
            sync_msgs: syncs,
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
    }
}

#[test]
fn a_robot_lingering_at_a_waypoint_is_one_visit() {
    let mut m = started();
    // a waits at waypoint 0 (a barrier there) from 1 s to 5 s, seen at 5 Hz; b comes at 15 s.
    for k in 0..=20 {
        let t = 1.0 + f64::from(k) * 0.2;
        m.handle(at(t), Event::Telemetry(Box::new(tel("a", 0.0, 0.0, 1, 0))));
    }
    m.handle(at(15.0), Event::Telemetry(Box::new(tel("b", 0.0, 0.3, 1, 0))));
    let x = m.metrics();
    assert_eq!(x.visits[0], 2, "{x:?}");
    assert!(x.avg_idleness.is_some_and(|i| (i - 14.0).abs() < 1e-9), "from a's arrival at 1 s to b's at 15 s: {x:?}");
}

#[test]
fn robots_side_by_side_at_a_waypoint_are_one_arrival_each() {
    let mut m = started();
    m.handle(at(1.0), Event::Telemetry(Box::new(tel("a", 0.0, 0.0, 1, 0))));
    m.handle(at(3.0), Event::Telemetry(Box::new(tel("b", 0.5, 0.0, 1, 0))));
    // a is still there (it waits at a barrier), sampled again after b came: not a new arrival.
    for t in [4.0, 6.0, 8.0] {
        m.handle(at(t), Event::Telemetry(Box::new(tel("a", 0.0, 0.0, 1, 0))));
        m.handle(at(t), Event::Telemetry(Box::new(tel("b", 0.5, 0.0, 1, 0))));
    }
    let x = m.metrics();
    assert_eq!(x.visits[0], 2, "{x:?}");
    assert_eq!(x.avg_idleness, Some(2.0), "{x:?}");
}

#[test]
fn sparse_samples_of_one_pass_are_one_visit_and_a_return_is_another() {
    // Telemetry comes at a wall-clock rate: at a time scale of 10, 5 Hz is a sample every 2
    // robot seconds, farther apart than the debounce.
    let mut m = started();
    m.handle(at(1.0), Event::Telemetry(Box::new(tel("a", -1.0, 0.0, 1, 0))));
    m.handle(at(3.0), Event::Telemetry(Box::new(tel("a", 1.0, 0.0, 1, 0))));
    m.handle(at(5.0), Event::Telemetry(Box::new(tel("a", 3.0, 0.0, 1, 0))));
    assert_eq!(m.metrics().visits[0], 1, "one pass");
    m.handle(at(25.0), Event::Telemetry(Box::new(tel("a", 0.5, 0.0, 1, 1))));
    let x = m.metrics();
    assert_eq!(x.visits[0], 2, "a came back: {x:?}");
    assert!(x.avg_idleness.is_some_and(|i| (i - 24.0).abs() < 1e-9), "from the arrival at 1 s to the next at 25 s: {x:?}");
}

#[test]
fn metrics_from_telemetry() {
    let mut m = started();
    // Not yet past the start barrier: no visit counted.
    m.handle(at(0.0), Event::Telemetry(Box::new(tel("a", 0.0, 0.0, 0, 0))));
    assert_eq!(m.metrics().visits.iter().sum::<u32>(), 0);
    m.handle(at(1.0), Event::Telemetry(Box::new(tel("a", 0.0, 0.0, 1, 0))));
    m.handle(at(1.2), Event::Telemetry(Box::new(tel("a", 0.1, 0.0, 1, 0)))); // debounced
    m.handle(at(11.0), Event::Telemetry(Box::new(tel("b", 0.0, 0.5, 2, 0))));
    m.handle(at(12.0), Event::Telemetry(Box::new(tel("c", 50.0, 50.0, 3, 1))));
    let x = m.metrics();
    assert_eq!(x.visits.iter().sum::<u32>(), 2);
    assert_eq!(x.avg_idleness, Some(10.0));
    assert_eq!(x.worst_idleness, Some(10.0));
    assert_eq!(x.sync_points_passed, 1);
    assert_eq!(x.rounds, 0);
    assert_eq!(x.messages["plan"], 3);
    assert_eq!(x.messages["sync"], 6);
    // Marginal benefit: L / (n v).
    let g = m.marginal(1).expect("marginal");
    assert_eq!((g.robots, g.with_robots), (3, 4));
    assert!((g.predicted - 20.0).abs() < 1e-9 && (g.current - 80.0 / 3.0).abs() < 1e-9);
    assert!(m.marginal(-3).is_err());
}

#[test]
fn stuck_members_are_shown_keep_their_place_and_go_when_they_move_again_or_leave() {
    let mut m = started();
    let stuck = |id: &str, why: &str| Telemetry { stuck: Some(why.into()), ..tel(id, 0.0, 0.0, 0, 0) };
    assert!(m.handle(at(1.0), Event::Telemetry(Box::new(stuck("a", "Nav2 (/navigate_to_pose) rejected the goal to (1.00, 0.00)")))).is_empty(), "no replan");
    m.handle(at(1.1), Event::Telemetry(Box::new(stuck("b", &"x".repeat(5000)))));
    m.handle(at(1.2), Event::Telemetry(Box::new(stuck("z", "not a member"))));
    let v = m.view(false);
    assert_eq!(v.stuck.keys().collect::<Vec<_>>(), ["a", "b"]);
    assert!(v.stuck["a"].contains("rejected") && v.stuck["b"].len() <= MAX_STUCK_REASON);
    assert_eq!(v.robots, ["a", "b", "c"], "they keep their place");
    m.handle(at(2.0), Event::Telemetry(Box::new(tel("a", 0.5, 0.0, 0, 0))));
    let cmds = m.handle(at(2.1), Event::Left { ids: vec!["b".into()] });
    assert!(!cmds.is_empty(), "b leaving replans");
    assert!(m.view(false).stuck.is_empty(), "a moves again, b left");
}

#[test]
fn changes_are_handed_out_once_with_a_growing_revision() {
    let mut m = started();
    let first = m.changes().expect("the initial state");
    assert!(m.changes().is_none(), "nothing new");
    m.handle(at(1.0), Event::Left { ids: vec!["b".into()] });
    let second = m.changes().expect("b left");
    assert_eq!(second.revision, first.revision + 1);
    assert_eq!(second.members.len(), 2);
    // A new head restored from it goes on counting from there.
    let mut n = MissionManager::restore(second.clone(), "other".into()).expect("restore");
    assert!(n.changes().is_none());
    n.handle(at(2.0), Event::Left { ids: vec!["c".into()] });
    assert_eq!(n.changes().map(|s| s.revision), Some(second.revision + 1));
    // Resume asks again only when the predecessor died while planning (epoch 2 has no plan).
    assert!(matches!(n.handle(at(3.0), Event::Resume).as_slice(), [Command::RequestPlan { epoch: 4, .. }]));
}

#[test]
fn metrics_survive_a_takeover_through_the_replicated_state() {
    let mut m = started();
    m.handle(at(1.0), Event::Telemetry(Box::new(tel("a", 0.0, 0.0, 1, 0))));
    m.handle(at(11.0), Event::Telemetry(Box::new(tel("b", 0.0, 0.5, 2, 0))));
    m.handle(at(12.0), Event::Telemetry(Box::new(tel("c", 20.0, 0.0, 3, 1))));
    // Telemetry alone does not touch the replicated state; the checkpoint does.
    let before = m.changes();
    assert!(before.as_ref().is_some_and(|s| s.tally.is_none()), "{before:?}");
    m.handle(at(12.5), Event::Checkpoint);
    let snap = m.changes().expect("the checkpoint changed the replicated state");
    assert_eq!(snap.tally.as_ref().map(|t| t.visits.iter().sum::<u32>()), Some(3));
    assert!(m.changes().is_none(), "nothing new to replicate");
    // A new head on another node (its own clock: 1000 s there is 12.5 s here).
    let mut n = MissionManager::restore(snap.clone(), "other".into()).expect("restore");
    assert_eq!(n.metrics().visits, m.metrics().visits);
    assert_eq!(n.metrics().avg_idleness, Some(10.0));
    n.handle(at(1000.0), Event::Telemetry(Box::new(tel("a", 5.0, 5.0, 4, 1))));
    // (0, 0) was last visited 1 s before the last telemetry of the old head; the new head places
    // that at its first telemetry (1000 s): a visit at 1014 s is a 15 s gap.
    n.handle(at(1014.0), Event::Telemetry(Box::new(tel("b", 0.0, 0.0, 4, 1))));
    let x = n.metrics();
    assert_eq!(x.visits.iter().sum::<u32>(), 4);
    assert_eq!(x.worst_idleness, Some(15.0));
    assert_eq!(x.avg_idleness, Some(12.5));
    // A tally that does not fit the tour (or holds nonsense) is ignored: counting starts afresh.
    let mut bad = snap;
    if let Some(t) = bad.tally.as_mut() {
        t.since_visit[0] = Some(f64::NAN);
    }
    let k = MissionManager::restore(bad, "third".into()).expect("restore");
    assert_eq!(k.metrics().visits.iter().sum::<u32>(), 0);
}

#[test]
fn barrier_messages_of_an_earlier_plan_still_count_after_a_replan() {
    let mut m = started();
    for id in ["a", "b", "c"] {
        m.handle(at(1.0), Event::Telemetry(Box::new(tel(id, 50.0, 50.0, 4, 1))));
    }
    assert_eq!(m.metrics().messages["sync"], 12);
    // c leaves: 4 of its own stay counted; a and b go on under epoch 2, from 0.
    let cmds = m.handle(at(2.0), Event::Left { ids: vec!["c".into()] });
    let (epoch, plan) = plan_for(&cmds);
    m.handle(at(2.0), Event::PlanReady { epoch, plan: Box::new(plan) });
    for id in ["a", "b"] {
        let mut t = tel(id, 50.0, 50.0, 1, 0);
        if let Some(p) = t.progress.as_mut() {
            p.epoch = epoch;
        }
        m.handle(at(3.0), Event::Telemetry(Box::new(t)));
    }
    assert_eq!(m.metrics().messages["sync"], 12 + 2, "{:?}", m.metrics().messages);
}

#[test]
fn the_barrier_mode_of_the_mission_goes_out_with_every_plan() {
    let modes = |spec: MissionSpec| -> Vec<BarrierMode> {
        let mut m = MissionManager::new(spec, "node".into(), vec![robot("a", "ground", 0.0), robot("b", "ground", 5.0)]);
        let (epoch, plan) = plan_for(&m.handle(at(0.0), Event::Start));
        m.handle(at(0.0), Event::PlanReady { epoch, plan: Box::new(plan) })
            .iter()
            .filter_map(|c| match c {
                Command::SendPlan { assignment, .. } => Some(assignment.barrier),
                _ => None,
            })
            .collect()
    };
    assert_eq!(modes(spec()), [BarrierMode::Mesh, BarrierMode::Mesh]);
    let mut leader = spec();
    leader.params.insert("barrier".into(), "leader".into());
    assert_eq!(modes(leader), [BarrierMode::Leader, BarrierMode::Leader]);
    // Without the parameter, large teams get the leader barrier.
    let team: Vec<Member> = (0..LEADER_BARRIER_FROM).map(|i| robot(&format!("r{i}"), "ground", i as f64)).collect();
    let mut m = MissionManager::new(spec(), "node".into(), team);
    let (epoch, plan) = plan_for(&m.handle(at(0.0), Event::Start));
    let cmds = m.handle(at(0.0), Event::PlanReady { epoch, plan: Box::new(plan) });
    let leaders = cmds.iter().filter(|c| matches!(c, Command::SendPlan { assignment, .. } if assignment.barrier == BarrierMode::Leader)).count();
    assert_eq!(leaders, LEADER_BARRIER_FROM, "every plan of a large team runs the leader barrier");
    let mut mesh = spec();
    mesh.params.insert("barrier".into(), "mesh".into());
    let team: Vec<Member> = (0..LEADER_BARRIER_FROM).map(|i| robot(&format!("r{i}"), "ground", i as f64)).collect();
    let mut m = MissionManager::new(mesh, "node".into(), team);
    let (epoch, plan) = plan_for(&m.handle(at(0.0), Event::Start));
    let cmds = m.handle(at(0.0), Event::PlanReady { epoch, plan: Box::new(plan) });
    assert!(cmds.iter().any(|c| matches!(c, Command::SendPlan { assignment, .. } if assignment.barrier == BarrierMode::Mesh)), "the parameter wins");
}

/// An update replans the same members as the next epoch, with the new parameters; the same
/// spec again changes nothing.
#[test]
fn an_update_replans_the_same_members_as_the_next_epoch() {
    let mut m = started();
    let mut s = spec();
    s.params.insert("waypoints".into(), "[[0,0],[30,0],[30,30],[0,30]]".into());
    let cmds = m.handle(at(1.0), Event::Update(Box::new(s.clone())));
    let (epoch, plan) = plan_for(&cmds);
    assert_eq!(epoch, 2);
    let PlanSummary::Patrol(p) = &plan.summary else { panic!("patrol") };
    assert!((p.length - 120.0).abs() < 1e-9, "the new square: {}", p.length);
    let cmds = m.handle(at(1.0), Event::PlanReady { epoch, plan: Box::new(plan) });
    assert_eq!(sent_to(&cmds), [("a".into(), 2, 3), ("b".into(), 2, 3), ("c".into(), 2, 3)]);
    assert_eq!(m.snapshot().spec.params["waypoints"], "[[0,0],[30,0],[30,30],[0,30]]", "replicated with the state");
    assert!(m.handle(at(1.0), Event::Update(Box::new(s))).is_empty(), "the same spec re-sent");
}

/// Paused, every member holds (a plan of its own, no planner asked, no barrier), joins and
/// leaves too; resumed, the team is planned again from where it stands.
#[test]
fn a_paused_mission_holds_its_members_and_resumes() {
    let mut m = started();
    let mut s = spec();
    s.paused = true;
    let cmds = m.handle(at(1.0), Event::Update(Box::new(s.clone())));
    assert!(!cmds.iter().any(|c| matches!(c, Command::RequestPlan { .. })), "no planner while paused: {cmds:?}");
    assert_eq!(sent_to(&cmds), [("a".into(), 2, 3), ("b".into(), 2, 3), ("c".into(), 2, 3)]);
    for c in &cmds {
        if let Command::SendPlan { assignment, .. } = c {
            assert_eq!(assignment.plan.steps, vec![Step::Stream, Step::Hold { seconds: None }]);
        }
    }
    assert_eq!(m.view(false).status, MissionStatus::Paused);
    assert!(m.view(false).summary.is_some(), "the last plan's figures stay on show");
    // A newcomer while paused holds too.
    let cmds = m.handle(at(1.5), Event::Joined(robot("d", "ground", 3.0)));
    assert_eq!(sent_to(&cmds).len(), 4);
    assert!(!cmds.iter().any(|c| matches!(c, Command::RequestPlan { .. })));
    // The paused state is replicated: a new head goes on paused.
    let again = MissionManager::restore(m.snapshot(), "other".into()).expect("restore");
    assert_eq!(again.view(false).status, MissionStatus::Paused);
    s.paused = false;
    let cmds = m.handle(at(2.0), Event::Update(Box::new(s)));
    let (epoch, plan) = plan_for(&cmds);
    assert_eq!(epoch, 4);
    m.handle(at(2.0), Event::PlanReady { epoch, plan: Box::new(plan) });
    assert_eq!(m.view(false).status, MissionStatus::Running);
}

/// A burst of losses is planned around once: the epoch moves on at the first loss (a successor
/// would replan), the plan is asked for when the burst is over, for the members left.
#[test]
fn a_burst_of_losses_costs_one_replan() {
    let mut m = MissionManager::new(spec(), "node".into(), (0..6).map(|i| robot(&format!("r{i}"), "ground", i as f64)).collect());
    let (epoch, plan) = plan_for(&m.handle(at(0.0), Event::Start));
    m.handle(at(0.0), Event::PlanReady { epoch, plan: Box::new(plan) });
    for (i, id) in ["r1", "r2", "r3"].iter().enumerate() {
        let out = m.handle(at(1.0 + 0.1 * i as f64), Event::Lost { ids: vec![id.into()] });
        assert!(out.is_empty(), "no plan asked per loss: {out:?}");
    }
    assert_eq!(m.epoch(), 2, "the plan is outdated at once");
    assert!(m.handle(at(1.8), Event::Tick).is_empty(), "the burst is not over");
    let out = m.handle(at(2.1), Event::Tick);
    let asked: Vec<&Command> = out.iter().filter(|c| matches!(c, Command::RequestPlan { .. })).collect();
    assert_eq!(asked.len(), 1, "{out:?}");
    let Command::RequestPlan { epoch, request, .. } = asked[0] else { unreachable!() };
    assert_eq!((*epoch, request.robots.len()), (2, 3));
    assert!(m.handle(at(2.5), Event::Tick).is_empty(), "once");
    // A successor taking over inside a burst sees the plan outdated and replans.
    m.handle(at(3.0), Event::Lost { ids: vec!["r4".into()] });
    let again = MissionManager::restore(m.snapshot(), "other".into()).expect("restore");
    assert_ne!(again.snapshot().plan.map(|(e, _)| e), Some(again.epoch()));
}

/// A member lost and back within a burst (links flapping on a loaded machine) costs no plan of its
/// own: the replan held for the burst takes it in.
#[test]
fn a_member_back_within_a_burst_is_planned_with_it() {
    let mut m = MissionManager::new(spec(), "node".into(), (0..6).map(|i| robot(&format!("r{i}"), "ground", i as f64)).collect());
    let (epoch, plan) = plan_for(&m.handle(at(0.0), Event::Start));
    m.handle(at(0.0), Event::PlanReady { epoch, plan: Box::new(plan) });
    let asked = |out: &[Command]| {
        out.iter()
            .filter_map(|c| if let Command::RequestPlan { epoch, request, .. } = c { Some((*epoch, request.robots.len())) } else { None })
            .collect::<Vec<_>>()
    };
    m.handle(at(1.0), Event::Lost { ids: vec!["r1".into(), "r2".into()] });
    assert!(asked(&m.handle(at(1.4), Event::Joined(robot("r1", "ground", 1.0)))).is_empty(), "held with the burst");
    assert!(asked(&m.handle(at(1.95), Event::Tick)).is_empty(), "a second after the first loss");
    assert_eq!(asked(&m.handle(at(2.0), Event::Tick)), [(2, 5)], "one plan: r1 in, r2 out");
    // With no burst held, a join is planned at once.
    assert_eq!(asked(&m.handle(at(5.0), Event::Joined(robot("r2", "ground", 2.0)))), [(3, 6)]);
}

/// Losses noticed one after another (each within half a second of the last) are one burst, and
/// the replan is held at most three seconds after the first.
#[test]
fn losses_seen_one_after_another_are_one_burst_within_its_bound() {
    let mut m = MissionManager::new(spec(), "node".into(), (0..12).map(|i| robot(&format!("r{i}"), "ground", i as f64)).collect());
    let (epoch, plan) = plan_for(&m.handle(at(0.0), Event::Start));
    m.handle(at(0.0), Event::PlanReady { epoch, plan: Box::new(plan) });
    let asked = |out: &[Command]| out.iter().filter(|c| matches!(c, Command::RequestPlan { .. })).count();
    let mut replans = 0;
    // A loss every 0.4 s from t = 1: the first burst's bound (t = 4) ends it.
    for k in 0..10 {
        let t = 1.0 + 0.4 * k as f64;
        replans += asked(&m.handle(at(t), Event::Tick));
        m.handle(at(t), Event::Lost { ids: vec![format!("r{k}").into()] });
        replans += asked(&m.handle(at(t + 0.2), Event::Tick));
    }
    assert_eq!(replans, 1, "one replan for the losses up to the bound");
    assert_eq!(m.epoch(), 3, "the losses after the bound are a burst of their own");
    // Three losses 0.8 s apart each: one burst, planned 0.5 s after the last.
    let mut m = MissionManager::new(spec(), "node".into(), (0..6).map(|i| robot(&format!("r{i}"), "ground", i as f64)).collect());
    let (epoch, plan) = plan_for(&m.handle(at(0.0), Event::Start));
    m.handle(at(0.0), Event::PlanReady { epoch, plan: Box::new(plan) });
    m.handle(at(1.0), Event::Lost { ids: vec!["r1".into()] });
    assert_eq!(asked(&m.handle(at(1.8), Event::Tick)), 0);
    m.handle(at(1.8), Event::Lost { ids: vec!["r2".into()] });
    assert_eq!(asked(&m.handle(at(2.2), Event::Tick)), 0, "held: a loss 0.4 s ago");
    m.handle(at(2.2), Event::Lost { ids: vec!["r3".into()] });
    assert_eq!(asked(&m.handle(at(2.6), Event::Tick)), 0);
    let out = m.handle(at(2.8), Event::Tick);
    assert_eq!(asked(&out), 1);
    assert_eq!(m.epoch(), 2, "one epoch for the three");
}

#[test]
fn a_recipe_of_teams_gives_each_robot_its_leaf_team_and_the_mission_barrier() {
    let spec = MissionSpec {
        name: "e".into(),
        recipe_name: "escort".into(),
        recipe_xml: recipe::bank("escort").expect("bank").into(),
        params: BTreeMap::new(),
        ..spec()
    };
    let members = vec![robot("a", "ground", 0.0), robot("b", "ground", 5.0), robot("c", "aerial", 10.0)];
    let mut m = MissionManager::new(spec, "node".into(), members);
    let (epoch, plan) = plan_for(&m.handle(at(0.0), Event::Start));
    let cmds = m.handle(at(0.0), Event::PlanReady { epoch, plan: Box::new(plan) });
    let sent: BTreeMap<String, PlanAssignment> = cmds
        .iter()
        .filter_map(|c| match c {
            Command::SendPlan { robot, assignment } => Some((robot.to_string(), (**assignment).clone())),
            _ => None,
        })
        .collect();
    assert_eq!(sent.len(), 3);
    // Each robot's own barriers are its leaf team's: it never waits on the sibling team.
    assert_eq!((sent["a"].team.as_str(), sent["a"].subteam.as_str()), ("e/ground", "e/ground/ground"));
    assert_eq!(sent["a"].members, ["a", "b"]);
    assert_eq!((sent["c"].team.as_str(), sent["c"].members.as_slice()), ("e/air", ["c".into()].as_slice()));
    // The recipe's start barrier is the whole mission's.
    for a in sent.values() {
        assert_eq!(a.scopes, [mrmm_proto::ScopeMembers { team: "e".into(), members: vec!["a".into(), "b".into(), "c".into()] }]);
        assert!(a.plan.steps.contains(&Step::Sync { point: 0, scope: Some(String::new()) }));
        assert_eq!(a.scope_path(Some("")), "e");
    }
    let v = m.view(false);
    assert_eq!(v.teams["e/ground"], ["a", "b"]);
    assert_eq!(v.teams["e/air"], ["c"]);
}

mod reach;

//! Agent rules and attention management, asserting the emitted commands.

use super::*;
use crate::at;
use mrmm_proto::plan::PatrolSummary;
use mrmm_proto::{BatteryState, ManagerView, MissionMetrics, MissionStatus, PlanSummary, RobotStatus};

fn robot(id: &str, status: RobotStatus, mission: Option<&str>, x: f64, behaviour: &str) -> RobotView {
    RobotView {
        id: id.into(),
        robot_type: "ground".into(),
        capabilities: vec![],
        status,
        mission: mission.map(Into::into),
        pose: Some(Pose { x, y: 0.0, theta: 0.0 }),
        behaviour: Some(behaviour.into()),
        goal: None,
        last_mission: None,
        stuck: None,
        battery: None,
        vehicle: None,
    }
}

fn mission(name: &str, planner: &str, robots: &[&str], worst: Option<f64>, standard: Option<f64>) -> MissionView {
    MissionView {
        name: name.into(),
        recipe: planner.into(),
        planner: planner.into(),
        status: MissionStatus::Running,
        robots: robots.iter().map(|s| s.into()).collect(),
        lost: vec![],
        stuck: Default::default(),
        held: vec![],
        teams: Default::default(),
        team_views: vec![],
        manager: ManagerView { node: "central".into(), epoch: 1, chain_epoch: 1, chain: vec![], uncommitted_s: None },
        metrics: MissionMetrics { worst_idleness: worst, ..MissionMetrics::default() },
        summary: (planner == "patrol").then(|| {
            PlanSummary::Patrol(PatrolSummary {
                tour: vec![],
                waypoints: vec![],
                length: 120.0,
                offset: 0.0,
                spacing: 0.0,
                team_speed: 1.0,
                sync_per_round: 1,
                formation_time: 0.0,
                predicted_worst_idleness: 0.0,
                idleness_lower_bound: 0.0,
            })
        }),
        summary_unchanged: false,
        params: standard.map(|s| [("max_worst_idleness".to_string(), s.to_string())].into()).unwrap_or_default(),
        error: None,
        plans: None,
        map: None,
        requires: vec![],
    }
}

fn raised(cmds: &[Command]) -> Vec<(String, Priority)> {
    cmds.iter()
        .filter_map(|c| match c {
            Command::Publish(AdviceEvent::Raised(a)) => Some((a.id.clone(), a.priority)),
            _ => None,
        })
        .collect()
}

fn withdrawn(cmds: &[Command]) -> Vec<String> {
    cmds.iter()
        .filter_map(|c| match c {
            Command::Publish(AdviceEvent::Withdrawn { id, .. }) => Some(id.clone()),
            _ => None,
        })
        .collect()
}

fn snap(robots: Vec<RobotView>, missions: Vec<MissionView>) -> Event {
    Event::Snapshot { robots, missions, traffic: vec![] }
}

#[test]
fn robot_lost_is_critical_once_and_withdrawn_when_back() {
    let mut a = Agent::new(AgentConfig::default());
    let p = || mission("p", "patrol", &["r1", "r2"], None, None);
    a.handle(
        at(0.0),
        snap(
            vec![
                robot("r1", RobotStatus::Busy, Some("p"), 0.0, "step 1"),
                robot("r2", RobotStatus::Busy, Some("p"), 1.0, "step 1"),
                robot("r3", RobotStatus::Busy, Some("p"), 2.0, "step 1"),
            ],
            vec![mission("p", "patrol", &["r1", "r2", "r3"], None, None)],
        ),
    );
    let lost = vec![
        robot("r1", RobotStatus::Busy, Some("p"), 0.0, "step 1"),
        robot("r2", RobotStatus::Busy, Some("p"), 1.0, "step 1"),
        robot("r3", RobotStatus::Lost, None, 2.0, "step 1"),
    ];
    let cmds = a.handle(at(1.0), snap(lost.clone(), vec![p()]));
    assert_eq!(raised(&cmds), [("lost/r3".into(), Priority::Critical)]);
    let adv = a.advice();
    assert_eq!(adv[0].reason, "robot r3 lost; mission p replanned for its 2 remaining robots");
    assert_eq!(adv[0].evidence["remaining"], 2);
    // Not repeated while it stands; its text follows the situation quietly.
    let mut shrunk = p();
    shrunk.robots.pop();
    assert!(a.handle(at(2.0), snap(lost, vec![shrunk])).is_empty());
    assert_eq!(a.advice()[0].reason, "robot r3 lost; mission p replanned for its 1 remaining robots");
    // Back: withdrawn.
    let back = vec![
        robot("r1", RobotStatus::Busy, Some("p"), 0.0, "step 1"),
        robot("r2", RobotStatus::Busy, Some("p"), 1.0, "step 1"),
        robot("r3", RobotStatus::Idle, None, 2.0, "hold"),
    ];
    let cmds = a.handle(at(3.0), snap(back, vec![p()]));
    assert_eq!(withdrawn(&cmds), ["lost/r3"]);
}

#[test]
fn a_robot_lost_before_the_agent_ever_saw_it_working_still_says_what_was_done() {
    let mut a = Agent::new(AgentConfig::default());
    let mut r3 = robot("r3", RobotStatus::Lost, None, 2.0, "step 1");
    r3.last_mission = Some("p".into());
    a.handle(at(0.0), snap(vec![robot("r1", RobotStatus::Busy, Some("p"), 0.0, "step 1"), r3], vec![mission("p", "patrol", &["r1"], None, None)]));
    assert_eq!(a.advice()[0].reason, "robot r3 lost; mission p replanned for its 1 remaining robots");
}

#[test]
fn below_standard_names_the_donor_and_the_predicted_gain() {
    let mut a = Agent::new(AgentConfig::default());
    let robots = vec![
        robot("r1", RobotStatus::Busy, Some("p"), 0.0, "step 2"),
        robot("r2", RobotStatus::Busy, Some("p"), 1.0, "step 2"),
        robot("r6", RobotStatus::Busy, Some("c"), 5.0, "hold"),
        robot("r7", RobotStatus::Busy, Some("c"), 6.0, "hold"),
    ];
    let missions = vec![mission("p", "patrol", &["r1", "r2"], Some(70.0), Some(50.0)), mission("c", "coverage", &["r6", "r7"], None, None)];
    let cmds = a.handle(at(0.0), snap(robots, missions));
    assert_eq!(raised(&cmds), [("standard/p".into(), Priority::Warning)]);
    let adv = &a.advice()[0];
    assert_eq!(adv.reason, "p below standard (worst idleness 70 s > 50 s): move r7 from c to p: predicted worst idleness 60 s → 40 s");
    assert_eq!(adv.suggestion.as_deref(), Some("mrmm op move r7 p"));
    assert_eq!(adv.evidence["predicted_with_one_more"], 40.0);
}

#[test]
fn idle_robots_are_pointed_where_they_help_most() {
    let mut a = Agent::new(AgentConfig::default());
    let robots = vec![robot("r1", RobotStatus::Busy, Some("p"), 0.0, "step 2"), robot("r4", RobotStatus::Idle, None, 3.0, "hold")];
    let cmds = a.handle(at(0.0), snap(robots, vec![mission("p", "patrol", &["r1"], None, None), mission("c", "coverage", &[], None, None)]));
    assert_eq!(raised(&cmds), [("idle".into(), Priority::Info)]);
    let adv = &a.advice()[0];
    assert_eq!(adv.reason, "1 idle robot(s) (r4): adding r4 to p cuts its predicted worst idleness by 60 s");
    assert_eq!(adv.suggestion.as_deref(), Some("mrmm op move r4 p"));
}

#[test]
fn while_the_operator_is_busy_only_critical_advice_interrupts() {
    let mut a = Agent::new(AgentConfig { busy_window_s: 10.0, ..AgentConfig::default() });
    a.handle(at(0.0), Event::OperatorCommand);
    let robots = vec![
        robot("r1", RobotStatus::Busy, Some("p"), 0.0, "step 2"),
        robot("r4", RobotStatus::Idle, None, 3.0, "hold"),
        robot("r5", RobotStatus::Lost, None, 9.0, "hold"),
    ];
    let ms = vec![mission("p", "patrol", &["r1"], None, None)];
    let cmds = a.handle(at(1.0), snap(robots.clone(), ms.clone()));
    assert_eq!(raised(&cmds), [("lost/r5".into(), Priority::Critical)], "info waits");
    assert!(raised(&a.handle(at(5.0), snap(robots.clone(), ms.clone()))).is_empty());
    // The operator is done: the queued advice comes out.
    assert_eq!(raised(&a.handle(at(11.0), snap(robots, ms))), [("idle".into(), Priority::Info)]);
}

#[test]
fn act_runs_the_move_and_says_so_once() {
    let mut a = Agent::new(AgentConfig { autonomy: Autonomy::Act, ..AgentConfig::default() });
    let robots = vec![robot("r1", RobotStatus::Busy, Some("p"), 0.0, "step 2"), robot("r4", RobotStatus::Idle, None, 3.0, "hold")];
    let ms = vec![mission("p", "patrol", &["r1"], None, None)];
    let cmds = a.handle(at(0.0), snap(robots.clone(), ms.clone()));
    assert!(cmds.contains(&Command::Move { advice: "idle".into(), mv: RobotMove { robot: "r4".into(), to: Some("p".into()), replaces: None } }));
    let adv = &a.advice()[0];
    assert!(adv.acted && adv.reason.starts_with("acting: "));
    assert!(!a.handle(at(1.0), snap(robots.clone(), ms.clone())).iter().any(|c| matches!(c, Command::Move { .. })), "acts once");
    // The move's result is recorded on the advice and published.
    let cmds = a.handle(at(1.5), Event::Acted { advice: "idle".into(), result: Err("robot \"r4\" is lost".into()) });
    let [Command::Publish(AdviceEvent::Raised(adv))] = cmds.as_slice() else { panic!("{cmds:?}") };
    assert!(!adv.acted && !adv.reason.starts_with("acting: "));
    assert_eq!(adv.outcome.as_deref(), Some("failed: robot \"r4\" is lost"));
    assert!(!a.handle(at(2.0), snap(robots, ms)).iter().any(|c| matches!(c, Command::Move { .. })), "a failed move is not retried on its own");
}

#[test]
fn manager_loss_and_failover_and_stuck_robots() {
    let mut a = Agent::new(AgentConfig { stuck_after_s: 10.0, event_advice_s: 30.0, ..AgentConfig::default() });
    let mut p = mission("p", "patrol", &["r1"], None, None);
    let r = |x: f64| vec![robot("r1", RobotStatus::Busy, Some("p"), x, "step 4 goto(9.0,0.0)")];
    a.handle(at(0.0), snap(r(0.0), vec![p.clone()]));
    // Stuck: not moving for 10 s while driving.
    assert!(raised(&a.handle(at(5.0), snap(r(0.05), vec![p.clone()]))).is_empty());
    assert_eq!(raised(&a.handle(at(10.5), snap(r(0.1), vec![p.clone()]))), [("stuck/r1".into(), Priority::Warning)]);
    assert_eq!(withdrawn(&a.handle(at(11.0), snap(r(3.0), vec![p.clone()]))), ["stuck/r1"]);
    // A robot that says it is stuck (its navigator refused the goal) is raised at once, with its
    // reason, and withdrawn when it no longer says so.
    let says = |x: f64| {
        vec![RobotView {
            stuck: Some("Nav2 (/navigate_to_pose) rejected the goal to (3.00, 0.00)".into()),
            ..robot("r1", RobotStatus::Busy, Some("p"), x, "goto(3.00,0.00)")
        }]
    };
    let cmds = a.handle(at(11.5), snap(says(3.5), vec![p.clone()]));
    assert_eq!(raised(&cmds), [("stuck/r1".into(), Priority::Warning)]);
    assert!(format!("{cmds:?}").contains("rejected the goal"), "{cmds:?}");
    assert_eq!(withdrawn(&a.handle(at(12.0), snap(r(3.6), vec![p.clone()]))), ["stuck/r1"]);
    // The manager moves: an event advice that stands for a while.
    p.manager = ManagerView { node: "r2".into(), epoch: 2, chain_epoch: 1, chain: vec![], uncommitted_s: None };
    assert_eq!(raised(&a.handle(at(12.0), snap(r(4.0), vec![p.clone()]))), [("failover/p".into(), Priority::Warning)]);
    assert_eq!(withdrawn(&a.handle(at(43.0), snap(r(5.0), vec![p.clone()]))), ["failover/p"]);
    // The manager's host is lost: critical while stalled.
    p.status = MissionStatus::Stalled;
    p.error = Some("mission host r2 lost; its robots keep their last plans".into());
    assert_eq!(raised(&a.handle(at(44.0), snap(r(6.0), vec![p]))), [("manager/p".into(), Priority::Critical)]);
}

#[test]
fn config_is_validated() {
    assert!(AgentConfig::default().validate().is_ok());
    let bad = AgentConfig { stuck_after_s: f64::NAN, ..AgentConfig::default() };
    assert!(bad.validate().expect_err("nan").starts_with("agent.stuck_after_s"));
    let bad = AgentConfig { battery_low: 0.5, charged: 0.4, ..AgentConfig::default() };
    assert!(bad.validate().expect_err("charged below low").starts_with("agent.charged: must be above battery_low"));
}

#[test]
fn one_robot_is_moved_once_per_look() {
    let mut a = Agent::new(AgentConfig { autonomy: Autonomy::Act, ..AgentConfig::default() });
    // Two missions each lost a robot; one idle robot could replace either.
    let lost = |id: &str, x: f64, m: &str| RobotView { last_mission: Some(m.into()), ..robot(id, RobotStatus::Lost, None, x, "hold") };
    let robots = vec![
        lost("r1", 0.0, "p"),
        lost("r2", 1.0, "q"),
        robot("r3", RobotStatus::Busy, Some("p"), 2.0, "step 2"),
        robot("r4", RobotStatus::Busy, Some("q"), 3.0, "step 2"),
        robot("r5", RobotStatus::Idle, None, 4.0, "hold"),
    ];
    let ms = vec![mission("p", "patrol", &["r3"], None, None), mission("q", "patrol", &["r4"], None, None)];
    let cmds = a.handle(at(0.0), snap(robots, ms));
    let moves: Vec<&RobotMove> = cmds
        .iter()
        .filter_map(|c| match c {
            Command::Move { mv, .. } => Some(mv),
            _ => None,
        })
        .collect();
    assert_eq!(moves.iter().filter(|m| m.robot == "r5").count(), 1, "r5 moved once in one look: {moves:?}");
}

#[test]
fn a_robot_that_lost_what_its_mission_requires_is_replaced_by_one_that_has_it() {
    let mut a = Agent::new(AgentConfig::default());
    let with = |mut r: RobotView, caps: &[&str]| {
        r.capabilities = caps.iter().map(|c| c.to_string()).collect();
        r
    };
    let mut p = mission("p", "patrol", &["r1", "r2"], None, None);
    p.requires = vec!["camera".into()];
    let q = mission("q", "patrol", &["r5", "r6"], None, None);
    let before = vec![
        with(robot("r1", RobotStatus::Busy, Some("p"), 0.0, "step 1"), &["camera"]),
        with(robot("r2", RobotStatus::Busy, Some("p"), 1.0, "step 1"), &["camera"]),
        robot("r3", RobotStatus::Idle, None, 2.0, "hold"),
        with(robot("r4", RobotStatus::Idle, None, 3.0, "hold"), &["camera", "lidar"]),
        robot("r5", RobotStatus::Busy, Some("q"), 4.0, "step 1"),
        robot("r6", RobotStatus::Busy, Some("q"), 5.0, "step 1"),
    ];
    a.handle(at(0.0), snap(before.clone(), vec![p.clone(), q.clone()]));
    // r2's camera is gone: central took it out of p.
    let mut after = before.clone();
    after[1] = with(robot("r2", RobotStatus::Idle, None, 1.0, "hold"), &[]);
    p.robots = vec!["r1".into()];
    let cmds = a.handle(at(20.0), snap(after.clone(), vec![p.clone(), q.clone()]));
    assert!(raised(&cmds).contains(&("capability/r2".into(), Priority::Warning)), "{cmds:?}");
    let adv = a.advice().into_iter().find(|a| a.id == "capability/r2").expect("advice");
    assert_eq!(adv.reason, "robot r2 no longer has camera, which mission p requires: it left the mission: add r4, which has camera");
    assert_eq!(adv.action, Some(RobotMove { robot: "r4".into(), to: Some("p".into()), replaces: None }), "r3 is idle too but has no camera");
    // The idle advice, too, only points a robot where it fits: r2 and r3 (no camera) go to q.
    let idle = a.advice().into_iter().find(|a| a.id == "idle").expect("idle advice");
    assert!(idle.action.as_ref().is_some_and(|m| m.to.as_ref().map(|x| x.as_str()) == Some("q") || m.robot == "r4"), "{idle:?}");
    // No idle robot with a camera: one is taken from another mission only if it has one.
    after[3] = with(robot("r4", RobotStatus::Busy, Some("q"), 3.0, "step 1"), &["camera"]);
    let mut q2 = q.clone();
    q2.robots = vec!["r4".into(), "r5".into(), "r6".into()];
    let mut b = Agent::new(AgentConfig::default());
    b.handle(
        at(0.0),
        snap(
            before.iter().cloned().map(|r| if r.id == "r4" { after[3].clone() } else { r }).collect(),
            vec![mission("p", "patrol", &["r1", "r2"], None, None), q2.clone()],
        ),
    );
    let mut p2 = p.clone();
    p2.robots = vec!["r1".into()];
    b.handle(at(1.0), snap(after.clone(), vec![p2, q2]));
    let adv = b.advice().into_iter().find(|a| a.id == "capability/r2").expect("advice");
    assert!(adv.reason.ends_with("add r4 from q, which has camera"), "{}", adv.reason);
    // It is an event: gone after a while.
    let cmds = a.handle(at(60.0), snap(after, vec![p, q]));
    assert!(withdrawn(&cmds).contains(&"capability/r2".to_string()), "{cmds:?}");
}

#[test]
fn a_leaf_team_below_its_minimum_is_critical_with_a_robot_that_fits_it() {
    let mut a = Agent::new(AgentConfig::default());
    let team = |name: &str, members: &[&str], min: usize, robot_type: &str| mrmm_proto::TeamView {
        team: format!("e/{name}"),
        planner: "patrol".into(),
        members: members.iter().map(|s| s.into()).collect(),
        barriers_passed: 3,
        min,
        wants: format!("type {robot_type}"),
        robot_type: Some(robot_type.into()),
        requires: vec![],
    };
    let mut e = mission("e", "patrol", &["r1", "r3"], None, None);
    e.team_views = vec![team("ground", &["r1"], 2, "ground"), team("air", &["r3"], 1, "aerial")];
    let mut aerial = robot("r4", RobotStatus::Idle, None, 4.0, "hold");
    aerial.robot_type = "aerial".into();
    let robots = vec![
        robot("r1", RobotStatus::Busy, Some("e"), 0.0, "step 1"),
        robot("r2", RobotStatus::Lost, None, 1.0, "step 1"),
        robot("r3", RobotStatus::Busy, Some("e"), 2.0, "step 1"),
        aerial,
        robot("r5", RobotStatus::Idle, None, 5.0, "hold"),
    ];
    a.handle(at(0.0), snap(robots.clone(), vec![e.clone()]));
    let adv = a.advice().into_iter().find(|a| a.id == "team/e/ground").expect("advice");
    assert_eq!(adv.priority, Priority::Critical);
    assert_eq!(adv.reason, "team e/ground of mission e has 1 of the 2 members it needs: add r5 (type ground)");
    assert_eq!(adv.action, Some(RobotMove { robot: "r5".into(), to: Some("e".into()), replaces: None }), "r4 is idle too but aerial");
    assert!(a.advice().iter().all(|a| a.id != "team/e/air"), "a team at its minimum is fine");
    // Filled again: withdrawn.
    e.team_views[0].members.push("r5".into());
    let cmds = a.handle(at(1.0), snap(robots, vec![e]));
    assert!(withdrawn(&cmds).contains(&"team/e/ground".to_string()), "{cmds:?}");
}

/// A robot waiting in traffic is not stuck: after `traffic_wait_s` for the same robots it is
/// raised with who is in the way and what would clear it; blocked (no way around) at once; the
/// advice is withdrawn when the way is free.
#[test]
fn robots_waiting_or_blocked_in_traffic_are_raised_with_who_is_in_the_way() {
    use mrmm_proto::traffic::{TrafficRobotView, TrafficView};
    let mut a = Agent::new(AgentConfig { stuck_after_s: 10.0, traffic_wait_s: 30.0, ..AgentConfig::default() });
    let ms = vec![mission("p", "patrol", &["r1"], None, None)];
    let robots = |x: f64| vec![robot("r1", RobotStatus::Busy, Some("p"), x, "step 4 goto(9.0,0.0)"), robot("r2", RobotStatus::Idle, None, 5.0, "idle")];
    let view = |waiting: Option<f64>, blocked: bool| {
        let r1 = TrafficRobotView {
            robot: "r1".into(),
            route: vec![1, 2, 3],
            points: vec![],
            reached: Some(0),
            granted: Some(0),
            holds: vec![1],
            waits_for: if waiting.is_some() { vec!["r2".into()] } else { vec![] },
            waiting_s: waiting,
            blocked: if blocked { vec!["r2".into()] } else { vec![] },
            lost: false,
            docked: false,
        };
        vec![TrafficView { map: "h".repeat(64), incarnation: 1, deputies: vec![], robots: vec![r1] }]
    };
    let look = |robots, traffic| Event::Snapshot { robots, missions: ms.clone(), traffic };
    a.handle(at(0.0), look(robots(0.0), view(Some(0.0), false)));
    // Waiting 20 s: not stuck (it is told why it waits), not raised yet.
    assert!(raised(&a.handle(at(20.0), look(robots(0.0), view(Some(20.0), false)))).is_empty());
    let cmds = a.handle(at(31.0), look(robots(0.0), view(Some(31.0), false)));
    assert_eq!(raised(&cmds), [("traffic/r1".into(), Priority::Warning)]);
    assert!(format!("{cmds:?}").contains("mrmm op goto r2"), "an idle robot in the way is driven away: {cmds:?}");
    assert_eq!(withdrawn(&a.handle(at(32.0), look(robots(1.0), view(None, false)))), ["traffic/r1"]);
    // Blocked: at once.
    assert_eq!(raised(&a.handle(at(33.0), look(robots(1.0), view(Some(1.0), true)))), [("traffic/r1".into(), Priority::Warning)]);
}

/// A battery below the low mark, not charging, is a warning; empty, critical (and not also
/// "stuck"); charging, or charged again, it is withdrawn.
#[test]
fn low_and_empty_batteries_are_raised_and_withdrawn_once_charging() {
    let mut a = Agent::new(AgentConfig::default());
    let with = |charge: f64, charging: bool| {
        let mut r = robot("r1", RobotStatus::Busy, Some("p"), 1.0, "step 2 goto(9.0,0.0)");
        r.battery = Some(BatteryState { charge, charging, reach_m: Some(charge * 1000.0) });
        vec![r]
    };
    assert!(raised(&a.handle(at(1.0), snap(with(0.5, false), vec![]))).is_empty());
    let low = a.handle(at(2.0), snap(with(0.15, false), vec![]));
    assert_eq!(raised(&low), [("battery/r1/low".into(), Priority::Warning)]);
    assert!(format!("{low:?}").contains("15 %, 150 m left"), "{low:?}");
    // Empty and stuck at its goal: one critical advice, not a stuck one besides.
    let mut empty = with(0.0, false);
    empty[0].stuck = Some("its battery is empty".into());
    let cmds = a.handle(at(3.0), snap(empty.clone(), vec![]));
    assert_eq!(raised(&cmds), [("battery/r1/empty".into(), Priority::Critical)]);
    assert_eq!(withdrawn(&cmds), ["battery/r1/low"]);
    let cmds = a.handle(at(30.0), snap(empty, vec![]));
    assert!(!format!("{cmds:?}").contains("stuck/r1"), "{cmds:?}");
    assert_eq!(withdrawn(&a.handle(at(31.0), snap(with(0.0, true), vec![]))), ["battery/r1/empty"]);
    let charged = a.handle(at(32.0), snap(with(0.9, false), vec![]));
    assert!(!format!("{charged:?}").contains("battery/"), "{charged:?}");
    // A lost robot's battery is not raised (the loss is).
    let mut lost = with(0.1, false);
    lost[0].status = RobotStatus::Lost;
    assert!(!format!("{:?}", a.handle(at(40.0), snap(lost, vec![]))).contains("battery/r1"));
}

/// The energy forecast: two robots of a mission draining 0.1 % a second (low in 5 and 12 minutes) and
/// no spare — the mission will be short in 5 minutes; one idle spare charged enough covers the
/// first, a second spare charging and done in time covers the second, and the advice goes.
#[test]
fn a_mission_that_will_run_short_of_charged_spares_is_forecast() {
    let mut a = Agent::new(AgentConfig::default());
    let with = |mut r: RobotView, charge: f64, charging: bool| {
        r.battery = Some(BatteryState { charge, charging, reach_m: None });
        r
    };
    let fleet = |t: f64, spares: usize| {
        let mut v = vec![
            with(robot("r1", RobotStatus::Busy, Some("p"), 0.0, "step 1"), 0.5 - 0.001 * t, false),
            with(robot("r2", RobotStatus::Busy, Some("p"), 5.0, "step 1"), 0.9 - 0.001 * t, false),
        ];
        if spares >= 1 {
            v.push(with(robot("s1", RobotStatus::Idle, None, 9.0, "hold"), 0.8, false));
        }
        if spares >= 2 {
            v.push(with(robot("s2", RobotStatus::Idle, None, 9.0, "hold"), 0.5 + 0.002 * t, true));
        }
        v
    };
    let forecasts = |cmds: &[Command]| raised(cmds).into_iter().filter(|(id, _)| id.starts_with("forecast/")).collect::<Vec<_>>();
    let p = || mission("p", "coverage", &["r1", "r2"], None, None);
    assert!(forecasts(&a.handle(at(0.0), snap(fleet(0.0, 0), vec![p()]))).is_empty(), "no rate measured yet");
    let cmds = a.handle(at(30.0), snap(fleet(30.0, 0), vec![p()]));
    assert_eq!(forecasts(&cmds), [("forecast/p".into(), Priority::Warning)]);
    let advice = a.advice().into_iter().find(|x| x.id == "forecast/p").expect("standing");
    assert!(advice.reason.contains("short of robots in about 4 min") && advice.reason.contains("2 of its robots"), "{}", advice.reason);
    assert!((advice.evidence["short_in_s"].as_f64().expect("seconds") - 270.0).abs() < 1.0, "{}", advice.evidence);
    assert_eq!(advice.evidence["needs"][0]["robot"], "r1");
    // One spare charged enough: r1 is covered, r2 is not (still standing, now about r2).
    a.handle(at(40.0), snap(fleet(40.0, 1), vec![p()]));
    let advice = a.advice().into_iter().find(|x| x.id == "forecast/p").expect("still short");
    assert_eq!(advice.evidence["short_by"], 1);
    // A second spare, charging at 0.2 % a second: done in about 3 minutes, before r2 is low.
    a.handle(at(50.0), snap(fleet(50.0, 2), vec![p()]));
    let cmds = a.handle(at(80.0), snap(fleet(80.0, 2), vec![p()]));
    assert_eq!(withdrawn(&cmds), ["forecast/p"]);
    // Off: nothing.
    let mut off = Agent::new(AgentConfig { forecast_s: 0.0, ..AgentConfig::default() });
    off.handle(at(0.0), snap(fleet(0.0, 0), vec![p()]));
    assert!(forecasts(&off.handle(at(30.0), snap(fleet(30.0, 0), vec![p()]))).is_empty());
}

/// A low robot of a mission with `charging=ask` comes with the order that sends it; with `off`
/// the advice says the mission does not charge its robots.
#[test]
fn low_robots_of_missions_that_do_not_charge_automatically_say_so() {
    let mut r1 = robot("r1", RobotStatus::Busy, Some("p"), 0.0, "step 1");
    r1.battery = Some(BatteryState { charge: 0.1, charging: false, reach_m: None });
    for (mode, says, suggests) in [("ask", "on the operator's word", Some("mrmm op charge r1")), ("off", "charging=off", None), ("auto", "not charging", None)]
    {
        let mut a = Agent::new(AgentConfig::default());
        let mut p = mission("p", "coverage", &["r1"], None, None);
        p.params.insert("charging".into(), mode.into());
        a.handle(at(0.0), snap(vec![r1.clone()], vec![p]));
        let advice = a.advice().into_iter().find(|x| x.id == "battery/r1/low").expect("raised");
        assert!(advice.reason.contains(says), "{mode}: {}", advice.reason);
        assert_eq!(advice.suggestion.as_deref(), suggests, "{mode}");
    }
}

/// A member its mission's plan holds for want of reach, in a mission that charges on the
/// operator's word, is raised with the order that sends it; with `auto` (central sends it) it
/// is not; out of the held list, withdrawn.
#[test]
fn a_robot_held_for_want_of_reach_where_the_operator_decides_is_raised() {
    let mut a = Agent::new(AgentConfig::default());
    let mut r1 = robot("r1", RobotStatus::Busy, Some("p"), 0.0, "hold");
    r1.battery = Some(BatteryState { charge: 0.4, charging: false, reach_m: Some(35.0) });
    let p = |mode: &str, held: &[&str]| MissionView {
        params: [("charging".to_string(), mode.to_string())].into(),
        held: held.iter().map(|&h| h.into()).collect(),
        ..mission("p", "patrol", &["r1", "r2"], None, None)
    };
    assert!(raised(&a.handle(at(1.0), snap(vec![r1.clone()], vec![p("auto", &["r1"])]))).is_empty(), "auto: central sends it");
    let cmds = a.handle(at(2.0), snap(vec![r1.clone()], vec![p("ask", &["r1"])]));
    assert_eq!(raised(&cmds), [("reach/r1".into(), Priority::Warning)]);
    let advice = a.advice().into_iter().find(|x| x.id == "reach/r1").expect("standing");
    assert_eq!(advice.suggestion.as_deref(), Some("mrmm op charge r1"));
    assert!(advice.reason.contains("35 m") && advice.reason.contains("mission p"), "{}", advice.reason);
    assert_eq!(withdrawn(&a.handle(at(3.0), snap(vec![r1], vec![p("ask", &[])]))), ["reach/r1"]);
}

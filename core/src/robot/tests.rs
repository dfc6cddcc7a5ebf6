//! Unit tests of the robot machine: commands and who may give them, plans, telemetry.

use super::*;
use crate::body::Limits;
use mrmm_proto::{PlanAssignment, Pose, RobotPlan, Role, Step};

fn cfg() -> RobotSetup {
    RobotSetup { time_scale: 4.0, ..RobotSetup::sim("r1", "ground", Limits { max_speed: 2.0, max_turn_rate: 3.0 }, Pose::default()) }
}

/// A robot of speed 1 and turn rate 1 with these capabilities, durable or not.
fn with_capabilities(capabilities: &[&str], durable: bool) -> RobotSetup {
    RobotSetup {
        capabilities: capabilities.iter().map(|c| c.to_string()).collect(),
        durable,
        ..RobotSetup::sim("r1", "ground", Limits { max_speed: 1.0, max_turn_rate: 1.0 }, Pose::default())
    }
}

fn plan(mission: &str, epoch: u64) -> RobotCommand {
    RobotCommand::Plan(Box::new(PlanAssignment {
        handover: None,
        mission: mission.into(),
        epoch,
        team: mission.into(),
        subteam: format!("{mission}/ground"),
        members: vec!["r1".into()],
        plan: RobotPlan {
            robot: "r1".into(),
            robot_type: "ground".into(),
            slot: 0,
            steps: vec![Step::Navigate { x: 4.0, y: 0.0, speed: None }, Step::Hold { seconds: None }],
            team: String::new(),
        },
        managers: vec![],
        barrier: BarrierMode::Mesh,
        scopes: vec![],
        map: None,
    }))
}

/// The reply and the team change of a command.
fn cmd(r: &mut Robot, c: RobotCommand) -> (Result<CommandAck, String>, Option<Command>) {
    cmd_from(r, c, Sender::new(Role::Central, "central"))
}

fn cmd_from(r: &mut Robot, c: RobotCommand, from: Sender) -> (Result<CommandAck, String>, Option<Command>) {
    let out = r.handle(0.0, Event::Command { cmd: c, from });
    let reply = out.iter().find_map(|c| match c {
        Command::Reply(r) => Some(r.clone()),
        Command::Refuse(e) => Some(Err(e.clone())),
        _ => None,
    });
    let change = out.into_iter().find(|c| matches!(c, Command::JoinTeam { .. } | Command::LeaveTeam));
    (reply.expect("a reply"), change)
}

fn telemetry(r: &mut Robot, now: f64) -> Telemetry {
    match r.handle(now, Event::TelemetryDue).pop() {
        Some(Command::Telemetry(t)) => t,
        other => panic!("no telemetry: {other:?}"),
    }
}

#[test]
fn goto_then_arrive_with_time_scale() {
    let mut r = Robot::new(cfg());
    let (ack, _) = cmd(&mut r, RobotCommand::Goto { x: 8.0, y: 0.0, via: vec![] });
    assert_eq!(ack.expect("ack").behaviour, Behaviour::Navigate { x: 8.0, y: 0.0 });
    // 8 m at 2 m/s = 4 simulated s = 1 wall s at time scale 4.
    for i in 0..=110 {
        r.handle(i as f64 * 0.01, Event::Tick);
    }
    let t = telemetry(&mut r, 1.1);
    assert_eq!(t.behaviour, Behaviour::Hold);
    assert!((t.pose.x - 8.0).abs() <= crate::body::ARRIVAL_TOLERANCE);
    assert!((t.t - 4.4).abs() < 1e-9);
    assert_eq!(t.seq, 2, "one telemetry after the command, one now");
}

/// A goto with a route drives through its corners in turn, then holds at the goal.
#[test]
fn goto_follows_its_route() {
    let mut r = Robot::new(cfg());
    let (ack, _) = cmd(&mut r, RobotCommand::Goto { x: 4.0, y: 4.0, via: vec![[4.0, 0.0]] });
    assert_eq!(ack.expect("ack").behaviour, Behaviour::Navigate { x: 4.0, y: 0.0 }, "the first corner first");
    let mut farthest_x_before_turn: f64 = 0.0;
    for i in 0..=400 {
        r.handle(i as f64 * 0.01, Event::Tick);
        let p = r.telemetry().pose;
        if p.y < 0.5 {
            farthest_x_before_turn = farthest_x_before_turn.max(p.x);
        } else {
            assert!(p.x > 3.5, "cut the corner: {p:?}");
        }
    }
    let t = telemetry(&mut r, 4.1);
    assert_eq!(t.behaviour, Behaviour::Hold);
    assert!((t.pose.x - 4.0).abs() <= 0.1 && (t.pose.y - 4.0).abs() <= crate::body::ARRIVAL_TOLERANCE, "{:?}", t.pose);
    assert!(farthest_x_before_turn > 3.9);
    let too_many = vec![[0.0, 0.0]; MAX_GOTO_VIA + 1];
    assert!(cmd(&mut r, RobotCommand::Goto { x: 0.0, y: 0.0, via: too_many }).0.is_err());
}

#[test]
fn rejects_non_finite_goal_and_hostile_plans() {
    let mut r = Robot::new(cfg());
    assert!(cmd(&mut r, RobotCommand::Goto { x: f64::NAN, y: 0.0, via: vec![] }).0.is_err());
    assert_eq!(r.behaviour(), Behaviour::Hold);
    for bad in [
        Step::Navigate { x: 1.0, y: 0.0, speed: Some(f64::NAN) },
        Step::Navigate { x: 1.0, y: 0.0, speed: Some(-1.0) },
        Step::Hold { seconds: Some(f64::INFINITY) },
        Step::Loop { to: 5, rounds: None },
    ] {
        let RobotCommand::Plan(mut a) = plan("m", 1) else { unreachable!() };
        a.plan.steps.push(bad.clone());
        let (reply, change) = cmd(&mut r, RobotCommand::Plan(a));
        assert!(reply.is_err(), "{bad:?} accepted");
        assert!(change.is_none());
    }
}

#[test]
fn a_plan_carried_on_after_a_hand_over_keeps_the_robot_driving() {
    let mut r = Robot::new(cfg());
    assert!(cmd(&mut r, plan("m", 2)).0.is_ok());
    r.handle(0.01, Event::Tick);
    r.handle(0.2, Event::Tick);
    let moving = telemetry(&mut r, 0.2);
    assert!(moving.velocity.v > 0.0, "on its way to (4, 0)");
    // Another member was replaced: the same plan under epoch 3, with the newcomer.
    let RobotCommand::Plan(mut a) = plan("m", 3) else { unreachable!() };
    a.members.push("r9".into());
    a.handover = Some(mrmm_proto::Handover { planned: 2, step: 0, round: 0 });
    let (ack, change) = cmd(&mut r, RobotCommand::Plan(a.clone()));
    assert!(ack.is_ok());
    assert!(matches!(change, Some(Command::JoinTeam { ref members, .. }) if members.len() == 2), "its team has the newcomer: {change:?}");
    r.handle(0.25, Event::Tick);
    let t = telemetry(&mut r, 0.25);
    assert!(t.velocity.v > 0.0, "not stopped by the new epoch");
    assert_eq!(t.progress.as_ref().map(|p| (p.epoch, p.step)), Some((3, 0)));
    // The robot that comes in with a plan of that lineage starts where the handover says.
    let mut n = Robot::new(cfg());
    a.handover = Some(mrmm_proto::Handover { planned: 2, step: 1, round: 7 });
    assert!(cmd(&mut n, RobotCommand::Plan(a)).0.is_ok());
    n.handle(0.01, Event::Tick);
    assert_eq!(telemetry(&mut n, 0.01).progress.map(|p| (p.step, p.round)), Some((0, 7)), "on the leg to step 1's barrier-less hold: the navigate before it");
}

#[test]
fn plans_epochs_and_leaving() {
    let mut r = Robot::new(cfg());
    let (_, change) = cmd(&mut r, plan("m", 2));
    assert_eq!(
        change,
        Some(Command::JoinTeam { team: "m".into(), subteam: "m/ground".into(), barrier: BarrierMode::Mesh, members: vec!["r1".into()], scopes: vec![] })
    );
    r.handle(0.01, Event::Tick);
    assert_eq!(telemetry(&mut r, 0.01).mission.as_ref().map(|x| x.as_str()), Some("m"));
    assert!(cmd(&mut r, plan("m", 1)).0.unwrap_err().contains("stale epoch"));
    // The same plan again changes nothing.
    assert_eq!(cmd(&mut r, plan("m", 2)), (Ok(r.ack()), None));
    // A leave for an older epoch or another mission is ignored.
    assert_eq!(cmd(&mut r, RobotCommand::Leave { mission: "m".into(), epoch: 1 }).1, None);
    assert_eq!(cmd(&mut r, RobotCommand::Leave { mission: "x".into(), epoch: 9 }).1, None);
    // Another mission's plan replaces this one (a move).
    assert!(matches!(cmd(&mut r, plan("n", 1)).1, Some(Command::JoinTeam { .. })));
    assert_eq!(cmd(&mut r, RobotCommand::Leave { mission: "n".into(), epoch: 1 }).1, Some(Command::LeaveTeam));
    assert_eq!(telemetry(&mut r, 0.02).mission, None);
    // A plan for somebody else is refused.
    let RobotCommand::Plan(mut a) = plan("m", 3) else { unreachable!() };
    a.plan.robot = "r2".into();
    assert!(cmd(&mut r, RobotCommand::Plan(a)).0.is_err());
}

#[test]
fn only_central_orders_and_only_managers_of_the_mission_plan() {
    let mut r = Robot::new(cfg());
    r.handle(0.0, Event::CentralAlive(true));
    let rogue = Sender::new(Role::Robot, "r9");
    assert!(cmd_from(&mut r, RobotCommand::Goto { x: 1.0, y: 1.0, via: vec![] }, rogue.clone()).0.unwrap_err().contains("robot:r9 may not"));
    assert!(cmd_from(&mut r, RobotCommand::Hold, Sender::new(Role::Operator, "op")).0.is_err());
    // A robot that is not a teammate cannot plan for an idle robot, nor for one in a mission.
    assert!(cmd_from(&mut r, plan("m", u64::MAX), rogue.clone()).0.is_err());
    let host = Sender::new(Role::Host, "h1");
    assert!(cmd_from(&mut r, plan("m", 1), host).0.is_ok());
    assert!(cmd_from(&mut r, plan("m", u64::MAX), rogue.clone()).0.is_err(), "a stranger's huge epoch is refused");
    // A teammate may (it may have taken the mission over).
    let RobotCommand::Plan(mut a) = plan("m", 2) else { unreachable!() };
    a.members.push("r2".into());
    assert!(cmd_from(&mut r, RobotCommand::Plan(a.clone()), Sender::new(Role::Host, "h1")).0.is_ok());
    a.epoch = 3;
    assert!(cmd_from(&mut r, RobotCommand::Plan(a), Sender::new(Role::Robot, "r2")).0.is_ok());
    // Another mission's robot head needs an admission from central naming it.
    let RobotCommand::Plan(b) = plan("n", 1) else { unreachable!() };
    let r3 = Sender::new(Role::Robot, "r3");
    assert!(cmd_from(&mut r, RobotCommand::Plan(b.clone()), r3.clone()).0.is_err());
    let admit = RobotCommand::Admit { mission: "n".into(), managers: vec!["r3".into()], members: vec!["r1".into(), "r4".into()] };
    assert!(cmd_from(&mut r, admit.clone(), rogue.clone()).0.is_err());
    assert!(cmd(&mut r, admit).0.is_ok());
    let ids = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    assert_eq!(r.team(), vec![("m".into(), ids(&["r1", "r2"])), ("n".into(), ids(&["r1", "r3", "r4"]))], "its plan's team and its admission's");
    assert!(cmd_from(&mut r, RobotCommand::Plan(b.clone()), rogue).0.is_err());
    assert!(cmd_from(&mut r, RobotCommand::Plan(b), r3).0.is_ok());
}

#[test]
fn an_idle_robot_takes_a_robot_heads_plan_only_while_central_is_unreachable() {
    let mut r = Robot::new(cfg());
    r.handle(0.0, Event::CentralAlive(true));
    let head = Sender::new(Role::Robot, "r2");
    assert!(cmd_from(&mut r, plan("m", 3), head.clone()).0.is_err(), "central admits robots while it is up");
    r.handle(0.0, Event::CentralAlive(false));
    assert!(cmd_from(&mut r, plan("m", 3), head).0.is_ok(), "without central, a restarted robot rejoins");
    // Busy in a mission, it stays deaf to strangers even then.
    assert!(cmd_from(&mut r, plan("n", 9), Sender::new(Role::Robot, "r9")).0.is_err());
}

#[test]
fn capabilities_change_on_centrals_word_and_telemetry_says_so() {
    let mut r = Robot::new(with_capabilities(&["camera", "lidar"], false));
    assert_eq!((r.info(vec![]).rev, telemetry(&mut r, 0.0).info_rev), (0, 0));
    let change = |add: &[&str], remove: &[&str]| RobotCommand::Capabilities {
        add: add.iter().map(|s| s.to_string()).collect(),
        remove: remove.iter().map(|s| s.to_string()).collect(),
    };
    // Only central changes them (the operator goes through central).
    assert!(cmd_from(&mut r, change(&[], &["camera"]), Sender::new(Role::Operator, "op")).0.unwrap_err().contains("may not"));
    assert!(cmd_from(&mut r, change(&[], &["camera"]), Sender::new(Role::Robot, "r2")).0.is_err());
    assert_eq!(r.info(vec![]).capabilities, ["camera", "lidar"]);
    let ack = cmd(&mut r, change(&["gripper"], &["camera"])).0.expect("ack");
    assert_eq!(ack.capabilities.as_deref(), Some(&["gripper".to_string(), "lidar".to_string()][..]));
    let info = r.info(vec![]);
    assert_eq!((info.capabilities.clone(), info.rev), (vec!["gripper".to_string(), "lidar".to_string()], 1));
    assert_eq!(telemetry(&mut r, 0.1).info_rev, 1);
    // No change, no new revision; bad names are refused and change nothing.
    cmd(&mut r, change(&["lidar"], &["camera"])).0.expect("ack");
    assert_eq!(r.info(vec![]).rev, 1);
    assert!(cmd(&mut r, change(&["night vision"], &[])).0.unwrap_err().contains("bad capability"));
    assert!(cmd(&mut r, change(&["a"], &["a"])).0.unwrap_err().contains("both added and removed"));
    let many: Vec<String> = (0..40).map(|i| format!("c{i}")).collect();
    assert!(cmd(&mut r, RobotCommand::Capabilities { add: many, remove: vec![] }).0.unwrap_err().contains("at most 32"));
    assert_eq!(r.info(vec![]).capabilities, ["gripper", "lidar"]);
    // Any other command's answer leaves them out.
    assert_eq!(cmd(&mut r, RobotCommand::Hold).0.expect("ack").capabilities, None);
}

#[test]
fn a_robot_with_a_state_dir_keeps_changed_capabilities() {
    let change = RobotCommand::Capabilities { add: vec![], remove: vec!["camera".into()] };
    let keeps = |out: &[Command]| {
        out.iter().find_map(|c| match c {
            Command::KeepCapabilities { configured, now } => Some((configured.clone(), now.clone())),
            _ => None,
        })
    };
    let mut stateless = Robot::new(with_capabilities(&["camera"], false));
    assert_eq!(keeps(&stateless.handle(0.0, Event::Command { cmd: change.clone(), from: Sender::new(Role::Central, "central") })), None);
    let mut r = Robot::new(with_capabilities(&["camera"], true));
    let out = r.handle(0.0, Event::Command { cmd: change.clone(), from: Sender::new(Role::Central, "central") });
    assert_eq!(keeps(&out), Some((vec!["camera".to_string()], vec![])));
    // Kept before it is acknowledged: an operator told it is done does not lose it if the robot
    // dies right after (the flake of tests/capabilities.rs, which kills the robot at the ack).
    let kept_at = out.iter().position(|c| matches!(c, Command::KeepCapabilities { .. }));
    let acked_at = out.iter().position(|c| matches!(c, Command::Reply(Ok(_))));
    assert!(kept_at < acked_at && acked_at.is_some(), "{out:?}");
    // No change, nothing to keep.
    assert_eq!(keeps(&r.handle(0.1, Event::Command { cmd: change, from: Sender::new(Role::Central, "central") })), None);
    // After a restart, what was kept replaces the config's list.
    let mut again = Robot::new(with_capabilities(&["camera"], true));
    again.restore_capabilities(vec!["lidar".into()]);
    assert_eq!(again.info(vec![]).capabilities, ["lidar"]);
}

#[test]
fn a_simulated_robot_crashes_on_centrals_word_after_answering_and_a_ros_robot_refuses() {
    let mut r = Robot::new(cfg());
    // Only central orders it (the operator's word reaches the robot through central).
    assert!(cmd_from(&mut r, RobotCommand::Crash, Sender::new(Role::Operator, "op")).0.unwrap_err().contains("only central"));
    assert!(cmd_from(&mut r, RobotCommand::Crash, Sender::new(Role::Robot, "r2")).0.is_err());
    let out = r.handle(0.0, Event::Command { cmd: RobotCommand::Crash, from: Sender::new(Role::Central, "central") });
    assert!(matches!(out.as_slice(), [Command::Reply(Ok(_)), Command::Crash]), "answered, then crashed, nothing else: {out:?}");

    let ros = RobotSetup { body: BodyKind::Ros { odom_timeout_s: 1.0, stop_on_fleet_loss: true, localised: false, nav2: None }, ..cfg() };
    let mut r = Robot::new(ros);
    let out = r.handle(0.0, Event::Command { cmd: RobotCommand::Crash, from: Sender::new(Role::Central, "central") });
    assert!(!out.iter().any(|c| matches!(c, Command::Crash)), "a real robot is not crashed: {out:?}");
    assert!(matches!(&out[0], Command::Reply(Err(e)) if e.contains("only a simulated robot")), "{out:?}");
}

/// A robot that took a plan on a map (`steps`, else [`plan`]'s), and that map.
fn planned_on_map(steps: Option<Vec<Step>>) -> (Robot, mrmm_proto::MapRef) {
    plan_on_map(Robot::new(cfg()), steps)
}

/// Robot `r` given a plan on a map (`steps`, else [`plan`]'s), and that map.
fn plan_on_map(mut r: Robot, steps: Option<Vec<Step>>) -> (Robot, mrmm_proto::MapRef) {
    let map = mrmm_proto::MapRef { name: "building".into(), hash: "ab".repeat(32) };
    let RobotCommand::Plan(mut a) = plan("m", 1) else { unreachable!() };
    a.map = Some(map.clone());
    if let Some(steps) = steps {
        a.plan.steps = steps;
    }
    cmd(&mut r, RobotCommand::Plan(a)).0.expect("plan taken");
    (r, map)
}

/// On a map, a plan's goal goes to traffic first; when traffic answers that the map has no lanes
/// (a grid map), the body drives to that goal — the plan does not skip it for the next one (an
/// aerial robot of the demo once flew straight through the building's walls so).
#[test]
fn a_goal_given_to_traffic_is_driven_when_the_map_has_no_lanes() {
    let (mut r, map) = planned_on_map(Some(vec![
        Step::Navigate { x: 4.0, y: 0.0, speed: None },
        Step::Navigate { x: 4.0, y: -4.0, speed: None },
        Step::Hold { seconds: None },
    ]));
    // Traffic has not answered yet: the robot stands, waiting for its word.
    for i in 0..10 {
        r.handle(i as f64 * 0.01, Event::Tick);
    }
    assert_eq!(r.body.goal(), None);
    r.handle(0.1, Event::Traffic { map: map.hash.clone(), order: mrmm_proto::TrafficOrder::Free, deputy: false });
    r.handle(0.11, Event::Tick);
    assert_eq!(r.body.goal(), Some((4.0, 0.0)), "the first goal, not the next one");
    // It gets there, then drives on to the next.
    let mut seen_first = false;
    for i in 12..400 {
        r.handle(i as f64 * 0.01, Event::Tick);
        let p = r.body.pose();
        seen_first |= (p.x - 4.0).abs() < 0.2 && p.y.abs() < 0.2;
    }
    assert!(seen_first, "passed by (4, 0)");
    let p = r.body.pose();
    assert!((p.x - 4.0).abs() < 0.1 && (p.y + 4.0).abs() < 0.1, "{p:?}");
}

/// The same for a goto given to traffic before it answered: its route is driven point by point.
#[test]
fn a_goto_given_to_traffic_is_driven_along_its_route_when_the_map_has_no_lanes() {
    let (mut r, map) = planned_on_map(None);
    cmd(&mut r, RobotCommand::Goto { x: 4.0, y: 4.0, via: vec![[4.0, 0.0]] }).0.expect("goto taken");
    r.handle(0.0, Event::Tick);
    assert_eq!(r.body.goal(), None, "traffic's word first");
    r.handle(0.05, Event::Traffic { map: map.hash.clone(), order: mrmm_proto::TrafficOrder::Free, deputy: false });
    assert_eq!(r.body.goal(), Some((4.0, 0.0)), "the route's first point");
}

/// On a grid map traffic may give a way off the lanes to the goal (`off`): the robot drives the
/// route, then straight to the goal; for its next goal it first drives back to the vertex it
/// left the lanes at, never straight across.
#[test]
fn a_way_off_the_lanes_is_driven_there_and_back_by_the_vertex() {
    use mrmm_proto::traffic::RouteVertex;
    let (mut r, map) = planned_on_map(Some(vec![
        Step::Navigate { x: 3.0, y: 1.0, speed: None },
        Step::Navigate { x: 0.0, y: -1.0, speed: None },
        Step::Hold { seconds: None },
    ]));
    let (v0, v1) = (RouteVertex::at(0, 0.0, 0.0), RouteVertex::at(1, 3.0, 0.0));
    let order = |goal: u64, version: u64, route: Vec<RouteVertex>, off: [f64; 2]| Event::Traffic {
        map: map.hash.clone(),
        order: mrmm_proto::TrafficOrder::Route { goal, incarnation: 1, version, route, reached: Some(0), upto: Some(1), deputies: vec![], off: Some(off) },
        deputy: false,
    };
    r.handle(0.0, Event::Tick);
    r.handle(0.01, order(1, 1, vec![v0.clone(), v1.clone()], [3.0, 1.0]));
    let (mut t, mut at_goal, mut back, mut second_order) = (0.02, false, false, false);
    while t < 12.0 {
        r.handle(t, Event::Tick);
        let p = r.body.pose();
        at_goal |= (p.x - 3.0).abs() < 0.1 && (p.y - 1.0).abs() < 0.1;
        if at_goal && !second_order {
            // The plan went on to its next goal: the robot heads back to (3, 0) before any order.
            back |= (p.x - 3.0).abs() < 0.16 && p.y.abs() < 0.16;
            if back {
                r.handle(t, order(2, 2, vec![v1.clone(), v0.clone()], [0.0, -1.0]));
                second_order = true;
            }
        }
        if at_goal {
            // Never across: on the way back (x = 3), then on the lane (y = 0), then down (x = 0).
            assert!((p.x - 3.0).abs() < 0.15 || p.y.abs() < 0.15 || p.x.abs() < 0.15, "off the ways: {p:?}");
        }
        t += 0.01;
    }
    assert!(at_goal && back && second_order, "at the first goal {at_goal}, back at its vertex {back}");
    let p = r.body.pose();
    assert!(p.x.abs() < 0.1 && (p.y + 1.0).abs() < 0.1, "at the second goal: {p:?}");
}

/// A robot the operator took off the lanes while it was away (central's `cleared` order) holds
/// nothing: it stops where it is and asks for its way anew. A deputy's word to that effect is not
/// taken (only central clears).
#[test]
fn a_robot_taken_off_the_lanes_stops_and_asks_anew() {
    use mrmm_proto::traffic::RouteVertex;
    use mrmm_proto::TrafficOrder;
    let (mut r, map) = planned_on_map(Some(vec![Step::Navigate { x: 100.0, y: 0.0, speed: None }, Step::Hold { seconds: None }]));
    let (v0, v1) = (RouteVertex::at(0, 0.0, 0.0), RouteVertex::at(1, 100.0, 0.0));
    let order = |order: TrafficOrder, deputy: bool| Event::Traffic { map: map.hash.clone(), order, deputy };
    r.handle(0.0, Event::Tick);
    let route = TrafficOrder::Route {
        goal: 1,
        incarnation: 1,
        version: 1,
        route: vec![v0.clone(), v1.clone()],
        reached: Some(0),
        upto: Some(1),
        deputies: vec![],
        off: None,
    };
    r.handle(0.01, order(route, false));
    let mut t = 0.02;
    // Ticks until `until`: whether the robot asked for its way without holding any.
    let mut drive = |r: &mut Robot, until: f64| {
        let mut asked = false;
        while t < until {
            let out = r.handle(t, Event::Tick);
            asked |= out.iter().any(|c| matches!(c, Command::TrafficReport { report, .. } if report.held.is_none() && report.goal.is_some()));
            t += 0.01;
        }
        asked
    };
    drive(&mut r, 0.5);
    let x = r.body.pose().x;
    assert!(x > 0.3, "it drives what it was granted: {x}");
    r.handle(0.5, order(TrafficOrder::Cleared { incarnation: 1 }, true));
    drive(&mut r, 1.0);
    assert!(r.body.pose().x > x + 0.3, "a deputy cannot clear it: {x} then {}", r.body.pose().x);
    let x = r.body.pose().x;
    r.handle(1.0, order(TrafficOrder::Cleared { incarnation: 1 }, false));
    assert!(drive(&mut r, 3.0), "it asks for its way anew");
    assert!(r.body.pose().x < x + 0.5, "it drove on after it was cleared: from {x} to {}", r.body.pose().x);
}

/// Central plugs a simulated robot with a battery in where it stands: it charges and does not
/// drive until a new goal unplugs it; a robot without a battery, one running a plan, and anyone
/// but central are refused.
#[test]
fn a_robot_with_a_battery_charges_on_centrals_word() {
    use crate::body::battery::{Battery, BatteryModel};
    let mut r = Robot::new(RobotSetup { battery: Some(Battery::new(BatteryModel::lasting(100.0, 2.0), 0.5)), ..cfg() });
    assert!(cmd(&mut Robot::new(cfg()), RobotCommand::Charge { on: true }).0.unwrap_err().contains("has no battery"));
    assert!(cmd_from(&mut r, RobotCommand::Charge { on: true }, Sender::new(Role::Robot, "r2")).0.unwrap_err().contains("may not"));
    cmd(&mut r, plan("m", 1)).0.expect("plan");
    assert!(cmd(&mut r, RobotCommand::Charge { on: true }).0.unwrap_err().contains("running a plan"));
    cmd(&mut r, RobotCommand::Goto { x: 10.0, y: 0.0, via: vec![] }).0.expect("goto");
    cmd(&mut r, RobotCommand::Charge { on: true }).0.expect("plugged");
    let before = r.pose();
    for k in 0..50 {
        r.handle(f64::from(k) * 0.1, Event::Tick);
    }
    assert_eq!(r.pose(), before, "plugged in, it stands");
    let b = telemetry(&mut r, 5.0).battery.expect("battery");
    assert!(b.charging && b.charge > 0.6, "{b:?}");
    cmd(&mut r, RobotCommand::Goto { x: 10.0, y: 0.0, via: vec![] }).0.expect("goto");
    r.handle(5.1, Event::Tick);
    r.handle(5.3, Event::Tick);
    assert!(r.pose().x > before.x, "a new goal unplugs it");
    assert!(!telemetry(&mut r, 5.4).battery.expect("battery").charging);
}

/// A robot whose body is a VDA 5050 vehicle.
fn vda_robot() -> Robot {
    Robot::new(RobotSetup {
        body: BodyKind::Vda { order_prefix: "gw".into(), map_id: "m".into() },
        ..RobotSetup::sim("r1", "ground", Limits { max_speed: 1.0, max_turn_rate: 1.0 }, Pose::default())
    })
}

/// A VDA 5050 vehicle is sent the goal a tick gives it within that tick (a grant is on the wire
/// at once, not a tick later), and the vehicle's state drives the robot on along its goto.
#[test]
fn a_vda_vehicle_is_sent_its_next_goal_in_the_tick_that_gives_it() {
    let mut r = vda_robot();
    let state = |last: &str, seq: u64, x: f64| {
        let mut s = mrmm_vda5050::State { order_id: "gw-1".into(), last_node_id: last.into(), last_node_sequence_id: seq, ..Default::default() };
        s.agv_position = Some(mrmm_vda5050::msg::AgvPosition { x, y: 0.0, theta: 0.0, map_id: "m".into(), position_initialized: true });
        Event::Vda(Box::new(mrmm_vda5050::FromVehicle::State(Box::new(s))))
    };
    r.handle(0.0, state("", 0, 0.0));
    cmd(&mut r, RobotCommand::Goto { x: 4.0, y: 4.0, via: vec![[4.0, 0.0]] }).0.expect("goto taken");
    let orders = |out: Vec<Command>| out.into_iter().filter(|c| matches!(c, Command::Vda(crate::body::vda::VdaOut::Order(_)))).count();
    assert_eq!(orders(r.handle(0.02, Event::Tick)), 1, "the first corner");
    r.handle(0.5, state("gw-p1", 2, 4.0));
    assert_eq!(orders(r.handle(0.52, Event::Tick)), 1, "the corner passed: the goal after it goes out in the same tick");
}

/// The fleet's charging policy plugs a VDA 5050 vehicle in by `startCharging` (and out by
/// `stopCharging`), not on a plan.
#[test]
fn a_vda_vehicle_is_charged_by_instant_actions() {
    let mut r = vda_robot();
    let actions = |out: Vec<Command>| -> Vec<String> {
        out.into_iter()
            .filter_map(|c| match c {
                Command::Vda(crate::body::vda::VdaOut::Instant(a)) => Some(a.into_iter().map(|a| a.action_type)),
                _ => None,
            })
            .flatten()
            .collect()
    };
    cmd(&mut r, RobotCommand::Charge { on: true }).0.expect("plugged");
    assert_eq!(actions(r.handle(0.02, Event::Tick)), ["startCharging"]);
    cmd(&mut r, RobotCommand::Charge { on: false }).0.expect("unplugged");
    assert_eq!(actions(r.handle(0.04, Event::Tick)), ["stopCharging"]);
}

/// A VDA 5050 vehicle driving back from a goal off the lanes to the vertex it left them at is
/// sent its next route from that vertex in the tick traffic grants it, as an update of the order
/// it drives back by: it drives on through that vertex (the ~1 s grant → order waits the bench
/// found were vehicles sent their next route only once back), never across, no order refused.
/// Driven against the simulated vehicle of `mrmm-vda5050`.
#[test]
fn a_vda_vehicle_driving_back_to_the_lanes_is_sent_its_next_grant_on_the_way() {
    use crate::body::vda::VdaOut;
    use mrmm_proto::traffic::RouteVertex;
    use mrmm_vda5050::sim::{SimIn, SimOut, SimVehicle};
    use mrmm_vda5050::{FromVehicle, InstantActions, VehicleId};
    let (mut r, map) = plan_on_map(
        vda_robot(),
        Some(vec![Step::Navigate { x: 3.0, y: 1.0, speed: None }, Step::Navigate { x: 0.0, y: -1.0, speed: None }, Step::Hold { seconds: None }]),
    );
    let mut vehicle = SimVehicle::new(VehicleId::new("mrmm", "agv1").unwrap(), "m", (0.0, 0.0, 0.0), 1.0);
    let (v0, v1) = (RouteVertex::at(0, 0.0, 0.0), RouteVertex::at(1, 3.0, 0.0));
    let order = |goal: u64, route: Vec<RouteVertex>, off: [f64; 2]| Event::Traffic {
        map: map.hash.clone(),
        order: mrmm_proto::TrafficOrder::Route {
            goal,
            incarnation: 1,
            version: goal,
            route,
            reached: Some(0),
            upto: Some(1),
            deputies: vec![],
            off: Some(off),
        },
        deputy: false,
    };
    let mut to_robot: Vec<SimOut> = vehicle.connect(0);
    // The authority's order, which it sends again in answer to every report.
    let mut current = (1, vec![v0.clone(), v1.clone()], [3.0, 1.0]);
    r.handle(0.0, Event::Tick);
    r.handle(0.0, order(current.0, current.1.clone(), current.2));
    let (mut at_goal, mut granted, mut released, mut cancels) = (false, None, None, 0);
    for k in 1..1500u64 {
        let t = k as f64 * 0.01;
        for out in to_robot.drain(..) {
            let msg = match out {
                SimOut::State(s) => {
                    assert!(s.errors.is_empty(), "the vehicle refused: {:?}", s.errors);
                    FromVehicle::State(s)
                }
                SimOut::Visualization(v) => FromVehicle::Visualization(v),
                _ => continue,
            };
            r.handle(t, Event::Vda(Box::new(msg)));
        }
        let p = r.body.pose();
        at_goal |= (p.x - 3.0).abs() < 0.1 && (p.y - 1.0).abs() < 0.1;
        if at_goal && granted.is_none() && p.y < 0.6 {
            // On its way back to (3, 0): traffic grants the next route, from there.
            current = (2, vec![v1.clone(), v0.clone()], [0.0, -1.0]);
            r.handle(t, order(current.0, current.1.clone(), current.2));
            granted = Some(t);
        }
        if at_goal {
            assert!((p.x - 3.0).abs() < 0.15 || p.y.abs() < 0.15 || p.x.abs() < 0.15, "off the ways: {p:?}");
        }
        for c in r.handle(t, Event::Tick) {
            let input = match c {
                Command::TrafficReport { .. } => {
                    r.handle(t, order(current.0, current.1.clone(), current.2));
                    continue;
                }
                Command::Vda(VdaOut::Order(o)) => {
                    if granted.is_some() && released.is_none() && o.nodes.iter().any(|n| n.released && n.node_id == "v0") {
                        released = Some(t);
                    }
                    SimIn::Order(o)
                }
                Command::Vda(VdaOut::Instant(actions)) => {
                    cancels += actions.iter().filter(|a| a.action_type == "cancelOrder").count();
                    SimIn::Instant(InstantActions { header: Default::default(), actions })
                }
                _ => continue,
            };
            to_robot.extend(vehicle.handle(k * 10, input));
        }
        to_robot.extend(vehicle.handle(k * 10, SimIn::Tick));
    }
    let (granted, released) = (granted.expect("back from the goal off the lanes"), released.expect("the next route released"));
    assert!(released - granted < 0.02, "the grant at {granted:.2} s went out at {released:.2} s");
    assert_eq!(cancels, 0, "no order cancelled");
    let p = r.body.pose();
    assert!(p.x.abs() < 0.1 && (p.y + 1.0).abs() < 0.1, "at the second goal: {p:?}");
}

/// A way off the lanes given, and traffic quiet by the time the robot stands at the route's last
/// vertex: it waits there (the goal is not reached, the plan does not go on) until traffic speaks
/// again, then drives off to the goal.
#[test]
fn a_way_off_the_lanes_waits_for_traffic_gone_quiet() {
    use mrmm_proto::traffic::RouteVertex;
    let (mut r, map) = planned_on_map(Some(vec![Step::Navigate { x: 40.0, y: 1.0, speed: None }, Step::Hold { seconds: None }]));
    let order = || Event::Traffic {
        map: map.hash.clone(),
        order: mrmm_proto::TrafficOrder::Route {
            goal: 1,
            incarnation: 1,
            version: 1,
            route: vec![RouteVertex::at(0, 0.0, 0.0), RouteVertex::at(1, 40.0, 0.0)],
            reached: Some(0),
            upto: Some(1),
            deputies: vec![],
            off: Some([40.0, 1.0]),
        },
        deputy: false,
    };
    // 40 m at 8 m/s (2 m/s, time scale 4): at the vertex after traffic's 3 s of quiet.
    r.handle(0.0, Event::Tick);
    r.handle(0.01, order());
    let mut t = 0.02;
    while t < 10.0 {
        r.handle(t, Event::Tick);
        t += 0.01;
    }
    let p = r.body.pose();
    assert!((p.x - 40.0).abs() < 0.1 && p.y.abs() < 0.1, "waits at the vertex: {p:?}");
    assert_eq!(telemetry(&mut r, t).progress.map(|p| p.step), Some(0), "the goal off the lanes is not reached");
    r.handle(t, order());
    while t < 13.0 {
        r.handle(t, Event::Tick);
        t += 0.01;
    }
    let p = r.body.pose();
    assert!((p.x - 40.0).abs() < 0.1 && (p.y - 1.0).abs() < 0.1, "at the goal once traffic spoke again: {p:?}");
}

//! Unit tests of the robot machine: commands and who may give them, plans, telemetry.

use super::*;
use crate::at;
use crate::body::Limits;
use mrmm_proto::{PlanAssignment, Pose, RobotPlan, Role, Step, Time};

mod lanes;
mod vda;

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
    let out = r.handle(at(0.0), Event::Command { cmd: c, from });
    let reply = out.iter().find_map(|c| match c {
        Command::Reply(r) => Some(r.clone()),
        Command::Refuse(e) => Some(Err(e.clone())),
        _ => None,
    });
    let change = out.into_iter().find(|c| matches!(c, Command::JoinTeam { .. } | Command::LeaveTeam));
    (reply.expect("a reply"), change)
}

fn telemetry(r: &mut Robot, now: Time) -> Telemetry {
    match r.handle(now, Event::TelemetryDue).pop() {
        Some(Command::Telemetry(t)) => t,
        other => panic!("no telemetry: {other:?}"),
    }
}

#[test]
fn goto_then_arrive_with_time_scale() {
    let mut r = Robot::new(cfg());
    let (ack, _) = cmd(&mut r, RobotCommand::Goto { x: 8.0, y: 0.0, via: vec![], map: None });
    assert_eq!(ack.expect("ack").behaviour, Behaviour::Navigate { x: 8.0, y: 0.0 });
    // 8 m at 2 m/s = 4 simulated s = 1 wall s at time scale 4.
    for i in 0..=110 {
        r.handle(at(i as f64 * 0.01), Event::Tick);
    }
    let t = telemetry(&mut r, at(1.1));
    assert_eq!(t.behaviour, Behaviour::Hold);
    assert!((t.pose.x - 8.0).abs() <= crate::body::ARRIVAL_TOLERANCE);
    assert!((t.t - 4.4).abs() < 1e-9);
    assert_eq!(t.seq, 2, "one telemetry after the command, one now");
}

/// A goto with a route drives through its corners in turn, then holds at the goal.
#[test]
fn goto_follows_its_route() {
    let mut r = Robot::new(cfg());
    let (ack, _) = cmd(&mut r, RobotCommand::Goto { x: 4.0, y: 4.0, via: vec![[4.0, 0.0]], map: None });
    assert_eq!(ack.expect("ack").behaviour, Behaviour::Navigate { x: 4.0, y: 0.0 }, "the first corner first");
    let mut farthest_x_before_turn: f64 = 0.0;
    for i in 0..=400 {
        r.handle(at(i as f64 * 0.01), Event::Tick);
        let p = r.telemetry().pose;
        if p.y < 0.5 {
            farthest_x_before_turn = farthest_x_before_turn.max(p.x);
        } else {
            assert!(p.x > 3.5, "cut the corner: {p:?}");
        }
    }
    let t = telemetry(&mut r, at(4.1));
    assert_eq!(t.behaviour, Behaviour::Hold);
    assert!((t.pose.x - 4.0).abs() <= 0.1 && (t.pose.y - 4.0).abs() <= crate::body::ARRIVAL_TOLERANCE, "{:?}", t.pose);
    assert!(farthest_x_before_turn > 3.9);
    let too_many = vec![[0.0, 0.0]; MAX_GOTO_VIA + 1];
    assert!(cmd(&mut r, RobotCommand::Goto { x: 0.0, y: 0.0, via: too_many, map: None }).0.is_err());
}

#[test]
fn rejects_non_finite_goal_and_hostile_plans() {
    let mut r = Robot::new(cfg());
    assert!(cmd(&mut r, RobotCommand::Goto { x: f64::NAN, y: 0.0, via: vec![], map: None }).0.is_err());
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
    r.handle(at(0.01), Event::Tick);
    r.handle(at(0.2), Event::Tick);
    let moving = telemetry(&mut r, at(0.2));
    assert!(moving.velocity.v > 0.0, "on its way to (4, 0)");
    // Another member was replaced: the same plan under epoch 3, with the newcomer.
    let RobotCommand::Plan(mut a) = plan("m", 3) else { unreachable!() };
    a.members.push("r9".into());
    a.handover = Some(mrmm_proto::Handover { planned: 2, step: 0, round: 0 });
    let (ack, change) = cmd(&mut r, RobotCommand::Plan(a.clone()));
    assert!(ack.is_ok());
    assert!(matches!(change, Some(Command::JoinTeam { ref members, .. }) if members.len() == 2), "its team has the newcomer: {change:?}");
    r.handle(at(0.25), Event::Tick);
    let t = telemetry(&mut r, at(0.25));
    assert!(t.velocity.v > 0.0, "not stopped by the new epoch");
    assert_eq!(t.progress.as_ref().map(|p| (p.epoch, p.step)), Some((3, 0)));
    // The robot that comes in with a plan of that lineage starts where the handover says.
    let mut n = Robot::new(cfg());
    a.handover = Some(mrmm_proto::Handover { planned: 2, step: 1, round: 7 });
    assert!(cmd(&mut n, RobotCommand::Plan(a)).0.is_ok());
    n.handle(at(0.01), Event::Tick);
    assert_eq!(
        telemetry(&mut n, at(0.01)).progress.map(|p| (p.step, p.round)),
        Some((0, 7)),
        "on the leg to step 1's barrier-less hold: the navigate before it"
    );
}

#[test]
fn plans_epochs_and_leaving() {
    let mut r = Robot::new(cfg());
    let (_, change) = cmd(&mut r, plan("m", 2));
    assert_eq!(
        change,
        Some(Command::JoinTeam { team: "m".into(), subteam: "m/ground".into(), barrier: BarrierMode::Mesh, members: vec!["r1".into()], scopes: vec![] })
    );
    r.handle(at(0.01), Event::Tick);
    assert_eq!(telemetry(&mut r, at(0.01)).mission.as_ref().map(|x| x.as_str()), Some("m"));
    assert!(cmd(&mut r, plan("m", 1)).0.unwrap_err().contains("stale epoch"));
    // The same plan again changes nothing.
    assert_eq!(cmd(&mut r, plan("m", 2)), (Ok(r.ack()), None));
    // A leave for an older epoch or another mission is ignored.
    assert_eq!(cmd(&mut r, RobotCommand::Leave { mission: "m".into(), epoch: 1 }).1, None);
    assert_eq!(cmd(&mut r, RobotCommand::Leave { mission: "x".into(), epoch: 9 }).1, None);
    // Another mission's plan replaces this one (a move).
    assert!(matches!(cmd(&mut r, plan("n", 1)).1, Some(Command::JoinTeam { .. })));
    assert_eq!(cmd(&mut r, RobotCommand::Leave { mission: "n".into(), epoch: 1 }).1, Some(Command::LeaveTeam));
    assert_eq!(telemetry(&mut r, at(0.02)).mission, None);
    // A plan for somebody else is refused.
    let RobotCommand::Plan(mut a) = plan("m", 3) else { unreachable!() };
    a.plan.robot = "r2".into();
    assert!(cmd(&mut r, RobotCommand::Plan(a)).0.is_err());
}

#[test]
fn only_central_orders_and_only_managers_of_the_mission_plan() {
    let mut r = Robot::new(cfg());
    r.handle(at(0.0), Event::CentralAlive(true));
    let rogue = Sender::new(Role::Robot, "r9");
    assert!(cmd_from(&mut r, RobotCommand::Goto { x: 1.0, y: 1.0, via: vec![], map: None }, rogue.clone()).0.unwrap_err().contains("robot:r9 may not"));
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
    r.handle(at(0.0), Event::CentralAlive(true));
    let head = Sender::new(Role::Robot, "r2");
    assert!(cmd_from(&mut r, plan("m", 3), head.clone()).0.is_err(), "central admits robots while it is up");
    r.handle(at(0.0), Event::CentralAlive(false));
    assert!(cmd_from(&mut r, plan("m", 3), head).0.is_ok(), "without central, a restarted robot rejoins");
    // Busy in a mission, it stays deaf to strangers even then.
    assert!(cmd_from(&mut r, plan("n", 9), Sender::new(Role::Robot, "r9")).0.is_err());
}

#[test]
fn capabilities_change_on_centrals_word_and_telemetry_says_so() {
    let mut r = Robot::new(with_capabilities(&["camera", "lidar"], false));
    assert_eq!((r.info(vec![]).rev, telemetry(&mut r, at(0.0)).info_rev), (0, 0));
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
    assert_eq!(telemetry(&mut r, at(0.1)).info_rev, 1);
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
    assert_eq!(keeps(&stateless.handle(at(0.0), Event::Command { cmd: change.clone(), from: Sender::new(Role::Central, "central") })), None);
    let mut r = Robot::new(with_capabilities(&["camera"], true));
    let out = r.handle(at(0.0), Event::Command { cmd: change.clone(), from: Sender::new(Role::Central, "central") });
    assert_eq!(keeps(&out), Some((vec!["camera".to_string()], vec![])));
    // Kept before it is acknowledged: an operator told it is done does not lose it if the robot
    // dies right after (the flake of tests/capabilities.rs, which kills the robot at the ack).
    let kept_at = out.iter().position(|c| matches!(c, Command::KeepCapabilities { .. }));
    let acked_at = out.iter().position(|c| matches!(c, Command::Reply(Ok(_))));
    assert!(kept_at < acked_at && acked_at.is_some(), "{out:?}");
    // No change, nothing to keep.
    assert_eq!(keeps(&r.handle(at(0.1), Event::Command { cmd: change, from: Sender::new(Role::Central, "central") })), None);
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
    let out = r.handle(at(0.0), Event::Command { cmd: RobotCommand::Crash, from: Sender::new(Role::Central, "central") });
    assert!(matches!(out.as_slice(), [Command::Reply(Ok(_)), Command::Crash]), "answered, then crashed, nothing else: {out:?}");

    let ros = RobotSetup { body: BodyKind::Ros { odom_timeout_s: 1.0, stop_on_fleet_loss: true, localised: false, nav2: None }, ..cfg() };
    let mut r = Robot::new(ros);
    let out = r.handle(at(0.0), Event::Command { cmd: RobotCommand::Crash, from: Sender::new(Role::Central, "central") });
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
    cmd(&mut r, RobotCommand::Goto { x: 10.0, y: 0.0, via: vec![], map: None }).0.expect("goto");
    cmd(&mut r, RobotCommand::Charge { on: true }).0.expect("plugged");
    let before = r.pose();
    for k in 0..50 {
        r.handle(at(f64::from(k) * 0.1), Event::Tick);
    }
    assert_eq!(r.pose(), before, "plugged in, it stands");
    let b = telemetry(&mut r, at(5.0)).battery.expect("battery");
    assert!(b.charging && b.charge > 0.6, "{b:?}");
    cmd(&mut r, RobotCommand::Goto { x: 10.0, y: 0.0, via: vec![], map: None }).0.expect("goto");
    r.handle(at(5.1), Event::Tick);
    r.handle(at(5.3), Event::Tick);
    assert!(r.pose().x > before.x, "a new goal unplugs it");
    assert!(!telemetry(&mut r, at(5.4)).battery.expect("battery").charging);
}

/// A robot whose body is a VDA 5050 vehicle.
fn vda_robot() -> Robot {
    Robot::new(RobotSetup {
        body: BodyKind::Vda { order_prefix: "gw".into(), map_id: "m".into() },
        ..RobotSetup::sim("r1", "ground", Limits { max_speed: 1.0, max_turn_rate: 1.0 }, Pose::default())
    })
}

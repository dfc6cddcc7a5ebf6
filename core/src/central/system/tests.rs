//! System manager: registry, operator queries and mission commands, asserting emitted commands.

use super::*;
use crate::at;
use crate::Failure;
use mrmm_proto::{Behaviour, CommandAck, ManagerView, MissionCtl, MissionMetrics, MissionStatus, MissionView, Pose, Time};

/// The commands without the admissions sent to robots (they go with every start and join).
/// Handling as the driver does it: dry runs (off the loop there) are carried out at once.
trait Drive {
    fn drive(&mut self, now: Time, ev: Event) -> Vec<Command>;
}

impl Drive for SystemManager {
    fn drive(&mut self, now: Time, ev: Event) -> Vec<Command> {
        let mut out = Vec::new();
        for c in self.handle(now, ev) {
            match c {
                Command::DryRun(d) => {
                    let result = d.run();
                    out.extend(self.drive(now, Event::DryRunDone { id: d.id, result }));
                }
                // What goes to the journal is checked in `journal.rs`.
                Command::Journal(_) => {}
                other => out.push(other),
            }
        }
        out
    }
}

fn no_admits(cmds: Vec<Command>) -> Vec<Command> {
    cmds.into_iter().filter(|c| !matches!(c, Command::SendToRobot { cmd: RobotCommand::Admit { .. }, .. })).collect()
}

/// A head's report as the driver hands it over: proven to come from its manager node (central,
/// else a mission host).
fn status(v: MissionView) -> Event {
    let role = if v.manager.node == "central" { mrmm_proto::Role::Central } else { mrmm_proto::Role::Host };
    let from = mrmm_proto::Sender::new(role, v.manager.node.clone());
    Event::MissionStatus { view: Box::new(v), from }
}

fn info(id: &str) -> RobotInfo {
    RobotInfo { capabilities: vec!["camera".into()], ..RobotInfo::new(id, "ground", 1.0) }
}

fn telemetry(id: &str, seq: u64, behaviour: Behaviour) -> Telemetry {
    Telemetry { seq, t: seq as f64, pose: Pose { x: seq as f64, y: 0.0, theta: 0.0 }, behaviour, ..Telemetry::resting(id, 0.0) }
}

fn registered(ids: &[&str]) -> SystemManager {
    // Started a while ago: past the adoption period, commands are not held.
    let mut sm = SystemManager::new("node".into(), at(-ADOPT_S));
    for id in ids {
        assert_eq!(sm.drive(at(0.0), Event::RobotAlive { id: (*id).into() }), vec![Command::FetchInfo { id: (*id).into() }]);
        assert!(sm.drive(at(0.0), Event::RobotRegistered(info(id))).is_empty());
        // Its first telemetry: it runs no plan.
        let mut t = telemetry(id, 1, Behaviour::Hold);
        t.pose = Pose::default();
        assert!(sm.drive(at(0.0), Event::Telemetry(Box::new(t))).is_empty());
    }
    sm
}

/// A request as the driver decodes it.
fn decode<T: serde::de::DeserializeOwned>(body: &str) -> T {
    serde_json::from_str(body).expect("a well-formed request")
}

fn decode_bytes<T: serde::de::DeserializeOwned>(body: &[u8]) -> T {
    serde_json::from_slice(body).expect("a well-formed request")
}

fn reply(cmds: Vec<Command>) -> Result<Value, String> {
    match cmds.as_slice() {
        [Command::Reply { result, .. }] => result.clone().map_err(|e| e.error),
        other => panic!("expected one reply, got {other:?}"),
    }
}

#[test]
fn registration_then_loss() {
    let mut sm = registered(&["r1", "r2"]);
    let views = sm.views();
    assert_eq!(views.len(), 2);
    assert!(views.iter().all(|v| v.status == RobotStatus::Idle));
    sm.drive(at(1.0), Event::RobotGone { id: "r2".into() });
    assert_eq!(sm.view("r2").map(|v| v.status), Some(RobotStatus::Lost));
    let st = sm.status(at(2.0));
    assert_eq!((st.robots_total, st.idle, st.lost), (2, 1, 1));
    // Comes back: alive again, info asked again.
    assert_eq!(sm.drive(at(3.0), Event::RobotAlive { id: "r2".into() }), vec![Command::FetchInfo { id: "r2".into() }]);
    assert_eq!(sm.view("r2").map(|v| v.status), Some(RobotStatus::Idle));
}

#[test]
fn unregistered_robots_are_not_listed_and_info_is_retried() {
    let mut sm = SystemManager::new("n".into(), at(0.0));
    sm.drive(at(0.0), Event::RobotAlive { id: "r1".into() });
    assert!(sm.views().is_empty());
    assert!(sm.drive(at(0.5), Event::Tick).is_empty(), "no roll call within a second of a liveliness event");
    assert_eq!(sm.drive(at(1.2), Event::Tick), vec![Command::FetchInfo { id: "r1".into() }, Command::RollCall]);
    assert!(sm.drive(at(1.5), Event::Tick).is_empty());
    // Info from a robot never seen alive is ignored.
    sm.drive(at(2.0), Event::RobotRegistered(info("ghost")));
    assert!(sm.view("ghost").is_none());
}

/// A roll call's answer: these robots' tokens up, and the hosts'.
fn present(robots: &[&str], hosts: &[&str], complete: bool) -> Event {
    let robots = robots.iter().map(|r| Key::RobotAlive((*r).into()).to_string());
    let hosts = hosts.iter().map(|h| Key::HostAlive((*h).into()).to_string());
    Event::RollCall(Ok(crate::roll_call::Present { up: robots.chain(hosts).collect(), complete }))
}

/// A roll call asked at `now`.
fn roll_call(sm: &mut SystemManager, now: Time) {
    assert!(sm.drive(now, Event::Tick).contains(&Command::RollCall), "a roll call is due at {now}");
}

#[test]
fn a_return_the_liveliness_events_missed_is_taken_from_the_roll_call() {
    let mut sm = registered(&["r1", "r2"]);
    sm.drive(at(1.0), Event::RobotGone { id: "r2".into() });
    // Its token came back, but the event was lost: the roll call lists it.
    roll_call(&mut sm, at(2.0));
    assert_eq!(sm.drive(at(2.1), present(&["r1", "r2"], &[], true)), vec![Command::FetchInfo { id: "r2".into() }]);
    assert_eq!(sm.view("r2").map(|v| v.status), Some(RobotStatus::Idle));
    // Not asked again before its period.
    assert!(!sm.drive(at(3.0), Event::Tick).contains(&Command::RollCall));
}

#[test]
fn a_loss_the_liveliness_events_missed_counts_when_two_roll_calls_miss_it() {
    let mut sm = registered(&["r1", "r2"]);
    roll_call(&mut sm, at(1.0));
    sm.drive(at(1.1), present(&["r1"], &[], true));
    assert_eq!(sm.view("r2").map(|v| v.status), Some(RobotStatus::Idle), "missed once: not lost yet");
    // An answer cut short never counts against a robot.
    roll_call(&mut sm, at(1.0 + crate::roll_call::ROLL_CALL_S));
    sm.drive(at(4.1), present(&["r1"], &[], false));
    assert_eq!(sm.view("r2").map(|v| v.status), Some(RobotStatus::Idle));
    roll_call(&mut sm, at(1.0 + 2.0 * crate::roll_call::ROLL_CALL_S));
    sm.drive(at(7.1), present(&["r1"], &[], true));
    assert_eq!(sm.view("r2").map(|v| v.status), Some(RobotStatus::Lost), "missed twice running");
    assert_eq!(sm.view("r1").map(|v| v.status), Some(RobotStatus::Idle));
}

#[test]
fn a_liveliness_event_after_the_question_wins_over_the_answer() {
    let mut sm = registered(&["r1", "r2"]);
    // Asked while r2 was up; it went before the answer came, which still lists it.
    roll_call(&mut sm, at(1.0));
    sm.drive(at(1.05), Event::RobotGone { id: "r2".into() });
    assert!(sm.drive(at(1.1), present(&["r1", "r2"], &[], true)).is_empty());
    assert_eq!(sm.view("r2").map(|v| v.status), Some(RobotStatus::Lost));
    // Asked while r1 was down; it came back before the answer, which misses it, twice.
    sm.drive(at(2.0), Event::RobotGone { id: "r1".into() });
    for k in 1..=2 {
        let asked = at(1.0 + f64::from(k) * crate::roll_call::ROLL_CALL_S);
        roll_call(&mut sm, asked);
        sm.drive(asked + 0.05, Event::RobotAlive { id: "r1".into() });
        sm.drive(asked + 0.1, present(&[], &[], true));
    }
    assert_eq!(sm.view("r1").map(|v| v.status), Some(RobotStatus::Idle));
    // An answer with no question out (a late one) is not acted on.
    assert!(sm.drive(at(8.0), present(&["r2"], &[], true)).is_empty());
    assert_eq!(sm.view("r2").map(|v| v.status), Some(RobotStatus::Lost));
}

#[test]
fn mission_hosts_the_liveliness_events_missed_are_taken_from_the_roll_call() {
    let mut sm = registered(&[]);
    roll_call(&mut sm, at(1.0));
    sm.drive(at(1.1), present(&[], &["h1", "h2"], true));
    assert!(sm.fleet.has_host("h1") && sm.fleet.has_host("h2"));
    for k in 1..=2 {
        let asked = at(1.0 + f64::from(k) * crate::roll_call::ROLL_CALL_S);
        roll_call(&mut sm, asked);
        sm.drive(asked + 0.1, present(&[], &["h1"], true));
    }
    assert!(sm.fleet.has_host("h1") && !sm.fleet.has_host("h2"));
}

#[test]
fn telemetry_updates_pose_and_status() {
    let mut sm = registered(&["r1"]);
    sm.drive(at(1.0), Event::Telemetry(Box::new(telemetry("r1", 2, Behaviour::Navigate { x: 5.0, y: 0.0 }))));
    let v = sm.view("r1").expect("r1");
    assert_eq!(v.status, RobotStatus::Busy);
    assert_eq!(v.pose.map(|p| p.x), Some(2.0));
    // An older message does not overwrite a newer one.
    sm.drive(at(1.1), Event::Telemetry(Box::new(telemetry("r1", 1, Behaviour::Hold))));
    assert_eq!(sm.view("r1").and_then(|v| v.pose).map(|p| p.x), Some(2.0));
    sm.drive(at(1.2), Event::Telemetry(Box::new(telemetry("r1", 3, Behaviour::Hold))));
    assert_eq!(sm.view("r1").map(|v| v.status), Some(RobotStatus::Idle));
    // Unknown robots' telemetry is dropped.
    sm.drive(at(1.3), Event::Telemetry(Box::new(telemetry("zz", 1, Behaviour::Hold))));
    assert!(sm.view("zz").is_none());
}

#[test]
fn goto_is_validated_then_relayed() {
    let mut sm = registered(&["r1", "r2"]);
    let go = |sm: &mut SystemManager, body: &str| sm.drive(at(1.0), Event::Operator { req: Req::Query(7), request: Request::Goto(decode(body)) });
    assert_eq!(
        go(&mut sm, r#"{"robot":"r1","x":3,"y":4}"#),
        vec![Command::SendToRobot { req: Some(Req::Query(7)), robot: "r1".into(), cmd: RobotCommand::Goto { x: 3.0, y: 4.0, via: vec![], map: None } }]
    );
    let e = reply(go(&mut sm, r#"{"robot":"nope","x":3,"y":4}"#)).expect_err("unknown");
    assert!(e.contains("unknown robot \"nope\""), "{e}");
    sm.drive(at(1.0), Event::RobotGone { id: "r2".into() });
    let e = reply(go(&mut sm, r#"{"robot":"r2","x":3,"y":4}"#)).expect_err("lost");
    assert!(e.contains("lost"), "{e}");
    let ack = CommandAck { ok: true, robot: "r1".into(), behaviour: Behaviour::Navigate { x: 3.0, y: 4.0 }, capabilities: None };
    let v = reply(sm.drive(at(2.0), Event::RobotCommandDone { req: Some(Req::Query(7)), robot: "r1".into(), result: Ok(ack) })).expect("ack");
    assert_eq!(v["ok"], Value::Bool(true));
    let e =
        reply(sm.drive(at(2.0), Event::RobotCommandDone { req: Some(Req::Query(8)), robot: "r1".into(), result: Err("timeout".into()) })).expect_err("failed");
    assert_eq!(e, "robot r1: timeout");
}

/// The operator crashes a simulated robot through central: relayed to a live robot (which decides
/// whether it can be crashed), refused for an unknown or lost one; decoded from its own key.
#[test]
fn a_crash_is_relayed_to_a_live_robot_only() {
    let mut sm = registered(&["r1", "r2"]);
    let key = Key::SystemCmd(mrmm_proto::SystemCmd::Crash).to_string();
    let crash = |sm: &mut SystemManager, body: &str| {
        let request = Request::decode(&key, body.as_bytes()).expect("a crash request");
        sm.drive(at(1.0), Event::Operator { req: Req::Query(7), request })
    };
    assert_eq!(crash(&mut sm, r#"{"robot":"r1"}"#), vec![Command::SendToRobot { req: Some(Req::Query(7)), robot: "r1".into(), cmd: RobotCommand::Crash }]);
    assert!(reply(crash(&mut sm, r#"{"robot":"nope"}"#)).expect_err("unknown").contains("unknown robot \"nope\""));
    sm.drive(at(1.0), Event::RobotGone { id: "r2".into() });
    assert!(reply(crash(&mut sm, r#"{"robot":"r2"}"#)).expect_err("lost").contains("lost"));
    assert!(Request::decode(&key, br#"{"robot":"r1","now":true}"#).is_err(), "unknown fields are refused");
}

/// On a map, a goto goes along its corridors: central sends the route's corners with it.
#[test]
fn a_goto_on_a_map_follows_a_route() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../maps/data/building/building.yaml");
    let bundle = mrmm_maps::Bundle::collect(&path.to_string_lossy(), |p| std::fs::read(p).map_err(|e| e.to_string())).expect("the demo building");
    let held = crate::maps::Held::new("building", &bundle).expect("the demo building");
    let grid = held.map.grid().expect("a grid").clone();
    let mut sm = registered(&["r1"]).with_maps([("building".to_string(), std::sync::Arc::new(held))].into());
    let go = |sm: &mut SystemManager, body: &str| sm.drive(at(1.0), Event::Operator { req: Req::Query(7), request: Request::Goto(decode(body)) });
    // From the corridor (0, 0) into an office: through its door, never through a wall.
    let out = go(&mut sm, r#"{"robot":"r1","x":-8,"y":8}"#);
    let [Command::SendToRobot { cmd: RobotCommand::Goto { x, y, via, map }, .. }] = out.as_slice() else { panic!("a goto: {out:?}") };
    assert!(!via.is_empty(), "a route, not a straight line");
    assert_eq!(map.as_ref().map(|m| m.name.as_str()), Some("building"), "the goal's map, for its traffic");
    let mut pts = vec![mrmm_maps::Point::new(0.0, 0.0)];
    pts.extend(via.iter().map(|p| mrmm_maps::Point::new(p[0], p[1])));
    pts.push(mrmm_maps::Point::new(*x, *y));
    assert!(pts.windows(2).all(|w| grid.segment_free(w[0], w[1])), "{pts:?}");
    // A goal in a wall is refused in words; a map central does not hold too.
    let e = reply(go(&mut sm, r#"{"robot":"r1","x":-4,"y":6}"#)).expect_err("in a wall");
    assert!(e.starts_with("map building: goal 0 at (-4, 6) is in an occupied cell"), "{e}");
    let e = reply(go(&mut sm, r#"{"robot":"r1","x":1,"y":1,"map":"elsewhere"}"#)).expect_err("no such map");
    assert_eq!(e, "no map \"elsewhere\"");
}

#[test]
fn operator_queries_answer_json() {
    let mut sm = registered(&["r1"]);
    let v = reply(sm.drive(at(1.0), Event::Operator { req: Req::Query(1), request: Request::Robots })).expect("robots");
    assert_eq!(v[0]["id"], "r1");
    assert_eq!(v[0]["type"], "ground");
    assert_eq!(v[0]["status"], "idle");
    assert_eq!(v[0]["mission"], Value::Null);
    let e = reply(sm.drive(at(1.0), Event::Operator { req: Req::Query(2), request: Request::Robot("x".into()) })).expect_err("unknown");
    assert!(e.contains("unknown robot"));
    let v = reply(sm.drive(at(5.0), Event::Operator { req: Req::Query(3), request: Request::Status })).expect("status");
    assert_eq!(v["robots_total"], 1);
    assert_eq!(v["uptime_s"], 5.0 + ADOPT_S);
}

#[test]
fn commands_wait_while_a_fresh_manager_learns_the_fleet() {
    let mut sm = SystemManager::new("n".into(), at(0.0));
    for id in ["r1", "r2"] {
        sm.drive(at(0.0), Event::RobotAlive { id: id.into() });
        sm.drive(at(0.0), Event::RobotRegistered(info(id)));
    }
    sm.drive(at(0.0), Event::HostAlive { node: "central".into() });
    let create = Request::Create(decode(r#"{"name": "m", "recipe": "patrol", "count": 1}"#));
    assert!(sm.drive(at(0.5), Event::Operator { req: Req::Query(1), request: create }).is_empty(), "held");
    // A head reports it runs r1 (central restarted): r1 is not idle any more.
    let mut v = MissionViewBuilder::running("p", "central", &["r1"]);
    v.lost = vec!["r2".into()];
    let joined = no_admits(sm.drive(at(1.0), status(v)));
    // r2 is alive: p's head is ordered to take it back.
    assert!(
        matches!(joined.as_slice(), [Command::Ctl { mission, ctl: MissionCtl::Joined { member }, .. }] if mission == "p" && member.spec.id == "r2"),
        "{joined:?}"
    );
    assert!(reply(sm.drive(at(1.5), Event::Operator { req: Req::Query(2), request: Request::Robots })).is_ok(), "queries are answered at once");
    let cmds = sm.drive(at(2.1), Event::Tick);
    // r2 keeps its place in p though lost to p's head: nobody is idle, the create fails.
    let e = cmds.iter().find_map(|c| match c {
        Command::Reply { req: Req::Query(1), result } => Some(result.clone()),
        _ => None,
    });
    assert!(e.expect("answered after the adoption period").expect_err("no idle robot").error.contains("0 idle robots"));
    assert_eq!(sm.assignment().get("r2").map(|m| m.as_str()), Some("p"));
}

/// Mission reports as heads publish them.
struct MissionViewBuilder;

impl MissionViewBuilder {
    fn running(name: &str, host: &str, robots: &[&str]) -> MissionView {
        MissionView::running(name, "patrol", host, 5, robots)
    }
}

mod missions;

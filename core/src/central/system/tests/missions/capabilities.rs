//! What a mission requires of its robots: checked on create and move; a member whose capabilities
//! change (on the operator's word, or as it comes back) leaves a mission it no longer fits.

use super::*;
use crate::at;

/// The bank's patrol, requiring a camera.
fn camera_patrol(name: &str, robots: Option<&[&str]>) -> String {
    let xml = mrmm_planner::recipe::bank("patrol").expect("bank").replace("  <params>", "  <requires capability=\"camera\"/>\n  <params>");
    let mut body = serde_json::json!({"name": name, "recipe": xml, "params": {"waypoints": [[0,0],[20,0],[20,20],[0,20]]}});
    if let Some(r) = robots {
        body["robots"] = serde_json::json!(r);
    }
    body.to_string()
}

fn without_camera(sm: &mut SystemManager, id: &str) {
    assert!(sm.drive(at(0.0), Event::RobotRegistered(RobotInfo { capabilities: vec!["lidar".into()], ..info(id) })).is_empty());
}

fn caps(sm: &mut SystemManager, body: &str) -> Vec<Command> {
    sm.drive(at(6.0), Event::Operator { req: Req::Query(20), request: Request::Capabilities(decode(body)) })
}

fn err_of(seen: &Seen) -> String {
    seen.replies[0].1.clone().expect_err("refused").error
}

#[test]
fn only_robots_with_what_a_mission_requires_are_assigned_to_it() {
    let mut sm = with_host(&["r1", "r2", "r3", "r4"]);
    without_camera(&mut sm, "r3");
    without_camera(&mut sm, "r4");
    let e = err_of(&create(&mut sm, 1, &camera_patrol("p", Some(&["r1", "r3"]))));
    assert_eq!(e, "robot \"r3\" lacks camera (mission p requires camera)");
    let e = err_of(&create(&mut sm, 2, &camera_patrol("p", None).replace("\"name\"", "\"count\":3,\"name\"")));
    assert_eq!(e, "count 3: 2 idle robots with camera available");
    // The equal share (the whole fleet for a first mission) takes only the robots with a camera.
    let seen = create(&mut sm, 3, &camera_patrol("p", None));
    assert_eq!(seen.starts, [("central".into(), "p".into(), vec!["r1".into(), "r2".into()])]);
    assert_eq!(sm.mission_views()[0].requires, ["camera"]);
    let e = err_of(&mv(&mut sm, r#"{"robot": "r3", "to": "p"}"#));
    assert_eq!(e, "robot \"r3\" lacks camera (mission p requires camera)");
    // A mission that requires nothing takes anyone; from it, only a robot with a camera goes to p.
    assert!(create(&mut sm, 4, &format!(r#"{{"name": "q", "recipe": "patrol", "robots": ["r3", "r4"], {WAYPOINTS}}}"#)).replies[0].1.is_ok());
    assert!(mv(&mut sm, r#"{"robot": "r4", "to": "p"}"#).replies[0].1.is_err());
    // A new camera mission's equal share (one robot) is taken from p, not from q (as large,
    // listed last, but without cameras); then no robot with a camera can be spared.
    let seen = create(&mut sm, 5, &camera_patrol("p2", None));
    assert_eq!(seen.starts, [("central".into(), "p2".into(), vec!["r2".into()])]);
    let e = err_of(&create(&mut sm, 6, &camera_patrol("p3", None)));
    assert!(e.starts_with("no robot with camera available"), "{e}");
}

#[test]
fn a_member_that_loses_what_its_mission_requires_leaves_it() {
    let mut sm = with_host(&["r1", "r2", "r3"]);
    assert!(create(&mut sm, 1, &camera_patrol("p", Some(&["r1", "r2", "r3"]))).replies[0].1.is_ok());
    // Checked here, carried out by the robot.
    assert_eq!(
        caps(&mut sm, r#"{"robot": "r2", "remove": ["camera"]}"#),
        [Command::SendToRobot {
            req: Some(Req::Query(20)),
            robot: "r2".into(),
            cmd: RobotCommand::Capabilities { add: vec![], remove: vec!["camera".into()] }
        }]
    );
    assert!(reply(caps(&mut sm, r#"{"robot": "zz", "add": ["x"]}"#)).unwrap_err().contains("unknown robot"));
    assert!(reply(caps(&mut sm, r#"{"robot": "r2", "add": ["night vision"]}"#)).unwrap_err().contains("bad capability"));
    // Its answer says it has no camera now: it leaves p at once, and the operator is told.
    let ack = CommandAck { ok: true, robot: "r2".into(), behaviour: Behaviour::Hold, capabilities: Some(vec![]) };
    let cmds = sm.drive(at(6.5), Event::RobotCommandDone { req: Some(Req::Query(20)), robot: "r2".into(), result: Ok(ack) });
    let seen = settle(&mut sm, cmds);
    assert_eq!(seen.ctls, [("p".into(), left(&["r2"]))]);
    assert_eq!(seen.leaves, ["r2 p"]);
    let v = seen.replies[0].1.as_ref().expect("answer");
    assert_eq!((v["capabilities"].clone(), v["left"].clone()), (serde_json::json!([]), serde_json::json!("p")));
    assert_eq!(mission_of(&sm, "r2"), None);
    assert_eq!(sm.view("r2").map(|v| v.capabilities), Some(vec![]));
    // Its telemetry carries the new revision of its info: asked again, once per retry period.
    let t = |seq| Event::Telemetry(Box::new(Telemetry { info_rev: 1, ..telemetry("r2", seq, Behaviour::Hold) }));
    assert!(sm.drive(at(7.0), t(2)).contains(&Command::FetchInfo { id: "r2".into() }));
    assert!(!sm.drive(at(7.5), t(3)).contains(&Command::FetchInfo { id: "r2".into() }));
    assert!(sm.drive(at(7.6), Event::RobotRegistered(RobotInfo { capabilities: vec![], rev: 1, ..info("r2") })).is_empty());
    assert!(!sm.drive(at(9.0), t(4)).contains(&Command::FetchInfo { id: "r2".into() }), "up to date");
    // A member that comes back without it (its config changed, say) leaves too.
    sm.drive(at(10.0), Event::RobotGone { id: "r3".into() });
    sm.drive(at(11.0), Event::RobotAlive { id: "r3".into() });
    let cmds = sm.drive(at(11.1), Event::RobotRegistered(RobotInfo { capabilities: vec![], ..info("r3") }));
    let seen = settle(&mut sm, cmds);
    assert_eq!((seen.ctls, seen.leaves), (vec![("p".into(), left(&["r3"]))], vec!["r3 p".to_string()]));
    assert_eq!(mission_of(&sm, "r1").as_deref(), Some("p"));
    // A robot still with a camera stays: adding a capability changes nothing for its mission.
    let ack = CommandAck { ok: true, robot: "r1".into(), behaviour: Behaviour::Hold, capabilities: Some(vec!["camera".into(), "gripper".into()]) };
    let cmds = sm.drive(at(12.0), Event::RobotCommandDone { req: Some(Req::Query(21)), robot: "r1".into(), result: Ok(ack) });
    assert!(reply(cmds).expect("answer").get("left").is_none());
    assert_eq!(mission_of(&sm, "r1").as_deref(), Some("p"));
    // A robot answering with a list that is not one is not believed.
    let bad = CommandAck { ok: true, robot: "r1".into(), behaviour: Behaviour::Hold, capabilities: Some(vec!["a b".into()]) };
    sm.drive(at(12.5), Event::RobotCommandDone { req: None, robot: "r1".into(), result: Ok(bad) });
    assert_eq!(sm.view("r1").map(|v| v.capabilities.len()), Some(2));
}

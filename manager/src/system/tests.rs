//! System manager: registry, operator queries and mission commands, asserting emitted commands.

use super::*;
use mrmm_peer::proto::{Behaviour, Pose, Velocity};

fn info(id: &str) -> RobotInfo {
    RobotInfo {
        id: id.into(),
        robot_type: "ground".into(),
        capabilities: vec!["camera".into()],
        max_speed: 1.0,
        endpoints: vec![],
        time_scale: 1.0,
    }
}

fn telemetry(id: &str, seq: u64, behaviour: Behaviour) -> Telemetry {
    Telemetry {
        id: id.into(),
        seq,
        t: seq as f64,
        pose: Pose { x: seq as f64, y: 0.0, theta: 0.0 },
        velocity: Velocity::default(),
        behaviour,
        mission: None,
        progress: None,
    }
}

fn registered(ids: &[&str]) -> SystemManager {
    let mut sm = SystemManager::new("node".into(), 0.0);
    for id in ids {
        assert_eq!(sm.handle(0.0, Event::RobotAlive { id: (*id).into() }), vec![Command::FetchInfo { id: (*id).into() }]);
        assert!(sm.handle(0.0, Event::RobotRegistered(info(id))).is_empty());
    }
    sm
}

fn reply(cmds: Vec<Command>) -> Result<Value, String> {
    match cmds.as_slice() {
        [Command::Reply { result, .. }] => result.clone(),
        other => panic!("expected one reply, got {other:?}"),
    }
}

#[test]
fn registration_then_loss() {
    let mut sm = registered(&["r1", "r2"]);
    let views = sm.views();
    assert_eq!(views.len(), 2);
    assert!(views.iter().all(|v| v.status == RobotStatus::Idle));
    sm.handle(1.0, Event::RobotGone { id: "r2".into() });
    assert_eq!(sm.view("r2").map(|v| v.status), Some(RobotStatus::Lost));
    let st = sm.status(2.0);
    assert_eq!((st.robots_total, st.idle, st.lost), (2, 1, 1));
    // Comes back: alive again, info asked again.
    assert_eq!(sm.handle(3.0, Event::RobotAlive { id: "r2".into() }), vec![Command::FetchInfo { id: "r2".into() }]);
    assert_eq!(sm.view("r2").map(|v| v.status), Some(RobotStatus::Idle));
}

#[test]
fn unregistered_robots_are_not_listed_and_info_is_retried() {
    let mut sm = SystemManager::new("n".into(), 0.0);
    sm.handle(0.0, Event::RobotAlive { id: "r1".into() });
    assert!(sm.views().is_empty());
    assert!(sm.handle(0.5, Event::Tick).is_empty());
    assert_eq!(sm.handle(1.2, Event::Tick), vec![Command::FetchInfo { id: "r1".into() }]);
    assert!(sm.handle(1.5, Event::Tick).is_empty());
    // Info from a robot never seen alive is ignored.
    sm.handle(2.0, Event::RobotRegistered(info("ghost")));
    assert!(sm.view("ghost").is_none());
}

#[test]
fn telemetry_updates_pose_and_status() {
    let mut sm = registered(&["r1"]);
    sm.handle(1.0, Event::Telemetry(Box::new(telemetry("r1", 2, Behaviour::Navigate { x: 5.0, y: 0.0 }))));
    let v = sm.view("r1").expect("r1");
    assert_eq!(v.status, RobotStatus::Busy);
    assert_eq!(v.pose.map(|p| p.x), Some(2.0));
    // An older message does not overwrite a newer one.
    sm.handle(1.1, Event::Telemetry(Box::new(telemetry("r1", 1, Behaviour::Hold))));
    assert_eq!(sm.view("r1").and_then(|v| v.pose).map(|p| p.x), Some(2.0));
    sm.handle(1.2, Event::Telemetry(Box::new(telemetry("r1", 3, Behaviour::Hold))));
    assert_eq!(sm.view("r1").map(|v| v.status), Some(RobotStatus::Idle));
    // Unknown robots' telemetry is dropped.
    sm.handle(1.3, Event::Telemetry(Box::new(telemetry("zz", 1, Behaviour::Hold))));
    assert!(sm.view("zz").is_none());
}

#[test]
fn goto_is_validated_then_relayed() {
    let mut sm = registered(&["r1", "r2"]);
    let go = |sm: &mut SystemManager, body: &str| {
        sm.handle(1.0, Event::Operator { req: 7, request: Request::Goto(body.as_bytes().to_vec()) })
    };
    assert_eq!(
        go(&mut sm, r#"{"robot":"r1","x":3,"y":4}"#),
        vec![Command::SendToRobot { req: Some(7), robot: "r1".into(), cmd: RobotCommand::Goto { x: 3.0, y: 4.0 } }]
    );
    let e = reply(go(&mut sm, r#"{"robot":"nope","x":3,"y":4}"#)).expect_err("unknown");
    assert!(e.contains("unknown robot \"nope\""), "{e}");
    let e = reply(go(&mut sm, "not json")).expect_err("garbage");
    assert!(e.contains("goto request"), "{e}");
    sm.handle(1.0, Event::RobotGone { id: "r2".into() });
    let e = reply(go(&mut sm, r#"{"robot":"r2","x":3,"y":4}"#)).expect_err("lost");
    assert!(e.contains("lost"), "{e}");
    let ack = CommandAck { ok: true, robot: "r1".into(), behaviour: Behaviour::Navigate { x: 3.0, y: 4.0 } };
    let v = reply(sm.handle(2.0, Event::RobotCommandDone { req: Some(7), robot: "r1".into(), result: Ok(ack) }))
        .expect("ack");
    assert_eq!(v["ok"], Value::Bool(true));
    let e = reply(sm.handle(2.0, Event::RobotCommandDone { req: Some(8), robot: "r1".into(), result: Err("timeout".into()) }))
        .expect_err("failed");
    assert_eq!(e, "robot r1: timeout");
}

#[test]
fn operator_queries_answer_json() {
    let mut sm = registered(&["r1"]);
    let v = reply(sm.handle(1.0, Event::Operator { req: 1, request: Request::Robots })).expect("robots");
    assert_eq!(v[0]["id"], "r1");
    assert_eq!(v[0]["type"], "ground");
    assert_eq!(v[0]["status"], "idle");
    assert_eq!(v[0]["mission"], Value::Null);
    let e = reply(sm.handle(1.0, Event::Operator { req: 2, request: Request::Robot("x".into()) })).expect_err("unknown");
    assert!(e.contains("unknown robot"));
    let v = reply(sm.handle(5.0, Event::Operator { req: 3, request: Request::Status })).expect("status");
    assert_eq!(v["robots_total"], 1);
    assert_eq!(v["uptime_s"], 5.0);
}

mod missions {
    use super::*;
    use mrmm_planner::recipe;

    const WAYPOINTS: &str = r#""params": {"waypoints": [[0,0],[20,0],[20,20],[0,20]]}"#;

    fn create(sm: &mut SystemManager, req: u64, body: &str) -> Vec<Command> {
        sm.handle(1.0, Event::Operator { req, request: Request::Create(body.as_bytes().to_vec()) })
    }

    fn create_settled(sm: &mut SystemManager, req: u64, body: &str) -> (Vec<(String, String, u64)>, Vec<(u64, Result<Value, String>)>) {
        let cmds = create(sm, req, body);
        settle(sm, cmds)
    }

    fn mv_settled(sm: &mut SystemManager, body: &str) -> (Vec<(String, String, u64)>, Vec<(u64, Result<Value, String>)>) {
        let cmds = sm.handle(5.0, Event::Operator { req: 9, request: Request::Move(body.as_bytes().to_vec()) });
        settle(sm, cmds)
    }

    /// Plays the planner service and the robots: answers plan requests until quiet; returns the
    /// plan sends (robot, mission, epoch) and the replies.
    fn settle(sm: &mut SystemManager, mut cmds: Vec<Command>) -> (Vec<(String, String, u64)>, Vec<(u64, Result<Value, String>)>) {
        let (mut sends, mut replies) = (Vec::new(), Vec::new());
        while let Some(c) = cmds.pop() {
            match c {
                Command::RequestPlan { mission, epoch, request, .. } => {
                    let r = recipe::parse(&request.recipe).expect("recipe");
                    let result = recipe::build(&r, &request.params, &request.robots).map(Box::new).map_err(|e| e.to_string());
                    cmds.extend(sm.handle(2.0, Event::PlanResult { mission, epoch, result }));
                }
                Command::SendToRobot { robot, cmd: RobotCommand::Plan(a), .. } => sends.push((robot, a.mission.clone(), a.epoch)),
                Command::SendToRobot { robot, cmd: RobotCommand::Leave { mission, .. }, .. } => sends.push((robot, format!("leave {mission}"), 0)),
                Command::Reply { req, result } => replies.push((req, result)),
                _ => {}
            }
        }
        sends.sort();
        (sends, replies)
    }

    fn mission_of(sm: &SystemManager, id: &str) -> Option<String> {
        sm.view(id).and_then(|v| v.mission)
    }

    #[test]
    fn create_with_robots_then_terminate() {
        let mut sm = registered(&["r1", "r2", "r3"]);
        let cmds = create(&mut sm, 1, &format!(r#"{{"name": "p1", "recipe": "patrol", "robots": ["r1", "r2"], {WAYPOINTS}}}"#));
        let (sends, replies) = settle(&mut sm, cmds);
        assert_eq!(sends, [("r1".into(), "p1".into(), 1), ("r2".into(), "p1".into(), 1)]);
        assert_eq!(replies.len(), 1);
        let v = replies[0].1.as_ref().expect("created");
        assert_eq!(v["status"], "running");
        assert_eq!(mission_of(&sm, "r1").as_deref(), Some("p1"));
        assert_eq!(sm.view("r3").map(|v| v.status), Some(RobotStatus::Idle));

        let cmds = sm.handle(3.0, Event::Operator { req: 2, request: Request::Terminate(br#"{"name": "p1"}"#.to_vec()) });
        let (sends, replies) = settle(&mut sm, cmds);
        assert_eq!(sends, [("r1".into(), "leave p1".into(), 0), ("r2".into(), "leave p1".into(), 0)]);
        assert!(replies[0].1.is_ok());
        assert_eq!(mission_of(&sm, "r1"), None);
        assert_eq!(sm.status(3.0).missions, 0);
    }

    #[test]
    fn bad_creates_change_nothing() {
        let mut sm = registered(&["r1", "r2"]);
        let cases = [
            (r#"{"name": "p/1", "recipe": "patrol"}"#, "mission name"),
            (r#"{"name": "p1", "recipe": "swarm"}"#, "unknown recipe"),
            (r#"{"name": "p1", "recipe": "patrol", "robots": ["zz"]}"#, "unknown robot"),
            (r#"{"name": "p1", "recipe": "patrol", "robots": ["r1", "r1"]}"#, "listed twice"),
            (r#"{"name": "p1", "recipe": "patrol", "count": 3}"#, "2 idle robots"),
            (r#"{"name": "p1", "recipe": "patrol", "count": 1, "robots": ["r1"]}"#, "not both"),
            (r#"{"name": "p1", "recipe": "patrol", "params": {"waypoints": [[0,0]]}}"#, "at least 2 points"),
            (r#"{"name": "p1", "recipe": "patrol", "params": {"rounds": 0}}"#, "rounds"),
            (r#"{"name": "p1", "recipe": "coverage", "params": {"region": [[0,0],[1,1],[0,1],[1,0]]}}"#, "self-intersecting"),
            (r#"{"name": "p1", "recipe": "<recipe name='x' planner='patrol'><fly/></recipe>"}"#, "unknown element <fly>"),
            (r#"{"name": "p1", "recipe": "patrol", "colour": "red"}"#, "unknown field"),
            ("garbage", "mission create request"),
        ];
        for (i, (body, want)) in cases.iter().enumerate() {
            let cmds = create(&mut sm, i as u64, body);
            let (sends, replies) = settle(&mut sm, cmds);
            assert!(sends.is_empty(), "{body}");
            let e = replies[0].1.as_ref().expect_err(body);
            assert!(e.contains(want), "{body}: {e}");
        }
        assert_eq!(sm.status(1.0).missions, 0);
        assert!(sm.views().iter().all(|v| v.mission.is_none()));
        // Duplicate name.
        let (_, r) = create_settled(&mut sm, 50, r#"{"name": "p1", "recipe": "patrol", "count": 1}"#);
        assert!(r[0].1.is_ok());
        let (_, r) = create_settled(&mut sm, 51, r#"{"name": "p1", "recipe": "patrol", "count": 1}"#);
        assert!(r[0].1.as_ref().expect_err("dup").contains("already exists"));
    }

    #[test]
    fn default_split_is_equal_and_takes_from_running_missions() {
        let mut sm = registered(&["r1", "r2", "r3", "r4", "r5", "r6"]);
        let (sends, _) = create_settled(&mut sm, 1, r#"{"name": "a", "recipe": "patrol"}"#);
        assert_eq!(sends.len(), 6, "alone, a mission gets the whole fleet");
        let (sends, replies) = create_settled(&mut sm, 2, r#"{"name": "b", "recipe": "coverage"}"#);
        assert!(replies[0].1.is_ok());
        let in_b: Vec<_> = sm.views().into_iter().filter(|v| v.mission.as_deref() == Some("b")).collect();
        let in_a: Vec<_> = sm.views().into_iter().filter(|v| v.mission.as_deref() == Some("a")).collect();
        assert_eq!((in_a.len(), in_b.len()), (3, 3));
        // a replanned (epoch 2) for its 3, b planned (epoch 1) for its 3.
        assert_eq!(sends.iter().filter(|s| s.1 == "a" && s.2 == 2).count(), 3);
        assert_eq!(sends.iter().filter(|s| s.1 == "b" && s.2 == 1).count(), 3);
    }

    #[test]
    fn move_and_loss_replan_both_missions() {
        let mut sm = registered(&["r1", "r2", "r3", "r4", "r5", "r6"]);
        create_settled(&mut sm, 1, &format!(r#"{{"name": "p", "recipe": "patrol", "robots": ["r1","r2","r3","r4"], {WAYPOINTS}}}"#));
        create_settled(&mut sm, 2, r#"{"name": "c", "recipe": "coverage", "robots": ["r5","r6"]}"#);
        let (sends, replies) = mv_settled(&mut sm, r#"{"robot": "r4", "to": "c"}"#);
        assert_eq!(replies[0].1.as_ref().expect("moved")["from"], "p");
        assert_eq!(sends.iter().filter(|s| s.1 == "p").count(), 3, "patrol replanned for 3");
        assert_eq!(sends.iter().filter(|s| s.1 == "c").count(), 3, "coverage replanned for 3");
        let p: Value = sm.missions["p"].view(false).summary;
        assert!((p["spacing"].as_f64().expect("spacing") - 80.0 / 3.0).abs() < 1e-9, "evenly spaced");
        // Errors.
        for (body, want) in [
            (r#"{"robot": "r4", "to": "c"}"#, "already in mission c"),
            (r#"{"robot": "r4", "to": "zz"}"#, "unknown mission"),
            (r#"{"robot": "zz", "to": "c"}"#, "unknown robot"),
        ] {
            let (_, r) = mv_settled(&mut sm, body);
            assert!(r[0].1.as_ref().expect_err(body).contains(want), "{body}");
        }
        // A patrol robot is lost: replanned to 2 without it.
        let cmds = sm.handle(6.0, Event::RobotGone { id: "r1".into() });
        let (sends, _) = settle(&mut sm, cmds);
        assert_eq!(sends.iter().map(|s| s.0.as_str()).collect::<Vec<_>>(), ["r2", "r3"]);
        assert_eq!(sm.missions["p"].view(false).robots, ["r2", "r3"]);
        // A goto on a mission robot is refused; moving it out frees it.
        let g = sm.handle(7.0, Event::Operator { req: 3, request: Request::Goto(br#"{"robot":"r2","x":0,"y":0}"#.to_vec()) });
        assert!(reply(g).expect_err("in mission").contains("in mission p"));
        let (sends, _) = mv_settled(&mut sm, r#"{"robot": "r2", "to": null}"#);
        assert!(sends.contains(&("r2".into(), "leave p".into(), 0)));
        assert_eq!(mission_of(&sm, "r2"), None);
    }

    #[test]
    fn a_robot_running_a_foreign_plan_is_told_to_leave() {
        let mut sm = registered(&["r1", "r2"]);
        let mut t = telemetry("r1", 1, Behaviour::Hold);
        t.mission = Some("old".into());
        // A mission this manager never heard of (central restarted): left alone.
        assert!(sm.handle(0.5, Event::Telemetry(Box::new(t.clone()))).is_empty());
        create_settled(&mut sm, 1, r#"{"name": "old", "recipe": "patrol", "robots": ["r2"]}"#);
        t.seq = 2;
        let cmds = sm.handle(1.0, Event::Telemetry(Box::new(t.clone())));
        assert!(matches!(cmds.as_slice(), [Command::SendToRobot { cmd: RobotCommand::Leave { .. }, .. }]));
        t.seq = 3;
        assert!(sm.handle(1.5, Event::Telemetry(Box::new(t.clone()))).is_empty(), "not again so soon");
        t.seq = 4;
        assert_eq!(sm.handle(4.0, Event::Telemetry(Box::new(t.clone()))).len(), 1);
        // Terminated missions stay known: stragglers are still ordered out.
        sm.handle(5.0, Event::Operator { req: 9, request: Request::Terminate(br#"{"name": "old"}"#.to_vec()) });
        t.seq = 5;
        assert_eq!(sm.handle(9.0, Event::Telemetry(Box::new(t))).len(), 1);
    }

    #[test]
    fn mission_queries_and_marginal() {
        let mut sm = registered(&["r1", "r2"]);
        create_settled(&mut sm, 1, &format!(r#"{{"name": "p", "recipe": "patrol", "count": 2, {WAYPOINTS}}}"#));
        let v = reply(sm.handle(2.0, Event::Operator { req: 2, request: Request::Missions })).expect("missions");
        assert_eq!(v[0]["name"], "p");
        assert!(v[0].get("plans").is_none());
        let v = reply(sm.handle(2.0, Event::Operator { req: 3, request: Request::Mission("p".into()) })).expect("mission");
        assert_eq!(v["plans"].as_array().map(Vec::len), Some(2));
        assert_eq!(v["manager"]["epoch"], 1);
        let g = reply(sm.handle(2.0, Event::Operator { req: 4, request: Request::Marginal { mission: "p".into(), add: 1 } })).expect("marginal");
        assert_eq!(g["with_robots"], 3);
        assert!(reply(sm.handle(2.0, Event::Operator { req: 5, request: Request::Mission("q".into()) })).is_err());
        // Status is published about once a second.
        let cmds = sm.handle(3.5, Event::Tick);
        assert!(cmds.iter().any(|c| matches!(c, Command::Publish { key, .. } if key == "mrmm/missions/p/status")));
    }
}

//! Operator commands on missions — create, terminate, move — against fake hosts that start and acknowledge at once; and the journal (`journal.rs`).

use super::*;
use crate::at;

mod admit;
mod capabilities;
mod changes;
mod journal;

const WAYPOINTS: &str = r#""params": {"waypoints": [[0,0],[20,0],[20,20],[0,20]]}"#;

/// What the fake hosts and robots saw.
#[derive(Debug, Default)]
struct Seen {
    starts: Vec<(String, String, Vec<String>)>,
    ctls: Vec<(String, MissionCtl)>,
    leaves: Vec<String>,
    replies: Vec<(Req, Result<Value, mrmm_proto::ErrorReply>)>,
    forwards: Vec<String>,
}

fn with_host(ids: &[&str]) -> SystemManager {
    let mut sm = registered(ids);
    assert!(sm.drive(at(0.0), Event::HostAlive { node: "central".into() }).is_empty());
    sm
}

/// Plays the mission hosts: every start succeeds at once, every control is acknowledged.
fn settle(sm: &mut SystemManager, cmds: Vec<Command>) -> Seen {
    let mut seen = Seen::default();
    let mut cmds: std::collections::VecDeque<Command> = cmds.into();
    while let Some(c) = cmds.pop_front() {
        match c {
            Command::StartMission { host, start } => {
                let robots: Vec<String> = start.members.iter().map(|m| m.spec.id.to_string()).collect();
                seen.starts.push((host.to_string(), start.spec.name.to_string(), robots.clone()));
                let view = MissionView {
                    name: start.spec.name.clone(),
                    recipe: start.spec.recipe_name.clone(),
                    planner: start.spec.planner.clone(),
                    status: MissionStatus::Running,
                    robots: robots.iter().map(Into::into).collect(),
                    lost: vec![],
                    stuck: Default::default(),
                    held: vec![],
                    teams: Default::default(),
                    team_views: vec![],
                    manager: ManagerView { node: host, epoch: 1, chain_epoch: 1, chain: vec![], uncommitted_s: None },
                    metrics: MissionMetrics::default(),
                    summary: None,
                    summary_unchanged: false,
                    params: Default::default(),
                    error: None,
                    plans: None,
                    map: None,
                    requires: vec![],
                };
                cmds.extend(sm.drive(at(2.0), Event::MissionStarted { mission: start.spec.name, result: Ok(Box::new(view)) }));
            }
            Command::Ctl { id, mission, ctl, .. } => {
                seen.ctls.push((mission.to_string(), ctl));
                cmds.extend(sm.drive(at(2.0), Event::CtlDone { id, result: Ok(()) }));
            }
            Command::SendToRobot { robot, cmd: RobotCommand::Leave { mission, .. }, .. } => seen.leaves.push(format!("{robot} {mission}")),
            Command::Reply { req, result } => seen.replies.push((req, result)),
            Command::Forward { key, .. } => seen.forwards.push(key.to_string()),
            _ => {}
        }
    }
    seen.leaves.sort();
    seen
}

fn create(sm: &mut SystemManager, req: u64, body: &str) -> Seen {
    let cmds = sm.drive(at(1.0), Event::Operator { req: Req::Query(req), request: Request::Create(decode(body)) });
    settle(sm, cmds)
}

fn mv(sm: &mut SystemManager, body: &str) -> Seen {
    let cmds = sm.drive(at(5.0), Event::Operator { req: Req::Query(9), request: Request::Move(decode(body)) });
    settle(sm, cmds)
}

fn mission_of(sm: &SystemManager, id: &str) -> Option<String> {
    sm.view(id).and_then(|v| v.mission).map(Into::into)
}

fn left(ids: &[&str]) -> MissionCtl {
    MissionCtl::Left { ids: ids.iter().map(|s| s.into()).collect() }
}

#[test]
fn create_starts_on_a_host_then_terminate_frees_the_robots() {
    let mut sm = with_host(&["r1", "r2", "r3"]);
    let seen = create(&mut sm, 1, &format!(r#"{{"name": "p1", "recipe": "patrol", "robots": ["r1", "r2"], {WAYPOINTS}}}"#));
    assert_eq!(seen.starts, [("central".into(), "p1".into(), vec!["r1".into(), "r2".into()])]);
    let v = seen.replies[0].1.as_ref().expect("created");
    assert_eq!(v["status"], "running");
    assert_eq!(mission_of(&sm, "r1").as_deref(), Some("p1"));
    assert_eq!(sm.view("r3").map(|v| v.status), Some(RobotStatus::Idle));

    let cmds = sm.drive(at(3.0), Event::Operator { req: Req::Query(2), request: Request::Terminate(decode_bytes(br#"{"name": "p1"}"#)) });
    let seen = settle(&mut sm, cmds);
    assert_eq!(seen.ctls, [("p1".into(), MissionCtl::Terminate)]);
    assert_eq!(seen.leaves, ["r1 p1", "r2 p1"]);
    assert!(seen.replies[0].1.is_ok());
    assert_eq!(mission_of(&sm, "r1"), None);
    assert_eq!(sm.status(at(3.0)).missions, 0);
}

#[test]
fn bad_creates_change_nothing() {
    let mut sm = with_host(&["r1", "r2"]);
    use mrmm_proto::ErrorCode::{Conflict, Invalid, NotFound};
    let cases = [
        (r#"{"name": "p/1", "recipe": "patrol"}"#, "mission name", Invalid),
        (r#"{"name": "p1", "recipe": "swarm"}"#, "unknown recipe", NotFound),
        (r#"{"name": "p1", "recipe": "patrol", "robots": ["zz"]}"#, "unknown robot", NotFound),
        (r#"{"name": "p1", "recipe": "patrol", "robots": ["r1", "r1"]}"#, "listed twice", Invalid),
        (r#"{"name": "p1", "recipe": "patrol", "count": 3}"#, "2 idle robots", Conflict),
        (r#"{"name": "p1", "recipe": "patrol", "count": 1, "robots": ["r1"]}"#, "not both", Invalid),
        (r#"{"name": "p1", "recipe": "patrol", "params": {"waypoints": [[0,0]]}}"#, "at least 2 points", Invalid),
        (r#"{"name": "p1", "recipe": "patrol", "params": {"rounds": 0}}"#, "rounds", Invalid),
        (r#"{"name": "p1", "recipe": "coverage", "params": {"region": [[0,0],[1,1],[0,1],[1,0]]}}"#, "self-intersecting", Invalid),
        (r#"{"name": "p1", "recipe": "<recipe name='x' planner='patrol'><fly/></recipe>"}"#, "unknown element <fly>", Invalid),
        (r#"{"name": "p1", "recipe": "patrol", "host": "elsewhere"}"#, "no mission host \"elsewhere\"", NotFound),
    ];
    // Each error says what is wrong in words, and what to do about it in its code.
    for (i, (body, want, code)) in cases.iter().enumerate() {
        let seen = create(&mut sm, i as u64, body);
        assert!(seen.starts.is_empty() && seen.ctls.is_empty(), "{body}");
        let e = seen.replies[0].1.as_ref().expect_err(body);
        assert!(e.error.contains(want), "{body}: {e}");
        assert_eq!(e.code, Some(*code), "{body}: {e}");
    }
    assert_eq!(sm.status(at(1.0)).missions, 0);
    assert!(sm.views().iter().all(|v| v.mission.is_none()));
    assert!(create(&mut sm, 50, r#"{"name": "p1", "recipe": "patrol", "count": 1}"#).replies[0].1.is_ok());
    let e = create(&mut sm, 51, r#"{"name": "p1", "recipe": "patrol", "count": 1}"#).replies[0].1.clone();
    let e = e.expect_err("dup");
    assert!(e.error.contains("already exists") && e.is(Conflict), "{e:?}");
}

#[test]
fn a_failed_start_frees_the_robots() {
    let mut sm = with_host(&["r1"]);
    let cmds =
        sm.drive(at(1.0), Event::Operator { req: Req::Query(1), request: Request::Create(decode_bytes(br#"{"name": "p", "recipe": "patrol", "count": 1}"#)) });
    // r1 is admitted (a robot may come to lead p), then the mission starts.
    assert!(
        matches!(cmds.as_slice(), [Command::SendToRobot { robot, cmd: RobotCommand::Admit { mission, managers, members }, .. }, Command::StartMission { .. }]
        if robot == "r1" && mission == "p" && *managers == ["central"] && *members == ["r1"]),
        "{cmds:?}"
    );
    assert_eq!(mission_of(&sm, "r1").as_deref(), Some("p"));
    let v = reply(sm.drive(at(2.0), Event::Operator { req: Req::Query(2), request: Request::Missions })).expect("missions");
    assert_eq!(v[0]["status"], "planning");
    let r = sm.drive(at(3.0), Event::MissionStarted { mission: "p".into(), result: Err(Failure::fatal("no planner service")) });
    assert_eq!(reply(r).expect_err("failed"), "no planner service");
    assert_eq!(mission_of(&sm, "r1"), None);
    assert_eq!(sm.status(at(3.0)).missions, 0);
}

/// A start its host answers "taken over" (by its code, whatever the words) runs elsewhere: the
/// mission and its robots stay; the same words without the code are a failure.
#[test]
fn a_start_taken_over_runs_elsewhere_by_its_code_not_its_words() {
    for (code, runs) in [(Some(mrmm_proto::ErrorCode::TakenOver), true), (None, false)] {
        let mut sm = with_host(&["r1"]);
        sm.drive(at(1.0), Event::Operator { req: Req::Query(1), request: Request::Create(decode_bytes(br#"{"name": "p", "recipe": "patrol", "count": 1}"#)) });
        let e = mrmm_proto::ErrorReply { error: "taken over: mission p: a newer head".into(), code };
        let r = sm.drive(at(3.0), Event::MissionStarted { mission: "p".into(), result: Err(Failure::answered(e)) });
        assert_eq!(reply(r).is_ok(), runs, "code {code:?}");
        assert_eq!(mission_of(&sm, "r1").is_some(), runs, "code {code:?}");
    }
}

#[test]
fn a_start_nobody_answered_is_ended_before_its_robots_go_elsewhere() {
    let mut sm = with_host(&["r1"]);
    let cmds = no_admits(
        sm.drive(at(1.0), Event::Operator { req: Req::Query(1), request: Request::Create(decode(r#"{"name": "p", "recipe": "patrol", "count": 1}"#)) }),
    );
    assert!(matches!(cmds.as_slice(), [Command::StartMission { .. }]));
    let no_answer = Failure::retry("no answer");
    let cmds = sm.drive(at(26.0), Event::MissionStarted { mission: "p".into(), result: Err(no_answer) });
    let end = cmds.iter().find_map(|c| match c {
        Command::Ctl { id, mission, ctl: MissionCtl::Terminate, .. } if mission == "p" => Some(*id),
        _ => None,
    });
    let end = end.expect("the mission is ended in case it started");
    assert!(cmds.iter().any(|c| matches!(c, Command::Reply { result: Err(e), .. } if e.error.contains("did not start"))));
    // r1 is free, but a new mission takes it only once p's end is acknowledged.
    let cmds = sm.drive(at(27.0), Event::Operator { req: Req::Query(2), request: Request::Create(decode(r#"{"name": "q", "recipe": "patrol", "count": 1}"#)) });
    assert!(cmds.is_empty(), "{cmds:?}");
    let cmds = no_admits(sm.drive(at(28.0), Event::CtlDone { id: end, result: Ok(()) }));
    assert!(matches!(cmds.as_slice(), [Command::StartMission { start, .. }] if start.spec.name == "q"), "{cmds:?}");
}

#[test]
fn default_split_is_equal_and_takes_from_running_missions() {
    let mut sm = with_host(&["r1", "r2", "r3", "r4", "r5", "r6"]);
    let seen = create(&mut sm, 1, r#"{"name": "a", "recipe": "patrol"}"#);
    assert_eq!(seen.starts[0].2.len(), 6, "alone, a mission gets the whole fleet");
    let seen = create(&mut sm, 2, r#"{"name": "b", "recipe": "coverage"}"#);
    assert!(seen.replies[0].1.is_ok());
    assert_eq!(seen.starts[0].2, ["r6", "r5", "r4"]);
    assert_eq!(seen.ctls, [("a".into(), left(&["r6", "r5", "r4"]))], "one replan for all three");
    let count = |m: &str| sm.views().into_iter().filter(|v| v.mission.as_ref().map(|x| x.as_str()) == Some(m)).count();
    assert_eq!((count("a"), count("b")), (3, 3));
}

#[test]
fn move_and_loss_steer_both_missions() {
    let mut sm = with_host(&["r1", "r2", "r3", "r4", "r5", "r6"]);
    create(&mut sm, 1, &format!(r#"{{"name": "p", "recipe": "patrol", "robots": ["r1","r2","r3","r4"], {WAYPOINTS}}}"#));
    create(&mut sm, 2, r#"{"name": "c", "recipe": "coverage", "robots": ["r5","r6"]}"#);
    let seen = mv(&mut sm, r#"{"robot": "r4", "to": "c"}"#);
    assert_eq!(seen.replies[0].1.as_ref().expect("moved")["from"], "p");
    // Out of p first; into c once p let it go.
    assert_eq!(seen.ctls.len(), 2);
    assert_eq!(seen.ctls[0], ("p".into(), left(&["r4"])));
    assert!(matches!(&seen.ctls[1], (m, MissionCtl::Joined { member }) if m == "c" && member.spec.id == "r4"));
    assert!(seen.leaves.is_empty(), "the new plan replaces the old one");
    use mrmm_proto::ErrorCode::{Conflict, NotFound};
    for (body, want, code) in [
        (r#"{"robot": "r4", "to": "c"}"#, "already in mission c", Conflict),
        (r#"{"robot": "r4", "to": "zz"}"#, "unknown mission", NotFound),
        (r#"{"robot": "zz", "to": "c"}"#, "unknown robot", NotFound),
    ] {
        let e = mv(&mut sm, body).replies[0].1.clone().expect_err(body);
        assert!(e.error.contains(want) && e.is(code), "{body}: {e:?}");
    }
    // A patrol robot is lost: its head plans around it on its own; it keeps its place.
    let cmds = sm.drive(at(6.0), Event::RobotGone { id: "r1".into() });
    assert!(settle(&mut sm, cmds).ctls.is_empty());
    assert_eq!(sm.view("r1").and_then(|v| v.last_mission).as_ref().map(|x| x.as_str()), Some("p"));
    let v = reply(sm.drive(at(6.5), Event::Operator { req: Req::Query(4), request: Request::Missions })).expect("missions");
    assert_eq!(v[1]["robots"], serde_json::json!(["r2", "r3"]));
    // No other mission can take it while it is away, and it is back in p when it returns.
    let e = mv(&mut sm, r#"{"robot": "r1", "to": "c"}"#).replies[0].1.clone().expect_err("lost");
    assert!(e.error.contains("lost"), "{e}");
    sm.drive(at(7.0), Event::RobotAlive { id: "r1".into() });
    assert_eq!(mission_of(&sm, "r1").as_deref(), Some("p"));
    // A goto on a mission robot is refused; moving it out frees it.
    let g = sm.drive(at(7.0), Event::Operator { req: Req::Query(3), request: Request::Goto(decode(r#"{"robot":"r2","x":0,"y":0}"#)) });
    assert!(reply(g).expect_err("in mission").contains("in mission p"));
    let seen = mv(&mut sm, r#"{"robot": "r2", "to": null}"#);
    assert_eq!(seen.leaves, ["r2 p"]);
    assert_eq!(mission_of(&sm, "r2"), None);
    // A lost robot can be freed by the operator: its head forgets it.
    sm.drive(at(8.0), Event::RobotGone { id: "r3".into() });
    let seen = mv(&mut sm, r#"{"robot": "r3", "to": null}"#);
    assert_eq!(seen.ctls, [("p".into(), left(&["r3"]))]);
    assert!(seen.leaves.is_empty(), "a lost robot is not ordered anything");
    assert_eq!(sm.view("r3").and_then(|v| v.last_mission), None);
}

#[test]
fn a_robot_takes_a_members_place_with_one_control_and_the_member_is_freed() {
    let mut sm = with_host(&["r1", "r2", "r3", "r4"]);
    create(&mut sm, 1, &format!(r#"{{"name": "p", "recipe": "patrol", "robots": ["r1","r2"], {WAYPOINTS}}}"#));
    create(&mut sm, 2, r#"{"name": "c", "recipe": "coverage", "robots": ["r4"]}"#);
    let refused = |sm: &mut SystemManager, body: &str| mv(sm, body).replies[0].1.clone().expect_err("refused").error;
    assert!(refused(&mut sm, r#"{"robot": "r3", "to": "p", "replaces": "r4"}"#).contains("not in mission p"));
    assert!(refused(&mut sm, r#"{"robot": "r3", "to": null, "replaces": "r1"}"#).contains("`to` is needed"));
    assert!(refused(&mut sm, r#"{"robot": "r1", "to": "p", "replaces": "r1"}"#).contains("already in mission p"));
    let seen = mv(&mut sm, r#"{"robot": "r3", "to": "p", "replaces": "r1"}"#);
    let Some((mission, MissionCtl::Replaced { out, member })) = seen.ctls.first() else { panic!("one control: {:?}", seen.ctls) };
    assert_eq!((mission.as_str(), out.as_str(), member.spec.id.as_str(), seen.ctls.len()), ("p", "r1", "r3", 1));
    assert_eq!(seen.leaves, ["r1 p"], "the member freed is told to leave");
    assert_eq!(seen.replies[0].1.as_ref().expect("moved")["replaces"], "r1");
    assert_eq!(mission_of(&sm, "r3").as_deref(), Some("p"));
    assert_eq!(mission_of(&sm, "r1"), None);
    // From another mission: that one lets it go first.
    let seen = mv(&mut sm, r#"{"robot": "r4", "to": "p", "replaces": "r2"}"#);
    assert_eq!(seen.ctls.iter().map(|(m, c)| (m.as_str(), matches!(c, MissionCtl::Replaced { .. }))).collect::<Vec<_>>(), [("c", false), ("p", true)]);
    assert_eq!(seen.ctls[0].1, left(&["r4"]));
}

#[test]
fn controls_are_sent_again_until_acknowledged_and_in_order() {
    let mut sm = with_host(&["r1", "r2", "r3"]);
    create(&mut sm, 1, &format!(r#"{{"name": "p", "recipe": "patrol", "robots": ["r1","r2"], {WAYPOINTS}}}"#));
    create(&mut sm, 2, r#"{"name": "c", "recipe": "coverage", "robots": ["r3"]}"#);
    let cmds = sm.drive(at(5.0), Event::Operator { req: Req::Query(9), request: Request::Move(decode(r#"{"robot": "r2", "to": "c"}"#)) });
    let ctl = |cmds: &[Command]| -> Vec<(u64, String)> {
        cmds.iter()
            .filter_map(|c| match c {
                Command::Ctl { id, mission, .. } => Some((*id, mission.to_string())),
                _ => None,
            })
            .collect()
    };
    let first = ctl(&cmds);
    assert_eq!(first.iter().map(|c| c.1.as_str()).collect::<Vec<_>>(), ["p"], "c waits for p to let r2 go");
    let (id, _) = first[0].clone();
    let no_answer = || Err(Failure::retry("no answer"));
    assert!(ctl(&sm.drive(at(6.0), Event::CtlDone { id, result: no_answer() })).is_empty(), "not again at once");
    assert_eq!(ctl(&sm.drive(at(7.0), Event::Tick)), [(id, "p".to_string())], "sent again");
    let joined = ctl(&sm.drive(at(7.5), Event::CtlDone { id, result: Ok(()) }));
    assert_eq!(joined.iter().map(|c| c.1.as_str()).collect::<Vec<_>>(), ["c"], "then r2 joins c");
    // While p has not acknowledged, its reports still listing r2 are older than the order.
    let mut v = sm.mission_views().into_iter().find(|v| v.name == "p").expect("p");
    v.robots = vec!["r1".into(), "r2".into()];
    assert!(ctl(&sm.drive(at(8.0), status(v))).is_empty());
    assert_eq!(mission_of(&sm, "r2").as_deref(), Some("c"));
}

#[test]
fn a_terminated_mission_still_reporting_is_ended_again() {
    let mut sm = with_host(&["r1"]);
    create(&mut sm, 1, r#"{"name": "p", "recipe": "patrol", "robots": ["r1"]}"#);
    let view = sm.mission_views()[0].clone();
    let cmds = sm.drive(at(3.0), Event::Operator { req: Req::Query(2), request: Request::Terminate(decode(r#"{"name": "p"}"#)) });
    settle(&mut sm, cmds);
    let cmds = sm.drive(at(4.0), status(view.clone()));
    assert!(matches!(cmds.as_slice(), [Command::Ctl { ctl: MissionCtl::Terminate, .. }]), "{cmds:?}");
    assert!(sm.drive(at(4.1), status(view)).is_empty(), "once while it is pending");
    assert_eq!(sm.status(at(4.0)).missions, 0);
}

#[test]
fn a_robot_running_a_foreign_plan_is_told_to_leave() {
    let mut sm = with_host(&["r1", "r2"]);
    let mut t = telemetry("r1", 1, Behaviour::Hold);
    t.mission = Some("old".into());
    // A mission this manager never heard of (central restarted): left alone.
    assert!(sm.drive(at(0.5), Event::Telemetry(Box::new(t.clone()))).is_empty());
    create(&mut sm, 1, r#"{"name": "old", "recipe": "patrol", "robots": ["r2"]}"#);
    t.seq = 2;
    let cmds = sm.drive(at(1.0), Event::Telemetry(Box::new(t.clone())));
    assert!(matches!(cmds.as_slice(), [Command::SendToRobot { cmd: RobotCommand::Leave { .. }, .. }]));
    t.seq = 3;
    assert!(sm.drive(at(1.5), Event::Telemetry(Box::new(t.clone()))).is_empty(), "not again so soon");
    t.seq = 4;
    assert_eq!(sm.drive(at(4.0), Event::Telemetry(Box::new(t.clone()))).len(), 1);
    // Terminated missions stay known: stragglers are still ordered out.
    let cmds = sm.drive(at(5.0), Event::Operator { req: Req::Query(9), request: Request::Terminate(decode(r#"{"name": "old"}"#)) });
    settle(&mut sm, cmds);
    t.seq = 5;
    assert_eq!(sm.drive(at(9.0), Event::Telemetry(Box::new(t))).len(), 1);
}

#[test]
fn mission_views_follow_head_publications_and_host_loss() {
    let mut sm = with_host(&["r1", "r2"]);
    create(&mut sm, 1, &format!(r#"{{"name": "p", "recipe": "patrol", "count": 2, {WAYPOINTS}}}"#));
    // Details come from the head.
    let cmds = sm.drive(at(2.0), Event::Operator { req: Req::Query(3), request: Request::Mission("p".into()) });
    assert_eq!(settle(&mut sm, cmds).forwards, [Key::MissionView("p".into()).to_string()]);
    assert!(reply(sm.drive(at(2.0), Event::Operator { req: Req::Query(5), request: Request::Mission("q".into()) })).is_err());
    // Status publications update the table.
    let m = reply(sm.drive(at(2.0), Event::Operator { req: Req::Query(2), request: Request::Missions })).expect("m");
    let mut v: MissionView = serde_json::from_value(m[0].clone()).expect("view");
    v.metrics.rounds = 7;
    v.manager.epoch = 4;
    sm.drive(at(3.0), status(v));
    let m = reply(sm.drive(at(3.0), Event::Operator { req: Req::Query(4), request: Request::Missions })).expect("missions");
    assert_eq!((m[0]["metrics"]["rounds"].as_u64(), m[0]["manager"]["epoch"].as_u64()), (Some(7), Some(4)));
    // The host dies: the mission is stalled, the operator is told why.
    sm.drive(at(4.0), Event::HostGone { node: "central".into() });
    let m = reply(sm.drive(at(4.0), Event::Operator { req: Req::Query(6), request: Request::Missions })).expect("missions");
    assert_eq!(m[0]["status"], "stalled");
    assert!(m[0]["error"].as_str().is_some_and(|e| e.contains("central lost")));
}

#[test]
fn a_restarted_manager_adopts_missions_its_heads_report() {
    let mut sm = with_host(&["r1", "r2", "r3"]);
    sm.drive(at(0.0), Event::HostAlive { node: "h2".into() });
    create(&mut sm, 1, r#"{"name": "mine", "recipe": "patrol", "robots": ["r3"]}"#);
    let report = MissionViewBuilder::running;
    // r1 and r2 say (in their own telemetry) they run p.
    for id in ["r1", "r2"] {
        let mut t = telemetry(id, 5, Behaviour::Hold);
        t.mission = Some("p".into());
        sm.drive(at(0.5), Event::Telemetry(Box::new(t)));
    }
    // r3 is already in "mine": the head is told to let it go; r1 and r2 are adopted.
    let cmds = sm.drive(at(1.0), status(report("p", "h2", &["r1", "r2", "r3"])));
    let admitted: Vec<&str> = cmds
        .iter()
        .filter_map(|c| match c {
            Command::SendToRobot { robot, cmd: RobotCommand::Admit { mission, .. }, .. } if mission == "p" => Some(robot.as_str()),
            _ => None,
        })
        .collect();
    assert_eq!(admitted, ["r1", "r2"], "robots recorded from a report are admitted");
    let cmds = no_admits(cmds);
    assert!(matches!(cmds.as_slice(), [Command::Ctl { mission, ctl, .. }] if mission == "p" && *ctl == left(&["r3"])), "{cmds:?}");
    assert_eq!((mission_of(&sm, "r1").as_deref(), mission_of(&sm, "r3").as_deref()), (Some("p"), Some("mine")));
    let m = reply(sm.drive(at(2.0), Event::Operator { req: Req::Query(2), request: Request::Missions })).expect("missions");
    assert_eq!(m[1]["manager"]["node"], "h2");
    assert_eq!(m[1]["robots"], serde_json::json!(["r1", "r2"]));
    // Reports from unknown hosts are not adopted.
    assert!(sm.drive(at(3.0), status(report("q", "ghost", &["r1"]))).is_empty());
    assert_eq!(sm.status(at(3.0)).missions, 2);
}

#[test]
fn a_report_cannot_claim_robots_nor_speak_for_another_manager() {
    let mut sm = with_host(&["r1", "r2", "r3"]);
    sm.drive(at(0.0), Event::HostAlive { node: "r3".into() });
    let mut v = MissionViewBuilder::running("fake", "r3", &["r1", "r2", "r3"]);
    v.manager.node = "r3".into();
    // r3 reports a mission with r1 and r2 in it; their telemetry says they run another.
    for id in ["r1", "r2"] {
        let mut t = telemetry(id, 7, Behaviour::Hold);
        t.mission = Some("other".into());
        sm.drive(at(0.5), Event::Telemetry(Box::new(t)));
    }
    let from = mrmm_proto::Sender::new(mrmm_proto::Role::Robot, "r3");
    sm.drive(at(1.0), Event::MissionStatus { view: Box::new(v.clone()), from: from.clone() });
    assert_eq!((mission_of(&sm, "r1"), mission_of(&sm, "r2")), (None, None), "robots are not claimed by a report");
    // Nor can a node report a mission as managed by someone else.
    let mut other = MissionViewBuilder::running("p2", "central", &["r1"]);
    other.manager.node = "central".into();
    let cmds = sm.drive(at(1.1), Event::MissionStatus { view: Box::new(other), from: from.clone() });
    assert!(matches!(cmds.as_slice(), [Command::Refused(mrmm_proto::edge::Refused::NotEntitled { from: f, .. })] if *f == from), "{cmds:?}");
}

/// Issue 50: a robot's certificate published a status of a mission nobody created, naming
/// itself its head and four idle robots; central adopted it, journaled it and admitted the idle
/// robots under the robot, which then drove them. Now nothing is adopted on a robot's word.
#[test]
fn a_robot_cannot_invent_a_mission_with_idle_robots() {
    let mut sm = with_host(&["r1", "r2", "r3", "r4"]);
    sm.drive(at(0.0), Event::HostAlive { node: "r1".into() });
    let from = mrmm_proto::Sender::new(mrmm_proto::Role::Robot, "r1");
    let mut evil = MissionViewBuilder::running("evil", "r1", &["r1", "r2", "r3", "r4"]);
    evil.manager.node = "r1".into();
    for t in [1.0, 2.0, 3.0] {
        let cmds = sm.handle(at(t), Event::MissionStatus { view: Box::new(evil.clone()), from: from.clone() });
        assert!(cmds.is_empty(), "nothing journaled, admitted or said: {cmds:?}");
    }
    assert_eq!(["r2", "r3", "r4"].map(|r| mission_of(&sm, r)), [None, None, None], "idle robots stay idle");
    assert_eq!(sm.status(at(3.0)).missions, 0);
    assert_eq!(sm.adoptions_refused.len(), 1, "logged once for the sender");
    // Its own telemetry naming the mission changes nothing: it speaks only for itself.
    let mut t = telemetry("r1", 9, Behaviour::Hold);
    t.mission = Some("evil".into());
    sm.drive(at(3.5), Event::Telemetry(Box::new(t)));
    assert!(sm.handle(at(4.0), Event::MissionStatus { view: Box::new(evil.clone()), from: from.clone() }).is_empty());
    // A robot heading a mission after a takeover is believed once a member it lists runs it by
    // its own telemetry, and only such members are recorded.
    let mut t = telemetry("r2", 9, Behaviour::Hold);
    t.mission = Some("evil".into());
    sm.drive(at(4.5), Event::Telemetry(Box::new(t)));
    sm.drive(at(5.0), Event::MissionStatus { view: Box::new(evil), from });
    assert_eq!(["r1", "r2", "r3", "r4"].map(|r| mission_of(&sm, r)), [Some("evil".into()), Some("evil".into()), None, None]);
}

#[test]
fn members_learn_of_a_new_head_from_central_when_the_manager_moves() {
    let mut sm = with_host(&["r1", "r2", "r3"]);
    create(&mut sm, 1, &format!(r#"{{"name": "p", "recipe": "patrol", "robots": ["r1", "r2"], {WAYPOINTS}}}"#));
    // Central's host replicates p on r3 (not a member: a replica left in the chain) ...
    let mut v = sm.mission_views().into_iter().find(|v| v.name == "p").expect("p");
    v.manager = ManagerView { node: "central".into(), epoch: 1, chain_epoch: 1, chain: vec!["central".into(), "r3".into()], uncommitted_s: None };
    sm.drive(at(2.5), status(v.clone()));
    // ... which takes over.
    v.manager = ManagerView { node: "r3".into(), epoch: 2, chain_epoch: 2, chain: vec!["r3".into(), "central".into()], uncommitted_s: None };
    let from = mrmm_proto::Sender::new(mrmm_proto::Role::Robot, "r3");
    let cmds = sm.drive(at(3.0), Event::MissionStatus { view: Box::new(v.clone()), from: from.clone() });
    let admitted: Vec<(String, Vec<String>)> = cmds
        .iter()
        .filter_map(|c| match c {
            Command::SendToRobot { robot, cmd: RobotCommand::Admit { mission, managers, .. }, .. } if mission == "p" => {
                Some((robot.to_string(), managers.iter().map(|m| m.to_string()).collect()))
            }
            _ => None,
        })
        .collect();
    let robots: Vec<&str> = admitted.iter().map(|(r, _)| r.as_str()).collect();
    assert_eq!(robots, ["r1", "r2"], "{cmds:?}");
    assert!(admitted.iter().all(|(_, m)| m.contains(&"r3".to_string())), "the new head among the managers: {admitted:?}");
    // Not again while the head stays.
    let again = sm.drive(at(4.0), Event::MissionStatus { view: Box::new(v), from });
    assert!(!again.iter().any(|c| matches!(c, Command::SendToRobot { cmd: RobotCommand::Admit { .. }, .. })), "{again:?}");
}

/// Central, seeing p's head r3 gone (it was not), takes p over and reports a chain without r3
/// before that chain took: r3 wins the next chain epoch and reports. It was a manager before the
/// last change, and its epoch is newer: taken (membership sim, seed 926, refused it for ever).
/// A robot never among p's managers is refused whatever epoch it claims, and so is a former one
/// reporting no newer epoch.
#[test]
fn a_head_dropped_by_a_takeover_that_lost_its_election_reports_again() {
    let mut sm = with_host(&["r1", "r2", "r3", "r4"]);
    create(&mut sm, 1, &format!(r#"{{"name": "p", "recipe": "patrol", "robots": ["r1", "r2"], {WAYPOINTS}}}"#));
    let mut v = sm.mission_views().into_iter().find(|v| v.name == "p").expect("p");
    let manager = |node: &str, chain_epoch: u64, chain: &[&str]| ManagerView {
        node: node.into(),
        epoch: 1,
        chain_epoch,
        chain: chain.iter().map(|&n| n.into()).collect(),
        uncommitted_s: None,
    };
    let refused = |cmds: &[Command]| cmds.iter().any(|c| matches!(c, Command::Refused(_)));
    let as_robot = |id: &str| mrmm_proto::Sender::new(mrmm_proto::Role::Robot, id);
    // Central's host replicates p on r3, which takes over.
    v.manager = manager("central", 1, &["central", "r3"]);
    sm.drive(at(1.5), status(v.clone()));
    v.manager = manager("r3", 8, &["r3", "central"]);
    assert!(!refused(&sm.drive(at(2.0), Event::MissionStatus { view: Box::new(v.clone()), from: as_robot("r3") })));
    v.manager = manager("central", 9, &["central"]);
    sm.drive(at(2.5), status(v.clone()));
    assert!(!sm.managers("p").iter().any(|n| n == "r3"));
    // r4 was never a manager of p.
    v.manager = manager("r4", 12, &["r4", "r3"]);
    assert!(refused(&sm.drive(at(2.8), Event::MissionStatus { view: Box::new(v.clone()), from: as_robot("r4") })));
    v.manager = manager("r3", 9, &["r3"]);
    assert!(refused(&sm.drive(at(2.9), Event::MissionStatus { view: Box::new(v.clone()), from: as_robot("r3") })), "no newer epoch");
    v.manager = manager("r3", 12, &["r3"]);
    let cmds = sm.drive(at(3.0), Event::MissionStatus { view: Box::new(v.clone()), from: as_robot("r3") });
    assert!(!refused(&cmds), "{cmds:?}");
    assert_eq!(sm.managers("p").first().map(|n| n.to_string()).as_deref(), Some("r3"), "r3 heads p here again");
}

/// p's head stops reporting while central runs (its chain lost its majority) and its robots run
/// on: after `RUNNING_WAIT_S` without a report, p is started anew (next lineage) with them — but
/// not while reports come, and not by a central that hears none of p's robots (cut off itself).
#[test]
fn a_mission_whose_managers_fell_silent_while_central_runs_is_started_anew_with_its_robots() {
    let run = |robots_heard: bool, reports_go_on: bool| run_with(robots_heard, reports_go_on, |_| None);
    let started = run(true, false);
    assert_eq!(started.len(), 1, "{started:?}");
    let (at, robots, lineage, anew) = &started[0];
    assert!(*at >= 3.0 + RUNNING_WAIT_S, "started anew {at} s in, before the wait");
    assert_eq!((robots.as_slice(), *lineage, *anew), (&["r1".to_string(), "r2".to_string()][..], 1, true));
    assert!(run(true, true).is_empty(), "its head still reports");
    assert!(run(false, false).is_empty(), "a central that hears none of its robots left it alone");
}

/// p's head goes on reporting, but says it has not been able to commit since 4 s (its chain
/// lost the memory of a majority of its nodes): p is started anew once that reaches
/// `UNCOMMITTED_WAIT_S` — not while its head commits again within it.
#[test]
fn a_mission_whose_head_cannot_commit_is_started_anew_with_its_robots() {
    let started = run_with(true, true, |now| Some(now - 4.0).filter(|s| *s >= 1.0));
    assert_eq!(started.len(), 1, "{started:?}");
    let (at, robots, lineage, anew) = &started[0];
    assert!(*at >= 4.0 + UNCOMMITTED_WAIT_S, "started anew {at} s in, before the wait");
    assert_eq!((robots.as_slice(), *lineage, *anew), (&["r1".to_string(), "r2".to_string()][..], 1, true));
    // A head that cannot commit for a while (a repair waiting for a vote), then commits.
    assert!(run_with(true, true, |now| Some(now - 4.0).filter(|s| (1.0..UNCOMMITTED_WAIT_S - 2.0).contains(s))).is_empty());
}

/// Mission p of r1, r2 created; its head reports (or not) with `uncommitted(now)`, its robots
/// are heard (or not) by central: the starts anew central orders, with when, robots, lineage.
#[allow(clippy::type_complexity)]
fn run_with(robots_heard: bool, reports_go_on: bool, uncommitted: impl Fn(f64) -> Option<f64>) -> Vec<(f64, Vec<String>, u32, bool)> {
    {
        let mut sm = with_host(&["r1", "r2", "r3"]);
        create(&mut sm, 1, &format!(r#"{{"name": "p", "recipe": "patrol", "robots": ["r1", "r2"], {WAYPOINTS}}}"#));
        let m = reply(sm.drive(at(3.0), Event::Operator { req: Req::Query(2), request: Request::Missions })).expect("missions");
        let view: MissionView = serde_json::from_value(m[0].clone()).expect("view");
        sm.drive(at(3.0), status(view.clone()));
        for id in ["r1", "r2"] {
            let mut t = telemetry(id, 2, Behaviour::Hold);
            t.mission = Some("p".into());
            sm.drive(at(3.0), Event::Telemetry(Box::new(t)));
            if !robots_heard {
                sm.drive(at(3.5), Event::RobotGone { id: id.into() });
            }
        }
        let mut started = vec![];
        let mut now = 4.0;
        while now < 4.0 + RUNNING_WAIT_S.max(UNCOMMITTED_WAIT_S) + 2.0 {
            if reports_go_on {
                let mut v = view.clone();
                v.manager.uncommitted_s = uncommitted(now);
                sm.drive(at(now), status(v));
            }
            for c in sm.drive(at(now), Event::Tick) {
                if let Command::StartMission { start, .. } = c {
                    started.push((now, start.members.iter().map(|m| m.spec.id.to_string()).collect::<Vec<_>>(), start.lineage, start.anew));
                }
            }
            now += 0.5;
        }
        started
    }
}

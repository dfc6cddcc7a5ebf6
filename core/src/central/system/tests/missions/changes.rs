//! Updating, pausing and resuming a running mission: checked in full before anything changes,
//! the definition replaced (and journaled), the head told with the whole new spec.

use super::*;
use crate::at;

fn update(sm: &mut SystemManager, body: &str) -> Seen {
    let cmds = sm.drive(at(3.0), Event::Operator { req: Req::Query(20), request: Request::Update(decode(body)) });
    settle(sm, cmds)
}

fn pause(sm: &mut SystemManager, name: &str, paused: bool) -> Seen {
    let p = decode(&format!(r#"{{"name": "{name}"}}"#));
    let request = if paused { Request::Pause(p) } else { Request::Resume(p) };
    let cmds = sm.drive(at(3.0), Event::Operator { req: Req::Query(21), request });
    settle(sm, cmds)
}

fn spec(sm: &SystemManager, name: &str) -> mrmm_proto::MissionSpecWire {
    sm.durable().missions[name].spec.clone().expect("a spec")
}

#[test]
fn an_update_is_checked_then_sent_whole_to_the_head() {
    let mut sm = with_host(&["r1", "r2"]);
    assert!(create(&mut sm, 1, &format!(r#"{{"name": "p1", "recipe": "patrol", "robots": ["r1", "r2"], {WAYPOINTS}}}"#)).replies[0].1.is_ok());
    let seen = update(&mut sm, r#"{"name": "p1", "params": {"waypoints": [[0,0],[30,0],[30,30]], "rounds": 4}}"#);
    let v = seen.replies[0].1.as_ref().expect("updated");
    assert_eq!((v["ok"].as_bool(), v["changed"].as_bool()), (Some(true), Some(true)));
    let s = spec(&sm, "p1");
    assert_eq!((s.params["waypoints"].as_str(), s.params["rounds"].as_str()), ("[[0,0],[30,0],[30,30]]", "4"));
    assert_eq!(seen.ctls, [("p1".to_string(), MissionCtl::Update { spec: s.clone() })]);
    assert_eq!(mission_of(&sm, "r1").as_deref(), Some("p1"), "its members stay");
    // What is wrong is refused in words and changes nothing.
    for (body, want) in [
        (r#"{"name": "p1", "params": {"waypoints": [[0,0]]}}"#, "at least 2 points"),
        (r#"{"name": "p1", "params": {"rounds": 0}}"#, "rounds"),
        (r#"{"name": "p1", "params": {"speed": 3}}"#, "unknown parameter"),
        (r#"{"name": "p1"}"#, "nothing to change"),
        (r#"{"name": "p1", "map": "nowhere"}"#, "no map \"nowhere\""),
        (r#"{"name": "zz", "params": {"rounds": 2}}"#, "unknown mission"),
    ] {
        let seen = update(&mut sm, body);
        assert!(seen.ctls.is_empty(), "{body}");
        let e = seen.replies[0].1.as_ref().expect_err(body);
        assert!(e.error.contains(want), "{body}: {e}");
        assert_eq!(spec(&sm, "p1"), s, "{body} changed the mission");
    }
}

#[test]
fn pause_and_resume_go_to_the_head_and_into_the_definition() {
    let mut sm = with_host(&["r1"]);
    assert!(create(&mut sm, 1, &format!(r#"{{"name": "p1", "recipe": "patrol", "robots": ["r1"], {WAYPOINTS}}}"#)).replies[0].1.is_ok());
    let seen = pause(&mut sm, "p1", true);
    assert!(spec(&sm, "p1").paused, "journaled paused");
    assert!(matches!(&seen.ctls[..], [(m, MissionCtl::Update { spec })] if m == "p1" && spec.paused));
    // Paused again: nothing to tell.
    let seen = pause(&mut sm, "p1", true);
    assert!(seen.ctls.is_empty() && seen.replies[0].1.as_ref().is_ok_and(|v| v["changed"] == false));
    let seen = pause(&mut sm, "p1", false);
    assert!(!spec(&sm, "p1").paused);
    assert!(matches!(&seen.ctls[..], [(_, MissionCtl::Update { spec })] if !spec.paused));
    assert!(pause(&mut sm, "zz", true).replies[0].1.as_ref().is_err_and(|e| e.error.contains("unknown mission")));
}

#[test]
fn a_mission_of_teams_is_updated_team_by_team() {
    let mut sm = with_host(&["r1", "r2"]);
    assert!(create(&mut sm, 1, r#"{"name": "e", "recipe": "escort", "robots": ["r1", "r2"]}"#).replies[0].1.is_ok());
    let seen = update(&mut sm, r#"{"name": "e", "teams": {"ground": {"rounds": 3, "waypoints": [[0,0],[9,0],[9,9]]}}}"#);
    assert!(seen.replies[0].1.is_ok(), "{:?}", seen.replies);
    let s = spec(&sm, "e");
    assert_eq!((s.params["ground/rounds"].as_str(), s.params["ground/waypoints"].as_str()), ("3", "[[0,0],[9,0],[9,9]]"));
    for (body, want) in [
        (r#"{"name": "e", "teams": {"sea": {"rounds": 1}}}"#, "no leaf team \"sea\""),
        (r#"{"name": "e", "teams": {"air": {"rounds": 1}}}"#, "unknown parameter \"rounds\" for the coverage planner"),
        (r#"{"name": "e", "teams": {"ground": {"rounds": 0}}}"#, "rounds"),
    ] {
        let seen = update(&mut sm, body);
        let e = seen.replies[0].1.as_ref().expect_err(body);
        assert!(e.error.contains(want), "{body}: {e}");
        assert_eq!(spec(&sm, "e"), s, "{body} changed the mission");
    }
}

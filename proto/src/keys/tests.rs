//! Every key round-trips, is one of Zenoh's key expressions, and parses only as declared.

use super::*;
use proptest::prelude::*;
// Zenoh's own key expressions (a dev-dependency): every key is one, every pattern matches its keys.
use zenoh::key_expr::KeyExpr;

#[test]
fn ids_sort_naturally() {
    let mut ids = vec!["r10", "r2", "r1", "r100", "a", "r02", "r9b", "r9a", "x-3", "x-20", "r"];
    ids.sort_by(|a, b| natural_cmp(a, b));
    assert_eq!(ids, vec!["a", "r", "r1", "r2", "r02", "r9a", "r9b", "r10", "r100", "x-3", "x-20"]);
}

proptest! {
    #[test]
    fn natural_order_is_total(a in "[a-c0-9]{0,6}", b in "[a-c0-9]{0,6}") {
        prop_assert_eq!(natural_cmp(&a, &b), natural_cmp(&b, &a).reverse());
        prop_assert_eq!(natural_cmp(&a, &b) == std::cmp::Ordering::Equal, a == b);
    }
}

fn all_keys() -> Vec<Key> {
    vec![
        Key::RobotAlive(s("r1")),
        Key::RobotInfo(s("r-2")),
        Key::RobotTelemetry(s("a_b")),
        Key::RobotCmd(s("r1")),
        Key::TeamMember { subteam: s("p1/ground"), robot: s("r3") },
        Key::TeamMember { subteam: s("p1/sync"), robot: s("r3") },
        Key::TeamSync { team: s("p1"), point: 2, round: 7 },
        Key::TeamArrive { team: s("p1"), point: 2, round: 7 },
        Key::TeamRelease { team: s("p1"), point: 0, round: 3 },
        Key::TeamMember { subteam: s("p1/ground/north/drone"), robot: s("r3") },
        Key::TeamSync { team: s("p1/ground/north"), point: 2, round: 7 },
        Key::TeamSync { team: s("sync"), point: 2, round: 7 },
        Key::TeamArrive { team: s("p1/air"), point: 2, round: 7 },
        Key::TeamRelease { team: s("p1/air/a-1"), point: 0, round: 3 },
        Key::Planner(s("patrol")),
        Key::PlannerAlive { kind: s("coverage"), zid: s("0a1b") },
        Key::HostAlive(s("central")),
        Key::HostChain(s("r1")),
        Key::HostStart(s("h2")),
        Key::MissionCtl(s("m")),
        Key::MissionView(s("m")),
        Key::MissionMarginal(s("m")),
        Key::MissionStatus(s("m")),
        Key::AgentAdvice,
        Key::AgentAdviceLive,
        Key::Viewer(s("op")),
        Key::SystemStatus,
        Key::SystemRobots,
        Key::SystemRobot(s("r9")),
        Key::SystemMissions,
        Key::SystemMission(s("p1")),
        Key::SystemJournal,
        Key::SystemMaps,
        Key::MapChunk { hash: "0f".repeat(32), index: 3 },
        Key::MapManifest { hash: "0f".repeat(32) },
        Key::SystemCmd(SystemCmd::Goto),
        Key::SystemCmd(SystemCmd::Move),
        Key::SystemCmd(SystemCmd::Capabilities),
        Key::SystemCmd(SystemCmd::Crash),
        Key::SystemCmd(SystemCmd::Create),
        Key::SystemCmd(SystemCmd::Terminate),
        Key::SystemCmd(SystemCmd::Update),
        Key::SystemCmd(SystemCmd::Pause),
        Key::SystemCmd(SystemCmd::Resume),
        Key::SystemCmd(SystemCmd::ClearTraffic),
        Key::SystemCmd(SystemCmd::Charge),
        Key::SystemCmd(SystemCmd::Release),
    ]
}

#[test]
fn every_key_round_trips_and_is_a_valid_key_expression() {
    for k in all_keys() {
        let text = k.to_string();
        assert_eq!(Key::parse(&text), Some(k.clone()), "{text}");
        assert!(KeyExpr::try_from(text.as_str()).is_ok(), "{text}");
    }
    assert_eq!(Key::RobotAlive("r1".into()).to_string(), "mrmm/robots/r1/alive");
    assert_eq!(Key::TeamSync { team: "p1".into(), point: 2, round: 7 }.to_string(), "mrmm/team/p1/sync/2/7");
}

#[test]
fn patterns_match_the_keys_they_are_for() {
    let matches = |p: Pattern, k: Key| {
        let p = KeyExpr::try_from(p.to_string()).expect("pattern");
        let k = KeyExpr::try_from(k.to_string()).expect("key");
        p.intersects(&k)
    };

    assert!(matches(Pattern::AllRobotsAlive, Key::RobotAlive(s("r1"))));
    assert!(!matches(Pattern::AllRobotsAlive, Key::RobotInfo(s("r1"))));
    assert!(matches(Pattern::AllTelemetry, Key::RobotTelemetry(s("r1"))));
    assert!(matches(Pattern::AllHostsAlive, Key::HostAlive(s("r1"))));
    assert!(matches(Pattern::AllPlannersAlive, Key::PlannerAlive { kind: s("patrol"), zid: s("ab") }));
    assert!(matches(Pattern::AllMissionStatus, Key::MissionStatus(s("p"))));
    assert!(matches(Pattern::AllViewers, Key::Viewer(s("op"))));
    assert!(matches(Pattern::TeamMembers(s("p")), Key::TeamMember { subteam: s("p/ground"), robot: s("r1") }));
    assert!(!matches(Pattern::TeamMembers(s("p")), Key::TeamMember { subteam: s("q/ground"), robot: s("r1") }));
    assert!(matches(Pattern::TeamSync(s("p")), Key::TeamSync { team: s("p"), point: 0, round: 0 }));
    assert!(matches(Pattern::AllTeamSync, Key::TeamSync { team: s("q"), point: 1, round: 3 }));
    assert!(matches(Pattern::TeamArrive(s("p")), Key::TeamArrive { team: s("p"), point: 1, round: 3 }));
    assert!(!matches(Pattern::TeamArrive(s("p")), Key::TeamRelease { team: s("p"), point: 1, round: 3 }));
    assert!(matches(Pattern::TeamRelease(s("p")), Key::TeamRelease { team: s("p"), point: 1, round: 3 }));
    assert!(!matches(Pattern::TeamMembers(s("p")), Key::TeamArrive { team: s("p"), point: 1, round: 3 }));
    // A team's patterns take in the teams below it for membership, never a sibling's, and
    // only its own barriers.
    assert!(matches(Pattern::TeamMembers(s("p")), Key::TeamMember { subteam: s("p/air/north/drone"), robot: s("r1") }));
    assert!(matches(Pattern::TeamMembers(s("p/air")), Key::TeamMember { subteam: s("p/air/north/drone"), robot: s("r1") }));
    assert!(!matches(Pattern::TeamMembers(s("p/air")), Key::TeamMember { subteam: s("p/ground/drone"), robot: s("r1") }));
    assert!(!matches(Pattern::TeamMembers(s("p/air")), Key::TeamMember { subteam: s("p/air2/drone"), robot: s("r1") }));
    assert!(!matches(Pattern::TeamSync(s("p")), Key::TeamSync { team: s("p/air"), point: 0, round: 0 }));
    assert!(!matches(Pattern::TeamSync(s("p/air")), Key::TeamSync { team: s("p"), point: 0, round: 0 }));
    assert!(!matches(Pattern::TeamSync(s("p/air")), Key::TeamSync { team: s("p/ground"), point: 0, round: 0 }));
    assert!(matches(Pattern::AllTeamSync, Key::TeamSync { team: s("p/air/x"), point: 1, round: 3 }));
    assert!(matches(Pattern::AllTeamRelease, Key::TeamRelease { team: s("p/air/x"), point: 1, round: 3 }));
    assert!(matches(Pattern::AllTeamRelease, Key::TeamRelease { team: s("p"), point: 1, round: 3 }));
    assert!(matches(Pattern::SystemAll, Key::SystemCmd(SystemCmd::Create)));
    assert!(!matches(Pattern::SystemAll, Key::AgentAdvice));
}

#[test]
fn foreign_keys_are_refused() {
    for bad in [
        "mrmm/robots/r1/alive/x",
        "other/robots/r1/alive",
        "mrmm/robots/*/alive",
        "mrmm/system/robots/a/b",
        "mrmm/system/nope",
        "mrmm/team/p1/ground/member/*",
        "mrmm/team/p1/sync/-1/2",
        "mrmm/team/p1/sync/+1/2",
        "mrmm/team/p1/sync/99999999999/2",
        "mrmm/team/sync/3",
        "mrmm/team/p1/member/sync/1/2",
        "mrmm/team/p1/a/b/c/d/e/f/g/h/i/sync/1/2",
        "mrmm/team/member/r1",
        "mrmm/missions/*/marginal",
        "",
    ] {
        assert_eq!(Key::parse(bad), None, "{bad}");
    }
}

#[test]
fn ids_are_single_chunks() {
    assert!(validate_id("robot-01_a").is_ok());
    for bad in ["", "a/b", "*", "a b", "é", &"x".repeat(65)] {
        assert!(validate_id(bad).is_err(), "{bad:?}");
    }
    assert!(validate_subteam("m/ground").is_ok());
    assert!(validate_subteam("m/g/x").is_ok());
    for bad in ["m", "m/", "/g", "m/sync/x", "m/*", "m//g"] {
        assert!(validate_subteam(bad).is_err(), "{bad:?}");
    }
    assert!(validate_team_path("m/a/b").is_ok());
    assert!(validate_team_path(&format!("m{}", "/t".repeat(MAX_TEAM_DEPTH))).is_ok());
    assert!(validate_team_path(&format!("m{}", "/t".repeat(MAX_TEAM_DEPTH + 1))).is_err());
    assert!(team_within("m/a/b", "m/a") && team_within("m/a", "m/a") && team_within("m/a", "m"));
    assert!(!team_within("m/ab", "m/a") && !team_within("m", "m/a"));
    assert_eq!(marginal_selector("p", -2), "mrmm/missions/p/marginal?add=-2");
}

proptest! {
    #[test]
    fn parse_never_panics(s in "\\PC{0,60}") {
        let _ = Key::parse(&s);
    }

    /// Built and parsed from one declaration: a real key with one chunk changed (or added, or
    /// dropped) either does not parse, or is written back exactly as it came.
    #[test]
    fn what_parses_is_written_back_the_same(
        which in 0usize..64, at in 0usize..8, edit in 0u8..3,
        chunk in prop::sample::select(vec![
            "mrmm", "robots", "team", "sync", "arrive", "release", "member", "hosts", "missions", "system",
            "cmd", "robot", "mission", "goto", "create", "alive", "chain", "status", "r1", "p", "ground", "0", "12", "*",
        ])
    ) {
        let keys = all_keys();
        let mut chunks: Vec<String> = keys[which % keys.len()].to_string().split('/').map(str::to_string).collect();
        let at = at % (chunks.len() + 1);
        match edit {
            0 if at < chunks.len() => chunks[at] = chunk.to_string(),
            1 => chunks.insert(at, chunk.to_string()),
            _ if at < chunks.len() && chunks.len() > 1 => { chunks.remove(at); }
            _ => {}
        }
        let text = chunks.join("/");
        if let Some(k) = Key::parse(&text) {
            prop_assert_eq!(k.to_string(), text);
        }
    }
}

/// A key's field from a string: an id of any kind, or a team path.
fn s<T: From<String>>(v: &str) -> T {
    T::from(v.to_string())
}

//! Recipe tests: the shipped bank, every error with its position, and random input.

use super::*;
use mrmm_proto::plan::{RobotSpec, Step};

const PATROL: &str = include_str!("../../../recipes/patrol.xml");
const COVERAGE: &str = include_str!("../../../recipes/coverage.xml");

fn robots(types: &[&str]) -> Vec<RobotSpec> {
    types
        .iter()
        .enumerate()
        .map(|(i, t)| RobotSpec {
            id: format!("r{}", i + 1).into(),
            robot_type: t.to_string(),
            x: i as f64 * 3.0,
            y: -3.0,
            speed: 1.0 + i as f64 * 0.1,
            turn_rate: None,
            reach_m: None,
        })
        .collect()
}

fn err(text: &str) -> String {
    match parse(text).and_then(|r| validate(&r)) {
        Ok(()) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn shipped_recipes_parse_validate_and_build() {
    let r = parse(PATROL).expect("patrol.xml");
    validate(&r).expect("valid");
    assert_eq!(r.planner, PlannerKind::Patrol);
    let plan = build(&r, &BTreeMap::new(), &robots(&["ground", "aerial", "ground"])).expect("build");
    let MissionPlan::Patrol(p) = &plan else { panic!("patrol") };
    assert_eq!(p.plans.len(), 3);
    for rp in &p.plans {
        assert_eq!(rp.steps[0], Step::Stream);
        assert!(matches!(rp.steps[1], Step::Navigate { speed: None, .. }));
        assert_eq!(rp.steps[2], Step::Sync { point: 0, scope: None });
        assert!(matches!(rp.steps.last(), Some(Step::Loop { to: 3, rounds: None })));
    }
    let c = parse(COVERAGE).expect("coverage.xml");
    validate(&c).expect("valid");
    let plan = build(&c, &BTreeMap::new(), &robots(&["ground", "ground"])).expect("build");
    let MissionPlan::Coverage(cp) = &plan else { panic!("coverage") };
    assert_eq!(cp.points.len(), 2);
    assert!(matches!(cp.plans[0].steps.as_slice(), [Step::Stream, Step::Navigate { .. }, Step::Hold { seconds: None }]));
    // The JSON that travels to robots.
    let json = serde_json::to_value(&plan).expect("json");
    assert_eq!(json["planner"], "coverage");
    assert!(json["plans"][0]["steps"][1]["navigate"]["x"].is_number());
}

/// A patrol counts its robots' turns at the slowest turner's rate, unless the recipe or the
/// mission gives a turn rate; a rate out of range is refused, from a robot or a parameter.
#[test]
fn a_patrol_turns_at_its_slowest_robots_rate() {
    let r = parse(PATROL).expect("patrol.xml");
    let square = parse_overrides(&["waypoints=[[0,0],[10,0],[10,10],[0,10]]".into()]).expect("overrides");
    let team = |rates: [Option<f64>; 2]| {
        let mut rs = robots(&["ground", "ground"]);
        for (r, w) in rs.iter_mut().zip(rates) {
            r.speed = 1.0;
            r.turn_rate = w;
        }
        rs
    };
    let predicted = |o: &BTreeMap<String, String>, rates| match build(&r, o, &team(rates)).expect("build") {
        MissionPlan::Patrol(p) => p.predicted_worst_idleness,
        _ => panic!("patrol"),
    };
    // Four quarter turns rounded at 1 rad/s (the slower robot) add their arcs' time less the
    // legs' ends they cut to the 40 s round.
    let corner = |w: f64| {
        let b = crate::corner::Blend::through(std::f64::consts::FRAC_PI_2, 5.0, 5.0, (1.0, 1.0), w).expect("rounded");
        b.seconds() - 2.0 * b.tangent
    };
    let slowest = predicted(&square, [Some(2.0), Some(1.0)]);
    assert!((slowest - (40.0 + 4.0 * corner(1.0)) / 2.0).abs() < 1e-6, "{slowest}");
    assert!((predicted(&square, [None, None]) - 20.0).abs() < 1e-6, "turns unknown take no time");
    let mut given = square.clone();
    given.insert("turn_rate".into(), "4".into());
    assert!((predicted(&given, [Some(2.0), Some(1.0)]) - (40.0 + 4.0 * corner(4.0)) / 2.0).abs() < 1e-6);
    let e = build(&r, &square, &team([Some(0.0), Some(1.0)])).unwrap_err().to_string();
    assert!(e.contains("robot r1 turn_rate: 0 is not a turn rate"), "{e}");
    let e = build(&r, &parse_overrides(&["turn_rate=0.001".into()]).expect("o"), &team([None, None])).unwrap_err().to_string();
    assert!(e.contains("parameter turn_rate: \"0.001\" is not a turn rate"), "{e}");
}

#[test]
fn overrides_replace_parameters() {
    let r = parse(PATROL).expect("patrol.xml");
    let o = parse_overrides(&["waypoints=[[0,0],[10,0],[10,10],[0,10]]".into(), "rounds=2".into()]).expect("overrides");
    let plan = build(&r, &o, &robots(&["ground", "ground"])).expect("build");
    let MissionPlan::Patrol(p) = &plan else { panic!("patrol") };
    assert!((p.length - 40.0).abs() < 1e-9);
    assert!(matches!(p.plans[0].steps.last(), Some(Step::Loop { rounds: Some(2), .. })));
    let e = build(&r, &parse_overrides(&["rounds=0".into()]).expect("o"), &robots(&["ground"])).unwrap_err().to_string();
    assert!(e.contains("rounds"), "{e}");
    let e = build(&r, &parse_overrides(&["colour=red".into()]).expect("o"), &robots(&["ground"])).unwrap_err().to_string();
    assert!(e.contains("unknown parameter \"colour\""), "{e}");
    // The barrier mode is the mission manager's: checked here, no change to the plan.
    assert!(build(&r, &parse_overrides(&["barrier=leader".into()]).expect("o"), &robots(&["ground"])).is_ok());
    let e = build(&r, &parse_overrides(&["barrier=ring".into()]).expect("o"), &robots(&["ground"])).unwrap_err().to_string();
    assert!(e.contains("neither \"mesh\" nor \"leader\""), "{e}");
    // So is central's charging mode.
    assert!(build(&r, &parse_overrides(&["charging=ask".into()]).expect("o"), &robots(&["ground"])).is_ok());
    let e = build(&r, &parse_overrides(&["charging=sometimes".into()]).expect("o"), &robots(&["ground"])).unwrap_err().to_string();
    assert!(e.contains("parameter charging: \"sometimes\" is none of \"auto\", \"ask\", \"off\""), "{e}");
    let e = build(&r, &parse_overrides(&["waypoints=[[0,0]]".into()]).expect("o"), &robots(&["ground"])).unwrap_err().to_string();
    assert!(e.contains("at least 2 points"), "{e}");
    assert!(parse_overrides(&["novalue".into()]).is_err());
    let c = parse(COVERAGE).expect("coverage.xml");
    let o = parse_overrides(&[r#"region={"outer":[[0,0],[10,0],[10,10],[0,10]],"holes":[[[4,4],[6,4],[6,6]]]}"#.into()]).expect("o");
    let plan = build(&c, &o, &robots(&["ground", "ground", "ground"])).expect("build");
    assert_eq!(plan.plans().len(), 3);
}

#[test]
fn errors_name_line_and_column() {
    let bad = PATROL.replace("<stream/>", "<fly/>");
    let line = PATROL.lines().position(|l| l.contains("<stream/>")).expect("line") + 1;
    assert_eq!(err(&bad), format!("{line}:5: unknown behaviour <fly> (stream, navigate, sync, hold, round, loop)"));
    let e = err(&PATROL.replace("value=\"forever\"", "value=\"many\""));
    assert!(e.ends_with("parameter rounds: \"many\" is not a whole number in [1, 4294967295]"), "{e}");
    let e = err(&PATROL.replace("<description>", "<descriptio>").replace("</description>", "</descriptio>"));
    assert!(e.contains("unknown element <descriptio>"), "{e}");
    let e = err(&PATROL.replace("<point x=\"20\" y=\"0\"/>", "<point x=\"20\" y=\"zero\"/>"));
    assert!(e.contains("\"zero\" is not a finite number"), "{e}");
    let e = err(&PATROL.replace("<round/>", "<round extra=\"1\"/>"));
    assert!(e.contains("unknown attribute `extra` on <round>"), "{e}");
    let e = err(&COVERAGE.replace("<hold/>", "<loop><round/></loop>"));
    assert!(e.contains("<round/> is for patrol recipes"), "{e}");
    let e = err(&PATROL.replace("<round/>", "<loop><round/></loop>"));
    assert!(e.contains("nested"), "{e}");
    let e = err(&PATROL.replace("planner=\"patrol\"", "planner=\"swarm\""));
    assert!(e.contains("unknown planner \"swarm\""), "{e}");
    let e = err(&PATROL.replace("</recipe>", ""));
    assert!(e.contains("never closed") || e.contains("malformed"), "{e}");
    let e = err("<mission/>");
    assert_eq!(e, "1:1: root element must be <recipe>, found <mission>");
    let e = err(&PATROL.replace("<behaviour type=\"*\">", "<behaviour type=\"*\"><stream/></behaviour><behaviour type=\"*\">"));
    assert!(e.contains("a second <behaviour>"), "{e}");
    // Planner errors point at the waypoints element.
    let dup = PATROL.replace("<point x=\"20\" y=\"15\"/>", "<point x=\"0\" y=\"0\"/>");
    let r = parse(&dup).expect("parses");
    let e = build(&r, &BTreeMap::new(), &robots(&["ground"])).unwrap_err().to_string();
    let wline = PATROL.lines().position(|l| l.contains("<waypoints>")).expect("line") + 1;
    assert!(e.starts_with(&format!("{wline}:5: waypoints: points 0 and 2 are the same")), "{e}");
}

#[test]
fn robot_type_without_behaviour() {
    let only_aerial = PATROL.replace("type=\"*\"", "type=\"aerial\"");
    let r = parse(&only_aerial).expect("parse");
    let e = build(&r, &BTreeMap::new(), &robots(&["ground"])).unwrap_err().to_string();
    assert!(e.contains("no <behaviour> for robot type \"ground\" (robot r1)"), "{e}");
}

proptest::proptest! {
    #[test]
    fn random_text_never_panics(s in "\\PC{0,200}") {
        if let Ok(r) = parse(&s) {
            let _ = validate(&r);
        }
    }

    #[test]
    fn mutated_recipes_never_panic(cut in 0usize..1200, insert in "[<>/=\" a-z]{0,6}") {
        let mut text = PATROL.to_string();
        let at = (cut % text.len()).min(text.len());
        if text.is_char_boundary(at) {
            text.insert_str(at, &insert);
            if let Ok(r) = parse(&text) {
                if validate(&r).is_ok() {
                    let _ = build(&r, &BTreeMap::new(), &robots(&["ground"]));
                }
            }
        }
    }
}

#[test]
fn requires_lists_capabilities_with_their_errors() {
    let with = |req: &str| PATROL.replace("  <params>", &format!("{req}\n  <params>"));
    let r = parse(&with("  <requires capability=\"camera\"/>\n  <requires capability=\"arm.gripper\"/>")).expect("parse");
    validate(&r).expect("valid");
    assert_eq!(r.required(), ["arm.gripper", "camera"]);
    assert!(parse(PATROL).expect("patrol").required().is_empty());
    let e = err(&with("  <requires capability=\"camera\"/>\n  <requires capability=\"camera\"/>"));
    assert!(e.contains("capability \"camera\" required twice") && e.starts_with("7:3"), "{e}");
    let e = err(&with("  <requires capability=\"night vision\"/>"));
    assert!(e.contains("<requires capability=\"night vision\">: use 1 to 64 characters"), "{e}");
    let e = err(&with("  <requires/>"));
    assert!(e.contains("capability"), "{e}");
    let e = err(&with("  <requires capability=\"camera\"><x/></requires>"));
    assert!(e.contains("<requires> takes no child elements"), "{e}");
    let many: String = (0..=MAX_REQUIRES).map(|i| format!("<requires capability=\"c{i}\"/>")).collect();
    let e = err(&with(&many));
    assert!(e.contains("more than 32 <requires>"), "{e}");
    assert!(is_capability("thermal-cam_2.0") && !is_capability("") && !is_capability(&"c".repeat(65)) && !is_capability("a/b"));
}

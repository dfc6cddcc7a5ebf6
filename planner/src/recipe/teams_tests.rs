//! Team trees: grammar and its errors, assignment to leaf teams, plans per team.

use std::collections::BTreeMap;

use super::super::*;
use mrmm_proto::plan::{RobotSpec, Step};

fn robots(types: &[&str]) -> Vec<RobotSpec> {
    types
        .iter()
        .enumerate()
        .map(|(i, t)| RobotSpec {
            id: format!("r{}", i + 1).into(),
            robot_type: t.to_string(),
            x: i as f64 * 2.0,
            y: -2.0,
            speed: 1.0,
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

const LEAF: &str = r#"<params><waypoints><point x="0" y="0"/><point x="10" y="0"/><point x="10" y="10"/></waypoints></params><behaviour type="*"><stream/><navigate to="slot"/><sync point="start" scope="SCOPE"/><loop><round/></loop></behaviour>"#;

fn leaf(scope: &str) -> String {
    LEAF.replace("SCOPE", scope)
}

/// Three levels: site / wing / {north, south}, and a top-level team beside them.
fn three_levels() -> String {
    format!(
        r#"<recipe name="deep">
  <team name="site">
    <team name="wing">
      <requires capability="lidar"/>
      <team name="north" planner="patrol" min="1">{}</team>
      <team name="south" planner="patrol" max="1">{}</team>
    </team>
  </team>
  <team name="air" type="aerial" planner="patrol">{}</team>
</recipe>"#,
        leaf("parent"),
        leaf("team"),
        leaf("mission")
    )
}

#[test]
fn the_issue_example_parses_into_two_leaf_teams() {
    let r = parse(bank("escort").expect("bank")).expect("escort");
    validate(&r).expect("valid");
    assert!(r.has_teams());
    let leaves = r.leaves();
    let paths: Vec<&str> = leaves.iter().map(Leaf::path).collect();
    assert_eq!(paths, ["ground", "air"]);
    assert_eq!((leaves[0].recipe.planner, leaves[1].recipe.planner), (PlannerKind::Patrol, PlannerKind::Coverage));
    assert_eq!(leaves[0].min, 1);
    assert!(leaves[0].fits("ground", &[]) && !leaves[0].fits("aerial", &[]));
    assert_eq!(r.planner, PlannerKind::Patrol, "the first leaf's planner names the recipe's");
}

#[test]
fn teams_nest_three_levels_and_scopes_resolve_along_the_path() {
    let r = parse(&three_levels()).expect("parse");
    validate(&r).expect("valid");
    assert_eq!(r.team_paths(), ["site", "site/wing", "site/wing/north", "site/wing/south", "air"]);
    let leaves = r.leaves();
    assert!(leaves[0].fits("any", &["lidar".into()]) && !leaves[0].fits("any", &[]), "an inner team's requirement holds for its leaves");
    assert!(leaves[2].fits("aerial", &[]) && !leaves[2].fits("ground", &[]));
    assert_eq!(Scope::Parent.resolve("site/wing/north"), Some("site/wing".into()));
    assert_eq!(Scope::Parent.resolve("air"), Some(String::new()));
    assert_eq!(Scope::Mission.resolve("site/wing/north"), Some(String::new()));
    assert_eq!(Scope::Team.resolve("site/wing/north"), None);
    // A recipe planned as a whole has one team: every scope is that team.
    assert_eq!(Scope::Mission.resolve(""), None);

    let mut caps = BTreeMap::new();
    for id in ["r1", "r2", "r3"] {
        caps.insert(id.to_string(), vec!["lidar".to_string()]);
    }
    let plan = build_for(&r, &BTreeMap::new(), &robots(&["ground", "ground", "ground", "aerial"]), &caps, None).expect("plan");
    let MissionPlan::Teams { teams } = &plan else { panic!("teams") };
    let by_team: Vec<(&str, Vec<&str>)> = teams.iter().map(|t| (t.team.as_str(), t.plan.plans().iter().map(|p| p.robot.as_str()).collect())).collect();
    // south takes at most one; north takes the rest.
    assert_eq!(by_team, [("site/wing/north", vec!["r1", "r3"]), ("site/wing/south", vec!["r2"]), ("air", vec!["r4"])]);
    for p in plan.plans() {
        let sync = p.steps.iter().find_map(|s| if let Step::Sync { point: 0, scope } = s { Some(scope.clone()) } else { None });
        let want = match p.team.as_str() {
            "site/wing/north" => Some("site/wing".to_string()),
            "site/wing/south" => None,
            "air" => Some(String::new()),
            other => panic!("team {other}"),
        };
        assert_eq!(sync, Some(want), "{}", p.robot);
    }
    // Only robots with lidar can be in the wing.
    let e = build_for(&r, &BTreeMap::new(), &robots(&["ground", "aerial"]), &BTreeMap::new(), None).unwrap_err().to_string();
    assert!(e.contains("robot r1 (type ground) fits no team"), "{e}");
}

#[test]
fn minimums_are_met_where_robots_fit_several_teams() {
    let xml = format!(
        r#"<recipe name="m">
  <team name="any" planner="patrol" min="2">{l}</team>
  <team name="fly" planner="patrol" min="1"><requires capability="fly"/>{l}</team>
</recipe>"#,
        l = leaf("team")
    );
    let r = parse(&xml).expect("parse");
    // r1 flies: a greedy choice would put it in "any"; the flow puts it where only it can go.
    let caps = BTreeMap::from([("r1".to_string(), vec!["fly".to_string()])]);
    let groups = assign(&r, &robots(&["g", "g", "g"]), &caps).expect("assign");
    assert_eq!(groups, vec![vec![1, 2], vec![0]]);
    let e = assign(&r, &robots(&["g", "g", "g"]), &BTreeMap::new()).unwrap_err().to_string();
    assert!(e.contains("team fly needs at least 1 members (capabilities fly); of these 3 robots only 0 fit it"), "{e}");
    // A running mission replanned after a loss goes on with what it has.
    assert_eq!(assign_as(&r, &robots(&["g", "g"]), &caps, Bounds::Relaxed).expect("relaxed"), vec![vec![1], vec![0]]);
    let e = assign(&r, &robots(&["g", "g"]), &caps).unwrap_err().to_string();
    assert!(e.contains("the teams' minimums (any 2, fly 1) of recipe m need 3 robots that fit them; these 2 robots fill at most 2"), "{e}");
    // Beyond the minimums, an equal share.
    let caps: BTreeMap<String, Vec<String>> = (1..=7).map(|i| (format!("r{i}"), vec!["fly".to_string()])).collect();
    let groups = assign(&r, &robots(&["g"; 7]), &caps).expect("assign");
    assert_eq!((groups[0].len(), groups[1].len()), (4, 3));
}

#[test]
fn a_full_team_refuses_more_robots() {
    let xml = format!(r#"<recipe name="m"><team name="a" planner="patrol" max="2">{}</team></recipe>"#, leaf("team"));
    let r = parse(&xml).expect("parse");
    assert!(assign(&r, &robots(&["g", "g"]), &BTreeMap::new()).is_ok());
    let e = assign(&r, &robots(&["g", "g", "g"]), &BTreeMap::new()).unwrap_err().to_string();
    assert!(e.contains("robot r3 fits only teams that are full: a (max 2)"), "{e}");
}

#[test]
fn overrides_go_to_the_teams_that_take_them() {
    let r = parse(bank("escort").expect("bank")).expect("escort");
    let o = parse_overrides(&["ground/rounds=2".into(), "seed=7".into(), "waypoints=[[0,0],[8,0],[8,8]]".into()]).expect("o");
    let plan = build(&r, &o, &robots(&["ground", "aerial", "ground"])).expect("plan");
    let MissionPlan::Teams { teams } = &plan else { panic!("teams") };
    let MissionPlan::Patrol(g) = &teams[0].plan else { panic!("patrol") };
    assert!((g.length - (16.0 + 8.0 * 2f64.sqrt())).abs() < 1e-6, "{}", g.length);
    assert!(matches!(g.plans[0].steps.last(), Some(Step::Loop { rounds: Some(2), .. })));
    assert!(matches!(teams[1].plan, MissionPlan::Coverage(_)));
    assert!(plan.plans().iter().all(|p| !p.team.is_empty()));
    for bad in ["colour=red", "sea/rounds=1", "air/rounds=2", "ground/rounds=0"] {
        let o = parse_overrides(&[bad.into()]).expect("o");
        let e = build(&r, &o, &robots(&["ground", "aerial"])).unwrap_err().to_string();
        assert!(e.contains("parameter"), "{bad}: {e}");
    }
    // A team without members is not planned; its minimum still counts.
    let plan = build(&r, &BTreeMap::new(), &robots(&["ground"])).expect("plan");
    let MissionPlan::Teams { teams } = &plan else { panic!("teams") };
    assert_eq!(teams.len(), 1);
    let e = build(&r, &BTreeMap::new(), &robots(&["aerial"])).unwrap_err().to_string();
    assert!(e.contains("team ground needs at least 1"), "{e}");
    // The JSON keeps each team's figures.
    let json = serde_json::to_value(build(&r, &BTreeMap::new(), &robots(&["ground", "aerial"])).expect("plan")).expect("json");
    assert_eq!(json["planner"], "teams");
    assert_eq!(json["teams"][1]["team"], "air");
    assert_eq!(json["teams"][1]["planner"], "coverage");
}

#[test]
fn team_grammar_errors_name_line_and_column() {
    let l = leaf("team");
    let cases: Vec<(String, &str)> = vec![
        (format!("<recipe name=\"m\">\n  <team name=\"sync\" planner=\"patrol\">{l}</team></recipe>"), "2:3: <team name=\"sync\">: sync, arrive"),
        (format!("<recipe name=\"m\">\n <team name=\"a b\" planner=\"patrol\">{l}</team></recipe>"), "2:2: <team name=\"a b\">"),
        (
            format!("<recipe name=\"m\"><team name=\"a\" planner=\"patrol\">{l}</team>\n<team name=\"a\" planner=\"patrol\">{l}</team></recipe>"),
            "2:1: a second team named \"a\"",
        ),
        (format!("<recipe name=\"m\">\n<team name=\"a\" planner=\"patrol\" min=\"3\" max=\"2\">{l}</team></recipe>"), "2:1: team \"a\": min 3 is above max 2"),
        (
            format!("<recipe name=\"m\">\n<team name=\"a\" min=\"1\"><team name=\"b\" planner=\"patrol\">{l}</team></team></recipe>"),
            "2:1: team \"a\": min and max belong",
        ),
        (
            format!("<recipe name=\"m\">\n<team name=\"a\" planner=\"patrol\">{l}\n<team name=\"b\"/></team></recipe>"),
            "3:1: team \"a\" has a planner, so it is a leaf",
        ),
        (format!("<recipe name=\"m\"><team name=\"a\" planner=\"patrol\">{l}</team>\n<params/></recipe>"), "2:1: <params> belongs in a leaf <team>"),
        (format!("<recipe name=\"m\" planner=\"patrol\">{l}\n<team name=\"a\"/></recipe>"), "2:1: a recipe with teams has no planner"),
        ("<recipe name=\"m\">\n<team name=\"a\"></team></recipe>".into(), "2:1: team \"a\" has neither a planner nor teams"),
        ("<recipe name=\"m\">\n</recipe>".into(), "1:1: a recipe needs a planner"),
        (
            format!("<recipe name=\"m\"><team name=\"a\" planner=\"patrol\">{}</team></recipe>", leaf("everyone")),
            "<sync scope=\"everyone\">: team, parent or mission",
        ),
        (format!("<recipe name=\"m\"><team name=\"a\" planner=\"coverage\">{l}</team></recipe>"), "<waypoints> is for patrol recipes"),
    ];
    for (xml, want) in cases {
        let e = err(&xml);
        assert!(e.contains(want), "want {want:?}, got {e:?}");
    }
    let mut deep = String::from("<recipe name=\"m\">");
    for i in 0..MAX_TEAM_DEPTH {
        deep.push_str(&format!("\n<team name=\"t{i}\">"));
    }
    deep.push_str(&format!("\n<team name=\"leaf\" planner=\"patrol\">{l}</team>"));
    deep.push_str(&"</team>".repeat(MAX_TEAM_DEPTH));
    deep.push_str("</recipe>");
    let e = err(&deep);
    assert!(e.contains(&format!("{}:1: teams nest at most {MAX_TEAM_DEPTH} deep", MAX_TEAM_DEPTH + 2)), "{e}");
    // One level less is fine.
    let ok = deep.replacen("\n<team name=\"t0\">", "", 1).replacen("</team>", "", 1);
    parse(&ok).and_then(|r| validate(&r)).expect("eight levels");
}

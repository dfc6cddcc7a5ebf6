//! Recipes as an operator sends them in a mission create: parsed, validated and planned (the dry
//! run central makes), with the default parameters and three robots.

use mrmm_planner::recipe;
use mrmm_proto::plan::RobotSpec;

/// One input, as libFuzzer hands it over.
pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(r) = recipe::parse(text) else { return };
    if recipe::validate(&r).is_err() {
        return;
    }
    let robots: Vec<RobotSpec> = ["r1", "r2", "r3"]
        .iter()
        .enumerate()
        .map(|(i, id)| RobotSpec {
            id: (*id).into(),
            robot_type: "ground".into(),
            x: i as f64,
            y: 0.0,
            speed: 1.0,
            turn_rate: Some(1.0 + i as f64),
            reach_m: None,
        })
        .collect();
    let _ = recipe::build(&r, &Default::default(), &robots);
}

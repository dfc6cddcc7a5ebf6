//! Property tests: random (often hostile) inputs to the planners give a valid answer or a clear
//! error, never a panic.

use mrmm_planner::coverage::{self, CoverageParams};
use mrmm_planner::geom::Point;
use mrmm_planner::patrol::{self, PatrolParams};
use mrmm_planner::plan::RobotSpec;
use mrmm_planner::region::Region;
use mrmm_planner::tsp::{self, Budget, Instance, Metric};
use proptest::prelude::*;

fn coord() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => -100.0..100.0f64,
        1 => Just(0.0),
        1 => prop::sample::select(vec![f64::NAN, f64::INFINITY, -1e300, 1e300, 5e-324]),
    ]
}

fn points(max: usize) -> impl Strategy<Value = Vec<Point>> {
    prop::collection::vec((coord(), coord()).prop_map(|(x, y)| Point::new(x, y)), 0..max)
}

fn robots() -> impl Strategy<Value = Vec<RobotSpec>> {
    prop::collection::vec((coord(), coord(), prop_oneof![Just(0.0), 0.1..5.0f64, Just(-1.0)]), 0..6).prop_map(|v| {
        v.into_iter()
            .enumerate()
            .map(|(i, (x, y, speed))| RobotSpec { id: format!("r{i}"), robot_type: "ground".into(), x, y, speed })
            .collect()
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn tours_are_permutations_or_errors(pts in points(40)) {
        match Instance::new(pts.clone(), Metric::Euclidean) {
            Ok(inst) => {
                let (t, _) = tsp::solve(&inst, &Budget { max_kicks: 20, stop: None, seed: 1 }).expect("valid instance solves");
                prop_assert!(tsp::is_permutation(&t.order, pts.len()));
            }
            Err(_) => prop_assert!(pts.is_empty() || pts.iter().any(|p| !p.is_finite() || p.x.abs() > 1e150 || p.y.abs() > 1e150)),
        }
    }

    #[test]
    fn patrol_plans_or_errors(pts in points(12), rs in robots()) {
        let mut params = PatrolParams::new(pts);
        params.max_kicks = 10;
        if let Ok(p) = patrol::plan(&params, &rs) {
            prop_assert_eq!(p.plans.len(), rs.len());
            let mut slots: Vec<usize> = p.plans.iter().map(|r| r.slot).collect();
            slots.sort_unstable();
            prop_assert_eq!(slots, (0..rs.len()).collect::<Vec<_>>());
        }
    }

    #[test]
    fn coverage_plans_or_errors(outer in points(7), rs in robots()) {
        if let Ok(region) = Region::new(outer, vec![]) {
            let mut params = CoverageParams::new(region.clone());
            params.samples = 200;
            params.lloyd_iterations = 3;
            params.minimax_iterations = 3;
            if let Ok(p) = coverage::plan(&params, &rs) {
                prop_assert_eq!(p.points.len(), rs.len());
                prop_assert!(p.coverage_radius.is_finite());
            }
        }
    }
}

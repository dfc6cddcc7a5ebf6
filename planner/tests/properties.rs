//! Property tests: random (often hostile) inputs to the planners give a valid answer or a clear
//! error, never a panic.

use mrmm_planner::coverage::{self, CoverageParams};
use mrmm_planner::geom::Point;
use mrmm_planner::patrol::{self, PatrolParams};
use mrmm_planner::region::Region;
use mrmm_planner::tsp::{self, Budget, Instance, Metric};
use mrmm_proto::plan::RobotSpec;
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
            .map(|(i, (x, y, speed))| RobotSpec { id: format!("r{i}").into(), robot_type: "ground".into(), x, y, speed, turn_rate: None, reach_m: None })
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

/// Star-shaped polygons (always simple), stretched to extreme scales and aspect ratios.
fn star_polygon() -> impl Strategy<Value = Vec<Point>> {
    (
        prop::collection::vec((0.0..1.0f64, 0.2..1.0f64), 3..9),
        prop::sample::select(vec![1e-6, 1e-3, 1.0, 50.0, 1e4]),
        prop::sample::select(vec![1e-9, 0.01, 1.0, 100.0, 1e9]),
    )
        .prop_map(|(mut pts, scale, aspect)| {
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            pts.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-3);
            let n = pts.len() as f64;
            pts.iter()
                .enumerate()
                .map(|(i, &(jitter, r))| {
                    let a = std::f64::consts::TAU * (i as f64 + 0.5 * jitter) / n;
                    Point::new(scale * r * a.cos(), scale * aspect * r * a.sin())
                })
                .collect()
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn coverage_of_valid_regions_at_any_scale(outer in star_polygon(), n in 1usize..6) {
        let far = outer.iter().any(|p| p.x.abs() > mrmm_planner::limits::MAX_COORDINATE || p.y.abs() > mrmm_planner::limits::MAX_COORDINATE);
        if let Ok(region) = Region::new(outer, vec![]) {
            let mut params = CoverageParams::new(region.clone());
            params.samples = 300;
            params.lloyd_iterations = 3;
            params.minimax_iterations = 3;
            let rs: Vec<RobotSpec> = (0..n).map(|i| RobotSpec { id: format!("r{i}").into(), robot_type: "g".into(), x: 0.0, y: 0.0, speed: 1.0, turn_rate: None, reach_m: None }).collect();
            match coverage::plan(&params, &rs) {
                Ok(p) => {
                    prop_assert_eq!(p.points.len(), n);
                    prop_assert!(p.points.iter().all(|q| q.is_finite()));
                    prop_assert!(p.coverage_radius.is_finite() && p.coverage_radius >= 0.0);
                    prop_assert!(p.formation_time.is_finite() && p.formation_time >= 0.0);
                    prop_assert_eq!(p.plans.len(), n);
                }
                // A valid region fails only where it cannot be sampled at this scale, or lies
                // beyond the coordinates the planner accepts.
                Err(e) => prop_assert!(
                    matches!(&e, mrmm_planner::PlanError::Polygon(m) if m.contains("sample"))
                        || (far && matches!(&e, mrmm_planner::PlanError::Invalid(m) if m.contains("region vertex"))),
                    "a valid region failed otherwise: {e}"
                ),
            }
        }
    }
}

//! Upper bounds on everything an operator (or a stranger) can make the planner do, so that one
//! request cannot take a node's memory or hold its CPU: each is checked where the input enters,
//! with an error that names the limit.

use crate::error::PlanError;

/// Waypoints of one patrol.
pub const MAX_WAYPOINTS: usize = 2_000;
/// Vertices of one coverage region, outer ring and holes together.
pub const MAX_REGION_VERTICES: usize = 2_000;
/// Holes of one coverage region.
pub const MAX_HOLES: usize = 100;
/// Robots one plan is made for.
pub const MAX_ROBOTS: usize = 1_000;
/// Sync points of one patrol round (all robots together).
pub const MAX_SYNC_POINTS: usize = 10_000;
/// Steps of one robot's plan.
pub const MAX_PLAN_STEPS: usize = 100_000;
/// Iterated-local-search kicks of one tour.
pub const MAX_KICKS: u64 = 1_000_000;
/// Lloyd and minimax iterations of one coverage.
pub const MAX_ITERATIONS: u64 = 1_000;
/// Region samples of one coverage.
pub const MAX_SAMPLES: u64 = 200_000;
/// Bytes of one recipe (XML).
pub const MAX_RECIPE_BYTES: usize = 256 * 1024;
/// Nesting depth of a recipe's elements.
pub const MAX_RECIPE_DEPTH: usize = 32;
/// Elements of one recipe.
pub const MAX_RECIPE_ELEMENTS: usize = 10_000;

/// Largest coordinate, in metres, of a waypoint, region vertex or robot position (1 000 km from the
/// origin): beyond it the geometry loses its precision and sampling its meaning.
pub const MAX_COORDINATE: f64 = 1e6;

/// Checks that the point `(x, y)` of `what` is finite and within [`MAX_COORDINATE`].
pub fn coordinate(what: &str, x: f64, y: f64) -> Result<(), PlanError> {
    if !(x.is_finite() && y.is_finite() && x.abs() <= MAX_COORDINATE && y.abs() <= MAX_COORDINATE) {
        return Err(PlanError::Invalid(format!("{what}: ({x}, {y}) is not a point within {MAX_COORDINATE} m of the origin")));
    }
    Ok(())
}

/// Slowest and fastest turn rate of a robot, rad/s (the protocol's `MIN_TURN_RATE` and
/// `MAX_TURN_RATE`): a slower one would stretch a patrol's timed route without bound.
pub const TURN_RATES: std::ops::RangeInclusive<f64> = 0.01..=1e3;

/// Checks that `w` is a turn rate within [`TURN_RATES`].
pub fn turn_rate(what: &str, w: f64) -> Result<(), PlanError> {
    if !(w.is_finite() && TURN_RATES.contains(&w)) {
        return Err(PlanError::Invalid(format!("{what}: {w} is not a turn rate from {} to {} rad/s", TURN_RATES.start(), TURN_RATES.end())));
    }
    Ok(())
}

/// Checks that `what` has at most `max` items.
pub fn at_most(what: &str, got: usize, max: usize) -> Result<(), PlanError> {
    if got > max {
        return Err(PlanError::Invalid(format!("{what}: {got} given, at most {max}")));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::coverage::{self, CoverageParams};
    use crate::geom::Point;
    use crate::region::Region;
    use mrmm_proto::plan::RobotSpec;

    /// Found by the `recipe` fuzz target: a region vertex at y = -7.7e76 held the planner for
    /// minutes (precision lost in the geometry); points beyond a million metres are refused.
    #[test]
    fn far_away_coordinates_are_refused_at_once() {
        let region = Region { outer: vec![Point::new(-20.0, -20.0), Point::new(20.0, -1e30), Point::new(20.0, 30.0), Point::new(-66.0, 20.0)], holes: vec![] };
        let params = CoverageParams { samples: 1532, ..CoverageParams::new(region) };
        let robots = [RobotSpec { id: "r1".into(), robot_type: "ground".into(), x: 0.0, y: 0.0, speed: 1.0, turn_rate: None, reach_m: None }];
        let e = coverage::plan(&params, &robots).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("region vertex") && e.contains("1000000"), "{e}");
        let far = [RobotSpec { id: "r1".into(), robot_type: "ground".into(), x: 2e6, y: 0.0, speed: 1.0, turn_rate: None, reach_m: None }];
        let square = Region { outer: vec![Point::new(0.0, 0.0), Point::new(10.0, 0.0), Point::new(10.0, 10.0), Point::new(0.0, 10.0)], holes: vec![] };
        let e = coverage::plan(&CoverageParams::new(square), &far).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("robot r1 position"), "{e}");
    }
}

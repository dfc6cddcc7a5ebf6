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

/// Checks that `what` has at most `max` items.
pub fn at_most(what: &str, got: usize, max: usize) -> Result<(), PlanError> {
    if got > max {
        return Err(PlanError::Invalid(format!("{what}: {got} given, at most {max}")));
    }
    Ok(())
}

//! Plane geometry shared by the planners.

use crate::error::PlanError;

pub use mrmm_maps::Point;

/// Rejects an empty list and non-finite coordinates.
pub fn check_finite(points: &[Point]) -> Result<(), PlanError> {
    if points.is_empty() {
        return Err(PlanError::Empty);
    }
    for (index, p) in points.iter().enumerate() {
        if !p.is_finite() {
            return Err(PlanError::NonFinite { index, x: p.x, y: p.y });
        }
    }
    Ok(())
}

/// Rejects duplicate points (exactly equal coordinates).
pub fn check_distinct(points: &[Point]) -> Result<(), PlanError> {
    let mut idx: Vec<usize> = (0..points.len()).collect();
    idx.sort_by(|&a, &b| points[a].x.total_cmp(&points[b].x).then(points[a].y.total_cmp(&points[b].y)));
    for w in idx.windows(2) {
        let (a, b) = (w[0].min(w[1]), w[0].max(w[1]));
        if points[a] == points[b] {
            return Err(PlanError::Duplicate { a, b, x: points[a].x, y: points[a].y });
        }
    }
    Ok(())
}

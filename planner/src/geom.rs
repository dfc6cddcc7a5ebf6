//! Plane geometry shared by the planners.

use serde::{Deserialize, Serialize};

use crate::error::PlanError;

/// A point in the plane, metres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct Point {
    pub x: f64,
    pub y: f64,
}

impl Point {
    pub const fn new(x: f64, y: f64) -> Self {
        Point { x, y }
    }
    pub fn dist(self, o: Point) -> f64 {
        (self.x - o.x).hypot(self.y - o.y)
    }
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }
}

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

//! The error type of the planner crate.

use thiserror::Error;

/// Every way a planning request can be wrong.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum PlanError {
    #[error("no points given")]
    Empty,
    #[error("need at least {min} points, got {got}")]
    TooFewPoints { min: usize, got: usize },
    #[error("point {index} has a non-finite coordinate ({x}, {y})")]
    NonFinite { index: usize, x: f64, y: f64 },
    #[error("points {a} and {b} are the same ({x}, {y})")]
    Duplicate { a: usize, b: usize, x: f64, y: f64 },
    #[error("cost matrix: {0}")]
    Costs(String),
    #[error("{robots} robots but only {slots} slots")]
    TooManyRobots { robots: usize, slots: usize },
    #[error("polygon: {0}")]
    Polygon(String),
    #[error("TSPLIB line {line}: {msg}")]
    Tsplib { line: usize, msg: String },
    #[error("{line}:{column}: {msg}")]
    Recipe { line: usize, column: usize, msg: String },
    #[error("{0}")]
    Invalid(String),
    /// A map refused a point or could not be read.
    #[error("{0}")]
    Map(#[from] mrmm_maps::MapError),
}

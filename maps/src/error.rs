//! The error type of the maps crate.

use thiserror::Error;

/// Every way a map, or a point asked of it, can be wrong. Each names the file and the line or
/// field, or the point by its index and coordinates.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MapError {
    /// A file that is not what its format says: `at` is `line 12`, `field origin`, ….
    #[error("{file}: {at}: {problem}")]
    Malformed { file: String, at: String, problem: String },
    /// A file or map larger than [`crate::limits`] allow.
    #[error("{file}: {problem}")]
    TooLarge { file: String, problem: String },
    /// A file the map needs and the bundle lacks, or that could not be read.
    #[error("{file}: {problem}")]
    Missing { file: String, problem: String },
    /// A point asked of the map: a waypoint in a wall, a robot off the map, one cut off.
    #[error("{what} {index} at ({x}, {y}) {problem}")]
    Point { what: String, index: usize, x: f64, y: f64, problem: String },
    #[error("{0}")]
    Invalid(String),
}

impl MapError {
    pub(crate) fn malformed(file: &str, at: impl Into<String>, problem: impl Into<String>) -> Self {
        MapError::Malformed { file: file.to_string(), at: at.into(), problem: problem.into() }
    }

    pub(crate) fn too_large(file: &str, problem: impl Into<String>) -> Self {
        MapError::TooLarge { file: file.to_string(), problem: problem.into() }
    }

    pub(crate) fn point(what: &str, index: usize, p: crate::Point, problem: impl Into<String>) -> Self {
        MapError::Point { what: what.to_string(), index, x: round_mm(p.x), y: round_mm(p.y), problem: problem.into() }
    }
}

fn round_mm(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

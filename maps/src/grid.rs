//! Occupancy grids as `nav_msgs/OccupancyGrid` holds them: row 0 is the bottom row, values 0
//! (free) to 100 (occupied) and -1 (unknown); the origin is the pose of the lower-left cell's
//! outer corner, rotated by its yaw.

use crate::geom::Point;
use crate::GridSummary;

/// Occupancy of an unknown cell.
pub const UNKNOWN: i8 = -1;
/// Cells whose occupancy is below this are traversable (0 in trinary maps; "scale" maps' shades
/// under half occupied). Unknown cells never are.
pub const FREE_BELOW: i8 = 50;

/// An occupancy grid.
#[derive(Debug, Clone, PartialEq)]
pub struct OccupancyGrid {
    pub width: u32,
    pub height: u32,
    /// Metres per cell.
    pub resolution: f64,
    /// Pose of the lower-left corner: x, y, yaw (radians, counter-clockwise).
    pub origin: [f64; 3],
    /// `width × height` values, row by row from the bottom.
    pub data: Vec<i8>,
}

impl OccupancyGrid {
    /// Whether cell (col, row) can be driven through.
    #[inline]
    pub fn free(&self, col: u32, row: u32) -> bool {
        let v = self.data[row as usize * self.width as usize + col as usize];
        (0..FREE_BELOW).contains(&v)
    }

    /// The value of cell (col, row).
    pub fn value(&self, col: u32, row: u32) -> i8 {
        self.data[row as usize * self.width as usize + col as usize]
    }

    /// The point `p` in the grid's own frame, in cells (not rounded).
    #[inline]
    pub fn to_cells(&self, p: Point) -> (f64, f64) {
        let (dx, dy) = (p.x - self.origin[0], p.y - self.origin[1]);
        let (s, c) = self.origin[2].sin_cos();
        ((c * dx + s * dy) / self.resolution, (-s * dx + c * dy) / self.resolution)
    }

    /// The world point at grid coordinates (u, v) in cells.
    #[inline]
    pub fn from_cells(&self, u: f64, v: f64) -> Point {
        let (s, c) = self.origin[2].sin_cos();
        let (mx, my) = (u * self.resolution, v * self.resolution);
        Point::new(self.origin[0] + c * mx - s * my, self.origin[1] + s * mx + c * my)
    }

    /// The cell holding `p`, if it is on the map.
    pub fn cell_of(&self, p: Point) -> Option<(u32, u32)> {
        let (u, v) = self.to_cells(p);
        if u.is_finite() && v.is_finite() && u >= 0.0 && v >= 0.0 && u < self.width as f64 && v < self.height as f64 {
            Some((u as u32, v as u32))
        } else {
            None
        }
    }

    /// The centre of cell (col, row).
    pub fn center(&self, col: u32, row: u32) -> Point {
        self.from_cells(col as f64 + 0.5, row as f64 + 0.5)
    }

    /// What the cell under `p` is: `None` off the map, else its value.
    pub fn at(&self, p: Point) -> Option<i8> {
        self.cell_of(p).map(|(c, r)| self.value(c, r))
    }

    /// Whether `p` lies in a free cell.
    pub fn is_free(&self, p: Point) -> bool {
        self.cell_of(p).is_some_and(|(c, r)| self.free(c, r))
    }

    /// Corners of the axis-aligned box around the map.
    pub fn bounds(&self) -> (Point, Point) {
        let (w, h) = (self.width as f64, self.height as f64);
        let corners = [self.from_cells(0.0, 0.0), self.from_cells(w, 0.0), self.from_cells(0.0, h), self.from_cells(w, h)];
        let min = Point::new(corners.iter().map(|p| p.x).fold(f64::INFINITY, f64::min), corners.iter().map(|p| p.y).fold(f64::INFINITY, f64::min));
        let max = Point::new(corners.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max), corners.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max));
        (min, max)
    }

    pub fn summary(&self) -> GridSummary {
        let cell = self.resolution * self.resolution;
        let (mut free, mut occ, mut unknown) = (0u64, 0u64, 0u64);
        for &v in &self.data {
            if (0..FREE_BELOW).contains(&v) {
                free += 1;
            } else if v < 0 {
                unknown += 1;
            } else {
                occ += 1;
            }
        }
        GridSummary {
            width: self.width,
            height: self.height,
            resolution: self.resolution,
            free_m2: free as f64 * cell,
            occupied_m2: occ as f64 * cell,
            unknown_m2: unknown as f64 * cell,
        }
    }

    /// Whether the straight segment a → b stays in free cells (every cell it touches).
    pub fn segment_free(&self, a: Point, b: Point) -> bool {
        let (ua, va) = self.to_cells(a);
        let (ub, vb) = self.to_cells(b);
        crate::space::cells_on_segment(ua, va, ub, vb, |c, r| {
            c >= 0 && r >= 0 && (c as u32) < self.width && (r as u32) < self.height && self.free(c as u32, r as u32)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_round_trip_with_a_rotated_origin() {
        let g = OccupancyGrid { width: 10, height: 5, resolution: 0.1, origin: [2.0, 3.0, 1.0], data: vec![0; 50] };
        let p = g.center(3, 2);
        assert_eq!(g.cell_of(p), Some((3, 2)));
        let (u, v) = g.to_cells(p);
        assert!((u - 3.5).abs() < 1e-9 && (v - 2.5).abs() < 1e-9);
        assert_eq!(g.cell_of(Point::new(-100.0, 0.0)), None);
    }
}

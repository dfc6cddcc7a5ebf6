//! Polygonal regions with holes: validation, containment, area, sampling.

use serde::{Deserialize, Serialize};

use crate::error::PlanError;
use crate::geom::Point;

/// Largest coordinate magnitude of a region: squared distances stay finite.
pub const MAX_COORD: f64 = 1e100;

/// A polygon (outer ring, either orientation) with optional holes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Region {
    pub outer: Vec<Point>,
    #[serde(default)]
    pub holes: Vec<Vec<Point>>,
}

impl Region {
    /// Validates: rings of ≥ 3 finite vertices, non-zero area, no self-intersection, holes inside
    /// the outer ring and disjoint from each other.
    pub fn new(outer: Vec<Point>, holes: Vec<Vec<Point>>) -> Result<Self, PlanError> {
        check_ring("outer ring", &outer)?;
        for (i, h) in holes.iter().enumerate() {
            let name = format!("hole {}", i + 1);
            check_ring(&name, h)?;
            if rings_cross(&outer, h) || !h.iter().all(|&p| inside_ring(&outer, p)) {
                return Err(PlanError::Polygon(format!("{name} is not strictly inside the outer ring")));
            }
            for (j, g) in holes.iter().enumerate().take(i) {
                if rings_cross(g, h) || h.iter().any(|&p| inside_ring(g, p)) || g.iter().any(|&p| inside_ring(h, p)) {
                    return Err(PlanError::Polygon(format!("holes {} and {name} overlap", j + 1)));
                }
            }
        }
        Ok(Region { outer, holes })
    }

    /// Validates an already-built region (e.g. deserialised).
    pub fn validated(self) -> Result<Self, PlanError> {
        Region::new(self.outer, self.holes)
    }

    pub fn contains(&self, p: Point) -> bool {
        inside_ring(&self.outer, p) && !self.holes.iter().any(|h| inside_ring(h, p))
    }

    pub fn area(&self) -> f64 {
        ring_area(&self.outer).abs() - self.holes.iter().map(|h| ring_area(h).abs()).sum::<f64>()
    }

    /// Bounding box (min, max).
    pub fn bbox(&self) -> (Point, Point) {
        let mut lo = Point::new(f64::INFINITY, f64::INFINITY);
        let mut hi = Point::new(f64::NEG_INFINITY, f64::NEG_INFINITY);
        for p in &self.outer {
            lo = Point::new(lo.x.min(p.x), lo.y.min(p.y));
            hi = Point::new(hi.x.max(p.x), hi.y.max(p.y));
        }
        (lo, hi)
    }

    /// Points of a lattice over the bounding box that fall inside the region: rows `dy` apart,
    /// points `dx` apart in a row, every other row shifted by `dx / 2` when `stagger` (hexagonal).
    pub fn lattice(&self, dx: f64, dy: f64, stagger: bool) -> Vec<Point> {
        let (lo, hi) = self.bbox();
        let mut out = Vec::new();
        let mut y = lo.y + dy / 2.0;
        let mut row = 0usize;
        while y < hi.y {
            let mut x = lo.x + dx / 2.0 + if stagger && row % 2 == 1 { dx / 2.0 } else { 0.0 };
            while x < hi.x {
                let p = Point::new(x, y);
                if self.contains(p) {
                    out.push(p);
                }
                x += dx;
            }
            y += dy;
            row += 1;
        }
        out
    }

    /// Grid samples inside the region (cell centres, spacing `h`) plus samples every `h` along
    /// every ring, so that the boundary is covered too.
    pub fn samples(&self, h: f64) -> Vec<Point> {
        let mut out = self.lattice(h, h, false);
        for ring in std::iter::once(&self.outer).chain(&self.holes) {
            for i in 0..ring.len() {
                let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
                let k = (a.dist(b) / h).ceil().max(1.0) as usize;
                for s in 0..k {
                    let t = s as f64 / k as f64;
                    out.push(Point::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)));
                }
            }
        }
        out
    }
}

fn check_ring(name: &str, ring: &[Point]) -> Result<(), PlanError> {
    if ring.len() < 3 {
        return Err(PlanError::Polygon(format!("{name} needs at least 3 vertices, got {}", ring.len())));
    }
    if let Some(i) = ring.iter().position(|p| !p.is_finite()) {
        return Err(PlanError::Polygon(format!("{name} vertex {} is not finite", i + 1)));
    }
    if let Some(i) = ring.iter().position(|p| p.x.abs() > MAX_COORD || p.y.abs() > MAX_COORD) {
        return Err(PlanError::Polygon(format!("{name} vertex {}: coordinates beyond ±{MAX_COORD:e} are not supported", i + 1)));
    }
    let n = ring.len();
    for i in 0..n {
        for j in i + 1..n {
            let adjacent = j == i + 1 || (i == 0 && j == n - 1);
            let (a, b, c, d) = (ring[i], ring[(i + 1) % n], ring[j], ring[(j + 1) % n]);
            if adjacent {
                // Adjacent edges may only share their common vertex (no fold-back).
                if collinear_overlap(a, b, c, d) {
                    return Err(PlanError::Polygon(format!("{name} folds back on itself at vertex {}", j.max(i) + 1)));
                }
            } else if segments_touch(a, b, c, d) {
                return Err(PlanError::Polygon(format!("{name} is self-intersecting: edges {} and {} cross", i + 1, j + 1)));
            }
        }
    }
    let area = ring_area(ring).abs();
    if !area.is_finite() {
        return Err(PlanError::Polygon(format!("{name}: coordinates too large (area overflows)")));
    }
    if area < 1e-12 {
        return Err(PlanError::Polygon(format!("{name} has zero area")));
    }
    Ok(())
}

fn rings_cross(a: &[Point], b: &[Point]) -> bool {
    (0..a.len()).any(|i| (0..b.len()).any(|j| segments_touch(a[i], a[(i + 1) % a.len()], b[j], b[(j + 1) % b.len()])))
}

/// Shoelace area (signed).
fn ring_area(r: &[Point]) -> f64 {
    let mut s = 0.0;
    for i in 0..r.len() {
        let (a, b) = (r[i], r[(i + 1) % r.len()]);
        s += a.x * b.y - b.x * a.y;
    }
    s / 2.0
}

/// Even-odd containment.
pub fn inside_ring(r: &[Point], p: Point) -> bool {
    let mut inside = false;
    let mut j = r.len() - 1;
    for i in 0..r.len() {
        let (a, b) = (r[i], r[j]);
        if (a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x {
            inside = !inside;
        }
        j = i;
    }
    inside
}

fn orient(a: Point, b: Point, c: Point) -> f64 {
    (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)
}

fn on_segment(a: Point, b: Point, p: Point) -> bool {
    p.x >= a.x.min(b.x) && p.x <= a.x.max(b.x) && p.y >= a.y.min(b.y) && p.y <= a.y.max(b.y)
}

/// Whether segments ab and cd intersect or touch.
fn segments_touch(a: Point, b: Point, c: Point, d: Point) -> bool {
    let (o1, o2, o3, o4) = (orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b));
    if ((o1 > 0.0 && o2 < 0.0) || (o1 < 0.0 && o2 > 0.0)) && ((o3 > 0.0 && o4 < 0.0) || (o3 < 0.0 && o4 > 0.0)) {
        return true;
    }
    (o1 == 0.0 && on_segment(a, b, c)) || (o2 == 0.0 && on_segment(a, b, d)) || (o3 == 0.0 && on_segment(c, d, a)) || (o4 == 0.0 && on_segment(c, d, b))
}

/// Adjacent edges ab and cd (sharing one vertex) overlapping along a line.
fn collinear_overlap(a: Point, b: Point, c: Point, d: Point) -> bool {
    if orient(a, b, c) != 0.0 || orient(a, b, d) != 0.0 {
        return false;
    }
    // Shared vertex: the other two endpoints on the same side means overlap.
    let (shared, p, q) = if b == c {
        (b, a, d)
    } else if a == d {
        (a, b, c)
    } else {
        return true;
    };
    (p.x - shared.x) * (q.x - shared.x) + (p.y - shared.y) * (q.y - shared.y) > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(v: &[(f64, f64)]) -> Vec<Point> {
        v.iter().map(|&(x, y)| Point::new(x, y)).collect()
    }

    #[test]
    fn square_with_hole() {
        let r = Region::new(pts(&[(0., 0.), (10., 0.), (10., 10.), (0., 10.)]), vec![pts(&[(4., 4.), (6., 4.), (6., 6.), (4., 6.)])]).expect("valid");
        assert!((r.area() - 96.0).abs() < 1e-12);
        assert!(r.contains(Point::new(1.0, 1.0)));
        assert!(!r.contains(Point::new(5.0, 5.0)));
        assert!(!r.contains(Point::new(11.0, 5.0)));
        let s = r.samples(0.5);
        assert!(s.iter().filter(|p| r.contains(**p)).count() > 300);
    }

    #[test]
    fn invalid_polygons() {
        let bowtie = pts(&[(0., 0.), (10., 10.), (10., 0.), (0., 10.)]);
        assert!(Region::new(bowtie, vec![]).unwrap_err().to_string().contains("self-intersecting"));
        assert!(Region::new(pts(&[(0., 0.), (1., 1.)]), vec![]).is_err());
        let e = Region::new(pts(&[(0., 0.), (1., 1.), (2., 2.)]), vec![]).unwrap_err().to_string();
        assert!(e.contains("folds back") || e.contains("zero area"), "{e}");
        let sq = pts(&[(0., 0.), (10., 0.), (10., 10.), (0., 10.)]);
        let outside = pts(&[(8., 8.), (12., 8.), (12., 12.)]);
        assert!(Region::new(sq.clone(), vec![outside]).unwrap_err().to_string().contains("not strictly inside"));
        let h1 = pts(&[(2., 2.), (5., 2.), (5., 5.), (2., 5.)]);
        let h2 = pts(&[(4., 4.), (7., 4.), (7., 7.), (4., 7.)]);
        assert!(Region::new(sq.clone(), vec![h1, h2]).unwrap_err().to_string().contains("overlap"));
        let nan = pts(&[(0., 0.), (f64::NAN, 0.), (1., 1.)]);
        assert!(Region::new(nan, vec![]).is_err());
        // Non-convex (L-shape) is fine.
        assert!(Region::new(pts(&[(0., 0.), (10., 0.), (10., 4.), (4., 4.), (4., 10.), (0., 10.)]), vec![]).is_ok());
    }
}

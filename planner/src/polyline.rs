//! A closed route with cumulative arc lengths: positions along it, projections onto it, and the
//! same route timed with the turns a robot makes at its corners.

use crate::geom::Point;

/// A closed polyline with cumulative arc lengths.
#[derive(Debug, Clone)]
pub struct Polyline {
    pub points: Vec<Point>,
    /// `arcs[i]`: arc length from point 0 to point i; `arcs[n]` = total length.
    pub arcs: Vec<f64>,
    pub length: f64,
}

impl Polyline {
    pub fn closed(points: &[Point]) -> Self {
        let lengths: Vec<f64> = (0..points.len()).map(|i| points[i].dist(points[(i + 1) % points.len()])).collect();
        Polyline::closed_with(points, &lengths)
    }

    /// A closed polyline whose segment i (point i to the next) is `lengths[i]` long on its
    /// metric (a graph edge's length); positions within a segment are interpolated in
    /// proportion. Missing or invalid lengths are the straight line's.
    pub fn closed_with(points: &[Point], lengths: &[f64]) -> Self {
        let mut arcs = Vec::with_capacity(points.len() + 1);
        let mut acc = 0.0;
        arcs.push(0.0);
        for i in 0..points.len() {
            let straight = points[i].dist(points[(i + 1) % points.len()]);
            acc += lengths.get(i).copied().filter(|l| l.is_finite() && *l >= 0.0).unwrap_or(straight);
            arcs.push(acc);
        }
        Polyline { points: points.to_vec(), arcs, length: acc }
    }

    /// The point at arc length `s` (taken modulo the length).
    pub fn at(&self, s: f64) -> Point {
        if self.length <= 0.0 {
            return self.points[0];
        }
        let s = s.rem_euclid(self.length);
        let i = match self.arcs.binary_search_by(|a| a.total_cmp(&s)) {
            Ok(i) => i.min(self.points.len() - 1),
            Err(i) => i - 1,
        };
        let (a, b) = (self.points[i], self.points[(i + 1) % self.points.len()]);
        let seg = self.arcs[i + 1] - self.arcs[i];
        let t = if seg > 0.0 { (s - self.arcs[i]) / seg } else { 0.0 };
        Point::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y))
    }

    /// The same closed route timed for a robot driving at `speed` m/s that turns on the spot at
    /// `turn_rate` rad/s wherever its heading changes: each such corner appears twice, joined by
    /// a segment of `speed × angle / turn_rate` metres along which the position stays put. The
    /// arc length of the result is time × `speed`; its points are the route's.
    pub fn with_turns(&self, speed: f64, turn_rate: f64) -> Polyline {
        let n = self.points.len();
        let seg = |i: usize| self.arcs[i + 1] - self.arcs[i];
        let (mut points, mut lengths) = (Vec::with_capacity(2 * n), Vec::with_capacity(2 * n));
        for i in 0..n {
            points.push(self.points[i]);
            // The turn is counted where the robot leaves the corner (a corner drawn twice, with a
            // segment of no length between, turns once).
            let turn = self.turn_at(i).map_or(0.0, |a| speed * a / turn_rate);
            if turn > 1e-9 && turn.is_finite() {
                lengths.push(turn);
                points.push(self.points[i]);
            }
            lengths.push(seg(i));
        }
        Polyline::closed_with(&points, &lengths)
    }

    /// How far the heading turns at point `i`, radians in [0, π]: from the last segment arriving
    /// there to the segment leaving it; None where no segment leaves it (it has no length) or the
    /// whole route is one point.
    fn turn_at(&self, i: usize) -> Option<f64> {
        let n = self.points.len();
        let here = self.points[i];
        let next = self.points[(i + 1) % n];
        if here.dist(next) <= 1e-9 {
            return None;
        }
        let prev = (1..n).map(|k| self.points[(i + n - k) % n]).find(|p| p.dist(here) > 1e-9)?;
        let a_in = (here.y - prev.y).atan2(here.x - prev.x);
        let a_out = (next.y - here.y).atan2(next.x - here.x);
        let d = (a_out - a_in).rem_euclid(std::f64::consts::TAU);
        Some(if d > std::f64::consts::PI { std::f64::consts::TAU - d } else { d })
    }

    /// Arc length of the point of the polyline nearest to `p`.
    pub fn project(&self, p: Point) -> f64 {
        let n = self.points.len();
        let mut best = (f64::INFINITY, 0.0);
        for i in 0..n {
            let (a, b) = (self.points[i], self.points[(i + 1) % n]);
            let (dx, dy) = (b.x - a.x, b.y - a.y);
            let len2 = dx * dx + dy * dy;
            let t = if len2 > 0.0 { (((p.x - a.x) * dx + (p.y - a.y) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
            let q = Point::new(a.x + t * dx, a.y + t * dy);
            let d = q.dist(p);
            if d < best.0 {
                best = (d, self.arcs[i] + t * (self.arcs[i + 1] - self.arcs[i]));
            }
        }
        best.1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_timed_with_its_turns() {
        let square = [Point::new(0.0, 0.0), Point::new(10.0, 0.0), Point::new(10.0, 10.0), Point::new(0.0, 10.0)];
        let p = Polyline::closed(&square);
        // Four quarter turns at 0.5 rad/s, at 2 m/s: π s each, 2π m of arc each.
        let t = p.with_turns(2.0, 0.5);
        let turn = 2.0 * std::f64::consts::FRAC_PI_2 / 0.5;
        assert!((t.length - (40.0 + 4.0 * turn)).abs() < 1e-9, "{}", t.length);
        assert_eq!(t.points.len(), 8, "each corner twice");
        // The robot turns at the start, drives 10 m, stands at the next corner while it turns,
        // then drives on.
        assert_eq!(t.at(0.5 * turn), square[0]);
        assert!((t.at(turn + 5.0).x - 5.0).abs() < 1e-9);
        assert_eq!(t.at(turn + 10.0 + 0.5 * turn), square[1]);
        assert!((t.at(2.0 * turn + 15.0).y - 5.0).abs() < 1e-9);
        // Straight on, and a corner drawn twice, cost nothing more.
        let line = Polyline::closed(&[Point::new(0.0, 0.0), Point::new(5.0, 0.0), Point::new(5.0, 0.0), Point::new(10.0, 0.0)]);
        let timed = line.with_turns(1.0, 1.0);
        // Two half turns (at the ends of the out-and-back), one at 10 and one at 0.
        assert!((timed.length - (20.0 + 2.0 * std::f64::consts::PI)).abs() < 1e-9, "{}", timed.length);
    }
}

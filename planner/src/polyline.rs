//! A closed route with cumulative arc lengths: positions along it, projections onto it, and the
//! same route timed with the way a robot drives its corners.

use crate::corner::Blend;
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

    /// The arc length left at `s` (modulo the length) along a segment whose ends are the same
    /// point — a corner's turn on a route timed [`with_turns`](Self::with_turns) —, 0 elsewhere.
    pub fn still_at(&self, s: f64) -> f64 {
        if self.length <= 0.0 {
            return 0.0;
        }
        let s = s.rem_euclid(self.length);
        let i = self.arcs.partition_point(|a| *a <= s).saturating_sub(1).min(self.points.len() - 1);
        let (a, b) = (self.points[i], self.points[(i + 1) % self.points.len()]);
        if a.dist(b) > 1e-9 {
            return 0.0;
        }
        (self.arcs[i + 1] - s).max(0.0)
    }

    /// The same closed route timed for a robot driving at `speed` m/s that turns at most
    /// `turn_rate` rad/s: it rounds a corner on an arc where it can ([`Blend`]) and turns on the
    /// spot where it cannot (a U-turn). Each corner appears twice, joined by a segment of
    /// `speed ×` the corner's extra time (the arc's time, less the time of the legs' ends it
    /// cuts; a turn on the spot's time) along which the position stays put; an arc quicker than
    /// the legs it cuts shortens the leg after it instead. A segment's time is its length on
    /// the route's metric (a graph edge's) ÷ `speed`, a cut end's in proportion. The arc length
    /// of the result is time × `speed`; its points are the route's.
    pub fn with_turns(&self, speed: f64, turn_rate: f64) -> Polyline {
        let n = self.points.len();
        let seg = |i: usize| self.arcs[i + 1] - self.arcs[i];
        // Metric length per straight metre of segment i (1 for a straight segment).
        let pace = |i: usize| {
            let straight = self.points[i].dist(self.points[(i + 1) % n]);
            if straight > 1e-9 {
                seg(i) / straight
            } else {
                1.0
            }
        };
        let (mut points, mut lengths) = (Vec::with_capacity(2 * n), Vec::with_capacity(2 * n));
        for i in 0..n {
            points.push(self.points[i]);
            // The turn is counted where the robot leaves the corner (a corner drawn twice, with a
            // segment of no length between, turns once).
            let extra = self.corner_at(i).map_or(0.0, |c| {
                let (pace_in, pace_out) = (pace(c.from), pace(i));
                match Blend::through(c.angle, c.leg_in / 2.0, c.leg_out / 2.0, (speed / pace_in, speed / pace_out), turn_rate) {
                    Some(b) => speed * b.seconds() - b.tangent * (pace_in + pace_out),
                    None => speed * c.angle / turn_rate,
                }
            });
            if extra > 1e-9 && extra.is_finite() {
                lengths.push(extra);
                points.push(self.points[i]);
            }
            let cut = if extra < 0.0 && extra.is_finite() { extra } else { 0.0 };
            lengths.push((seg(i) + cut).max(0.0));
        }
        Polyline::closed_with(&points, &lengths)
    }

    /// The corner at point `i`: how far the heading turns there, from the last segment arriving
    /// to the segment leaving; None where no segment leaves it (it has no length) or the whole
    /// route is one point.
    fn corner_at(&self, i: usize) -> Option<Corner> {
        let n = self.points.len();
        let here = self.points[i];
        let next = self.points[(i + 1) % n];
        if here.dist(next) <= 1e-9 {
            return None;
        }
        let from = (1..n).map(|k| (i + n - k) % n).find(|&k| self.points[k].dist(here) > 1e-9)?;
        let prev = self.points[from];
        let a_in = (here.y - prev.y).atan2(here.x - prev.x);
        let a_out = (next.y - here.y).atan2(next.x - here.x);
        let d = (a_out - a_in).rem_euclid(std::f64::consts::TAU);
        let angle = if d > std::f64::consts::PI { std::f64::consts::TAU - d } else { d };
        Some(Corner { angle, from, leg_in: prev.dist(here), leg_out: here.dist(next) })
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

/// A corner of a route.
struct Corner {
    /// Heading change, radians in [0, π].
    angle: f64,
    /// The point the leg arriving at the corner starts from (its segment is the one from there).
    from: usize,
    /// Straight lengths of the legs arriving and leaving, metres.
    leg_in: f64,
    leg_out: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_time_left_in_a_turn() {
        // Out and back at 1 m/s, turning at 1 rad/s: π at each end, where the position stays.
        let timed = Polyline::closed(&[Point::new(0.0, 0.0), Point::new(10.0, 0.0)]).with_turns(1.0, 1.0);
        let pi = std::f64::consts::PI;
        assert!((timed.length - (20.0 + 2.0 * pi)).abs() < 1e-9);
        for (s, left) in [(0.0, pi), (1.0, pi - 1.0), (pi, 0.0), (5.0, 0.0), (10.0 + pi, pi), (10.0 + 1.5 * pi, 0.5 * pi), (15.0 + 2.0 * pi, 0.0)] {
            assert!((timed.still_at(s) - left).abs() < 1e-9, "at {s}: {} not {left}", timed.still_at(s));
        }
        assert!((timed.still_at(timed.length + 1.0) - (pi - 1.0)).abs() < 1e-9, "modulo the length");
    }

    #[test]
    fn a_square_timed_with_its_rounded_corners() {
        let square = [Point::new(0.0, 0.0), Point::new(10.0, 0.0), Point::new(10.0, 10.0), Point::new(0.0, 10.0)];
        let p = Polyline::closed(&square);
        // Four quarter turns rounded at 0.5 rad/s: each arc takes the turn's π s at 0.12 m/s and
        // cuts 0.24 m of each leg; at 2 m/s, 2π m of time-length less the two cut ends.
        let t = p.with_turns(2.0, 0.5);
        let b = Blend::through(std::f64::consts::FRAC_PI_2, 5.0, 5.0, (2.0, 2.0), 0.5).expect("rounded");
        let corner = 2.0 * b.seconds() - 2.0 * b.tangent;
        assert!((b.seconds() - std::f64::consts::PI).abs() < 1e-9);
        assert!((t.length - (40.0 + 4.0 * corner)).abs() < 1e-9, "{}", t.length);
        assert_eq!(t.points.len(), 8, "each corner twice");
        // The robot rounds the start, drives 10 m (less the cut ends), stands (in the model) at
        // the next corner while it rounds it, then drives on.
        assert_eq!(t.at(0.5 * corner), square[0]);
        assert!((t.at(corner + 5.0).x - 5.0).abs() < 1e-9);
        assert_eq!(t.at(corner + 10.0 + 0.5 * corner), square[1]);
        // Straight on, and a corner drawn twice, cost nothing more; a U-turn is turned on the
        // spot.
        let line = Polyline::closed(&[Point::new(0.0, 0.0), Point::new(5.0, 0.0), Point::new(5.0, 0.0), Point::new(10.0, 0.0)]);
        let timed = line.with_turns(1.0, 1.0);
        // Two half turns (at the ends of the out-and-back), one at 10 and one at 0.
        assert!((timed.length - (20.0 + 2.0 * std::f64::consts::PI)).abs() < 1e-9, "{}", timed.length);
        // A gentle bend at full speed is quicker than its legs: the leg after it is shortened.
        let bend = Polyline::closed(&[Point::new(0.0, 0.0), Point::new(10.0, 0.0), Point::new(20.0, 1.0), Point::new(10.0, 5.0)]);
        let timed = bend.with_turns(1.0, 3.0);
        let b = Blend::through(0.1f64.atan(), 5.0, 101f64.sqrt() / 2.0, (1.0, 1.0), 3.0).expect("rounded");
        assert!(b.seconds() < 2.0 * b.tangent);
        let k = timed.points.iter().position(|q| *q == bend.points[1]).expect("the bend");
        assert_eq!(timed.points[k + 1], bend.points[2], "no time standing at the bend");
        let after = timed.arcs[k + 1] - timed.arcs[k];
        assert!((after - (101f64.sqrt() - (2.0 * b.tangent - b.seconds()))).abs() < 1e-9, "{after}");
    }
}

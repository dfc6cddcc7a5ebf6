//! Closed patrol tours (travelling salesman) through points in the plane.
//!
//! [`solve`] builds a tour by greedy-edge construction, improves it with 2-opt and Or-opt moves
//! over neighbour lists with a queue of active cities (don't-look bits), then runs an iterated
//! local search with segment double-bridge kicks until its [`Budget`] runs out. Up to
//! [`EXACT_MAX`] points it solves exactly (Held-Karp). No clock inside: the caller bounds the
//! search with a kick count and an optional stop predicate; the same seed and kick count give the
//! same tour.

mod construct;
mod exact;
mod local;

use crate::error::PlanError;
use crate::geom::{check_finite, Point};

pub use local::Stats;

/// Up to this many points the tour is exact.
pub const EXACT_MAX: usize = 12;

/// How distances are measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Metric {
    /// Plain Euclidean distance (robots in the plane).
    Euclidean,
    /// TSPLIB EUC_2D: Euclidean distance rounded to the nearest integer.
    EucRound,
    /// TSPLIB CEIL_2D: Euclidean distance rounded up.
    Ceil,
    /// TSPLIB ATT: pseudo-Euclidean.
    Att,
    /// Given distances (shortest paths on a map): [`Instance::with_matrix`].
    Matrix,
}

/// Points plus the metric that measures them.
#[derive(Debug, Clone)]
pub struct Instance {
    pub points: Vec<Point>,
    pub metric: Metric,
    /// With [`Metric::Matrix`]: `n × n` distances, row-major.
    matrix: Option<std::sync::Arc<[f64]>>,
}

impl Instance {
    /// Validates the points (non-empty, finite).
    pub fn new(points: Vec<Point>, metric: Metric) -> Result<Self, PlanError> {
        check_finite(&points)?;
        check_span(&points)?;
        if metric == Metric::Matrix {
            return Err(PlanError::Invalid("a matrix instance is made with Instance::with_matrix".into()));
        }
        Ok(Instance { points, metric, matrix: None })
    }

    /// An instance measured by `matrix` (`n × n`, row-major, symmetric, finite, not negative);
    /// the points are where the cities are, for the neighbour lists' ties and for display.
    pub fn with_matrix(points: Vec<Point>, matrix: Vec<f64>) -> Result<Self, PlanError> {
        check_finite(&points)?;
        let n = points.len();
        if matrix.len() != n * n {
            return Err(PlanError::Costs(format!("{} distances for {n} points", matrix.len())));
        }
        if let Some(i) = matrix.iter().position(|d| !(d.is_finite() && *d >= 0.0)) {
            return Err(PlanError::Costs(format!("distance from {} to {} is {}", i / n, i % n, matrix[i])));
        }
        Ok(Instance { points, metric: Metric::Matrix, matrix: Some(matrix.into()) })
    }

    pub fn len(&self) -> usize {
        self.points.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Distance between points `i` and `j`.
    #[inline]
    pub fn d(&self, i: usize, j: usize) -> f64 {
        if let Some(m) = &self.matrix {
            return m[i * self.points.len() + j];
        }
        let (a, b) = (self.points[i], self.points[j]);
        let (dx, dy) = (a.x - b.x, a.y - b.y);
        match self.metric {
            Metric::Matrix => f64::NAN,
            Metric::Euclidean => (dx * dx + dy * dy).sqrt(),
            Metric::EucRound => ((dx * dx + dy * dy).sqrt() + 0.5).floor(),
            Metric::Ceil => (dx * dx + dy * dy).sqrt().ceil(),
            Metric::Att => {
                let r = ((dx * dx + dy * dy) / 10.0).sqrt();
                let t = r.round();
                if t < r {
                    t + 1.0
                } else {
                    t
                }
            }
        }
    }

    /// Length of a closed tour given as a visiting order.
    pub fn tour_length(&self, order: &[usize]) -> f64 {
        if order.len() < 2 {
            return 0.0;
        }
        let mut len = 0.0;
        for w in order.windows(2) {
            len += self.d(w[0], w[1]);
        }
        len + self.d(order[order.len() - 1], order[0])
    }
}

/// A closed tour: the visiting order (a permutation of the point indices, starting at 0) and
/// its length.
#[derive(Debug, Clone, PartialEq)]
pub struct Tour {
    pub order: Vec<usize>,
    pub length: f64,
}

/// How long the search may run.
pub struct Budget<'a> {
    /// Maximum number of kicks of the iterated local search.
    pub max_kicks: u64,
    /// Checked every few kicks; the search stops when it returns true (e.g. a wall-clock limit).
    pub stop: Option<&'a dyn Fn() -> bool>,
    /// Seed of the kicks.
    pub seed: u64,
}

impl Default for Budget<'_> {
    fn default() -> Self {
        Budget { max_kicks: 20_000, stop: None, seed: 1 }
    }
}

/// Solves the tour within the budget. Exact for up to [`EXACT_MAX`] points.
pub fn solve(inst: &Instance, budget: &Budget) -> Result<(Tour, Stats), PlanError> {
    check_finite(&inst.points)?;
    check_span(&inst.points)?;
    let n = inst.len();
    if n <= 3 {
        let order: Vec<usize> = (0..n).collect();
        let length = inst.tour_length(&order);
        return Ok((Tour { order, length }, Stats::default()));
    }
    if n <= EXACT_MAX {
        let order = exact::held_karp(inst);
        let length = inst.tour_length(&order);
        return Ok((Tour { order, length }, Stats::default()));
    }
    let start = construct::greedy(inst, &local::neighbours(inst, local::K));
    let (order, stats) = local::optimise(inst, start, budget);
    let order = rotate_to_zero(order);
    let length = inst.tour_length(&order);
    Ok((Tour { order, length }, stats))
}

/// Rejects point sets whose distances would overflow (a tour length must be finite).
fn check_span(points: &[Point]) -> Result<(), PlanError> {
    let (mut lo, mut hi) = (Point::new(f64::INFINITY, f64::INFINITY), Point::new(f64::NEG_INFINITY, f64::NEG_INFINITY));
    for p in points {
        lo = Point::new(lo.x.min(p.x), lo.y.min(p.y));
        hi = Point::new(hi.x.max(p.x), hi.y.max(p.y));
    }
    let span = (hi.x - lo.x).hypot(hi.y - lo.y);
    if span.is_finite() && span * (points.len() as f64) < f64::MAX / 4.0 && (hi.x - lo.x).powi(2).is_finite() && (hi.y - lo.y).powi(2).is_finite() {
        Ok(())
    } else {
        Err(PlanError::Invalid("coordinates span too large a range: distances would overflow".into()))
    }
}

/// Checks that `order` is a permutation of 0..n.
pub fn is_permutation(order: &[usize], n: usize) -> bool {
    if order.len() != n {
        return false;
    }
    let mut seen = vec![false; n];
    order.iter().all(|&c| c < n && !std::mem::replace(&mut seen[c], true))
}

fn rotate_to_zero(mut order: Vec<usize>) -> Vec<usize> {
    if let Some(p) = order.iter().position(|&c| c == 0) {
        order.rotate_left(p);
    }
    order
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// `n` uniform random points in a `side` × `side` square (shared by the tsp tests).
    pub(crate) fn random_instance(n: usize, seed: u64, side: f64) -> Instance {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let pts = (0..n).map(|_| Point::new(rng.gen_range(0.0..side), rng.gen_range(0.0..side))).collect();
        Instance::new(pts, Metric::Euclidean).expect("valid")
    }

    fn random(n: usize, seed: u64) -> Instance {
        random_instance(n, seed, 100.0)
    }

    #[test]
    fn exact_matches_brute_force() {
        for seed in 0..20 {
            let inst = random(7, seed);
            let (t, _) = solve(&inst, &Budget::default()).expect("tour");
            let brute = brute_force(&inst);
            assert!((t.length - brute).abs() < 1e-9, "seed {seed}: {} vs {brute}", t.length);
        }
    }

    #[test]
    fn heuristic_reaches_the_exact_optimum_on_small_instances() {
        // 12 points: exact; compare the heuristic engine on the same points.
        for seed in 0..10 {
            let inst = random(12, seed);
            let opt = inst.tour_length(&exact::held_karp(&inst));
            let start = construct::greedy(&inst, &local::neighbours(&inst, local::K));
            let (order, _) = local::optimise(&inst, start, &Budget { max_kicks: 300, stop: None, seed });
            assert!(is_permutation(&order, 12));
            let len = inst.tour_length(&order);
            assert!(len <= opt * 1.0 + 1e-9, "seed {seed}: {len} vs optimum {opt}");
        }
    }

    #[test]
    fn same_seed_same_tour() {
        let inst = random(200, 3);
        let b = Budget { max_kicks: 500, stop: None, seed: 9 };
        let (a, _) = solve(&inst, &b).expect("a");
        let (c, _) = solve(&inst, &b).expect("c");
        assert_eq!(a, c);
        assert!(is_permutation(&a.order, 200));
        assert_eq!(a.order[0], 0);
    }

    #[test]
    fn tiny_and_bad_inputs() {
        assert_eq!(Instance::new(vec![], Metric::Euclidean).unwrap_err(), PlanError::Empty);
        assert!(matches!(Instance::new(vec![Point::new(f64::NAN, 0.0)], Metric::Euclidean), Err(PlanError::NonFinite { index: 0, .. })));
        let inst = Instance::new(vec![Point::new(0.0, 0.0), Point::new(3.0, 4.0)], Metric::Euclidean).expect("two");
        let (t, _) = solve(&inst, &Budget::default()).expect("tour");
        assert_eq!(t.length, 10.0);
        // Duplicates are fine for the core solver.
        let inst = Instance::new(vec![Point::new(1.0, 1.0); 20], Metric::Euclidean).expect("dups");
        let (t, _) = solve(&inst, &Budget::default()).expect("tour");
        assert_eq!(t.length, 0.0);
        assert!(is_permutation(&t.order, 20));
    }

    #[test]
    fn stop_predicate_is_honoured() {
        let inst = random(300, 1);
        let calls = std::cell::Cell::new(0u32);
        let stop = || {
            calls.set(calls.get() + 1);
            calls.get() > 2
        };
        let (_, stats) = solve(&inst, &Budget { max_kicks: u64::MAX, stop: Some(&stop), seed: 1 }).expect("tour");
        assert!(stats.kicks < 1000, "stopped early: {}", stats.kicks);
    }

    fn brute_force(inst: &Instance) -> f64 {
        let n = inst.len();
        let mut rest: Vec<usize> = (1..n).collect();
        let mut best = f64::INFINITY;
        permute(&mut rest, 0, &mut |p| {
            let mut order = vec![0];
            order.extend_from_slice(p);
            best = best.min(inst.tour_length(&order));
        });
        best
    }

    fn permute(v: &mut Vec<usize>, k: usize, f: &mut dyn FnMut(&[usize])) {
        if k == v.len() {
            f(v);
            return;
        }
        for i in k..v.len() {
            v.swap(k, i);
            permute(v, k + 1, f);
            v.swap(k, i);
        }
    }
}

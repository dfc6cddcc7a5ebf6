//! Blanket coverage: place n robots in a region so that every point is close to some robot
//! (minimise the coverage radius), then assign robots to the points.
//!
//! Method: the region is sampled on a grid (plus its boundary); robots start on a hexagonal
//! lattice sized for n; Lloyd iterations move each robot to the centroid of its Voronoi cell
//! (centroidal Voronoi tessellation); then minimax iterations move each robot to the centre of
//! the smallest circle enclosing its cell, which shrinks the coverage radius directly. The best
//! configuration seen is kept. Points that would leave a non-convex region snap to the cell's
//! sample nearest to them. The reference is the hexagonal covering bound `√(2A / (3√3 n))`.

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::assign::{self, Costs};
use crate::error::PlanError;
use crate::geom::Point;
use crate::limits;
use crate::region::Region;
use mrmm_proto::plan::{RobotPlan, RobotSpec, Step};

/// Coverage parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CoverageParams {
    pub region: Region,
    /// Approximate number of interior samples.
    #[serde(default = "default_samples")]
    pub samples: usize,
    #[serde(default = "default_iterations")]
    pub lloyd_iterations: usize,
    #[serde(default = "default_iterations")]
    pub minimax_iterations: usize,
    #[serde(default = "default_seed")]
    pub seed: u64,
}

fn default_samples() -> usize {
    6000
}
fn default_iterations() -> usize {
    40
}
fn default_seed() -> u64 {
    1
}

impl CoverageParams {
    pub fn new(region: Region) -> Self {
        CoverageParams {
            region,
            samples: default_samples(),
            lloyd_iterations: default_iterations(),
            minimax_iterations: default_iterations(),
            seed: default_seed(),
        }
    }
}

/// A coverage plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CoveragePlan {
    /// The region covered.
    pub region: Region,
    pub points: Vec<Point>,
    /// Largest distance from a sample of the region to its nearest robot, metres.
    pub coverage_radius: f64,
    /// Hexagonal covering bound for this area and n.
    pub hexagonal_bound: f64,
    /// Time until the last robot is in place, s.
    pub formation_time: f64,
    pub plans: Vec<RobotPlan>,
    /// Robots left out: no point is within their battery's reach (`RobotSpec::reach_m`). The
    /// points are the others'.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub held: Vec<mrmm_proto::RobotId>,
}

/// Plans coverage of `params.region` by `robots`.
pub fn plan(params: &CoverageParams, robots: &[RobotSpec]) -> Result<CoveragePlan, PlanError> {
    let vertices = params.region.outer.len() + params.region.holes.iter().map(Vec::len).sum::<usize>();
    limits::at_most("region vertices", vertices, limits::MAX_REGION_VERTICES)?;
    limits::at_most("region holes", params.region.holes.len(), limits::MAX_HOLES)?;
    limits::at_most("robots", robots.len(), limits::MAX_ROBOTS)?;
    for (what, v, max) in [
        ("samples", params.samples as u64, limits::MAX_SAMPLES),
        ("lloyd_iterations", params.lloyd_iterations as u64, limits::MAX_ITERATIONS),
        ("minimax_iterations", params.minimax_iterations as u64, limits::MAX_ITERATIONS),
    ] {
        if v > max {
            return Err(PlanError::Invalid(format!("{what}: {v} given, at most {max}")));
        }
    }
    for p in params.region.outer.iter().chain(params.region.holes.iter().flatten()) {
        limits::coordinate("region vertex", p.x, p.y)?;
    }
    let region = params.region.clone().validated()?;
    crate::plan::check(robots)?;
    let mut team = robots.to_vec();
    let mut held = Vec::new();
    loop {
        let (points, radius) = place(&region, team.len(), params)?;
        let (a, short) = assign_points(&team, &points)?;
        let everyone = short.len() == team.len();
        held.extend(short.iter().map(|&i| team[i].id.clone()));
        if !short.is_empty() && !everyone {
            crate::plan::drop_at(&mut team, &short);
            continue;
        }
        let plans = if everyone { vec![] } else { plans_to(&team, &a.slot, &points) };
        let formation_time = if everyone { 0.0 } else { a.max };
        return Ok(CoveragePlan {
            hexagonal_bound: hexagonal_bound(region.area(), team.len()),
            region,
            points,
            coverage_radius: radius,
            formation_time,
            plans,
            held,
        });
    }
}

/// The robots assigned to the points (bottleneck of driving times, a point beyond a robot's
/// reach costing [`crate::plan::BEYOND_REACH_S`] more), and which robots got a point beyond
/// their reach.
fn assign_points(robots: &[RobotSpec], points: &[Point]) -> Result<(assign::Assignment, Vec<usize>), PlanError> {
    let rows: Vec<Vec<f64>> = robots
        .iter()
        .map(|r| {
            points
                .iter()
                .map(|p| {
                    let d = p.dist(Point::new(r.x, r.y));
                    d / r.speed + if r.reach_m.is_some_and(|m| d > m) { crate::plan::BEYOND_REACH_S } else { 0.0 }
                })
                .collect()
        })
        .collect();
    let a = assign::bottleneck(&Costs::from_rows(&rows)?);
    let short = a.slot.iter().enumerate().filter(|&(i, &k)| rows[i][k] >= crate::plan::BEYOND_REACH_S).map(|(i, _)| i).collect();
    Ok((a, short))
}

/// Each robot drives to its point and holds there.
fn plans_to(robots: &[RobotSpec], slots: &[usize], points: &[Point]) -> Vec<RobotPlan> {
    robots
        .iter()
        .zip(slots)
        .map(|(r, &slot)| RobotPlan {
            robot: r.id.clone(),
            robot_type: r.robot_type.clone(),
            slot,
            steps: vec![Step::Stream, Step::Navigate { x: points[slot].x, y: points[slot].y, speed: None }, Step::Hold { seconds: None }],
            team: String::new(),
        })
        .collect()
}

/// The covering radius of a hexagonal arrangement of n disks over area `area`.
pub fn hexagonal_bound(area: f64, n: usize) -> f64 {
    (2.0 * area / (3.0 * 3f64.sqrt() * n as f64)).sqrt()
}

/// Places n points; returns them with their coverage radius.
pub fn place(region: &Region, n: usize, params: &CoverageParams) -> Result<(Vec<Point>, f64), PlanError> {
    if n == 0 {
        return Err(PlanError::Invalid("no robots".into()));
    }
    let area = region.area();
    // Grid spacing from the bounding box, not the area, and never below longest side / samples:
    // at most `samples` grid points and `samples` per ring edge, for any shape.
    let (lo, hi) = region.bbox();
    let m = params.samples.clamp(100, 1_000_000) as f64;
    let (w, t) = (hi.x - lo.x, hi.y - lo.y);
    let h = (w * t / m).sqrt().max(w.max(t) / m);
    if !(h.is_finite() && h > 0.0) {
        return Err(PlanError::Polygon("region cannot be sampled (degenerate or too large)".into()));
    }
    let samples = region.samples(h);
    if samples.is_empty() {
        return Err(PlanError::Polygon("region too small to sample".into()));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    let mut gens = hex_start(region, n, area, &samples, &mut rng);
    let mut owner = vec![0usize; samples.len()];
    let mut best = (radius(&samples, &gens, &mut owner), gens.clone());
    for _ in 0..params.lloyd_iterations {
        let r = radius(&samples, &gens, &mut owner);
        if r < best.0 {
            best = (r, gens.clone());
        }
        let mut sum = vec![(0.0, 0.0, 0usize); n];
        for (s, &o) in samples.iter().zip(&owner) {
            sum[o].0 += s.x;
            sum[o].1 += s.y;
            sum[o].2 += 1;
        }
        for (g, (sx, sy, c)) in gens.iter_mut().zip(sum) {
            if c > 0 {
                *g = Point::new(sx / c as f64, sy / c as f64);
            }
        }
        snap_inside(region, &samples, &mut gens);
    }
    let mut cells: Vec<Vec<Point>> = vec![Vec::new(); n];
    for _ in 0..params.minimax_iterations {
        let r = radius(&samples, &gens, &mut owner);
        if r < best.0 {
            best = (r, gens.clone());
        }
        cells.iter_mut().for_each(Vec::clear);
        for (s, &o) in samples.iter().zip(&owner) {
            cells[o].push(*s);
        }
        for (g, cell) in gens.iter_mut().zip(cells.iter_mut()) {
            if !cell.is_empty() {
                let (c, _) = enclosing_circle(cell, &mut rng);
                // Move part of the way: full jumps oscillate between neighbouring cells.
                *g = Point::new(g.x + 0.5 * (c.x - g.x), g.y + 0.5 * (c.y - g.y));
            }
        }
        snap_inside(region, &samples, &mut gens);
    }
    let r = radius(&samples, &gens, &mut owner);
    if r < best.0 {
        best = (r, gens);
    }
    Ok((best.1, best.0))
}

/// Hexagonal lattice with about n points inside, completed or thinned to exactly n.
fn hex_start(region: &Region, n: usize, area: f64, samples: &[Point], rng: &mut ChaCha8Rng) -> Vec<Point> {
    let lattice = |d: f64| region.lattice(d, d * 3f64.sqrt() / 2.0, true);
    let mut d = (2.0 * area / (3f64.sqrt() * n as f64)).sqrt();
    let mut pts = lattice(d);
    for _ in 0..20 {
        if pts.len() == n {
            break;
        }
        d *= (pts.len().max(1) as f64 / n as f64).sqrt().clamp(0.8, 1.25);
        pts = lattice(d);
    }
    pts.shuffle(rng);
    pts.truncate(n);
    while pts.len() < n {
        if let Some(s) = samples.choose(rng) {
            pts.push(*s);
        }
    }
    pts
}

/// Coverage radius of `gens` over the samples; fills each sample's nearest generator.
fn radius(samples: &[Point], gens: &[Point], owner: &mut [usize]) -> f64 {
    let mut worst: f64 = 0.0;
    for (s, o) in samples.iter().zip(owner.iter_mut()) {
        let mut best = (f64::INFINITY, 0);
        for (i, g) in gens.iter().enumerate() {
            let d = (s.x - g.x).powi(2) + (s.y - g.y).powi(2);
            if d < best.0 {
                best = (d, i);
            }
        }
        *o = best.1;
        worst = worst.max(best.0);
    }
    worst.sqrt()
}

fn snap_inside(region: &Region, samples: &[Point], gens: &mut [Point]) {
    for g in gens.iter_mut() {
        if !region.contains(*g) {
            let nearest = samples.iter().filter(|s| region.contains(**s)).min_by(|a, b| a.dist(*g).total_cmp(&b.dist(*g)));
            if let Some(s) = nearest {
                *g = *s;
            }
        }
    }
}

/// Smallest enclosing circle (Welzl, iterative, expected linear time).
pub fn enclosing_circle(pts: &mut [Point], rng: &mut ChaCha8Rng) -> (Point, f64) {
    pts.shuffle(rng);
    let inside = |c: Point, r: f64, p: Point| c.dist(p) <= r * (1.0 + 1e-12) + 1e-12;
    let mut c = pts[0];
    let mut r = 0.0;
    for i in 1..pts.len() {
        if inside(c, r, pts[i]) {
            continue;
        }
        c = pts[i];
        r = 0.0;
        for j in 0..i {
            if inside(c, r, pts[j]) {
                continue;
            }
            c = Point::new((pts[i].x + pts[j].x) / 2.0, (pts[i].y + pts[j].y) / 2.0);
            r = pts[i].dist(pts[j]) / 2.0;
            for k in 0..j {
                if inside(c, r, pts[k]) {
                    continue;
                }
                (c, r) = circumcircle(pts[i], pts[j], pts[k]);
            }
        }
    }
    (c, r)
}

fn circumcircle(a: Point, b: Point, c: Point) -> (Point, f64) {
    let d = 2.0 * (a.x * (b.y - c.y) + b.x * (c.y - a.y) + c.x * (a.y - b.y));
    if d.abs() < 1e-12 {
        // Collinear: the circle on the farthest pair.
        let pairs = [(a, b), (a, c), (b, c)];
        let (p, q) = pairs.into_iter().max_by(|x, y| x.0.dist(x.1).total_cmp(&y.0.dist(y.1))).unwrap_or((a, b));
        return (Point::new((p.x + q.x) / 2.0, (p.y + q.y) / 2.0), p.dist(q) / 2.0);
    }
    let (a2, b2, c2) = (a.x * a.x + a.y * a.y, b.x * b.x + b.y * b.y, c.x * c.x + c.y * c.y);
    let ux = (a2 * (b.y - c.y) + b2 * (c.y - a.y) + c2 * (a.y - b.y)) / d;
    let uy = (a2 * (c.x - b.x) + b2 * (a.x - c.x) + c2 * (b.x - a.x)) / d;
    let center = Point::new(ux, uy);
    (center, center.dist(a))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(v: &[(f64, f64)]) -> Vec<Point> {
        v.iter().map(|&(x, y)| Point::new(x, y)).collect()
    }

    fn robots(n: usize) -> Vec<RobotSpec> {
        (0..n)
            .map(|i| RobotSpec { id: format!("r{i}").into(), robot_type: "ground".into(), x: i as f64, y: -5.0, speed: 1.0, turn_rate: None, reach_m: None })
            .collect()
    }

    #[test]
    fn square_coverage_is_close_to_the_hexagonal_bound() {
        let region = Region::new(pts(&[(0., 0.), (100., 0.), (100., 100.), (0., 100.)]), vec![]).expect("region");
        for n in [1usize, 4, 9, 16] {
            let p = plan(&CoverageParams::new(region.clone()), &robots(n)).expect("plan");
            assert_eq!(p.points.len(), n);
            assert!(p.points.iter().all(|q| region.contains(*q)));
            assert!(p.coverage_radius >= p.hexagonal_bound * 0.99, "n={n}: below the bound?");
            // Within 40 % of the hexagonal bound (boundary effects dominate for small n).
            assert!(p.coverage_radius <= p.hexagonal_bound * 1.4, "n={n}: {} vs bound {}", p.coverage_radius, p.hexagonal_bound);
            let mut slots: Vec<usize> = p.plans.iter().map(|r| r.slot).collect();
            slots.sort();
            assert_eq!(slots, (0..n).collect::<Vec<_>>());
        }
        // One robot in a square: the centre, radius half the diagonal.
        let p = plan(&CoverageParams::new(region), &robots(1)).expect("plan");
        assert!((p.coverage_radius - 50.0 * 2f64.sqrt()).abs() < 1.5, "{}", p.coverage_radius);
    }

    #[test]
    fn non_convex_with_hole_keeps_points_inside() {
        let region =
            Region::new(pts(&[(0., 0.), (60., 0.), (60., 20.), (20., 20.), (20., 60.), (0., 60.)]), vec![pts(&[(5., 5.), (12., 5.), (12., 12.), (5., 12.)])])
                .expect("region");
        let p = plan(&CoverageParams::new(region.clone()), &robots(6)).expect("plan");
        assert!(p.points.iter().all(|q| region.contains(*q)), "{:?}", p.points);
        assert!(p.coverage_radius < 25.0, "{}", p.coverage_radius);
    }

    #[test]
    fn enclosing_circle_of_a_square() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut p = pts(&[(0., 0.), (2., 0.), (2., 2.), (0., 2.), (1., 1.)]);
        let (c, r) = enclosing_circle(&mut p, &mut rng);
        assert!((c.x - 1.0).abs() < 1e-9 && (c.y - 1.0).abs() < 1e-9);
        assert!((r - 2f64.sqrt()).abs() < 1e-9);
    }
}

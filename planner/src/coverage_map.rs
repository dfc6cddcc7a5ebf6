//! Blanket coverage on a map: only the map's free space (within the region, if one is given)
//! is covered, and distances are shortest paths, so a robot behind a wall does not cover the
//! room. Method: farthest-first placement (Gonzalez's 2-approximation of the geodesic k-centre),
//! then Lloyd steps (each point to its cell's free point nearest the cell's centroid) and
//! minimax steps (the worst cell's point half way toward its farthest point), keeping the best.
//! On a graph map the points are vertices and the distances run along the edges.

use mrmm_maps::{Node, Space};

use crate::assign::{self, Costs};
use crate::coverage::{hexagonal_bound, CoverageParams, CoveragePlan};
use crate::error::PlanError;
use crate::geom::Point;
use crate::patrol::navigate_through;
use mrmm_proto::plan::{RobotPlan, RobotSpec, Step};

/// Plans coverage of the map's free space in `params.region` by `robots`; with the plan, each
/// robot's route to its point (the corners it drives through, its point last).
pub fn plan_on(params: &CoverageParams, robots: &[RobotSpec], space: &Space) -> Result<(CoveragePlan, Vec<Vec<Point>>), PlanError> {
    crate::plan::check(robots)?;
    let region = params.region.clone().validated()?;
    let robot_nodes = robots.iter().enumerate().map(|(i, r)| space.locate_robot(r.id.as_str(), i, Point::new(r.x, r.y))).collect::<Result<Vec<_>, _>>()?;
    // The free space the robots can get to: closed rooms and pockets between walls are not theirs
    // to cover.
    let reach = space.field_of(&robot_nodes);
    let pts: Vec<Node> =
        (0..space.nodes() as u32).filter_map(|i| space.node_at(i)).filter(|v| region.contains(v.at) && reach.dist[v.entry as usize].is_finite()).collect();
    if pts.is_empty() {
        return Err(PlanError::Invalid("the region holds none of the map's free space that the robots can reach".into()));
    }
    let mut team: Vec<usize> = (0..robots.len()).collect();
    let mut held = Vec::new();
    loop {
        let specs: Vec<RobotSpec> = team.iter().map(|&i| robots[i].clone()).collect();
        let nodes: Vec<Node> = team.iter().map(|&i| robot_nodes[i]).collect();
        let Covered { mut plan, routes, short } = cover(params, space, &region, &pts, &specs, &nodes)?;
        let everyone = short.len() == team.len();
        held.extend(short.iter().map(|&k| specs[k].id.clone()));
        if short.is_empty() || everyone {
            if everyone {
                plan.plans.clear();
                plan.formation_time = 0.0;
            }
            plan.held = held;
            return Ok((plan, if everyone { vec![] } else { routes }));
        }
        crate::plan::drop_at(&mut team, &short);
    }
}

/// One placement: the plan, each robot's route to its point, and which robots (indices) got a
/// point beyond their reach.
struct Covered {
    plan: CoveragePlan,
    routes: Vec<Vec<Point>>,
    short: Vec<usize>,
}

/// Places one point per robot and sends each to one (bottleneck of driving times, a point
/// beyond a robot's reach costing [`crate::plan::BEYOND_REACH_S`] more); the plan, each robot's
/// route, and which robots (indices) got a point beyond their reach.
fn cover(
    params: &CoverageParams,
    space: &Space,
    region: &crate::region::Region,
    pts: &[Node],
    robots: &[RobotSpec],
    robot_nodes: &[Node],
) -> Result<Covered, PlanError> {
    let n = robots.len();
    let (centers, radius) = place(space, pts, n, params.lloyd_iterations.min(30), params.minimax_iterations.min(30));
    if !radius.is_finite() {
        return Err(PlanError::Invalid(format!("the region's free space falls in parts that do not connect on the map: {n} robots cannot cover them all")));
    }
    let d = space.distances(robot_nodes, &centers);
    let beyond = |i: usize, j: usize| robots[i].reach_m.is_some_and(|m| d[i * n + j] > m);
    let rows: Vec<Vec<f64>> = robots
        .iter()
        .enumerate()
        .map(|(i, r)| (0..n).map(|j| d[i * n + j] / r.speed + if beyond(i, j) { crate::plan::BEYOND_REACH_S } else { 0.0 }).collect())
        .collect();
    let a = assign::bottleneck(&Costs::from_rows(&rows)?);
    if !a.max.is_finite() {
        let r = robots.iter().enumerate().find(|(i, _)| !d[i * n + a.slot[*i]].is_finite()).map(|(_, r)| r.id.clone()).unwrap_or_default();
        return Err(PlanError::Invalid(format!("robot {r} cannot reach its point of the coverage on the map")));
    }
    let short: Vec<usize> = (0..n).filter(|&i| beyond(i, a.slot[i])).collect();
    let mut routes = Vec::with_capacity(n);
    let plans = robots
        .iter()
        .enumerate()
        .zip(&a.slot)
        .map(|((i, r), &slot)| {
            let mut route = space.route(&robot_nodes[i], &centers[slot]).unwrap_or_else(|| vec![robot_nodes[i].at, centers[slot].at]);
            route.remove(0);
            let mut steps = vec![Step::Stream];
            steps.extend(navigate_through(&route, None));
            steps.push(Step::Hold { seconds: None });
            routes.push(route);
            RobotPlan { robot: r.id.clone(), robot_type: r.robot_type.clone(), slot, steps, team: String::new() }
        })
        .collect();
    let within = (0..n).filter(|i| !short.contains(i)).map(|i| rows[i][a.slot[i]]).fold(0.0, f64::max);
    let plan = CoveragePlan {
        hexagonal_bound: if space.is_graph() { 0.0 } else { hexagonal_bound(pts.len() as f64 * space.node_area(), n) },
        region: region.clone(),
        points: centers.iter().map(|c| c.at).collect(),
        coverage_radius: radius,
        formation_time: within,
        plans,
        held: vec![],
    };
    Ok(Covered { plan, routes, short })
}

/// Places `n` points on the free nodes `pts`; returns them and their coverage radius (the
/// largest shortest-path distance from a node of `pts` to its nearest point).
fn place(space: &Space, pts: &[Node], n: usize, lloyd: usize, minimax: usize) -> (Vec<Node>, f64) {
    let mean = pts.iter().fold(Point::new(0.0, 0.0), |a, p| Point::new(a.x + p.at.x / pts.len() as f64, a.y + p.at.y / pts.len() as f64));
    let first = *pts.iter().min_by(|a, b| a.at.dist(mean).total_cmp(&b.at.dist(mean))).unwrap_or(&pts[0]);
    let mut centers = vec![first];
    let mut best = space.field(&first, &[]).dist;
    let mut used = vec![false; pts.len()];
    while centers.len() < n {
        let far = (0..pts.len()).filter(|&k| !used[k]).max_by(|&a, &b| best[pts[a].entry as usize].total_cmp(&best[pts[b].entry as usize]).then(b.cmp(&a)));
        let Some(far) = far else { break };
        used[far] = true;
        let c = pts[far];
        let f = space.field(&c, &[]);
        best.iter_mut().zip(&f.dist).for_each(|(b, d)| *b = b.min(*d));
        centers.push(c);
    }
    while centers.len() < n {
        centers.push(centers[centers.len() % centers.len().max(1)]);
    }
    let worst = |centers: &[Node]| -> (f64, Vec<u32>, Vec<f64>) {
        let f = space.field_of(centers);
        let r = pts.iter().map(|p| f.dist[p.entry as usize]).fold(0.0, f64::max);
        (r, f.owner, f.dist)
    };
    let (mut r, mut owner, mut dist) = worst(&centers);
    let mut kept = (r, centers.clone());
    for it in 0..lloyd + minimax {
        let mut cells: Vec<Vec<Node>> = vec![Vec::new(); n];
        for p in pts {
            if let Some(c) = cells.get_mut(owner[p.entry as usize] as usize) {
                c.push(*p);
            }
        }
        if it < lloyd {
            for (c, cell) in centers.iter_mut().zip(&cells) {
                if cell.is_empty() {
                    continue;
                }
                let m = cell.iter().fold(Point::new(0.0, 0.0), |a, p| Point::new(a.x + p.at.x / cell.len() as f64, a.y + p.at.y / cell.len() as f64));
                *c = *cell.iter().min_by(|a, b| a.at.dist(m).total_cmp(&b.at.dist(m))).unwrap_or(c);
            }
        } else {
            // The cell holding the farthest node: its point moves half way toward that node.
            let far = pts.iter().max_by(|a, b| dist[a.entry as usize].total_cmp(&dist[b.entry as usize])).copied();
            if let Some(far) = far {
                let k = owner[far.entry as usize] as usize;
                if let (Some(c), Some(cell)) = (centers.get(k).copied(), cells.get(k)) {
                    let mid = Point::new(0.5 * (c.at.x + far.at.x), 0.5 * (c.at.y + far.at.y));
                    if let Some(m) = cell.iter().min_by(|a, b| a.at.dist(mid).total_cmp(&b.at.dist(mid))) {
                        centers[k] = *m;
                    }
                }
            }
        }
        (r, owner, dist) = worst(&centers);
        if r < kept.0 {
            kept = (r, centers.clone());
        }
    }
    let _ = r;
    (kept.1, kept.0)
}

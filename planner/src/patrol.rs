//! Circular patrol plans: a closed tour through the operator's waypoints, n robots spread
//! uniformly in time along it, assigned to their start slots optimally, with team sync points.
//!
//! Rules:
//! - **Team speed** is the slowest robot's: a circular formation keeps its spacing only if all
//!   robots move at one speed. Predicted worst idleness is then `L / (n · v_min)`; the lower
//!   bound for any strategy is `L / Σ v_i`.
//! - **Slots** sit every `L / n` along the tour. Their common offset is chosen among 0 and each
//!   robot's projection onto the tour (a spread of 16 of them in a larger team), minimising the
//!   time until the last robot is in place, then the total (bottleneck assignment of travel
//!   times).
//! - **Sync points**: `q = n · ⌈L / (n · d_max)⌉` per round, every `L / q` of arc, so sync points
//!   coincide with slots and consecutive ones are at most `d_max` apart. A robot whose speed is
//!   off by a fraction ε drifts at most `ε · d_max` before the next barrier realigns the team,
//!   however long the tour or large the team. Sync point 0 is the start barrier; a round's
//!   points are 1..=q.

use serde::{Deserialize, Serialize};

use crate::error::PlanError;
use crate::geom::{check_distinct, check_finite, Point};
use crate::limits;
use crate::onmap::{self, Approach};
use crate::tsp::{self, Budget, Instance, Metric};
use mrmm_maps::Space;
use mrmm_proto::plan::{RobotPlan, RobotSpec, Step};

pub use crate::polyline::Polyline;

mod slots;

use slots::{slots, Slots};

/// Patrol parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PatrolParams {
    pub waypoints: Vec<Point>,
    /// Largest arc distance between two sync points, metres.
    #[serde(default = "default_sync_spacing")]
    pub sync_spacing_max: f64,
    /// Rounds to patrol; None: until stopped.
    #[serde(default)]
    pub rounds: Option<u32>,
    /// Seed of the tour search.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Kicks of the tour search.
    #[serde(default = "default_kicks")]
    pub max_kicks: u64,
    /// How fast the team's slowest-turning robot turns on the spot, rad/s: slots and sync points
    /// are then spaced by driving time with the turns at the route's corners counted, so that
    /// robots reach each sync point together. None: turns take no time (spacing by arc length).
    #[serde(default)]
    pub turn_rate: Option<f64>,
}

fn default_sync_spacing() -> f64 {
    50.0
}
fn default_seed() -> u64 {
    1
}
fn default_kicks() -> u64 {
    5_000
}

impl PatrolParams {
    pub fn new(waypoints: Vec<Point>) -> Self {
        PatrolParams { waypoints, sync_spacing_max: default_sync_spacing(), rounds: None, seed: default_seed(), max_kicks: default_kicks(), turn_rate: None }
    }
}

/// A patrol plan for a team.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PatrolPlan {
    /// The closed route, in driving order: the waypoints and, on a map, every corner between
    /// them (consecutive points joined by straight free segments or graph edges).
    pub tour: Vec<Point>,
    /// The waypoints in visiting order (where the map put them: a graph's vertices).
    #[serde(default)]
    pub waypoints: Vec<Point>,
    pub length: f64,
    /// Arc offset of slot 0 along the tour (with a turn rate: driving time × team speed, turns
    /// included, as `spacing`).
    pub offset: f64,
    /// Arc distance between consecutive robots (with a turn rate: the time between them × the
    /// team's speed, turns included).
    pub spacing: f64,
    pub team_speed: f64,
    /// Sync points per round.
    pub sync_per_round: u32,
    /// Time until the last robot is at its slot, s.
    pub formation_time: f64,
    /// Predicted worst idleness of a waypoint, s (a round's driving time, turns included, over
    /// the team).
    pub predicted_worst_idleness: f64,
    /// Lower bound of the worst idleness for these robots, s.
    pub idleness_lower_bound: f64,
    /// Per robot: slot, start point and one round.
    #[serde(skip)]
    pub assignments: Vec<PatrolAssignment>,
    /// Plans with the default behaviour ([`PatrolAssignment::default_plan`]).
    pub plans: Vec<RobotPlan>,
    /// Robots left out: their battery's reach (`RobotSpec::reach_m`) is short of the way to every
    /// slot and on to the round's first sync point. The figures are the others'.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub held: Vec<mrmm_proto::RobotId>,
}

/// Plans a patrol of `robots` through `params.waypoints` in the plane.
pub fn plan(params: &PatrolParams, robots: &[RobotSpec]) -> Result<PatrolPlan, PlanError> {
    plan_on(params, robots, None)
}

/// Plans a patrol of `robots` through `params.waypoints`: on `map` (if given) the tour is solved
/// on shortest-path distances and follows the corridors, robots reach their slots along
/// shortest paths; without a map, everything is straight lines in the plane.
///
/// A robot that says how far its battery takes it (`reach_m`) is given no slot it cannot reach
/// and then drive on to the round's first sync point from; one that fits no slot is left out
/// and the patrol planned for the others ([`PatrolPlan::held`]; every robot, with no plans, when
/// none fits).
pub fn plan_on(params: &PatrolParams, robots: &[RobotSpec], map: Option<&Space>) -> Result<PatrolPlan, PlanError> {
    check_params(params, robots)?;
    let (waypoints, tour, route) = route(params, map)?;
    let mut team = robots.to_vec();
    let mut held = Vec::new();
    loop {
        let (mut plan, short) = formation(params, &team, map, &route)?;
        let everyone = short.len() == team.len();
        held.extend(short.iter().map(|&i| team[i].id.clone()));
        if short.is_empty() || everyone {
            if everyone {
                plan.plans.clear();
                plan.assignments.clear();
            }
            return Ok(PatrolPlan { waypoints, tour, held, ..plan });
        }
        crate::plan::drop_at(&mut team, &short);
    }
}

/// The team's formation on `route`: slots, sync points, each robot's assignment and plan (the
/// tour's own points are left for the caller); and which robots (indices into `robots`) were
/// given a slot beyond their reach.
fn formation(params: &PatrolParams, robots: &[RobotSpec], map: Option<&Space>, route: &Polyline) -> Result<(PatrolPlan, Vec<usize>), PlanError> {
    let team_speed = robots.iter().map(|r| r.speed).fold(f64::INFINITY, f64::min);
    // Everything below is spaced along the route timed at the team's speed (its arc length is
    // time × speed): with a turn rate, a corner takes the time of turning there.
    let path = match params.turn_rate {
        Some(w) => route.with_turns(team_speed, w),
        None => route.clone(),
    };
    let (l, n) = (path.length, robots.len());
    let spacing = l / n as f64;
    // Sync points per round: bounded before anything is allocated for them.
    let per_slot_f = (spacing / params.sync_spacing_max).ceil().max(1.0);
    if !per_slot_f.is_finite() || per_slot_f * n as f64 > limits::MAX_SYNC_POINTS as f64 {
        return Err(PlanError::Invalid(format!(
            "sync_spacing_max {} is too small for a tour of {l:.1} m and {n} robots: {per_slot_f:.0} sync points per robot per round (at most {} in all)",
            params.sync_spacing_max,
            limits::MAX_SYNC_POINTS
        )));
    }
    let q = sync_points_per_round(n, per_slot_f as usize, l, params.sync_spacing_max);

    // Slot offset and assignment: travel times to the slots, straight or along the map.
    let approach = Approach::new(map, robots, &path)?;
    let placed = slots(robots, &approach, &path, Slots { spacing, leg: l / q as f64 })?;
    let offset = placed.offset;
    let here = |r: &RobotSpec| Point::new(r.x, r.y);
    let assignments: Vec<PatrolAssignment> = robots
        .iter()
        .enumerate()
        .zip(&placed.slot)
        .map(|((i, r), &slot)| {
            let start_arc = offset + slot as f64 * spacing;
            PatrolAssignment {
                robot: r.id.to_string(),
                robot_type: r.robot_type.clone(),
                slot,
                start: path.at(start_arc),
                approach: approach.route(i, here(r), &path, start_arc),
                start_hold: round_cm(path.still_at(start_arc) / team_speed),
                round: round_steps(&path, start_arc, q, team_speed),
            }
        })
        .collect();
    let plans = assignments.iter().map(|a| a.default_plan(params.rounds)).collect();
    let plan = PatrolPlan {
        length: route.length,
        tour: vec![],
        waypoints: vec![],
        offset,
        spacing,
        team_speed,
        sync_per_round: q as u32,
        formation_time: placed.formation_time,
        predicted_worst_idleness: l / (n as f64 * team_speed),
        idleness_lower_bound: route.length / robots.iter().map(|r| r.speed).sum::<f64>(),
        assignments,
        plans,
        held: vec![],
    };
    Ok((plan, placed.short))
}

/// The patrol's parameters and team, within the planner's limits.
fn check_params(params: &PatrolParams, robots: &[RobotSpec]) -> Result<(), PlanError> {
    let wps = &params.waypoints;
    limits::at_most("waypoints", wps.len(), limits::MAX_WAYPOINTS)?;
    limits::at_most("robots", robots.len(), limits::MAX_ROBOTS)?;
    if params.max_kicks > limits::MAX_KICKS {
        return Err(PlanError::Invalid(format!("max_kicks: {} given, at most {}", params.max_kicks, limits::MAX_KICKS)));
    }
    check_finite(wps)?;
    for w in wps {
        limits::coordinate("waypoint", w.x, w.y)?;
    }
    if wps.len() < 2 {
        return Err(PlanError::TooFewPoints { min: 2, got: wps.len() });
    }
    check_distinct(wps)?;
    crate::plan::check(robots)?;
    if !(params.sync_spacing_max.is_finite() && params.sync_spacing_max > 0.0) {
        return Err(PlanError::Invalid(format!("sync_spacing_max must be positive (got {})", params.sync_spacing_max)));
    }
    if let Some(w) = params.turn_rate {
        limits::turn_rate("turn_rate", w)?;
    }
    Ok(())
}

/// The tour: its waypoints in visiting order, the closed route's corners and the route as a
/// polyline whose arc length is measured on the map's metric (a graph's edges may be longer
/// than the straight lines between their ends).
fn route(params: &PatrolParams, map: Option<&Space>) -> Result<(Vec<Point>, Vec<Point>, Polyline), PlanError> {
    let wps = &params.waypoints;
    let budget = Budget { max_kicks: params.max_kicks, stop: None, seed: params.seed };
    let (waypoints, tour, lengths) = match map {
        None => {
            let inst = Instance::new(wps.clone(), Metric::Euclidean)?;
            let (t, _) = tsp::solve(&inst, &budget)?;
            let tour: Vec<Point> = t.order.iter().map(|&i| wps[i]).collect();
            (tour.clone(), tour, None)
        }
        Some(space) => {
            let t = onmap::tour(space, wps, &budget)?;
            (t.waypoints, t.route, Some(t.lengths))
        }
    };
    limits::at_most("corners of the route", tour.len(), limits::MAX_PLAN_STEPS / 4)?;
    let path = match lengths {
        Some(lens) => Polyline::closed_with(&tour, &lens),
        None => Polyline::closed(&tour),
    };
    Ok((waypoints, tour, path))
}

/// Where one robot starts and what one round is for it.
#[derive(Debug, Clone, PartialEq)]
pub struct PatrolAssignment {
    pub robot: String,
    pub robot_type: String,
    pub slot: usize,
    /// The slot's start point.
    pub start: Point,
    /// The points the robot drives through to its slot, the slot last (straight in the plane;
    /// the route's corners on a map).
    pub approach: Vec<Point>,
    /// Seconds the robot holds after the start barrier: the part of a turn at its slot that the
    /// team's timing counts after the start. It faced its way before it said it was there (the
    /// executor's first barrier), so without the hold it would be that much ahead of its slot's
    /// time for the whole first leg, and the gap behind it that much longer.
    pub start_hold: f64,
    /// One round of the tour from the slot: navigation at team speed with the sync points.
    pub round: Vec<Step>,
}

impl PatrolAssignment {
    /// The default behaviour: stream, go to the slot, start barrier, loop the round.
    pub fn default_plan(&self, rounds: Option<u32>) -> RobotPlan {
        let mut steps = vec![Step::Stream];
        steps.extend(navigate_through(&self.approach, None));
        steps.push(Step::Sync { point: 0, scope: None });
        steps.extend(self.start_hold());
        let to = steps.len();
        steps.extend(self.round.iter().cloned());
        steps.push(Step::Loop { to, rounds });
        RobotPlan { robot: self.robot.as_str().into(), robot_type: self.robot_type.clone(), slot: self.slot, steps, team: String::new() }
    }

    /// The hold after the start barrier, if any ([`Self::start_hold`]).
    pub fn start_hold(&self) -> Option<Step> {
        (self.start_hold > 0.0).then_some(Step::Hold { seconds: Some(self.start_hold) })
    }
}

/// One round of the tour from arc `start`, with barriers 1..=q every `L / q` (the last one at the
/// slot again); point 0 is the start barrier. Barrier `(point, round)` is unique in a plan.
/// Sync points per round beyond which they no longer coincide with the slots.
pub const SYNC_PER_ROUND_CAP: usize = 32;

/// Sync points per round for `n` robots, `per_slot` per slot, on a tour of `l` metres: one or
/// more per slot (`n·per_slot`) up to [`SYNC_PER_ROUND_CAP`]; beyond, the cap, or as many as
/// keep them at most `spacing_max` apart. Every member travels `l/q` between two barriers
/// whatever `q`, so the formation holds either way; what grows with the team is the cost — a
/// round is `q` barriers of `n` members, and each member's plan has `2q` steps — so a large team
/// must not pass a barrier at every slot (150 robots on a 70 m tour: one every 0.47 m, 48 000
/// arrivals a second at 1 m/s).
fn sync_points_per_round(n: usize, per_slot: usize, l: f64, spacing_max: f64) -> usize {
    let at_slots = n * per_slot;
    if at_slots <= SYNC_PER_ROUND_CAP {
        return at_slots;
    }
    SYNC_PER_ROUND_CAP.max((l / spacing_max).ceil() as usize)
}

fn round_steps(path: &Polyline, start: f64, q: usize, speed: f64) -> Vec<Step> {
    let l = path.length;
    let p0 = path.at(start);
    let mut steps = Vec::new();
    // Events along one round, in arc order relative to `start`: tour vertices and sync points.
    let mut events: Vec<(f64, Option<u32>)> = Vec::new();
    for (i, &arc) in path.arcs.iter().enumerate().take(path.points.len()) {
        let rel = (arc - start).rem_euclid(l);
        if rel > 1e-9 && i < path.points.len() {
            events.push((rel, None));
        }
    }
    for j in 1..=q {
        events.push((j as f64 * l / q as f64, Some(j as u32)));
    }
    events.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.is_some().cmp(&b.1.is_some())));
    let mut last: Option<Point> = Some(p0);
    for (rel, sync) in events {
        let p = path.at(start + rel);
        if last.is_none_or(|lp| lp.dist(p) > 1e-9) {
            steps.push(Step::Navigate { x: round_cm(p.x), y: round_cm(p.y), speed: Some(speed) });
            last = Some(p);
        }
        if let Some(point) = sync {
            steps.push(Step::Sync { point, scope: None });
        }
    }
    steps
}

/// One navigate step per point of a route.
pub fn navigate_through(points: &[Point], speed: Option<f64>) -> impl Iterator<Item = Step> + '_ {
    points.iter().map(move |p| Step::Navigate { x: p.x, y: p.y, speed })
}

fn round_cm(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(super) fn square() -> Vec<Point> {
        vec![Point::new(0.0, 0.0), Point::new(40.0, 0.0), Point::new(40.0, 40.0), Point::new(0.0, 40.0)]
    }

    pub(super) fn robot(id: &str, x: f64, y: f64, speed: f64) -> RobotSpec {
        RobotSpec { id: id.into(), robot_type: "ground".into(), x, y, speed, turn_rate: None, reach_m: None }
    }

    #[test]
    fn four_robots_on_a_square() {
        let robots = vec![robot("a", 0.0, 0.0, 1.0), robot("b", 40.0, 0.0, 1.0), robot("c", 40.0, 40.0, 1.0), robot("d", 0.0, 40.0, 2.0)];
        let p = plan(&PatrolParams::new(square()), &robots).expect("plan");
        assert!((p.length - 160.0).abs() < 1e-9);
        assert!((p.spacing - 40.0).abs() < 1e-9);
        assert_eq!(p.team_speed, 1.0);
        // Each robot already stands on a slot corner: formation is immediate.
        assert!(p.formation_time < 1e-9, "formation {}", p.formation_time);
        assert!((p.predicted_worst_idleness - 40.0).abs() < 1e-9);
        assert!((p.idleness_lower_bound - 32.0).abs() < 1e-9);
        assert_eq!(p.sync_per_round, 4);
        let mut slots: Vec<usize> = p.plans.iter().map(|r| r.slot).collect();
        slots.sort();
        assert_eq!(slots, [0, 1, 2, 3]);
        for rp in &p.plans {
            let syncs: Vec<u32> = rp.steps.iter().filter_map(|s| if let Step::Sync { point, .. } = s { Some(*point) } else { None }).collect();
            assert_eq!(syncs, [0, 1, 2, 3, 4], "start barrier, then points 1..=q of each round");
            assert!(matches!(rp.steps.last(), Some(Step::Loop { to: 3, rounds: None })));
        }
    }

    #[test]
    fn a_large_team_does_not_pass_a_barrier_at_every_slot() {
        // 150 robots on a 160 m square: a slot every 1.07 m. One barrier per slot would be 150
        // per round, each plan 300 steps; capped, 32 per round, still evenly spaced.
        let robots: Vec<RobotSpec> = (0..150).map(|i| robot(&format!("r{i}"), (i % 20) as f64 * 1.5, -5.0 - (i / 20) as f64 * 1.5, 1.0)).collect();
        let p = plan(&PatrolParams::new(square()), &robots).expect("plan");
        assert_eq!(p.sync_per_round, SYNC_PER_ROUND_CAP as u32);
        for rp in &p.plans {
            let syncs: Vec<u32> = rp.steps.iter().filter_map(|s| if let Step::Sync { point, .. } = s { Some(*point) } else { None }).collect();
            assert_eq!(syncs, (0..=32).collect::<Vec<u32>>(), "start barrier, then 32 per round");
            assert!(rp.steps.len() <= 2 * 32 + 8, "{} steps", rp.steps.len());
        }
        // A tour long enough that the cap would put barriers too far apart: spacing_max rules.
        assert_eq!(sync_points_per_round(150, 1, 5_000.0, 50.0), 100);
        // Teams up to the cap keep one per slot (the paper's figures are unchanged).
        assert_eq!(sync_points_per_round(12, 1, 160.0, 50.0), 12);
        assert_eq!(sync_points_per_round(3, 4, 160.0, 15.0), 12);
    }

    #[test]
    fn long_tours_get_more_sync_points_and_slots_are_evenly_spaced() {
        let robots = vec![robot("a", 5.0, 5.0, 1.0), robot("b", 7.0, 5.0, 1.0), robot("c", 9.0, 5.0, 1.0)];
        let mut params = PatrolParams::new(square());
        params.sync_spacing_max = 15.0;
        let p = plan(&params, &robots).expect("plan");
        // spacing 160/3 = 53.3 → 4 sync points per slot.
        assert_eq!(p.sync_per_round, 12);
        let path = Polyline::closed(&p.tour);
        let mut starts: Vec<f64> = p
            .plans
            .iter()
            .map(|rp| match rp.steps[1] {
                Step::Navigate { x, y, .. } => path.project(Point::new(x, y)),
                _ => panic!("second step navigates to the slot"),
            })
            .collect();
        starts.sort_by(f64::total_cmp);
        for w in starts.windows(2) {
            assert!((w[1] - w[0] - p.spacing).abs() < 1e-6, "{starts:?}");
        }
    }

    #[test]
    fn bad_inputs() {
        let robots = vec![robot("a", 0.0, 0.0, 1.0)];
        assert_eq!(plan(&PatrolParams::new(vec![]), &robots).unwrap_err(), PlanError::Empty);
        assert!(matches!(plan(&PatrolParams::new(vec![Point::new(1.0, 1.0)]), &robots), Err(PlanError::TooFewPoints { .. })));
        let dup = vec![Point::new(1.0, 1.0), Point::new(2.0, 2.0), Point::new(1.0, 1.0)];
        assert!(matches!(plan(&PatrolParams::new(dup), &robots), Err(PlanError::Duplicate { a: 0, b: 2, .. })));
        let nan = vec![Point::new(1.0, 1.0), Point::new(f64::INFINITY, 2.0)];
        assert!(matches!(plan(&PatrolParams::new(nan), &robots), Err(PlanError::NonFinite { index: 1, .. })));
        assert!(plan(&PatrolParams::new(square()), &[]).is_err());
        assert!(plan(&PatrolParams::new(square()), &[robot("a", 0.0, 0.0, 0.0)]).is_err());
        assert!(plan(&PatrolParams::new(square()), &[robot("a", 0.0, 0.0, 1.0), robot("a", 1.0, 0.0, 1.0)]).is_err());
    }

    #[test]
    fn polyline_at_and_project_agree() {
        let path = Polyline::closed(&square());
        for s in [0.0, 10.0, 40.0, 95.5, 159.9, 170.0] {
            let p = path.at(s);
            assert!((path.project(p) - s.rem_euclid(160.0)).abs() < 1e-9, "s = {s}");
        }
    }

    /// With a turn rate, robots are spaced by time: on a route whose corners all lie on one side,
    /// two robots start half a round's time apart, not half its length.
    #[test]
    fn a_robot_whose_slot_is_in_a_turn_holds_the_rest_of_it_after_the_start() {
        // Out and back: a U-turn (π s at 1 rad/s) at each end, where the robots stand.
        let robots = vec![robot("a", 0.0, 0.0, 1.0), robot("b", 10.0, 0.0, 1.0)];
        let mut params = PatrolParams::new(vec![Point::new(0.0, 0.0), Point::new(10.0, 0.0)]);
        params.turn_rate = Some(1.0);
        let p = plan(&params, &robots).expect("plan");
        for (a, plan) in p.assignments.iter().zip(&p.plans) {
            assert!((a.start_hold - std::f64::consts::PI).abs() < 0.01, "{}: {}", a.robot, a.start_hold);
            let start = plan.steps.iter().position(|s| matches!(s, Step::Sync { point: 0, .. })).expect("start barrier");
            assert_eq!(plan.steps[start + 1], Step::Hold { seconds: Some(a.start_hold) }, "{:?}", plan.steps);
            assert!(matches!(plan.steps.last(), Some(Step::Loop { to, .. }) if *to == start + 2), "the hold is not looped");
        }
        // Turns that take no time: nothing to hold.
        params.turn_rate = None;
        let p = plan(&params, &robots).expect("plan");
        assert!(p.assignments.iter().all(|a| a.start_hold == 0.0));
        assert!(!p.plans.iter().any(|plan| plan.steps.iter().any(|s| matches!(s, Step::Hold { .. }))));
    }

    #[test]
    fn robots_are_spaced_by_time_when_turns_take_time() {
        // A 40 m straight back edge and a 40 m zigzag with 8 corners.
        let mut wps = vec![Point::new(0.0, 0.0)];
        for k in 1..=8 {
            wps.push(Point::new(k as f64 * 5.0, if k % 2 == 1 { 3.0 } else { 0.0 }));
        }
        wps.push(Point::new(40.0, -40.0));
        wps.push(Point::new(0.0, -40.0));
        let robots = vec![robot("a", 0.0, 0.0, 1.0), robot("b", 40.0, -40.0, 1.0)];
        let mut params = PatrolParams::new(wps);
        let by_arc = plan(&params, &robots).expect("plan");
        params.turn_rate = Some(0.2);
        let by_time = plan(&params, &robots).expect("plan");
        assert!((by_time.length - by_arc.length).abs() < 1e-9, "the route is the same");
        let round = by_time.predicted_worst_idleness * 2.0;
        // Each of the 8 corners (62°) is rounded at 0.12 m/s: 5.4 s on the arc for 0.72 m of legs.
        assert!(round > by_arc.length + 8.0 * 4.0, "the zigzag's turns take time: {round} s for {} m", by_arc.length);
        // Time from each robot's start to the other's, along the timed route.
        let timed = Polyline::closed(&by_time.tour).with_turns(1.0, 0.2);
        let starts: Vec<f64> = by_time.assignments.iter().map(|a| timed.project(a.start)).collect();
        let gap = (starts[1] - starts[0]).rem_euclid(timed.length);
        // (A start on a corner projects to where the robot reaches it, before the time it spends
        // rounding it: up to half a corner's 4.7 s off.)
        assert!((gap - timed.length / 2.0).abs() < 2.5, "half a round apart in time: {gap} of {}", timed.length);
        // By arc length they are not: the same gap in metres is not half the time.
        let arc = Polyline::closed(&by_arc.tour);
        let (a0, a1) = (timed.project(by_arc.assignments[0].start), timed.project(by_arc.assignments[1].start));
        let arc_gap = (a1 - a0).rem_euclid(timed.length);
        assert!((arc_gap - timed.length / 2.0).abs() > 2.0, "spacing by arc is uneven in time: {arc_gap} of {} ({} m)", timed.length, arc.length);
    }
}

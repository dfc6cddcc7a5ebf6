//! Conversions between the planner library's types and the protocol's plan types: the planner
//! can change its internals without changing what goes on the wire.

use mrmm_planner::geom::Point as PPoint;
use mrmm_planner::plan::{RobotPlan as PRobotPlan, RobotSpec as PRobotSpec, Step as PStep};
use mrmm_planner::recipe::MissionPlan as PMissionPlan;
use mrmm_proto::geom::Point;
use mrmm_proto::plan::{CoverageSummary, MissionPlan, PatrolSummary, PlanSummary, Region, RobotPlan, RobotSpec, Step, TeamSummary};

fn point(p: PPoint) -> Point {
    Point { x: p.x, y: p.y }
}

fn points(ps: &[PPoint]) -> Vec<Point> {
    ps.iter().copied().map(point).collect()
}

fn step(s: &PStep) -> Step {
    match s {
        PStep::Navigate { x, y, speed } => Step::Navigate { x: *x, y: *y, speed: *speed },
        PStep::Sync { point, scope } => Step::Sync { point: *point, scope: scope.clone() },
        PStep::Stream => Step::Stream,
        PStep::Hold { seconds } => Step::Hold { seconds: *seconds },
        PStep::Loop { to, rounds } => Step::Loop { to: *to, rounds: *rounds },
    }
}

fn robot_plan(p: &PRobotPlan) -> RobotPlan {
    RobotPlan {
        robot: p.robot.as_str().into(),
        robot_type: p.robot_type.clone(),
        slot: p.slot,
        steps: p.steps.iter().map(step).collect(),
        team: p.team.clone(),
    }
}

/// A planner's mission plan as the protocol carries it; a mission of teams has each leaf team's
/// figures in `teams` and the first one's in `summary`.
pub fn mission_plan(p: &PMissionPlan) -> MissionPlan {
    let plans = p.plans().into_iter().map(robot_plan).collect();
    match p {
        PMissionPlan::Teams { teams } => {
            let teams: Vec<TeamSummary> = teams.iter().map(|t| TeamSummary { team: t.team.clone(), summary: summary(&t.plan) }).collect();
            let first = teams.first().map(|t| t.summary.clone()).unwrap_or_else(|| summary(p));
            MissionPlan { summary: first, plans, teams }
        }
        _ => MissionPlan { summary: summary(p), plans, teams: vec![] },
    }
}

fn summary(p: &PMissionPlan) -> PlanSummary {
    match p {
        PMissionPlan::Patrol(p) => PlanSummary::Patrol(PatrolSummary {
            tour: points(&p.tour),
            waypoints: points(&p.waypoints),
            length: p.length,
            offset: p.offset,
            spacing: p.spacing,
            team_speed: p.team_speed,
            sync_per_round: p.sync_per_round,
            formation_time: p.formation_time,
            predicted_worst_idleness: p.predicted_worst_idleness,
            idleness_lower_bound: p.idleness_lower_bound,
        }),
        PMissionPlan::Coverage(c) => PlanSummary::Coverage(CoverageSummary {
            region: Region { outer: points(&c.region.outer), holes: c.region.holes.iter().map(|h| points(h)).collect() },
            points: points(&c.points),
            coverage_radius: c.coverage_radius,
            hexagonal_bound: c.hexagonal_bound,
            formation_time: c.formation_time,
        }),
        // (a team's plan is never itself of teams)
        PMissionPlan::Teams { .. } => PlanSummary::Coverage(CoverageSummary {
            region: Region { outer: vec![], holes: vec![] },
            points: vec![],
            coverage_radius: 0.0,
            hexagonal_bound: 0.0,
            formation_time: 0.0,
        }),
    }
}

/// A robot of the protocol as the planner takes it.
pub fn robot_spec(s: &RobotSpec) -> PRobotSpec {
    PRobotSpec { id: s.id.to_string(), robot_type: s.robot_type.clone(), x: s.x, y: s.y, speed: s.speed, turn_rate: s.turn_rate }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_planner::recipe;

    #[test]
    fn a_planned_patrol_keeps_its_figures_and_steps_on_the_wire() {
        let r = recipe::parse(recipe::bank("patrol").expect("bank")).expect("recipe");
        let robots = [RobotSpec { id: "a".into(), robot_type: "ground".into(), x: 0.0, y: 0.0, speed: 1.0, turn_rate: None }];
        let params = [("waypoints".to_string(), "[[0,0],[10,0],[10,10]]".to_string())].into();
        let planned = recipe::build(&r, &params, &robots.iter().map(robot_spec).collect::<Vec<_>>()).expect("plan");
        let wire = mission_plan(&planned);
        let PlanSummary::Patrol(p) = &wire.summary else { panic!("patrol") };
        let PMissionPlan::Patrol(q) = &planned else { panic!("patrol") };
        assert_eq!((p.length, p.tour.len(), p.sync_per_round), (q.length, q.tour.len(), q.sync_per_round));
        assert_eq!(wire.plans.len(), 1);
        assert_eq!(wire.plans[0].steps.len(), q.plans[0].steps.len());
        // The wire JSON has the shape the planner service always answered with.
        let a = serde_json::to_value(&wire).expect("json");
        let b = serde_json::to_value(&planned).expect("json");
        assert_eq!(a, b);
    }
}

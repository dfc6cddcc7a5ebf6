//! A planned mission as the protocol carries it (`mrmm_proto::plan::MissionPlan`): the robots'
//! plans as they are (the planners emit the protocol's `RobotPlan`s), the figures of the plan
//! (tour, spacing, bounds; per leaf team) as its summary. The planner can change its internals
//! without changing what goes on the wire.

use mrmm_proto::geom::Point;
use mrmm_proto::plan::{CoverageSummary, MissionPlan as Wire, PatrolSummary, PlanSummary, Region, TeamSummary};

use super::MissionPlan;
use crate::geom::Point as PPoint;

fn point(p: PPoint) -> Point {
    Point { x: p.x, y: p.y }
}

fn points(ps: &[PPoint]) -> Vec<Point> {
    ps.iter().copied().map(point).collect()
}

impl MissionPlan {
    /// The plan as the protocol carries it; a mission of teams has each leaf team's figures in
    /// `teams` and the first one's in `summary`.
    pub fn to_wire(&self) -> Wire {
        let plans = self.plans().into_iter().cloned().collect();
        let held = self.held();
        match self {
            MissionPlan::Teams { teams } => {
                let teams: Vec<TeamSummary> = teams.iter().map(|t| TeamSummary { team: t.team.clone(), summary: summary(&t.plan) }).collect();
                let first = teams.first().map(|t| t.summary.clone()).unwrap_or_else(|| summary(self));
                Wire { summary: first, plans, teams, held }
            }
            _ => Wire { summary: summary(self), plans, teams: vec![], held },
        }
    }
}

fn summary(p: &MissionPlan) -> PlanSummary {
    match p {
        MissionPlan::Patrol(p) => PlanSummary::Patrol(PatrolSummary {
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
        MissionPlan::Coverage(c) => PlanSummary::Coverage(CoverageSummary {
            region: Region { outer: points(&c.region.outer), holes: c.region.holes.iter().map(|h| points(h)).collect() },
            points: points(&c.points),
            coverage_radius: c.coverage_radius,
            hexagonal_bound: c.hexagonal_bound,
            formation_time: c.formation_time,
        }),
        // (a team's plan is never itself of teams)
        MissionPlan::Teams { .. } => PlanSummary::Coverage(CoverageSummary {
            region: Region { outer: vec![], holes: vec![] },
            points: vec![],
            coverage_radius: 0.0,
            hexagonal_bound: 0.0,
            formation_time: 0.0,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recipe;
    use mrmm_proto::plan::RobotSpec;

    #[test]
    fn a_planned_patrol_keeps_its_figures_and_steps_on_the_wire() {
        let r = recipe::parse(recipe::bank("patrol").expect("bank")).expect("recipe");
        let robots = [RobotSpec { id: "a".into(), robot_type: "ground".into(), x: 0.0, y: 0.0, speed: 1.0, turn_rate: None, reach_m: None }];
        let params = [("waypoints".to_string(), "[[0,0],[10,0],[10,10]]".to_string())].into();
        let planned = recipe::build(&r, &params, &robots).expect("plan");
        let wire = planned.to_wire();
        let PlanSummary::Patrol(p) = &wire.summary else { panic!("patrol") };
        let MissionPlan::Patrol(q) = &planned else { panic!("patrol") };
        assert_eq!((p.length, p.tour.len(), p.sync_per_round), (q.length, q.tour.len(), q.sync_per_round));
        assert_eq!(wire.plans.len(), 1);
        assert_eq!(wire.plans[0].steps.len(), q.plans[0].steps.len());
        // The wire JSON has the shape the planner service always answered with.
        let a = serde_json::to_value(&wire).expect("json");
        let b = serde_json::to_value(&planned).expect("json");
        assert_eq!(a, b);
    }
}

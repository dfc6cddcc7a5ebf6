//! The mission as the operator sees it: its view, metrics, and the predicted effect of more or
//! fewer robots.

use mrmm_proto::plan::PlanSummary;
use mrmm_proto::{self as proto, ManagerView, Marginal, MissionView};

use super::MissionManager;

impl MissionManager {
    pub fn metrics(&self) -> proto::MissionMetrics {
        self.metrics.view(self.members.keys(), self.plan_msgs, self.sync_msgs_left)
    }

    /// The operator's view.
    pub fn view(&self, with_plans: bool) -> MissionView {
        MissionView {
            name: self.spec.name.clone(),
            recipe: self.spec.recipe_name.clone(),
            planner: self.spec.planner.as_str().to_string(),
            requires: self.spec.requires.clone(),
            status: self.status,
            robots: self.members.keys().cloned().collect(),
            lost: self.lost.keys().cloned().collect(),
            stuck: self.stuck.clone(),
            held: self.held(),
            teams: self.teams(),
            team_views: self.team_views(),
            manager: ManagerView { node: self.node.clone(), epoch: self.epoch, chain_epoch: 0, chain: vec![], uncommitted_s: None },
            metrics: self.metrics(),
            summary: self.plan.as_ref().map(|(_, p)| p.summary.clone()),
            summary_unchanged: false,
            params: self.spec.params.clone(),
            error: self.error.clone(),
            plans: with_plans.then(|| self.plan.as_ref().map(|(_, p)| p.plans.clone()).unwrap_or_default()),
            map: self.spec.map.clone(),
        }
    }

    /// Predicted metric with `add` robots more (or fewer): patrol worst idleness `L / (n·v)`,
    /// coverage radius scaled by `√(n / n')` (radius ∝ 1/√n for a fixed area).
    pub fn marginal(&self, add: i64) -> Result<Marginal, String> {
        let (_, plan) = self.plan.as_ref().ok_or("the mission has no plan yet")?;
        let n = self.members.len();
        let with = (n as i64).checked_add(add).filter(|w| *w >= 1).ok_or_else(|| format!("the mission has {n} robots; cannot remove {}", -add))?;
        let with = with as usize;
        let (metric, current, predicted) = match &plan.summary {
            PlanSummary::Patrol(p) => ("worst_idleness", p.predicted_worst_idleness, p.length / (with as f64 * p.team_speed)),
            PlanSummary::Coverage(c) => ("coverage_radius", c.coverage_radius, c.coverage_radius * (n as f64 / with as f64).sqrt()),
        };
        Ok(Marginal { mission: self.spec.name.clone(), metric: metric.into(), robots: n, current, with_robots: with, predicted })
    }
}

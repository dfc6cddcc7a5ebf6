//! What a robot is told: its commands, who may give them, and the plans and admissions it
//! takes (checked before they change anything).

use mrmm_proto::{self as proto, MissionName, NodeId, PlanAssignment, RobotCommand, RobotId, Sender, Step};

use super::{traffic, BodyKind, Command, Robot, Unsent, MAX_ADMISSIONS, MAX_GOTO_VIA, MAX_PLAN_STEPS};
use crate::body::drive::Drive;
use crate::robot::executor::Executor;

impl Robot {
    /// Whether `from` may give this robot `cmd` ([`mrmm_proto::policy::POLICY`]): direct orders and
    /// admissions come from central only; plans from central, mission hosts, or a robot of this
    /// robot's mission (a teammate in its current plan of that mission, or a manager or member of
    /// the admission central gave it), or — central unreachable and this robot idle — the robot
    /// leading it.
    pub(super) fn entitled(&self, cmd: &RobotCommand, from: &Sender) -> Result<(), String> {
        use mrmm_proto::policy::{may, Act, Relation};
        let refuse = |what: String| format!("refused: {from} may not {what}");
        let RobotCommand::Plan(a) = cmd else {
            return may(Act::Order, from, Relation::Stranger).map_err(|w| refuse(format!("{w} (only central does)")));
        };
        let relation = self.plan_relation(a.mission.as_str(), from);
        if relation == Relation::Unattended {
            tracing::info!(robot = %self.cfg.id, from = %from, mission = %a.mission, "central unreachable: taking a plan from a robot leading the mission");
        }
        may(Act::Plan, from, relation).map_err(|w| refuse(format!("{w} of mission {} (neither a teammate nor a manager it was admitted under)", a.mission)))
    }

    /// What `from` is to `mission` for this robot: itself; a manager or teammate in its current
    /// plan of it; a manager or member of the admission central gave it (any of them may come to
    /// lead the mission: its chain is made of its members); the robot leading it while central is
    /// unreachable and this robot runs nothing (the paper's robots rejoin without central; a
    /// stranger with a fleet certificate could do the same then, see docs/security.md).
    fn plan_relation(&self, mission: &str, from: &Sender) -> mrmm_proto::policy::Relation {
        use mrmm_proto::policy::Relation;
        if from.id == self.cfg.id {
            return Relation::Itself;
        }
        let planned = self.exec.as_ref().filter(|e| e.mission() == mission).map(|e| &e.assignment);
        let admitted = self.admitted.iter().filter(|(m, _, _)| m.as_str() == mission);
        if planned.is_some_and(|a| a.managers.iter().any(|m| *m == from.id)) || admitted.clone().any(|(_, managers, _)| managers.iter().any(|m| *m == from.id))
        {
            return Relation::Manager;
        }
        if planned.is_some_and(|a| a.members.iter().any(|m| *m == from.id)) || admitted.clone().any(|(_, _, members)| members.iter().any(|m| *m == from.id)) {
            return Relation::Member;
        }
        if !self.central_up && self.exec.is_none() {
            return Relation::Unattended;
        }
        Relation::Stranger
    }

    /// Applies a command; returns the team change it makes. Direct orders (goto, hold) end any plan.
    /// Plugs the simulated body's battery in where it stands (it holds), or out.
    fn charge(&mut self, on: bool) -> Result<(), String> {
        if let Drive::Vda(vehicle) = &mut self.body {
            if on && self.exec.is_some() {
                return Err(format!("charge: robot {} is running a plan: it leaves its mission first", self.cfg.id));
            }
            if on {
                self.route.clear();
                if let Some(g) = self.traffic.as_mut() {
                    g.stop();
                }
            }
            vehicle.charge(on);
            tracing::info!(robot = %self.cfg.id, on, "charging (VDA 5050 startCharging/stopCharging)");
            return Ok(());
        }
        let Drive::Sim(body) = &mut self.body else {
            return Err("charge: a ROS 2 robot charges at its own dock, not on the fleet's word".into());
        };
        if body.battery().is_none() {
            return Err(format!("charge: robot {} has no battery", self.cfg.id));
        }
        if on && self.exec.is_some() {
            return Err(format!("charge: robot {} is running a plan: it leaves its mission first", self.cfg.id));
        }
        if on {
            self.route.clear();
            body.hold();
            // On lanes it has no goal now, and stands docked at its charger.
            if let Some(g) = self.traffic.as_mut() {
                g.stop();
            }
        }
        if let Some(b) = body.battery_mut() {
            b.set_charging(on);
        }
        tracing::info!(robot = %self.cfg.id, on, "charging");
        Ok(())
    }

    pub(super) fn command(&mut self, cmd: &RobotCommand) -> Result<Option<Command>, String> {
        let mut change = None;
        match cmd {
            RobotCommand::Goto { x, y, via, map } => {
                if !(x.is_finite() && y.is_finite()) {
                    return Err(format!("goto: coordinates must be finite (got {x}, {y})"));
                }
                if via.len() > MAX_GOTO_VIA || via.iter().any(|p| !(p[0].is_finite() && p[1].is_finite())) {
                    return Err(format!("goto: at most {MAX_GOTO_VIA} finite route points"));
                }
                if self.exec.take().is_some() {
                    change = Some(Command::LeaveTeam);
                }
                // On a map with lanes the goto is a goal of traffic's (its route is the lanes'):
                // the goal's map as central names it, else the one its last plan was on.
                self.unsent = None;
                if let Some(m) = map.as_ref().filter(|m| self.traffic.as_ref().is_none_or(|g| g.map() != *m)) {
                    self.traffic = Some(traffic::Gate::new(m.clone()));
                }
                if let Some(g) = self.traffic.as_mut().filter(|g| !g.free()) {
                    self.route.clear();
                    g.navigate(*x, *y, None);
                    self.unsent = Some(Unsent::Goto(via.iter().map(|p| (p[0], p[1])).chain([(*x, *y)]).collect()));
                    return Ok(change);
                }
                self.route = via.iter().map(|p| (p[0], p[1])).chain([(*x, *y)]).collect();
                if let Some((x, y)) = self.route.pop_front() {
                    self.body.navigate_capped(x, y, None);
                }
            }
            RobotCommand::Hold => {
                if self.exec.take().is_some() {
                    change = Some(Command::LeaveTeam);
                }
                self.route.clear();
                self.unsent = None;
                self.body.hold();
                // On lanes: it stops at the end of the one it drives, and gives back the rest.
                if let Some(g) = self.traffic.as_mut() {
                    g.stop();
                }
            }
            RobotCommand::Plan(a) => change = self.plan(a)?,
            RobotCommand::Admit { mission, managers, members } => self.admit(mission.as_str(), managers, members)?,
            RobotCommand::Leave { mission, epoch } => {
                // Out of the mission: its admission goes too.
                self.admitted.retain(|(m, _, _)| m != mission);
                let ours = self.exec.as_ref().is_some_and(|e| e.mission() == mission && e.epoch() <= *epoch);
                if ours {
                    tracing::info!(robot = %self.cfg.id, %mission, "left mission");
                    self.exec = None;
                    self.body.hold();
                    change = Some(Command::LeaveTeam);
                }
            }
            RobotCommand::Charge { on } => self.charge(*on)?,
            RobotCommand::Crash => {
                if !matches!(self.cfg.body, BodyKind::Sim) {
                    return Err("crash: only a simulated robot is crashed from the fleet (this one has a ROS 2 body)".into());
                }
                tracing::warn!(robot = %self.cfg.id, "crashing on the operator's order");
            }
            RobotCommand::Capabilities { add, remove } => {
                let new = proto::change_capabilities(&self.capabilities, add, remove)?;
                if new != self.capabilities {
                    tracing::info!(robot = %self.cfg.id, was = ?self.capabilities, now = ?new, "capabilities changed");
                    self.capabilities = new;
                    self.info_rev = self.info_rev.wrapping_add(1);
                    self.keep = true;
                }
            }
        }
        Ok(change)
    }

    /// A plan from a mission's head: checked, and run unless it is older than the one running or
    /// the same again (then only who manages it is learnt).
    fn plan(&mut self, a: &PlanAssignment) -> Result<Option<Command>, String> {
        self.check_plan(a)?;
        if let Some(e) = &self.exec {
            if e.mission() == a.mission && e.epoch() > a.epoch {
                return Err(format!("stale epoch {} for mission {} (running epoch {})", a.epoch, a.mission, e.epoch()));
            }
            if e.assignment.same_plan(a) {
                // The same plan again (a re-send, or a new head after a takeover): go on,
                // knowing who manages it now.
                if let Some(e) = self.exec.as_mut() {
                    e.assignment.managers.clone_from(&a.managers);
                }
                return Ok(None);
            }
        }
        let join =
            Command::JoinTeam { team: a.team.clone(), subteam: a.subteam.clone(), barrier: a.barrier, members: a.members.clone(), scopes: a.scopes.clone() };
        if let Some(e) = self.exec.as_mut().filter(|e| e.carried_on_by(a)) {
            // A hand-over: the same plan goes on with a new team, the body on its way.
            tracing::info!(robot = %self.cfg.id, mission = %a.mission, epoch = a.epoch, "plan carried on");
            e.carry_on(a.clone());
            return Ok(Some(join));
        }
        tracing::info!(robot = %self.cfg.id, mission = %a.mission, epoch = a.epoch, steps = a.plan.steps.len(), "new plan");
        self.route.clear();
        self.unsent = None;
        self.body.hold();
        // On lanes: it stops at the end of the one it drives until the new plan gives a goal.
        if let Some(g) = self.traffic.as_mut() {
            g.stop();
        }
        let exec = match a.handover {
            Some(h) => Executor::taking_over(a.clone(), h.step, h.round),
            None => Executor::new(a.clone()),
        };
        self.exec = Some(exec.with_time_scale(self.cfg.time_scale));
        match &a.map {
            Some(m) if self.traffic.as_ref().is_some_and(|g| g.map() == m) => {}
            Some(m) => self.traffic = Some(traffic::Gate::new(m.clone())),
            None => self.traffic = None,
        }
        Ok(Some(join))
    }

    /// Central admits this robot to `mission`: whom to trust as its managers and teammates.
    fn admit(&mut self, mission: &str, managers: &[NodeId], members: &[RobotId]) -> Result<(), String> {
        proto::validate_id(mission).map_err(|e| e.to_string())?;
        if managers.len() > proto::MAX_REPLICAS + 2 || managers.iter().any(|m| proto::validate_id(m.as_str()).is_err()) {
            return Err("admit: bad manager list".into());
        }
        if members.len() > proto::MAX_MISSION_ROBOTS || members.iter().any(|m| proto::validate_id(m.as_str()).is_err()) {
            return Err("admit: bad member list".into());
        }
        // The newest admission to a mission replaces the older one; the oldest of other
        // missions goes when there are too many.
        self.admitted.retain(|(m, _, _)| m != mission);
        if self.admitted.len() >= MAX_ADMISSIONS {
            self.admitted.remove(0);
        }
        self.admitted.push((MissionName::from(mission), managers.to_vec(), members.to_vec()));
        Ok(())
    }

    /// Everything in a plan that could hurt: another robot's plan, bad names, numbers that are
    /// not finite, loops that point nowhere.
    fn check_plan(&self, a: &PlanAssignment) -> Result<(), String> {
        if a.plan.robot != self.cfg.id {
            return Err(format!("plan is for robot {:?}, this is {:?}", a.plan.robot, self.cfg.id));
        }
        proto::validate_id(a.mission.as_str()).map_err(|e| e.to_string())?;
        proto::validate_team_path(&a.team).map_err(|_| format!("bad team path {:?}", a.team))?;
        if !proto::team_within(&a.team, a.mission.as_str()) {
            return Err(format!("team {:?} is not in mission {:?}", a.team, a.mission));
        }
        proto::validate_subteam(&a.subteam).map_err(|_| format!("bad sub-team path {:?}", a.subteam))?;
        if a.subteam.rsplit_once('/').map(|(t, _)| t) != Some(a.team.as_str()) {
            return Err(format!("sub-team {:?} is not in team {:?}", a.subteam, a.team));
        }
        if a.scopes.len() > proto::MAX_TEAM_DEPTH + 1 {
            return Err(format!("plan has {} wider teams (at most {})", a.scopes.len(), proto::MAX_TEAM_DEPTH + 1));
        }
        for sc in &a.scopes {
            proto::validate_team_path(&sc.team).map_err(|_| format!("bad team path {:?}", sc.team))?;
            if !proto::team_within(&sc.team, a.mission.as_str()) || !proto::team_within(&a.team, &sc.team) || sc.team == a.team {
                return Err(format!("team {:?} is not a team above {:?} in mission {:?}", sc.team, a.team, a.mission));
            }
            if sc.members.len() > proto::MAX_MISSION_ROBOTS
                || !sc.members.contains(&self.cfg.id)
                || sc.members.iter().any(|m| proto::validate_id(m.as_str()).is_err())
            {
                return Err(format!("bad member list for team {:?}", sc.team));
            }
        }
        for s in &a.plan.steps {
            if let Step::Sync { scope: Some(scope), .. } = s {
                let path = a.scope_path(Some(scope));
                if a.scope_members(&path).is_none() {
                    return Err(format!("plan has a barrier of team {path:?} but no members for it"));
                }
            }
        }
        if !a.members.contains(&self.cfg.id) {
            return Err("plan's member list does not include this robot".into());
        }
        if a.plan.steps.len() > MAX_PLAN_STEPS {
            return Err(format!("plan has {} steps (at most {MAX_PLAN_STEPS})", a.plan.steps.len()));
        }
        for (i, s) in a.plan.steps.iter().enumerate() {
            let ok = match s {
                Step::Navigate { x, y, speed } => x.is_finite() && y.is_finite() && speed.is_none_or(|v| v.is_finite() && v > 0.0),
                Step::Hold { seconds } => seconds.is_none_or(|v| v.is_finite() && v >= 0.0),
                Step::Loop { to, .. } => *to <= i,
                Step::Sync { .. } | Step::Stream => true,
            };
            if !ok {
                return Err(format!("plan step {i} is invalid: {s:?}"));
            }
        }
        Ok(())
    }
}

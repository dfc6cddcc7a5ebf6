//! Whom a mission host takes a mission's chain messages from, as a machine of its own. Central
//! and mission hosts always; a robot when this node counts it in the mission; on a robot's node,
//! the robot's team (as its plan and admission say) and the chain a head of that team last
//! published; elsewhere, a robot whose own telemetry says it runs a mission this node holds
//! nothing of. It also remembers missions this node holds nothing of whose chain messages it
//! hears: a start of such a mission (central starting it anew) is refused while they come.

use std::collections::BTreeMap;

use mrmm_proto::{MissionName, MissionView, NodeId, Role, Sender, Time};

use super::FOREIGN_CHAIN_S;

/// Missions whose chain messages this node heard while holding nothing of them, at most.
const MAX_FOREIGN: usize = 1024;

/// What a host knows of its own node's robot.
#[derive(Debug, Clone, PartialEq)]
enum Local {
    /// Central or a mission host: no robot here.
    NoRobot,
    /// A robot node: the missions its robot is in or admitted to, each with whom it trusts.
    Robot(Vec<(String, Vec<String>)>),
}

/// What the trust machine hears.
#[derive(Debug)]
pub(super) enum Heard<'a> {
    /// The missions this node's own robot is in or admitted to, each with whom it trusts.
    LocalTeam(Vec<(String, Vec<String>)>),
    /// A mission's head published its status (proven sender `from`).
    Status { view: &'a MissionView, from: &'a Sender },
    /// A chain message of `mission` from node `from`, which this node holds nothing of.
    Foreign { now: Time, mission: MissionName, from: NodeId },
}

/// What this node holds of a mission, for judging a robot's chain message about it.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Holding {
    /// The sender is in this node's replica's chain or team.
    pub counts_sender: bool,
    /// This node holds a replica of the mission (a config or a state).
    pub holds: bool,
    /// The sender's own telemetry says it runs the mission.
    pub sender_runs: bool,
}

/// Whom this host trusts, per mission.
#[derive(Debug, Clone)]
pub(super) struct Trust {
    local: Local,
    /// The chain of each of our robot's missions, as a head our robot trusts last published it.
    trusted_chain: BTreeMap<MissionName, Vec<NodeId>>,
    /// Missions this node holds nothing of whose chain messages it hears: when, and from whom.
    foreign: BTreeMap<MissionName, (Time, NodeId)>,
}

impl Trust {
    /// The trust of a node without a robot (central, a mission host), or with one (it learns
    /// its robot's team from [`Heard::LocalTeam`]).
    pub(super) fn new(robot: bool) -> Self {
        let local = if robot { Local::Robot(Vec::new()) } else { Local::NoRobot };
        Trust { local, trusted_chain: BTreeMap::new(), foreign: BTreeMap::new() }
    }

    pub(super) fn handle(&mut self, heard: Heard<'_>) {
        match heard {
            Heard::LocalTeam(teams) => {
                if let Local::Robot(t) = &mut self.local {
                    self.trusted_chain.retain(|m, _| teams.iter().any(|(tm, _)| tm == m));
                    *t = teams;
                }
            }
            // On a robot's node, a head its robot trusts tells it who else is in the chain: a
            // head that is a teammate (or not a robot).
            Heard::Status { view, from } => {
                let Local::Robot(teams) = &self.local else { return };
                let Some((_, members)) = teams.iter().find(|(m, _)| *m == view.name) else { return };
                let head_trusted = from.role != Role::Robot || members.contains(&from.id);
                let status = mrmm_proto::policy::Publication::Status { manager: view.manager.node.as_str() };
                if mrmm_proto::policy::may_publish(status, from).is_ok() && head_trusted {
                    self.trusted_chain.insert(view.name.clone(), view.manager.chain.clone());
                }
            }
            Heard::Foreign { now, mission, from } => {
                if self.foreign.len() < MAX_FOREIGN || self.foreign.contains_key(&mission) {
                    self.foreign.insert(mission, (now, from));
                }
            }
        }
    }

    /// The missions this node's robot is in or admitted to, with whom it trusts (none on a node
    /// without a robot).
    pub(super) fn teams(&self) -> &[(String, Vec<String>)] {
        match &self.local {
            Local::Robot(teams) => teams,
            Local::NoRobot => &[],
        }
    }

    /// Whether this node's robot is in or admitted to `mission`.
    pub(super) fn ours(&self, mission: &str) -> bool {
        self.teams().iter().any(|(m, _)| m == mission)
    }

    /// A node that sent chain messages of `mission` within [`FOREIGN_CHAIN_S`] while this node
    /// held nothing of it: the mission's old chain lives, and may take over again.
    pub(super) fn chain_elsewhere(&mut self, now: Time, mission: &str) -> Option<&NodeId> {
        self.foreign.retain(|_, (t, _)| now - *t < FOREIGN_CHAIN_S);
        self.foreign.get(mission).map(|(_, node)| node)
    }

    /// Whether `from` may send chain messages about `mission` to this node, given what this node
    /// holds of the mission (looked at only for a robot: central's and hosts' messages, the most
    /// frequent, need no look through the team).
    pub(super) fn may_chain(&self, mission: &str, from: &Sender, holding: impl FnOnce() -> Holding) -> bool {
        use mrmm_proto::policy::{allows, need, Act, Need};
        match need(Act::Chain, from.role) {
            Need::Always => return true,
            Need::Never => return false,
            Need::Any(_) => {}
        }
        allows(Act::Chain, from.role, self.chain_relation(mission, from, holding))
    }

    /// What `from` is to `mission` for this node: counted in its replica's chain or team, a
    /// member of its own robot's team of it (its plan and admission) or of the chain a head of
    /// that team last published; or — for a mission this node holds nothing of and its robot is
    /// not in — running it by its own telemetry (a node outside a mission can still be asked to
    /// hold a replica of it).
    fn chain_relation(&self, mission: &str, from: &Sender, holding: impl FnOnce() -> Holding) -> mrmm_proto::policy::Relation {
        use mrmm_proto::policy::Relation;
        let holding = holding();
        if holding.counts_sender {
            return Relation::Member;
        }
        let id = &from.id;
        match self.teams().iter().find(|(m, _)| m == mission).map(|(_, members)| members) {
            Some(members) if members.contains(id) => Relation::Member,
            Some(_) if self.trusted_chain.get(mission).is_some_and(|chain| chain.iter().any(|n| n == id)) => Relation::Manager,
            Some(_) => Relation::Stranger,
            None if !holding.holds && holding.sender_runs => Relation::Runs,
            None => Relation::Stranger,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::at;

    fn robot(id: &str) -> Sender {
        Sender::new(Role::Robot, id.to_string())
    }

    #[test]
    fn a_robots_node_takes_chain_messages_from_its_team_and_the_chain_its_head_published() {
        let mut t = Trust::new(true);
        t.handle(Heard::LocalTeam(vec![("m".into(), vec!["r1".into(), "r2".into()])]));
        let none = Holding::default();
        assert!(t.may_chain("m", &robot("r2"), || none));
        assert!(!t.may_chain("m", &robot("r9"), || none), "a stranger to our robot's team");
        // Even one that says it runs the mission: our robot's team decides.
        assert!(!t.may_chain("m", &robot("r9"), || Holding { sender_runs: true, ..none }));
        // A head that is not a teammate publishes a chain with r9: not trusted.
        let mut view = MissionView::running("m", "patrol", "r8", 1, &["r1"]);
        view.manager.chain = vec!["r8".into(), "r9".into()];
        t.handle(Heard::Status { view: &view, from: &robot("r8") });
        assert!(!t.may_chain("m", &robot("r9"), || none));
        // A teammate heading the mission (or central) does.
        view.manager.node = "r2".into();
        t.handle(Heard::Status { view: &view, from: &robot("r2") });
        assert!(t.may_chain("m", &robot("r9"), || none));
        // Our robot left: its chain is forgotten.
        t.handle(Heard::LocalTeam(vec![]));
        assert!(!t.may_chain("m", &robot("r9"), || none) && !t.ours("m"));
        assert!(t.may_chain("m", &Sender::new(Role::Host, "h".to_string()), || none));
        assert!(!t.may_chain("m", &Sender::new(Role::Operator, "o".to_string()), || Holding { counts_sender: true, ..none }));
    }

    #[test]
    fn elsewhere_a_robot_speaks_for_a_mission_it_runs_until_this_node_holds_some_of_it() {
        let t = Trust::new(false);
        let runs = Holding { sender_runs: true, ..Holding::default() };
        assert!(t.may_chain("m", &robot("r1"), || runs));
        assert!(!t.may_chain("m", &robot("r1"), Holding::default));
        assert!(!t.may_chain("m", &robot("r1"), || Holding { holds: true, ..runs }));
        assert!(t.may_chain("m", &robot("r1"), || Holding { holds: true, counts_sender: true, sender_runs: false }));
    }

    #[test]
    fn a_foreign_chain_holds_a_start_back_for_a_while_and_is_bounded() {
        let mut t = Trust::new(false);
        t.handle(Heard::Foreign { now: at(1.0), mission: "m".into(), from: "r1".into() });
        assert_eq!(t.chain_elsewhere(at(1.0 + FOREIGN_CHAIN_S - 0.1), "m").map(|n| n.as_str()), Some("r1"));
        assert!(t.chain_elsewhere(at(1.0 + FOREIGN_CHAIN_S), "m").is_none());
        for i in 0..2 * MAX_FOREIGN {
            t.handle(Heard::Foreign { now: at(10.0), mission: format!("m{i}").into(), from: "r1".into() });
        }
        assert_eq!(t.foreign.len(), MAX_FOREIGN);
    }
}

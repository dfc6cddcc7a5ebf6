//! Who may do what: one table, [`POLICY`] — for each thing a node may be sent ([`Act`]), which
//! roles may send it and in what relation to what it speaks of ([`Relation`]). Every node's
//! edge consults it ([`allows`], [`may`]): the robot for its commands and its team's barrier
//! messages, mission hosts for chain messages, starts and controls, central for telemetry and
//! status reports, planner services for plan requests, the viewer and the console for what
//! they draw. Each machine says what the sender is to the thing (a teammate, a manager it was
//! admitted under, itself…) from its own state; the table alone says whether that is enough.
//! docs/security.md shows the table as [`table`] renders it (a test checks they agree).

use crate::security::{Role, Sender};

/// What a node may be sent: a publication, a question, or an answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Act {
    /// `mrmm/robots/<id>/telemetry`.
    Telemetry,
    /// A barrier arrival on `mrmm/team/<m>[/<team>…]/sync|arrive/…`.
    Arrival,
    /// A barrier release on `mrmm/team/<m>/release/…`, announced by its leader.
    Release,
    /// `mrmm/missions/<m>/status`, a head's report.
    Status,
    /// A report on a mission central knows, taken into its view (after [`Act::Status`]).
    Report,
    /// A report on a mission central does not know (it lost its journal): adopted.
    Adopt,
    /// `mrmm/hosts/<n>/chain`, a chain message of a mission.
    Chain,
    /// `mrmm/hosts/<n>/start`: run a mission.
    Start,
    /// `mrmm/missions/<m>/ctl`: a control of a running mission.
    Control,
    /// `mrmm/robots/<id>/cmd`: goto, hold, leave, admit, capabilities, crash.
    Order,
    /// `mrmm/robots/<id>/cmd`: a plan of a mission.
    Plan,
    /// `mrmm/planner/<kind>`: plan these robots (on a map central publishes).
    PlanRequest,
    /// An answer on `mrmm/planner/<kind>`.
    PlanAnswer,
    /// `mrmm/system/cmd/**`: the operator API's commands.
    Command,
    /// `mrmm/system/**` and `mrmm/agent/**` reads.
    Read,
    /// `mrmm/agent/advice/live`, the advising agent's advice.
    Advice,
    /// `mrmm/viewers/<id>`, a viewer announcing itself to robots.
    Viewer,
    /// `mrmm/maps/<hash>/<chunk>`, a chunk of a map (checked against its hash).
    MapChunk,
    /// `mrmm/maps/<hash>/manifest`, a map's chunk hashes.
    MapManifest,
    /// `mrmm/traffic/<hash>/report/<id>`, a robot's word to the map's traffic authority.
    TrafficReport,
    /// `mrmm/traffic/<hash>/order/<id>`, the traffic authority's order to a robot.
    TrafficOrder,
}

/// What the sender is to what it speaks of, as the receiver knows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Relation {
    /// It speaks of itself: its own telemetry or arrival, a release it leads, a status naming
    /// it manager, a plan of its own.
    Itself,
    /// A manager of the mission in question: its head or a node of its chain, as the
    /// receiver's plan, admission or journal says (or a former manager of a newer chain epoch).
    Manager,
    /// A member of the mission in question, as the receiver's plan, team, admission or
    /// journal says.
    Member,
    /// Its own telemetry says it runs the mission in question (for a receiver that holds
    /// nothing of it yet, asked to replicate it); for a report of a mission central does not
    /// know, another robot it lists says so.
    Runs,
    /// It leads the mission in question while central is unreachable, and the receiver, an idle
    /// robot, runs nothing: the paper's robots rejoin without central.
    Unattended,
    /// A robot the receiver's traffic authority named its deputy on the map in question, while
    /// central is away (it follows the authority and takes over from it).
    Deputy,
    /// None of these.
    Stranger,
}

impl Relation {
    pub const ALL: [Relation; 7] =
        [Relation::Itself, Relation::Manager, Relation::Member, Relation::Runs, Relation::Unattended, Relation::Deputy, Relation::Stranger];

    fn text(self) -> &'static str {
        match self {
            Relation::Itself => "itself",
            Relation::Manager => "a manager",
            Relation::Member => "a member",
            Relation::Runs => "running it (by telemetry)",
            Relation::Unattended => "leading it, central away",
            Relation::Deputy => "its traffic deputy, central away",
            Relation::Stranger => "anyone",
        }
    }
}

/// What a role needs to do an act.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Need {
    /// Nothing more: any node of the role.
    Always,
    /// One of these relations.
    Any(&'static [Relation]),
    /// The role may not.
    Never,
}

/// One row of the policy.
#[derive(Debug, Clone, Copy)]
pub struct Row {
    pub act: Act,
    /// Where it travels, as docs/security.md shows it.
    pub key: &'static str,
    /// What a refusal says was attempted.
    pub what: &'static str,
    /// Per role, in [`Role::ALL`]'s order: operator, central, robot, host, planner, router.
    pub need: [Need; 6],
}

use Need::{Always, Any, Never};
use Relation::{Itself, Manager, Member, Runs, Unattended};

/// The policy: every act, who may.
pub const POLICY: [Row; 21] = [
    Row { act: Act::Telemetry, key: "`mrmm/robots/<id>/telemetry`", what: "publish telemetry", need: [Never, Never, Any(&[Itself]), Never, Never, Never] },
    Row { act: Act::Arrival, key: "`mrmm/team/<m>[/<team>…]/sync/…`, `…/arrive/…`", what: "publish a barrier arrival", need: [Never, Never, Any(&[Itself]), Never, Never, Never] },
    Row {
        act: Act::Release,
        key: "`mrmm/team/<m>/release/…`",
        what: "publish a barrier release",
        need: [Never, Never, Any(&[Itself]), Never, Never, Never],
    },
    Row {
        act: Act::Status,
        key: "`mrmm/missions/<m>/status`",
        what: "report a mission",
        need: [Never, Any(&[Itself]), Any(&[Itself]), Any(&[Itself]), Never, Never],
    },
    Row {
        act: Act::Report,
        key: "`mrmm/missions/<m>/status` of a mission central knows",
        what: "report on a mission central knows",
        need: [Never, Always, Any(&[Manager, Member]), Always, Never, Never],
    },
    Row {
        act: Act::Adopt,
        key: "`mrmm/missions/<m>/status` of a mission central does not know (adopted; from a robot, only its members that run it by their own telemetry are recorded)",
        what: "have a mission adopted",
        need: [Never, Always, Any(&[Runs]), Always, Never, Never],
    },
    Row {
        act: Act::Chain,
        key: "`mrmm/hosts/<n>/chain`",
        what: "send chain messages",
        need: [Never, Always, Any(&[Manager, Member, Runs]), Always, Never, Never],
    },
    Row { act: Act::Start, key: "`mrmm/hosts/<n>/start`", what: "start a mission", need: [Never, Always, Never, Never, Never, Never] },
    Row { act: Act::Control, key: "`mrmm/missions/<m>/ctl`", what: "control a mission", need: [Never, Always, Never, Never, Never, Never] },
    Row {
        act: Act::Order,
        key: "`mrmm/robots/<id>/cmd` (goto, hold, leave, admit, capabilities, crash)",
        what: "give a robot direct orders",
        need: [Never, Always, Never, Never, Never, Never],
    },
    Row {
        act: Act::Plan,
        key: "`mrmm/robots/<id>/cmd` (a plan of mission `m`)",
        what: "plan for a robot",
        need: [Never, Always, Any(&[Itself, Manager, Member, Unattended]), Always, Never, Never],
    },
    Row {
        act: Act::PlanRequest,
        key: "`mrmm/planner/<kind>` (a request; its map must be one central publishes)",
        what: "ask for plans",
        need: [Never, Always, Always, Always, Never, Never],
    },
    Row { act: Act::PlanAnswer, key: "an answer on `mrmm/planner/<kind>`", what: "answer plan requests", need: [Never, Always, Never, Never, Always, Never] },
    Row {
        act: Act::Command,
        key: "`mrmm/system/cmd/**` (central's access control: operators its config lists)",
        what: "command the fleet",
        need: [Always, Never, Never, Never, Never, Never],
    },
    Row { act: Act::Read, key: "`mrmm/system/**`, `mrmm/agent/**` (reads)", what: "read the fleet", need: [Always, Always, Always, Always, Always, Always] },
    Row { act: Act::Advice, key: "`mrmm/agent/advice/live`", what: "publish advice", need: [Never, Always, Never, Never, Never, Never] },
    Row { act: Act::Viewer, key: "`mrmm/viewers/<id>`", what: "announce a viewer", need: [Always, Always, Never, Never, Never, Never] },
    Row {
        act: Act::MapChunk,
        key: "`mrmm/maps/<hash>/<chunk>` (checked against the map's hash)",
        what: "serve map chunks",
        need: [Always, Always, Always, Always, Always, Always],
    },
    Row {
        act: Act::MapManifest,
        key: "`mrmm/maps/<hash>/manifest`",
        what: "answer with a map's manifest",
        need: [Never, Always, Never, Never, Never, Never],
    },
    Row {
        act: Act::TrafficReport,
        key: "`mrmm/traffic/<hash>/report/<id>`",
        what: "report to traffic",
        need: [Never, Never, Any(&[Itself]), Never, Never, Never],
    },
    Row {
        act: Act::TrafficOrder,
        key: "`mrmm/traffic/<hash>/order/<id>` (the traffic authority)",
        what: "give traffic orders",
        need: [Never, Always, Any(&[Relation::Deputy]), Never, Never, Never],
    },
];

/// The row of `act`.
pub fn row(act: Act) -> &'static Row {
    POLICY.iter().find(|r| r.act == act).unwrap_or(&POLICY[0])
}

/// What `role` needs to do `act`.
pub fn need(act: Act, role: Role) -> Need {
    let i = Role::ALL.iter().position(|r| *r == role).unwrap_or(0);
    row(act).need[i]
}

/// Whether a node of `role` that is `relation` to what it speaks of may do `act`.
pub fn allows(act: Act, role: Role, relation: Relation) -> bool {
    match need(act, role) {
        Always => true,
        Any(rels) => rels.contains(&relation),
        Never => false,
    }
}

/// [`allows`] for `from`: `Err` says what was attempted, as a refusal logs it.
pub fn may(act: Act, from: &Sender, relation: Relation) -> Result<(), String> {
    if allows(act, from.role, relation) {
        Ok(())
    } else {
        Err(row(act).what.to_string())
    }
}

/// The policy as the Markdown table docs/security.md shows.
pub fn table() -> String {
    let mut out = String::from("| what | where | operator | central | robot | host | planner | router |\n|---|---|---|---|---|---|---|---|\n");
    for r in &POLICY {
        let cells: Vec<String> = r
            .need
            .iter()
            .map(|n| match n {
                Always => "yes".to_string(),
                Never => "—".to_string(),
                Any(rels) => rels.iter().map(|r| r.text()).collect::<Vec<_>>().join(", "),
            })
            .collect();
        out.push_str(&format!("| {} | {} | {} |\n", r.what, r.key, cells.join(" | ")));
    }
    out
}

/// A publication, with the id it speaks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Publication<'a> {
    /// Robot `id`'s telemetry.
    Telemetry(&'a str),
    /// Robot `id`'s arrival at a barrier.
    Arrival(&'a str),
    /// A barrier's release announced by its leader, robot `id`.
    Release(&'a str),
    /// The advising agent's advice.
    Advice,
    /// A mission's status, published by its head on node `manager` (as the status says).
    Status { manager: &'a str },
    /// Robot `id`'s report to a traffic authority.
    TrafficReport(&'a str),
    /// A traffic authority's order; `deputy`: from a robot the receiver's authority named its
    /// deputy on the map, with central away.
    TrafficOrder { deputy: bool },
}

impl Publication<'_> {
    /// What was attempted, as a refusal says it: `publish the telemetry of r1`.
    pub fn what(&self) -> String {
        match self {
            Publication::Telemetry(id) => format!("publish the telemetry of {id}"),
            Publication::Arrival(id) => format!("publish the barrier arrival of {id}"),
            Publication::Release(id) => format!("publish the barrier release of {id}"),
            Publication::Advice => "publish advice".to_string(),
            Publication::Status { manager } => format!("report a mission as managed by {manager}"),
            Publication::TrafficReport(id) => format!("report to traffic for {id}"),
            Publication::TrafficOrder { .. } => "give traffic orders".to_string(),
        }
    }
}

/// Whether `from` may publish `p` ([`POLICY`]): a robot speaks only for itself (its telemetry,
/// its arrivals, the releases it announces as leader), advice comes from central, a status from
/// the node it names as manager. `Err` says what was attempted.
pub fn may_publish(p: Publication<'_>, from: &Sender) -> Result<(), String> {
    let itself = |id: &str| if from.id == id { Relation::Itself } else { Relation::Stranger };
    let (act, relation) = match p {
        Publication::Telemetry(id) => (Act::Telemetry, itself(id)),
        Publication::Arrival(id) => (Act::Arrival, itself(id)),
        Publication::Release(id) => (Act::Release, itself(id)),
        Publication::Advice => (Act::Advice, Relation::Stranger),
        Publication::Status { manager } => (Act::Status, itself(manager)),
        Publication::TrafficReport(id) => (Act::TrafficReport, itself(id)),
        Publication::TrafficOrder { deputy } => (Act::TrafficOrder, if deputy { Relation::Deputy } else { Relation::Stranger }),
    };
    may(act, from, relation).map_err(|_| p.what())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_robot_speaks_only_for_itself_and_advice_only_comes_from_central() {
        let r1 = Sender::new(Role::Robot, "r1");
        for p in [Publication::Telemetry("r1"), Publication::Arrival("r1"), Publication::Release("r1")] {
            assert_eq!(may_publish(p, &r1), Ok(()));
        }
        assert_eq!(may_publish(Publication::Telemetry("r2"), &r1), Err("publish the telemetry of r2".to_string()));
        assert_eq!(may_publish(Publication::Arrival("r2"), &r1), Err("publish the barrier arrival of r2".to_string()));
        // The same id under another role is someone else.
        for role in [Role::Operator, Role::Host, Role::Central] {
            assert!(may_publish(Publication::Release("r1"), &Sender::new(role, "r1")).is_err());
        }
        assert_eq!(may_publish(Publication::Advice, &Sender::new(Role::Central, "central")), Ok(()));
        assert_eq!(may_publish(Publication::Advice, &r1), Err("publish advice".to_string()));
        // A mission's status comes from the node that manages it, a node that hosts missions.
        assert_eq!(may_publish(Publication::Status { manager: "r1" }, &r1), Ok(()));
        assert!(may_publish(Publication::Status { manager: "r2" }, &r1).is_err());
        assert!(may_publish(Publication::Status { manager: "op" }, &Sender::new(Role::Operator, "op")).is_err());
    }

    /// Every act has one row, and the table says what the protocol promises: only central orders
    /// robots, starts and controls missions and speaks for the agent; a robot speaks only for
    /// itself and plans only for the missions it is in; operators alone command.
    #[test]
    fn the_policy_is_one_row_per_act_and_says_what_the_protocol_promises() {
        let mut acts: Vec<Act> = POLICY.iter().map(|r| r.act).collect();
        acts.sort();
        acts.dedup();
        assert_eq!(acts.len(), POLICY.len(), "one row per act");
        for act in [Act::Start, Act::Control, Act::Order, Act::Advice, Act::MapManifest] {
            for role in Role::ALL {
                for rel in Relation::ALL {
                    assert_eq!(allows(act, role, rel), role == Role::Central, "{act:?} by {role} as {rel:?}");
                }
            }
        }
        // Traffic orders: central, or a robot its deputy (named by the authority, central away).
        for role in Role::ALL {
            for rel in Relation::ALL {
                let may = role == Role::Central || (role == Role::Robot && rel == Relation::Deputy);
                assert_eq!(allows(Act::TrafficOrder, role, rel), may, "traffic orders by {role} as {rel:?}");
            }
        }
        for act in [Act::Telemetry, Act::Arrival, Act::Release, Act::TrafficReport] {
            assert!(allows(act, Role::Robot, Relation::Itself));
            assert!(!allows(act, Role::Robot, Relation::Member) && !allows(act, Role::Central, Relation::Itself));
        }
        assert!(!allows(Act::Plan, Role::Robot, Relation::Stranger) && !allows(Act::Plan, Role::Robot, Relation::Runs));
        assert!(!allows(Act::Chain, Role::Robot, Relation::Stranger) && !allows(Act::Chain, Role::Operator, Relation::Member));
        for role in Role::ALL {
            assert_eq!(allows(Act::Command, role, Relation::Stranger), role == Role::Operator);
        }
    }

    /// docs/security.md shows the policy as it is.
    #[test]
    fn the_security_guide_shows_this_table() {
        let doc = include_str!("../../docs/security.md");
        assert!(doc.contains(&table()), "docs/security.md must contain the policy table as `policy::table()` renders it:\n{}", table());
    }
}

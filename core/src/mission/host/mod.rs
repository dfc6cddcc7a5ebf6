//! The mission host as a state machine: the chain replicas of the missions this node takes part
//! in ([`Registry`]), the missions it leads ([`Head`]), and who is alive. Decoded messages in,
//! [`Command`]s out: [`HostCore::handle`] never does I/O. Queries are held by the driver under an
//! id; the core answers them (or lets them go unanswered) by that id.

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use mrmm_planner::recipe::PlannerKind;
use mrmm_proto::edge::Refused;
use mrmm_proto::{
    ChainEnvelope, CtlAck, ErrorCode, ErrorReply, Member, MissionCtl, MissionName, MissionPlan, MissionSnapshot, MissionStart, MissionView, NodeId,
    PlanAssignment, PlanRequest, RobotId, Role, Sender, Telemetry, CENTRAL_HOST,
};
use mrmm_proto::{Key, Time};
use serde_json::Value;

use self::head::Head;
use self::robots::Robots;
use crate::mission::chain::{self, Params, Registry};
use crate::mission::{self, MissionManager, MissionSpec};
use crate::Failure;

pub mod asks;
pub mod egress;
mod head;
pub mod ingress;
mod led;
mod peers;
mod robots;

#[cfg(test)]
mod tests;
mod ticks;
mod trust;
mod watch;

pub use egress::egress;
pub use head::{PLAN_RETRIES, REDELIVER_S};
pub use ingress::{ingress, question, question_sealed, sealed, Question};
pub use robots::UNJUDGED_S;

type ChainCmd = chain::Command<MissionSnapshot>;

/// Something that happened to the host.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// Time passes (every few tens of milliseconds): chains, plan re-deliveries.
    Tick,
    /// Once a second: status publications, chain pools.
    StatusTick,
    /// Query `query` on `mrmm/hosts/<node>/start`, from proven sender `from`.
    Start {
        query: u64,
        start: Box<MissionStart>,
        from: Sender,
    },
    /// Query `query` on `mrmm/missions/<mission>/ctl`, from proven sender `from`.
    Ctl {
        query: u64,
        mission: MissionName,
        ctl: MissionCtl,
        from: Sender,
    },
    /// Query `query` on `mrmm/missions/<mission>/view`.
    View {
        query: u64,
        mission: MissionName,
    },
    /// Query `query` on `mrmm/missions/<mission>/marginal?add=<add>`.
    Marginal {
        query: u64,
        mission: MissionName,
        add: i64,
    },
    Telemetry(Box<Telemetry>),
    /// The answer to a [`Command::RequestPlan`].
    Planned {
        mission: MissionName,
        epoch: u64,
        result: Result<Box<MissionPlan>, Failure>,
    },
    /// The answer to a [`Command::SendPlan`]: `Ok`, or the robot's refusal (`retryable`: nobody
    /// answered).
    PlanDelivered {
        mission: MissionName,
        robot: RobotId,
        epoch: u64,
        result: Result<(), Failure>,
    },
    /// A chain message from its proven sender (the driver checked that it is the envelope's
    /// `from`).
    Chain {
        envelope: Box<ChainEnvelope>,
        from: Sender,
    },
    /// The missions this node's own robot is in or admitted to, each with whom it trusts for it
    /// (robot nodes only).
    LocalTeam(Vec<(String, Vec<String>)>),
    /// A mission's head published its status (proven sender `from`): on a robot node, a head
    /// its robot trusts tells it who else is in the mission's chain.
    MissionStatus {
        view: Box<MissionView>,
        from: Sender,
    },
    HostAlive(NodeId),
    HostGone(NodeId),
    RobotAlive(RobotId),
    RobotGone(RobotId),
    PlannerAlive {
        kind: String,
        zid: String,
    },
    PlannerGone {
        kind: String,
        zid: String,
    },
    /// The answer to [`Command::RollCall`]: the tokens up, or why there is no answer.
    RollCall(Result<crate::roll_call::Present, String>),
}

impl Event {
    /// The key of the liveliness token this event is a change of, if it is one (what a roll
    /// call compares, [`crate::roll_call`]).
    pub fn token(&self) -> Option<Key> {
        match self {
            Event::HostAlive(node) | Event::HostGone(node) => Some(Key::HostAlive(node.clone())),
            Event::RobotAlive(id) | Event::RobotGone(id) => Some(Key::RobotAlive(id.clone())),
            Event::PlannerAlive { kind, zid } | Event::PlannerGone { kind, zid } => Some(Key::PlannerAlive { kind: kind.clone(), zid: zid.clone() }),
            _ => None,
        }
    }
}

/// What the driver must do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Send a chain message to host `to` (on `mrmm/hosts/<to>/chain`).
    Chain { to: NodeId, envelope: Box<ChainEnvelope> },
    /// Answer query `query` with JSON, or with a reply error.
    Reply { query: u64, result: Result<Value, ErrorReply> },
    /// Let query `query` go unanswered: its asker will ask again (maybe of a newer head).
    Drop { query: u64 },
    /// Serve `mission`'s ctl, view and marginal queryables: this node leads it.
    Serve { mission: MissionName },
    /// Stop serving them.
    Unserve { mission: MissionName },
    /// Ask the network which hosts', robots' and planners' liveliness tokens are up (a
    /// liveliness query on each); answer with [`Event::RollCall`] ([`crate::roll_call`]).
    RollCall,
    /// Ask for a plan: of a planner service, or (`local`, none alive) with the library here.
    /// Answer with [`Event::Planned`].
    RequestPlan { mission: MissionName, epoch: u64, kind: PlannerKind, request: PlanRequest, local: bool },
    /// Hand `robot` its plan; answer with [`Event::PlanDelivered`].
    SendPlan { mission: MissionName, robot: RobotId, assignment: Box<PlanAssignment> },
    /// Publish the mission's status on `mrmm/missions/<name>/status`.
    Status(Box<MissionView>),
    /// A proven sender sent what it may not: count it and say so in the log (always
    /// [`Refused::NotEntitled`]: the machine judges only proven senders).
    Refused(Refused),
    /// Durable hosts only: write what this node must remember of `mission`'s chain, and sync it,
    /// before carrying out the commands after this one.
    Persist { mission: MissionName, disk: Box<chain::Disk<MissionSnapshot>> },
}

/// The mission host of one node.
#[derive(Debug, Clone)]
pub struct HostCore {
    node: NodeId,
    registry: Registry<MissionSnapshot>,
    heads: BTreeMap<MissionName, Head>,
    /// The robots it knows of: whose token is up, what their telemetry says.
    robots: Robots,
    /// Planner services alive: (kind, zid).
    planners: BTreeSet<(String, String)>,
    /// What the network says is up, now and then: liveliness events this host missed.
    roll: crate::roll_call::RollCall,
    /// Whom it takes chain messages from: its own robot's team, if it has one; a start of a
    /// mission whose old chain is heard elsewhere is refused.
    trust: trust::Trust,
}

/// For this long after the last chain message of a mission this node holds nothing of, it
/// refuses to start it.
pub const FOREIGN_CHAIN_S: f64 = 3.0;

fn json<T: serde::Serialize>(v: &T) -> Result<Value, String> {
    serde_json::to_value(v).map_err(|e| e.to_string())
}

impl HostCore {
    /// The host of `node`, started at `now` (its replicas do not vote for `params.quarantine`).
    pub fn new(node: &str, params: Params, now: Time) -> Self {
        HostCore {
            node: node.into(),
            registry: Registry::new(node, params, now),
            heads: BTreeMap::new(),
            robots: Robots::default(),
            planners: BTreeSet::new(),
            roll: crate::roll_call::RollCall::default(),
            trust: trust::Trust::new(false),
        }
    }

    /// A durable host of `node`, started at `now`, going on from what it persisted (nothing on a
    /// first start): its chain replicas come back as they were and vote at once, and it puts out
    /// [`Command::Persist`] for every change they must remember.
    pub fn restore(node: &str, params: Params, now: Time, disk: Vec<(MissionName, chain::Disk<MissionSnapshot>)>) -> Self {
        let mut h = HostCore::new(node, params, now);
        h.registry = Registry::restore(node, params, now, now, disk);
        h
    }

    /// The host of a robot node: it learns its robot's team from [`Event::LocalTeam`].
    pub fn with_robot(mut self) -> Self {
        self.trust = trust::Trust::new(true);
        self
    }

    /// Whether `from` may send chain messages about `mission` to this node (see `trust.rs`): by
    /// what this node holds of the mission, and what the sender's telemetry says it runs.
    fn may_chain(&self, mission: &str, from: &Sender) -> bool {
        let holding = || {
            let replica = self.registry.replica(mission);
            let id = &from.id;
            trust::Holding {
                counts_sender: replica.is_some_and(|r| {
                    r.config().is_some_and(|c| c.chain.iter().any(|n| n == id))
                        || r.state().is_some_and(|s| s.members.iter().chain(&s.lost).any(|m| m.spec.id == *id))
                }),
                holds: replica.is_some_and(|r| r.config().is_some() || r.state().is_some()),
                sender_runs: self.robots.runs(id, mission),
            }
        };
        self.trust.may_chain(mission, from, holding)
    }

    pub fn node(&self) -> &str {
        self.node.as_str()
    }
    /// The missions this node leads.
    pub fn heads(&self) -> impl Iterator<Item = (&MissionName, &MissionManager)> {
        self.heads.iter().map(|(n, h)| (n, &h.mm))
    }
    /// The maps of the missions this node leads or replicates.
    pub fn maps(&self) -> Vec<mrmm_proto::MapRef> {
        let mut out: Vec<mrmm_proto::MapRef> = self.heads.values().filter_map(|h| h.mm.map().cloned()).collect();
        out.extend(self.registry.names().filter_map(|n| self.registry.replica(n.as_str())?.state()?.spec.map.clone()));
        out.sort();
        out.dedup();
        out
    }

    /// This node's chain replica of `mission`.
    pub fn replica(&self, mission: &str) -> Option<&chain::Replica<MissionSnapshot>> {
        self.registry.replica(mission)
    }
    /// Robots with a plan of `mission` still on its way.
    pub fn undelivered(&self, mission: &str) -> Vec<RobotId> {
        self.heads.get(mission).map(|h| h.undelivered().cloned().collect()).unwrap_or_default()
    }

    /// Handles one event at `now` (seconds).
    pub fn handle(&mut self, now: Time, ev: Event) -> Vec<Command> {
        let mut out = Vec::new();
        if let Some(token) = ev.token() {
            self.roll.heard(now, &token.to_string());
        }
        match ev {
            Event::Tick => self.tick(now, &mut out),
            Event::StatusTick => self.status_tick(now, &mut out),
            Event::Start { from, query, .. } | Event::Ctl { from, query, .. } if !steers(&from) => {
                out.push(Command::Reply {
                    query,
                    result: Err(ErrorReply::coded(ErrorCode::Refused, format!("refused: {from} may not steer missions (only central does)"))),
                });
                out.push(Command::Refused(Refused::NotEntitled { what: "steer a mission (start or control)".into(), from }));
            }
            Event::Start { query, start, .. } => self.start(now, query, *start, &mut out),
            Event::Ctl { query, mission, ctl, .. } => self.ctl(now, query, mission.as_str(), ctl, &mut out),
            Event::LocalTeam(teams) => self.trust.handle(trust::Heard::LocalTeam(teams)),
            Event::MissionStatus { view, from } => self.trust.handle(trust::Heard::Status { view: &view, from: &from }),
            Event::View { query, mission } => {
                let result = self.view(now, mission.as_str(), true).ok_or_else(|| format!("mission {mission:?} is not managed here")).and_then(|v| json(&v));
                out.push(Command::Reply { query, result: result.map_err(ErrorReply::from) });
            }
            Event::Marginal { query, mission, add } => {
                let result = if add == 0 || add.abs() > 1000 {
                    Err(format!("add={add}: give a non-zero whole number, e.g. add=1 or add=-1"))
                } else {
                    self.heads.get(&mission).ok_or_else(|| format!("mission {mission:?} is not managed here")).and_then(|h| h.mm.marginal(add))
                };
                out.push(Command::Reply { query, result: result.and_then(|m| json(&m)).map_err(ErrorReply::from) });
            }
            Event::Telemetry(t) => self.telemetry(now, &t, &mut out),
            Event::Planned { mission, epoch, result } => self.planned(now, mission.as_str(), epoch, result, &mut out),
            Event::PlanDelivered { mission, robot, epoch, result } => self.plan_delivered(now, mission.as_str(), robot.as_str(), epoch, result, &mut out),
            Event::Chain { envelope, from } => self.chain_message(now, *envelope, from, &mut out),
            Event::RollCall(result) => self.roll_call(now, result, &mut out),
            Event::HostAlive(node) | Event::HostGone(node) if node == self.node => {}
            Event::HostAlive(node) => self.host(now, node.as_str(), true, &mut out),
            Event::HostGone(node) => self.host(now, node.as_str(), false, &mut out),
            Event::RobotAlive(id) => {
                self.robots.up(id.as_str());
                self.robot(now, id.as_str(), true, &mut out);
            }
            Event::RobotGone(id) => {
                self.robots.down(id.as_str());
                self.robot(now, id.as_str(), false, &mut out);
            }
            Event::PlannerAlive { kind, zid } => {
                self.planners.insert((kind, zid));
            }
            Event::PlannerGone { kind, zid } => {
                self.planners.remove(&(kind, zid));
            }
        }
        out
    }

    /// The answer to a roll call: the liveliness changes this host missed, translated by its own
    /// ingress into the events it missed, and handled as those.
    fn roll_call(&mut self, now: Time, result: Result<crate::roll_call::Present, String>, out: &mut Vec<Command>) {
        let mut held: BTreeSet<String> = self.robots.alive_ids().iter().map(|id| Key::RobotAlive(id.clone()).to_string()).collect();
        // Its own token is up whatever it heard of it.
        held.extend(self.registry.alive().iter().chain([&self.node]).map(|n| Key::HostAlive(n.clone()).to_string()));
        held.extend(self.planners.iter().map(|(kind, zid)| Key::PlannerAlive { kind: kind.clone(), zid: zid.clone() }.to_string()));
        // A host keeps no registry: any token up it never heard of counts as new, a few per
        // answer.
        for m in self.roll.answered(result, &held, &BTreeSet::new()) {
            match ingress(crate::edge::Incoming { key: &m.key, payload: &[], put: m.up, from: None }) {
                Ok(e) if e.token().is_some() => out.extend(self.handle(now, e)),
                _ => tracing::debug!(key = %m.key.chars().take(200).collect::<String>(), "roll call: not a host's, robot's or planner's token"),
            }
        }
    }

    /// A robot's telemetry. Of a robot whose liveliness is gone it is stale (the driver's queues
    /// do not order it against liveliness): a lost member must not seem back.
    fn telemetry(&mut self, now: Time, t: &Telemetry, out: &mut Vec<Command>) {
        if !self.robots.heard(t) {
            return;
        }
        // A lost member heard again while central is away (or that central ordered back) may
        // rejoin now that it says where it belongs.
        if !self.central_reachable() || self.heads.values().any(|h| h.ordered_back.contains_key(t.id.as_str())) {
            self.robot(now, t.id.as_str(), true, out);
        }
        let names: Vec<MissionName> = self.heads.iter().filter(|(_, h)| h.mm.has(t.id.as_str())).map(|(n, _)| n.clone()).collect();
        for name in names {
            if let Some(h) = self.heads.get_mut(&name) {
                h.telemetry(now, t);
            }
            self.run(now, name.as_str(), mission::Event::Telemetry(Box::new(t.clone())), out);
        }
    }

    fn host(&mut self, now: Time, node: &str, up: bool, out: &mut Vec<Command>) {
        for (name, cmds) in self.registry.liveliness(now, node, up) {
            self.apply(now, name.as_str(), cmds, out);
        }
        if node == CENTRAL_HOST && !up {
            // Nobody orders lost members back now: take back those alive.
            let back: Vec<RobotId> = self.robots.alive_ids().iter().cloned().collect();
            for id in back {
                self.robot(now, id.as_str(), true, out);
            }
        }
    }

    /// Whether the system manager is reachable: it owns membership, so while it is, a lost
    /// member that comes back rejoins on its order (it may have given the robot away after a
    /// restart); while it is not, heads take their members back themselves.
    fn central_reachable(&self) -> bool {
        self.node == CENTRAL_HOST || self.registry.alive().contains(CENTRAL_HOST)
    }

    /// A member lost is taken out (the team goes on without it); a lost member back rejoins,
    /// on its own while central is unreachable.
    fn robot(&mut self, now: Time, id: &str, up: bool, out: &mut Vec<Command>) {
        // While central is reachable, a member back rejoins only on its order: one it gave
        // while the token was still gone here.
        let central = up && self.central_reachable();
        let ordered = |h: &Head| h.ordered_back.get(id).is_some_and(|t| now - *t < head::ORDERED_BACK_S);
        let names: Vec<MissionName> = self
            .heads
            .iter()
            .filter(|(n, h)| match up {
                true => h.mm.lost(id).is_some() && self.robots.free_for(id, n.as_str()) && (!central || ordered(h)),
                false => h.mm.has(id),
            })
            .map(|(n, _)| n.clone())
            .collect();
        for (n, h) in self.heads.iter_mut() {
            // Gone again: central orders it back again when it returns.
            if !up || names.contains(n) {
                h.ordered_back.remove(id);
            }
        }
        for name in names {
            let ev = match self.heads.get(&name).and_then(|h| h.mm.lost(id).cloned()) {
                Some(member) if up => {
                    tracing::info!(mission = %name, robot = %id, "lost member back: it rejoins");
                    mission::Event::Joined(member)
                }
                _ => mission::Event::Lost { ids: vec![id.into()] },
            };
            self.run(now, name.as_str(), ev, out);
        }
    }
}

/// Whether `from` may start and control missions here ([`mrmm_proto::policy::POLICY`]).
fn steers(from: &mrmm_proto::Sender) -> bool {
    use mrmm_proto::policy::{allows, Act, Relation};
    allows(Act::Start, from.role, Relation::Stranger) && allows(Act::Control, from.role, Relation::Stranger)
}

impl crate::machine::Machine for HostCore {
    type Event = Event;
    type Command = Command;

    fn handle(&mut self, now: Time, event: Event) -> Vec<Command> {
        HostCore::handle(self, now, event)
    }

    /// What a durable host's chains must remember is written before anything of its step leaves.
    fn effect(command: &Command) -> crate::machine::Effect {
        use crate::machine::Effect;
        match command {
            Command::Persist { .. } => Effect::Persist,
            Command::Chain { .. } | Command::Status(_) => Effect::Publish,
            Command::RequestPlan { .. } | Command::SendPlan { .. } => Effect::Ask,
            Command::Reply { .. } | Command::Drop { .. } => Effect::Reply,
            // Queryables declared or undeclared; a refusal logged.
            Command::Serve { .. } | Command::Unserve { .. } | Command::Refused(_) => Effect::Local,
            Command::RollCall => Effect::Ask,
        }
    }
}

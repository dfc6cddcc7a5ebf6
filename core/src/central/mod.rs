//! Central's decisions as one pure machine: the system manager and the advising agent composed.
//! The agent looks at the fleet once a second; its own moves (autonomy `act`) go through the
//! system manager like an operator's, and their results go back to the agent, which records
//! them on its advice. No I/O: [`CentralCore::handle`] returns [`Command`]s.

pub mod agent;
pub mod charging;
pub mod system;

use std::collections::VecDeque;

use mrmm_proto::{AdviceEvent, NodeId, Time};

use self::agent::{Agent, AgentConfig};
use self::charging::{Charging, ChargingConfig};
use self::system::{Req, Request, SystemManager};
use crate::edge::{Incoming, Refused};
use crate::egress::Sub;
use crate::traffic::authority::{self, Authority};

/// Seconds between two looks of the agent at the fleet.
pub const AGENT_PERIOD_S: f64 = 1.0;

/// Something that happened to central.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// Anything the system manager handles.
    System(system::Event),
    /// Query `query` on `mrmm/agent/advice`.
    Advice { query: u64 },
    /// A robot's report to the traffic authority of map `map` (its sender proven to be it).
    Traffic { map: String, report: mrmm_proto::TrafficReport },
}

impl Event {
    /// What kind of event this is, for logs and the driver's load figures.
    pub fn kind(&self) -> &'static str {
        match self {
            Event::System(e) => e.kind(),
            Event::Advice { .. } => "advice",
            Event::Traffic { .. } => "traffic",
        }
    }
}

/// What central's driver must do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// A system manager command (its replies to the agent never come out here).
    System(system::Command),
    /// Publish on `mrmm/agent/advice/live`.
    Publish(AdviceEvent),
    /// What the traffic authority decided.
    Traffic(authority::Command),
}

/// The system manager and the advising agent.
#[derive(Debug)]
pub struct CentralCore {
    system: SystemManager,
    agent: Agent,
    /// The charging policy (with the agent's `charging`).
    charging: Charging,
    last_look: Time,
    /// Traffic on the maps central publishes (and the former versions missions still use).
    traffic: Authority,
    started: Time,
}

impl CentralCore {
    /// Central on Zenoh node `node`, started at `now`.
    pub fn new(node: NodeId, agent: AgentConfig, now: Time) -> Self {
        CentralCore {
            system: SystemManager::new(node, now),
            charging: Charging::new(charging_config(&agent)),
            agent: Agent::new(agent),
            last_look: now,
            traffic: Authority::new(now, 1, []),
            started: now,
        }
    }

    /// Central restarted from its journal's `state`.
    pub fn restore(node: NodeId, agent: AgentConfig, now: Time, state: system::Durable) -> Self {
        CentralCore {
            charging: Charging::restored(charging_config(&agent), now, &state.errands),
            system: SystemManager::restore(node, now, state),
            agent: Agent::new(agent),
            last_look: now,
            traffic: Authority::new(now, 1, []),
            started: now,
        }
    }

    /// The maps missions may plan on, by name.
    pub fn with_maps(mut self, maps: std::collections::BTreeMap<String, std::sync::Arc<crate::maps::Held>>) -> Self {
        self.traffic.add_maps(maps.values().map(|h| (h.info.hash.clone(), h.map.clone())));
        self.system = self.system.with_maps(maps);
        self
    }

    /// Robots on the maps of these bundle hashes drive without traffic (no lanes).
    pub fn without_lanes(mut self, hashes: Vec<String>) -> Self {
        self.traffic.without_lanes(hashes);
        self
    }

    /// Former versions of the maps that journaled missions plan on.
    pub fn with_superseded(mut self, maps: Vec<std::sync::Arc<crate::maps::Held>>) -> Self {
        self.traffic.add_maps(maps.iter().map(|h| (h.info.hash.clone(), h.map.clone())));
        self.system = self.system.with_superseded(maps);
        self
    }

    /// The traffic authority's incarnation: above every earlier central's (the driver gives its
    /// start's wall-clock milliseconds), so that robots take its orders over theirs.
    pub fn with_traffic_incarnation(mut self, incarnation: u64) -> Self {
        self.traffic = self.traffic.with_incarnation(incarnation, self.started);
        self
    }

    pub fn traffic(&self) -> &Authority {
        &self.traffic
    }

    /// Robots lost this long (seconds) and in no mission leave the registry.
    pub fn forgetting_lost_after(mut self, s: f64) -> Self {
        self.system = self.system.forgetting_lost_after(s);
        self
    }

    pub fn system(&self) -> &SystemManager {
        &self.system
    }
    pub fn agent(&self) -> &Agent {
        &self.agent
    }

    /// Handles one event at `now` (seconds).
    pub fn handle(&mut self, now: Time, ev: Event) -> Vec<Command> {
        let mut out = Vec::new();
        match ev {
            Event::Advice { query } => {
                let result = system::to_value(&self.agent.advice());
                out.push(Command::System(system::Command::Reply { req: Req::Query(query), result }));
            }
            Event::Traffic { map, report } => {
                let cmds = self.traffic.handle(now, authority::Event::Report { map, report });
                out.extend(cmds.into_iter().map(Command::Traffic));
            }
            Event::System(ev) => {
                match &ev {
                    system::Event::RobotGone { id } => {
                        out.extend(self.traffic.handle(now, authority::Event::Gone(id.clone())).into_iter().map(Command::Traffic))
                    }
                    system::Event::RobotAlive { id } => {
                        out.extend(self.traffic.handle(now, authority::Event::Alive(id.clone())).into_iter().map(Command::Traffic))
                    }
                    system::Event::Tick => out.extend(self.traffic.handle(now, authority::Event::Tick).into_iter().map(Command::Traffic)),
                    _ => {}
                }
                if let system::Event::Operator { req, request: Request::Traffic } = &ev {
                    let views = system::to_value(&self.traffic.views(now));
                    out.push(Command::System(system::Command::Reply { req: req.clone(), result: views }));
                    return out;
                }
                if let system::Event::Operator { req, request: Request::ClearTraffic(c) } = &ev {
                    self.agent.handle(now, agent::Event::OperatorCommand);
                    let result = match self.traffic.clear(now, &c.robot) {
                        Ok((cleared, cmds)) => {
                            tracing::info!(robot = %c.robot, vertices = cleared.vertices, "traffic: the operator took a lost robot off the lanes");
                            out.extend(cmds.into_iter().map(Command::Traffic));
                            system::to_value(&cleared)
                        }
                        Err(why) => Err(why),
                    };
                    out.push(Command::System(system::Command::Reply { req: req.clone(), result }));
                    return out;
                }
                if let system::Event::Operator { req, request: request @ (Request::Charge(_) | Request::Release(_)) } = &ev {
                    self.agent.handle(now, agent::Event::OperatorCommand);
                    let result = self.charging_order(now, request, &mut out);
                    out.push(Command::System(system::Command::Reply { req: req.clone(), result }));
                    return out;
                }
                if let system::Event::Operator { req: Req::Query(_), request } = &ev {
                    if request.is_command() {
                        self.agent.handle(now, agent::Event::OperatorCommand);
                    }
                }
                let tick = ev == system::Event::Tick;
                let cmds = self.system.handle(now, ev);
                self.route(now, cmds, &mut out);
                if tick && now - self.last_look >= AGENT_PERIOD_S {
                    self.last_look = now;
                    let (robots, missions) = (self.system.views(), self.system.mission_views());
                    if self.agent.config().charging {
                        let maps = self.system.map_infos();
                        let cmds = self.charging.handle(now, charging::Fleet { robots: &robots, missions: &missions, maps: &maps });
                        self.system.keep_errands(self.charging.records());
                        self.charging_commands(now, cmds, &mut out);
                    }
                    let look = agent::Event::Snapshot { robots, missions, traffic: self.traffic.views(now) };
                    let cmds = self.agent.handle(now, look);
                    self.agent_commands(now, cmds, &mut out);
                }
            }
        }
        out
    }

    /// System commands go out, except answers to the agent, which go back to it.
    fn route(&mut self, now: Time, cmds: Vec<system::Command>, out: &mut Vec<Command>) {
        let mut queue: VecDeque<system::Command> = cmds.into();
        while let Some(c) = queue.pop_front() {
            match c {
                system::Command::Reply { req: Req::Agent(advice), result } => {
                    let cmds = self.agent.handle(now, agent::Event::Acted { advice, result: result.map(|_| ()).map_err(|e| e.error) });
                    self.agent_commands(now, cmds, out);
                }
                other => out.push(Command::System(other)),
            }
        }
    }

    /// The operator's charge or release of a robot: the policy's answer, its commands carried out.
    fn charging_order(&mut self, now: Time, request: &Request, out: &mut Vec<Command>) -> Result<serde_json::Value, mrmm_proto::ErrorReply> {
        let (robots, missions, maps) = (self.system.views(), self.system.mission_views(), self.system.map_infos());
        let fleet = charging::Fleet { robots: &robots, missions: &missions, maps: &maps };
        let (answer, cmds) = match request {
            Request::Charge(c) => {
                let (errand, cmds) = self.charging.charge(now, c.robot.as_str(), fleet)?;
                tracing::info!(robot = %c.robot, charger = %errand.charger.name, map = %errand.map, "the operator sends a robot to charge");
                (serde_json::json!({"robot": c.robot, "map": errand.map, "charger": errand.charger}), cmds)
            }
            Request::Release(c) => {
                let cmds = self.charging.release(c.robot.as_str(), fleet)?;
                tracing::info!(robot = %c.robot, "the operator ends a robot's charging");
                (serde_json::json!({"robot": c.robot, "released": true}), cmds)
            }
            _ => return Err(mrmm_proto::ErrorReply::invalid("not a charging order")),
        };
        self.system.keep_errands(self.charging.records());
        self.charging_commands(now, cmds, out);
        Ok(answer)
    }

    /// The charging policy's moves and gotos go through the system manager as the agent's do
    /// (journaled as the agent's, answers back to it under `charging/<robot>`); its plugs go to
    /// the robot.
    fn charging_commands(&mut self, now: Time, cmds: Vec<charging::Command>, out: &mut Vec<Command>) {
        for c in cmds {
            let (robot, request) = match c {
                charging::Command::Move { robot, to } => (robot.clone(), Request::Move(mrmm_proto::RobotMove { robot, to, replaces: None })),
                charging::Command::Replace { robot, to, out } => {
                    (robot.clone(), Request::Move(mrmm_proto::RobotMove { robot, to: Some(to), replaces: Some(out) }))
                }
                charging::Command::Goto { robot, map, x, y } => (robot.clone(), Request::Goto(mrmm_proto::GotoRequest { robot, x, y, map: Some(map) })),
                charging::Command::Plug { robot, on } => {
                    tracing::info!(%robot, on, "charging: plug");
                    out.push(Command::System(system::Command::SendToRobot { req: None, robot, cmd: mrmm_proto::RobotCommand::Charge { on } }));
                    continue;
                }
            };
            tracing::info!(%robot, ?request, "charging");
            let cmds = self.system.handle(now, system::Event::Operator { req: Req::Agent(format!("charging/{robot}")), request });
            self.route(now, cmds, out);
        }
    }

    fn agent_commands(&mut self, now: Time, cmds: Vec<agent::Command>, out: &mut Vec<Command>) {
        for c in cmds {
            match c {
                agent::Command::Publish(e) => out.push(Command::Publish(e)),
                agent::Command::Move { advice, mv } => {
                    tracing::info!(robot = %mv.robot, to = ?mv.to, %advice, "agent acts");
                    let cmds = self.system.handle(now, system::Event::Operator { req: Req::Agent(advice), request: Request::Move(mv) });
                    self.route(now, cmds, out);
                }
            }
        }
    }
}

/// The charging policy's thresholds: the agent's.
fn charging_config(agent: &AgentConfig) -> ChargingConfig {
    ChargingConfig { go_below: agent.battery_low, done_above: agent.charged }
}

/// What command `c` publishes, if anything: the agent's advice as it changes, the system
/// manager's chain messages.
pub fn egress(c: &Command) -> Option<crate::egress::Out> {
    match c {
        Command::Publish(e) => crate::egress::Out::json(mrmm_proto::Key::AgentAdviceLive, e, crate::egress::Audience::Fleet),
        Command::System(c) => system::egress(c),
        Command::Traffic(c) => authority::egress(c),
    }
}

/// What a sealed message on `key` is, for the driver to prove its sender (`None`: liveliness).
pub fn sealed(key: &str) -> Option<&'static str> {
    match mrmm_proto::Key::parse(key) {
        Some(mrmm_proto::Key::TrafficReport { .. }) => Some("traffic report"),
        _ => system::sealed(key),
    }
}

/// Translates what central hears: robots' traffic reports (each from the robot it is of), and
/// everything the system manager hears.
pub fn ingress(m: Incoming<'_>) -> Result<Event, Refused> {
    let Some(mrmm_proto::Key::TrafficReport { map, robot }) = mrmm_proto::Key::parse(m.key) else {
        return system::ingress(m).map(Event::System);
    };
    let what = "traffic report";
    let from = m.from.cloned().ok_or(Refused::Unproven { what })?;
    mrmm_proto::policy::may_publish(mrmm_proto::policy::Publication::TrafficReport(robot.as_str()), &from)
        .map_err(|what| Refused::NotEntitled { from: from.clone(), what })?;
    let report: mrmm_proto::TrafficReport =
        mrmm_proto::from_json_max(what, m.payload, mrmm_proto::traffic::MAX_MESSAGE).map_err(|e| Refused::Malformed { what, why: e.to_string() })?;
    if report.robot != robot {
        return Err(Refused::Malformed { what, why: format!("the report of {:?} published on {}", report.robot, m.key) });
    }
    report.check().map_err(|why| Refused::Malformed { what, why })?;
    Ok(Event::Traffic { map, report })
}

/// What central listens to: the system manager's subscriptions and robots' traffic reports.
pub fn subscriptions() -> Vec<Sub> {
    let mut subs = system::subscriptions();
    subs.push(Sub::any(mrmm_proto::Pattern::AllTrafficReports));
    subs
}

impl crate::machine::Machine for CentralCore {
    type Event = Event;
    type Command = Command;

    fn handle(&mut self, now: Time, event: Event) -> Vec<Command> {
        CentralCore::handle(self, now, event)
    }

    /// The system manager's journal entries are written before anything else of their step.
    fn effect(command: &Command) -> crate::machine::Effect {
        use crate::machine::Effect;
        use system::Command as S;
        match command {
            Command::System(S::Journal(_)) => Effect::Persist,
            Command::System(S::FetchInfo { .. } | S::SendToRobot { .. } | S::StartMission { .. } | S::Ctl { .. } | S::Forward { .. } | S::RollCall) => {
                Effect::Ask
            }
            Command::System(S::Reply { .. }) => Effect::Reply,
            Command::System(S::Chain { .. }) | Command::Publish(_) => Effect::Publish,
            // A refusal is logged; a dry run is planned off the loop, its result an event.
            Command::System(S::Refused(_) | S::DryRun(_)) => Effect::Local,
            Command::Traffic(authority::Command::Order { .. }) => Effect::Publish,
            Command::Traffic(authority::Command::Blocked { .. }) => Effect::Local,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::at;
    use crate::central::agent::Autonomy;
    use mrmm_proto::{RobotInfo, Telemetry};

    fn info(id: &str) -> RobotInfo {
        RobotInfo::new(id, "ground", 1.0)
    }

    #[test]
    fn the_agents_moves_go_through_the_system_manager_and_their_results_are_recorded() {
        let mut c = CentralCore::new("n".into(), AgentConfig { autonomy: Autonomy::Act, ..AgentConfig::default() }, at(-system::ADOPT_S));
        for id in ["r1", "r2"] {
            c.handle(at(0.0), Event::System(system::Event::RobotAlive { id: id.into() }));
            c.handle(at(0.0), Event::System(system::Event::RobotRegistered(info(id))));
            let t = Telemetry { seq: 1, ..Telemetry::resting(id, 0.0) };
            c.handle(at(0.0), Event::System(system::Event::Telemetry(Box::new(t))));
        }
        c.handle(at(0.0), Event::System(system::Event::HostAlive { node: "central".into() }));
        let create = mrmm_proto::MissionCreate {
            name: "p".into(),
            recipe: "patrol".into(),
            robots: Some(vec!["r1".into()]),
            params: [("waypoints".to_string(), serde_json::json!([[0, 0], [10, 0], [10, 10]]))].into(),
            ..Default::default()
        };
        // Without the journal entries, which come first in every batch that has them.
        let no_journal =
            |out: Vec<Command>| -> Vec<Command> { out.into_iter().filter(|c| !matches!(c, Command::System(system::Command::Journal(_)))).collect() };
        let out = no_journal(c.handle(at(0.1), Event::System(system::Event::Operator { req: Req::Query(1), request: Request::Create(create) })));
        // The dry run, as the driver makes it off the loop.
        let [Command::System(system::Command::DryRun(dry))] = out.as_slice() else { panic!("a dry run first: {out:?}") };
        let result = dry.run();
        let out = c.handle(at(0.1), Event::System(system::Event::DryRunDone { id: dry.id, result }));
        assert!(
            matches!(out.first(), Some(Command::System(system::Command::Journal(e))) if e.iter().any(|e| matches!(e, mrmm_proto::JournalEvent::MissionDefined { .. }))),
            "{out:?}"
        );
        let out = no_journal(out);
        assert!(
            matches!(out.as_slice(), [Command::System(system::Command::SendToRobot { .. }), Command::System(system::Command::StartMission { .. })]),
            "{out:?}"
        );
        let mut view = Box::new(c.system().mission_views()[0].clone());
        view.status = mrmm_proto::MissionStatus::Running;
        view.summary = Some(mrmm_proto::PlanSummary::Patrol(mrmm_proto::plan::PatrolSummary {
            tour: vec![],
            waypoints: vec![],
            length: 30.0,
            offset: 0.0,
            spacing: 30.0,
            team_speed: 1.0,
            sync_per_round: 1,
            formation_time: 0.0,
            predicted_worst_idleness: 30.0,
            idleness_lower_bound: 30.0,
        }));
        c.handle(at(0.2), Event::System(system::Event::MissionStarted { mission: "p".into(), result: Ok(view) }));
        // After the operator's busy window the agent sees r2 idle and moves it into p itself:
        // the move goes to p's head like an operator's, and its answer never leaves central.
        let out = no_journal(c.handle(at(11.0), Event::System(system::Event::Tick)));
        assert!(out.iter().any(|c| matches!(c, Command::Publish(AdviceEvent::Raised(a)) if a.acted)), "{out:?}");
        assert!(out.iter().any(|c| matches!(c, Command::System(system::Command::Ctl { mission, .. }) if mission == "p")), "{out:?}");
        assert!(!out.iter().any(|c| matches!(c, Command::System(system::Command::Reply { .. }))), "{out:?}");
        assert_eq!(c.system().assignment().get("r2").map(|m| m.as_str()), Some("p"));
        assert_eq!(c.agent().advice()[0].outcome.as_deref(), Some("done"));
    }
}

//! A robot as a state machine: its body, what it was told to do, and the plan it executes. No
//! I/O: [`Robot::handle`] takes the wall-clock time and an [`Event`] and returns the
//! [`Command`]s the runtime (`runtime.rs`) or a simulation carries out.

use mrmm_proto::{
    self as proto, BarrierMode, Behaviour, CommandAck, MissionName, NodeId, RobotCommand, RobotId, RobotInfo, Sender, SyncArrival, SyncRelease, Telemetry, Time,
};

use self::executor::Executor;
use crate::body::drive::Drive;
use crate::body::nav_goals::{Nav2Goals, NavCommand};
use crate::body::ros::RosDrive;
use crate::body::Body;
use mrmm_proto::nav::{GoalEvent, GoalId};

pub mod barrier;
mod commands;
pub mod executor;
mod ingress;
mod links;
mod setup;
pub mod traffic;
pub mod viewers;
pub use ingress::{sealed, Incoming, Refused};
pub use links::{Links, TeamLinks};
pub use setup::{BodyKind, Nav2Setup, RobotSetup};

/// Steps a plan may have at most.
pub const MAX_PLAN_STEPS: usize = 100_000;

/// Missions a robot holds admissions to at most (its mission and the ones it is moving to).
pub const MAX_ADMISSIONS: usize = 4;
/// Points of a goto's route at most.
pub const MAX_GOTO_VIA: usize = 10_000;
/// Something that happened to the robot.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// Time passed: the body moves and the plan advances.
    Tick,
    /// A command arrived (query on `mrmm/robots/<id>/cmd`) from a proven sender; answered with
    /// [`Command::Reply`].
    Command { cmd: RobotCommand, from: Sender },
    /// A teammate's barrier arrival.
    Heard(SyncArrival),
    /// A leader's barrier release.
    Released(SyncRelease),
    /// An arrival at a barrier of the wider team of this path (a scope of the plan).
    HeardIn(String, SyncArrival),
    /// A teammate's membership token appeared.
    MemberAlive(RobotId),
    /// A teammate's membership token disappeared.
    MemberGone(RobotId),
    /// Central's liveliness appeared (`true`) or went (`false`).
    CentralAlive(bool),
    /// Time to publish telemetry.
    TelemetryDue,
    /// A ROS 2 body's odometry (ignored by a simulated body).
    Odometry { pose: mrmm_proto::Pose, velocity: mrmm_proto::Velocity },
    /// A ROS 2 body's localiser pose.
    LocalisedPose(mrmm_proto::Pose),
    /// The robot's session has links to other fleet nodes (`true`) or none left.
    FleetLink(bool),
    /// A ROS 2 body's battery report (checked by the driver).
    Battery(mrmm_proto::BatteryState),
    /// Nav2's action server appeared in the robot's ROS graph or left it.
    Nav2Server(bool),
    /// The traffic authority of map `map` (a bundle hash) gave this robot an order.
    /// An order of the map's traffic authority (`deputy`: from a deputy robot, central away).
    Traffic { map: String, order: mrmm_proto::TrafficOrder, deputy: bool },
    /// What became of a goal sent to Nav2.
    Nav2Goal { id: GoalId, event: GoalEvent },
    /// What a VDA 5050 vehicle said: its state or where it is.
    Vda(Box<mrmm_vda5050::FromVehicle>),
}

/// What the runtime must do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Answer the command being handled.
    Reply(Result<CommandAck, String>),
    /// Refuse the command being handled: its sender may not give it.
    Refuse(String),
    /// Join a team: member token in `subteam`, subscriptions to `team`'s barriers (as `barrier`
    /// runs them) and members (leaving any other team); `members` (the plan's) are whom its
    /// barrier messages are for; `scopes`: the wider teams whose barriers the plan has (their
    /// arrivals, and the liveliness of their members, are heard too).
    JoinTeam { team: String, subteam: String, barrier: BarrierMode, members: Vec<RobotId>, scopes: Vec<proto::ScopeMembers> },
    /// Leave the current team.
    LeaveTeam,
    /// Publish a barrier arrival on the current team.
    Publish(SyncArrival),
    /// Publish an arrival at a barrier of the wider team of this path.
    PublishIn(String, SyncArrival),
    /// Announce a release on the current team (its leader).
    Release(SyncRelease),
    /// Hear the current team's arrivals (this robot leads its barriers) or stop.
    Lead(bool),
    /// Publish telemetry.
    Telemetry(Telemetry),
    /// Send a ROS 2 body this velocity command (`cmd_vel`).
    Drive(mrmm_proto::Velocity),
    /// Send Nav2 a goal or cancel one.
    Nav(NavCommand),
    /// Send a VDA 5050 vehicle an order or instant actions.
    Vda(crate::body::vda::VdaOut),
    /// Keep these capabilities, changed from the config's `configured`, in the state dir; only
    /// for a robot with one. Carried out (written and synced) before the commands after it: the
    /// reply acknowledging the change comes after.
    KeepCapabilities { configured: Vec<String>, now: Vec<String> },
    /// Publish this report to the traffic authority of map `map` (a bundle hash).
    TrafficReport { map: String, report: mrmm_proto::TrafficReport },
    /// Stop at once, as a crashed computer would (a simulated robot, on the operator's word):
    /// nothing more is sent, no team is told goodbye.
    Crash,
}

/// A goal given to traffic before it said whether it routes it ([`Robot::hand_over`]).
#[derive(Debug, Clone)]
enum Unsent {
    /// A navigate step of the plan.
    Step { x: f64, y: f64, then: Option<crate::body::Onward>, speed: Option<f64> },
    /// A goto: its points, the goal last.
    Goto(std::collections::VecDeque<(f64, f64)>),
}

/// A robot's state, independent of the network.
#[derive(Debug)]
pub struct Robot {
    cfg: RobotSetup,
    body: Drive,
    seq: u64,
    /// Simulated seconds since start.
    sim_t: Time,
    /// Wall-clock time of the last tick.
    last_tick: Option<Time>,
    exec: Option<Executor>,
    /// The missions the system manager admitted this robot to, oldest first: (mission, managers,
    /// members). More than one while it moves between missions; at most [`MAX_ADMISSIONS`].
    admitted: Vec<(MissionName, Vec<NodeId>, Vec<RobotId>)>,
    /// Whether central (which admits robots to missions) is reachable.
    central_up: bool,
    /// What the robot can do now: its config's list, changed at runtime by capabilities commands.
    capabilities: Vec<String>,
    /// Revision of its info: +1 per change of `capabilities` (telemetry carries it).
    info_rev: u32,
    /// Pending [`Command::KeepCapabilities`] (out before the reply to the change).
    keep: bool,
    /// The rest of a goto's route: driven to one by one once the body is idle.
    route: std::collections::VecDeque<(f64, f64)>,
    /// On a map: what traffic grants it (kept from plan to plan on the same map).
    traffic: Option<traffic::Gate>,
    /// The goal given to traffic before it said whether the map has lanes: driven as it is
    /// once traffic says it has none.
    unsent: Option<Unsent>,
}

impl Robot {
    pub fn new(cfg: RobotSetup) -> Self {
        let body = match &cfg.body {
            BodyKind::Sim => {
                let body = Body::new(cfg.start, cfg.limits);
                Drive::Sim(Box::new(match &cfg.battery {
                    Some(b) => body.with_battery(b.clone()),
                    None => body,
                }))
            }
            BodyKind::Ros { odom_timeout_s, stop_on_fleet_loss, localised, nav2 } => {
                let d = RosDrive::new(cfg.start, cfg.limits, *odom_timeout_s, *stop_on_fleet_loss, *localised);
                Drive::Ros(Box::new(match nav2 {
                    Some(n) => d.with_nav2(Nav2Goals::new(&n.action, n.goal_seed)),
                    None => d,
                }))
            }
            BodyKind::Vda { order_prefix, map_id } => Drive::Vda(Box::new(crate::body::vda::VdaDrive::new(cfg.start, cfg.limits, order_prefix, map_id))),
        };
        let capabilities = cfg.capabilities.clone();
        Robot {
            cfg,
            body,
            seq: 0,
            sim_t: Time::ZERO,
            last_tick: None,
            exec: None,
            admitted: Vec::new(),
            central_up: false,
            capabilities,
            info_rev: 0,
            keep: false,
            route: Default::default(),
            unsent: None,
            traffic: None,
        }
    }

    pub fn id(&self) -> &str {
        self.cfg.id.as_str()
    }

    /// What the robot is doing now.
    pub fn behaviour(&self) -> Behaviour {
        match self.body.goal() {
            Some((x, y)) => Behaviour::Navigate { x, y },
            None => Behaviour::Hold,
        }
    }

    /// Where the body is.
    pub fn pose(&self) -> mrmm_proto::Pose {
        self.body.pose()
    }

    /// The plan being executed, if any.
    /// What traffic grants it, on a map.
    pub fn traffic(&self) -> Option<&traffic::Gate> {
        self.traffic.as_ref()
    }

    pub fn executor(&self) -> Option<&Executor> {
        self.exec.as_ref()
    }

    /// The missions this robot is in (by its plan) or was admitted to (by central), each with
    /// everyone it trusts for it (teammates of its plan; members and managers of its
    /// admission): what its mission host needs to know whom to accept chain messages from.
    pub fn team(&self) -> Vec<(String, Vec<String>)> {
        let mut out: Vec<(String, Vec<String>)> = Vec::new();
        if let Some(e) = &self.exec {
            let members = e.assignment.members.iter().map(|m| m.to_string());
            out.push((e.mission().to_string(), members.chain(e.assignment.managers.iter().map(|m| m.to_string())).collect()));
        }
        for (m, managers, members) in &self.admitted {
            let ids = managers.iter().map(|m| m.to_string()).chain(members.iter().map(|m| m.to_string()));
            match out.iter_mut().find(|(mission, _)| mission == m) {
                Some((_, known)) => known.extend(ids),
                None => out.push((m.to_string(), ids.collect())),
            }
        }
        for (_, ids) in &mut out {
            ids.sort();
            ids.dedup();
        }
        out
    }

    /// Capabilities kept from before a restart (`mrmm_peer::kept`) replace the config's.
    pub fn restore_capabilities(&mut self, now: Vec<String>) {
        tracing::info!(robot = %self.cfg.id, configured = ?self.cfg.capabilities, now = ?now, "capabilities as changed before the restart");
        self.capabilities = now;
    }

    /// The registration record (answer of `mrmm/robots/<id>/info`).
    pub fn info(&self, endpoints: Vec<String>) -> RobotInfo {
        RobotInfo {
            id: self.cfg.id.clone(),
            robot_type: self.cfg.robot_type.clone(),
            capabilities: self.capabilities.clone(),
            max_speed: self.cfg.limits.max_speed,
            max_turn_rate: Some(self.cfg.limits.max_turn_rate),
            endpoints,
            time_scale: self.cfg.time_scale,
            durable: self.cfg.durable,
            rev: self.info_rev,
        }
    }

    /// Handles one event at wall-clock time `now` (seconds, any origin, never going back).
    pub fn handle(&mut self, now: Time, ev: Event) -> Vec<Command> {
        match ev {
            Event::Tick => self.tick(now),
            Event::Command { cmd, from } => {
                let mut out = Vec::new();
                if let Err(e) = self.entitled(&cmd, &from) {
                    return vec![Command::Refuse(e)];
                }
                match self.command(&cmd) {
                    Ok(change) => {
                        out.extend(change);
                        // What it must keep goes to disk before the change is acknowledged: an
                        // operator told it is done must not lose it to a power cut right after.
                        if std::mem::take(&mut self.keep) && self.cfg.durable {
                            out.push(Command::KeepCapabilities { configured: self.cfg.capabilities.clone(), now: self.capabilities.clone() });
                        }
                        let mut ack = self.ack();
                        if matches!(cmd, RobotCommand::Capabilities { .. }) {
                            ack.capabilities = Some(self.capabilities.clone());
                        }
                        out.push(Command::Reply(Ok(ack)));
                        if matches!(cmd, RobotCommand::Crash) {
                            // Answered first (the operator learns it was done), then nothing more.
                            out.push(Command::Crash);
                            return out;
                        }
                        // Tell the fleet at once, not at the next telemetry tick.
                        out.push(Command::Telemetry(self.telemetry()));
                    }
                    Err(e) => out.push(Command::Reply(Err(e))),
                }
                out
            }
            Event::Heard(a) => self.plan_event(executor::Event::Heard(a)),
            Event::Released(r) => self.plan_event(executor::Event::Released(r)),
            Event::HeardIn(team, a) => self.plan_event(executor::Event::HeardIn(team, a)),
            Event::MemberAlive(id) => self.plan_event(executor::Event::MemberAlive(id)),
            Event::MemberGone(id) => self.plan_event(executor::Event::MemberGone(id)),
            Event::CentralAlive(up) => {
                self.central_up = up;
                vec![]
            }
            Event::TelemetryDue => vec![Command::Telemetry(self.telemetry())],
            Event::Odometry { .. }
            | Event::LocalisedPose(_)
            | Event::Battery(_)
            | Event::FleetLink(_)
            | Event::Nav2Server(_)
            | Event::Nav2Goal { .. }
            | Event::Vda(_) => {
                self.body_event(now, ev);
                vec![]
            }
            Event::Traffic { map, order, deputy } => {
                if let Some(g) = self.traffic.as_mut().filter(|g| g.map().hash == map) {
                    g.order(now, order, deputy);
                    if g.free() {
                        self.hand_over();
                    }
                }
                vec![]
            }
        }
    }

    /// What a ROS 2 body's graph says (odometry, the localiser's pose, the battery, the fleet
    /// link, Nav2's server and goals); a simulated body ignores it.
    fn body_event(&mut self, now: Time, ev: Event) {
        match ev {
            Event::Odometry { pose, velocity } => {
                if let Drive::Ros(r) = &mut self.body {
                    r.on_odometry(now, pose, velocity);
                }
            }
            Event::LocalisedPose(pose) => {
                if let Drive::Ros(r) = &mut self.body {
                    r.on_pose(pose);
                }
            }
            Event::Battery(state) => {
                if let (Drive::Ros(r), Ok(())) = (&mut self.body, state.check()) {
                    r.on_battery(state);
                }
            }
            Event::FleetLink(up) => {
                if let Drive::Ros(r) = &mut self.body {
                    r.set_fleet(up);
                }
            }
            Event::Nav2Server(up) => {
                if let Some(n) = self.nav2() {
                    n.set_server(up);
                }
            }
            Event::Nav2Goal { id, event } => {
                if let Some(n) = self.nav2() {
                    n.on_event(now, id, event);
                }
            }
            Event::Vda(msg) => {
                if let (Drive::Vda(d), Ok(())) = (&mut self.body, msg.check()) {
                    d.on_message(&msg);
                }
            }
            _ => {}
        }
    }

    fn nav2(&mut self) -> Option<&mut Nav2Goals> {
        match &mut self.body {
            Drive::Ros(r) => r.nav2_mut(),
            Drive::Sim(_) | Drive::Vda(_) => None,
        }
    }

    fn ack(&self) -> CommandAck {
        CommandAck { ok: true, robot: self.cfg.id.clone(), behaviour: self.behaviour(), capabilities: None }
    }

    fn plan_event(&mut self, ev: executor::Event) -> Vec<Command> {
        let sim_t = self.sim_t;
        match self.exec.as_mut() {
            Some(e) => {
                let out = e.handle(sim_t, ev);
                self.carry_out(out)
            }
            None => vec![],
        }
    }

    /// Advances the body by the wall time since the last tick (scaled by `time_scale`) and the plan.
    fn tick(&mut self, now: Time) -> Vec<Command> {
        let wall_dt = self.last_tick.map_or(0.0, |t| (now - t).max(0.0));
        self.last_tick = Some(now);
        let dt = wall_dt * self.cfg.time_scale;
        self.sim_t += dt;
        let step = self.body.step(now, dt);
        if let Some(halt) = step.halt_changed {
            match halt {
                Some(why) => tracing::warn!(robot = %self.cfg.id, ?why, "ROS 2 body halted: zero twist until the cause is gone"),
                None => tracing::info!(robot = %self.cfg.id, "ROS 2 body driving"),
            }
        }
        let mut body_idle = self.body.idle();
        let mut out = Vec::new();
        // On a map with lanes the plan's goal is reached when traffic let the robot get there.
        if let Some(g) = self.traffic.as_mut().filter(|g| !g.free()) {
            body_idle = g.step(now, &mut self.body);
            if g.waiting() {
                if let Some(e) = self.exec.as_mut() {
                    e.waited_for_traffic(dt);
                }
            }
            if let Some(report) = g.report(now, &self.cfg.id, &self.body) {
                out.push(Command::TrafficReport { map: g.map().hash.clone(), report });
            }
        }
        // A goto's route: on to its next point.
        if body_idle && self.exec.is_none() {
            if let Some((x, y)) = self.route.pop_front() {
                self.body.navigate_capped(x, y, None);
                body_idle = false;
            }
        }
        out.extend(self.plan_event(executor::Event::Tick { body_idle }));
        // (A goal the plan gives now is driven to from the next tick, 20 ms on.)
        if let Some(t) = step.twist {
            out.push(Command::Drive(t));
        }
        out.extend(step.nav.into_iter().map(Command::Nav));
        // A VDA 5050 vehicle is sent what it was given since the last tick and in this one: a
        // grant goes out as an order update within the tick it was driven on.
        if let Drive::Vda(d) = &mut self.body {
            out.extend(d.take().into_iter().map(Command::Vda));
        }
        out
    }

    /// Traffic said the map has no lanes: the goal it was given is the body's now (the plan
    /// waits on its step until the body gets there).
    fn hand_over(&mut self) {
        match self.unsent.take() {
            Some(Unsent::Step { x, y, then, speed }) if self.exec.is_some() => self.body.navigate_through(x, y, then, speed),
            Some(Unsent::Goto(route)) if self.exec.is_none() => {
                self.route = route;
                if let Some((x, y)) = self.route.pop_front() {
                    self.body.navigate_capped(x, y, None);
                }
            }
            _ => {}
        }
    }

    /// Carries out the plan's commands on the body; arrivals go out.
    fn carry_out(&mut self, cmds: Vec<executor::Command>) -> Vec<Command> {
        let mut out = Vec::new();
        for c in cmds {
            match c {
                executor::Command::Navigate { x, y, then, speed } => match self.traffic.as_mut().filter(|g| !g.free()) {
                    Some(g) => {
                        g.navigate(x, y, speed);
                        self.unsent = Some(Unsent::Step { x, y, then, speed });
                    }
                    None => self.body.navigate_through(x, y, then, speed),
                },
                executor::Command::Hold => {
                    self.body.hold();
                    self.unsent = None;
                    // On lanes: it stops at the end of the one it drives, and gives back the rest.
                    if let Some(g) = self.traffic.as_mut() {
                        g.stop();
                    }
                }
                executor::Command::Face { x, y } => self.body.face(x, y),
                executor::Command::Publish(s) => out.push(Command::Publish(s)),
                executor::Command::PublishIn(team, s) => out.push(Command::PublishIn(team, s)),
                executor::Command::Release(r) => out.push(Command::Release(r)),
                executor::Command::Lead(on) => out.push(Command::Lead(on)),
            }
        }
        out
    }

    /// The next telemetry message.
    fn telemetry(&mut self) -> Telemetry {
        self.seq += 1;
        Telemetry {
            id: self.cfg.id.clone(),
            seq: self.seq,
            t: self.sim_t.secs(),
            pose: self.body.pose(),
            velocity: self.body.velocity(),
            behaviour: self.behaviour(),
            mission: self.exec.as_ref().map(|e| MissionName::from(e.mission())),
            progress: self.exec.as_ref().map(Executor::progress),
            admitted: self.admitted.iter().map(|(m, _, _)| m.clone()).collect(),
            stuck: self.body.stuck().map(str::to_string),
            info_rev: self.info_rev,
            battery: self.body.battery(),
            vehicle: self.body.vehicle().cloned().map(Box::new),
        }
    }
}

impl crate::machine::Machine for Robot {
    type Event = Event;
    type Command = Command;

    fn handle(&mut self, now: Time, event: Event) -> Vec<Command> {
        Robot::handle(self, now, event)
    }

    /// Capabilities changed by the operator are kept before the change is acknowledged.
    fn effect(command: &Command) -> crate::machine::Effect {
        use crate::machine::Effect;
        match command {
            Command::KeepCapabilities { .. } => Effect::Persist,
            // A refusal is answered too (and counted).
            Command::Reply(_) | Command::Refuse(_) => Effect::Reply,
            Command::Publish(_) | Command::PublishIn(..) | Command::Release(_) | Command::Telemetry(_) | Command::TrafficReport { .. } => Effect::Publish,
            // The team's subscriptions, the body, the log, the process.
            Command::JoinTeam { .. } | Command::LeaveTeam | Command::Lead(_) | Command::Drive(_) | Command::Nav(_) | Command::Vda(_) | Command::Crash => {
                Effect::Local
            }
        }
    }
}

#[cfg(test)]
mod tests;

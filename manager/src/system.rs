//! The system manager as a state machine: it knows every robot, answers operator requests and
//! relays operator commands. No I/O: [`SystemManager::handle`] takes an [`Event`] and returns the
//! [`Command`]s the driver must carry out.

use std::collections::BTreeMap;

use mrmm_peer::proto::{
    self, CommandAck, GotoRequest, RobotCommand, RobotInfo, RobotStatus, RobotView, SystemStatus,
    Telemetry,
};
use serde_json::Value;

/// Seconds between two info requests to a robot that is alive but not yet registered.
pub const INFO_RETRY_S: f64 = 1.0;

/// An operator request, already routed by key.
#[derive(Debug, Clone, PartialEq)]
pub enum Request {
    Status,
    Robots,
    Robot(String),
    /// Payload of `mrmm/system/cmd/robot/goto`, not yet parsed.
    Goto(Vec<u8>),
}

/// Something that happened.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// A robot's liveliness token appeared.
    RobotAlive { id: String },
    /// A robot's liveliness token disappeared (crash, freeze past the lease, or clean exit).
    RobotGone { id: String },
    /// A robot answered its info query.
    RobotRegistered(RobotInfo),
    /// An info query failed.
    InfoFailed { id: String, reason: String },
    Telemetry(Telemetry),
    /// An operator query `req` arrived.
    Operator { req: u64, request: Request },
    /// A command sent on behalf of operator query `req` completed.
    RobotCommandDone { req: u64, robot: String, result: Result<CommandAck, String> },
    /// Periodic tick.
    Tick,
}

/// Something the driver must do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Ask robot `id` for its [`RobotInfo`].
    FetchInfo { id: String },
    /// Send `cmd` to `robot`; report back with [`Event::RobotCommandDone`] for `req`.
    SendToRobot { req: u64, robot: String, cmd: RobotCommand },
    /// Answer operator query `req` with JSON, or with a reply error.
    Reply { req: u64, result: Result<Value, String> },
}

#[derive(Debug, Clone)]
struct Record {
    info: Option<RobotInfo>,
    alive: bool,
    last: Option<Telemetry>,
    /// When the last info request went out (seconds, driver clock).
    info_asked: Option<f64>,
    /// When liveliness was lost.
    lost_at: Option<f64>,
    /// Set when the robot (re)appears: its sequence numbers may restart from 1.
    fresh: bool,
}

/// The registry of robots and the operator-facing logic.
#[derive(Debug)]
pub struct SystemManager {
    node: String,
    started: f64,
    robots: BTreeMap<String, Record>,
}

impl SystemManager {
    /// `node` is the Zenoh id shown to operators; `now` the driver clock in seconds.
    pub fn new(node: String, now: f64) -> Self {
        SystemManager { node, started: now, robots: BTreeMap::new() }
    }

    /// Handles one event.
    pub fn handle(&mut self, now: f64, event: Event) -> Vec<Command> {
        match event {
            Event::RobotAlive { id } => {
                let rec = self.robots.entry(id.clone()).or_insert(Record {
                    info: None,
                    alive: false,
                    last: None,
                    info_asked: None,
                    lost_at: None,
                    fresh: true,
                });
                rec.alive = true;
                rec.fresh = true;
                rec.lost_at = None;
                // Ask again even if known: a restarted robot may have changed type or endpoints.
                rec.info_asked = Some(now);
                vec![Command::FetchInfo { id }]
            }
            Event::RobotGone { id } => {
                if let Some(rec) = self.robots.get_mut(&id) {
                    if rec.alive {
                        tracing::warn!(robot = %id, "robot lost");
                    }
                    rec.alive = false;
                    rec.lost_at = Some(now);
                }
                vec![]
            }
            Event::RobotRegistered(info) => {
                match self.robots.get_mut(&info.id) {
                    Some(rec) => {
                        if rec.info.is_none() {
                            tracing::info!(robot = %info.id, r#type = %info.robot_type, "robot registered");
                        }
                        rec.info = Some(info);
                    }
                    None => tracing::debug!(robot = %info.id, "info from a robot with no liveliness: ignored"),
                }
                vec![]
            }
            Event::InfoFailed { id, reason } => {
                tracing::debug!(robot = %id, "info request failed: {reason}");
                vec![]
            }
            Event::Telemetry(t) => {
                if let Some(rec) = self.robots.get_mut(&t.id) {
                    let newer = rec.fresh || rec.last.as_ref().is_none_or(|old| t.seq > old.seq);
                    if newer {
                        rec.last = Some(t);
                        rec.fresh = false;
                    }
                }
                vec![]
            }
            Event::Tick => self
                .robots
                .iter_mut()
                .filter(|(_, r)| r.alive && r.info.is_none())
                .filter(|(_, r)| r.info_asked.is_none_or(|t| now - t >= INFO_RETRY_S))
                .map(|(id, r)| {
                    r.info_asked = Some(now);
                    Command::FetchInfo { id: id.clone() }
                })
                .collect(),
            Event::Operator { req, request } => self.operator(now, req, request),
            Event::RobotCommandDone { req, robot, result } => {
                let result = match result {
                    Ok(ack) => serde_json::to_value(ack).map_err(|e| e.to_string()),
                    Err(e) => Err(format!("robot {robot}: {e}")),
                };
                vec![Command::Reply { req, result }]
            }
        }
    }

    fn operator(&mut self, now: f64, req: u64, request: Request) -> Vec<Command> {
        let reply = |result| vec![Command::Reply { req, result }];
        match request {
            Request::Status => reply(to_value(&self.status(now))),
            Request::Robots => reply(to_value(&self.views())),
            Request::Robot(id) => match self.view(&id) {
                Some(v) => reply(to_value(&v)),
                None => reply(Err(format!("unknown robot {id:?}"))),
            },
            Request::Goto(bytes) => match self.check_goto(&bytes) {
                Ok(g) => vec![Command::SendToRobot {
                    req,
                    robot: g.robot,
                    cmd: RobotCommand::Goto { x: g.x, y: g.y },
                }],
                Err(e) => reply(Err(e)),
            },
        }
    }

    fn check_goto(&self, bytes: &[u8]) -> Result<GotoRequest, String> {
        let g: GotoRequest = proto::from_json("goto request", bytes).map_err(|e| e.to_string())?;
        let rec = self
            .robots
            .get(&g.robot)
            .filter(|r| r.info.is_some())
            .ok_or_else(|| format!("unknown robot {:?}", g.robot))?;
        if !rec.alive {
            return Err(format!("robot {:?} is lost", g.robot));
        }
        if !(g.x.is_finite() && g.y.is_finite()) {
            return Err("x and y must be finite numbers".into());
        }
        Ok(g)
    }

    /// Registered robots, sorted by id.
    pub fn views(&self) -> Vec<RobotView> {
        self.robots.keys().filter_map(|id| self.view(id)).collect()
    }

    /// One registered robot.
    pub fn view(&self, id: &str) -> Option<RobotView> {
        let rec = self.robots.get(id)?;
        let info = rec.info.as_ref()?;
        let mission = rec.last.as_ref().and_then(|t| t.mission.clone());
        let moving = rec.last.as_ref().is_some_and(|t| t.behaviour != proto::Behaviour::Hold);
        let status = if !rec.alive {
            RobotStatus::Lost
        } else if mission.is_some() || moving {
            RobotStatus::Busy
        } else {
            RobotStatus::Idle
        };
        Some(RobotView {
            id: info.id.clone(),
            robot_type: info.robot_type.clone(),
            capabilities: info.capabilities.clone(),
            status,
            mission,
            pose: rec.last.as_ref().map(|t| t.pose),
            behaviour: rec.last.as_ref().map(|t| t.behaviour.describe()),
        })
    }

    /// Fleet summary.
    pub fn status(&self, now: f64) -> SystemStatus {
        let views = self.views();
        let count = |s| views.iter().filter(|v| v.status == s).count();
        SystemStatus {
            node: self.node.clone(),
            uptime_s: now - self.started,
            robots_total: views.len(),
            idle: count(RobotStatus::Idle),
            busy: count(RobotStatus::Busy),
            lost: count(RobotStatus::Lost),
        }
    }
}

fn to_value<T: serde::Serialize>(v: &T) -> Result<Value, String> {
    serde_json::to_value(v).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_peer::proto::{Behaviour, Pose, Velocity};

    fn info(id: &str) -> RobotInfo {
        RobotInfo {
            id: id.into(),
            robot_type: "ground".into(),
            capabilities: vec!["camera".into()],
            max_speed: 1.0,
            endpoints: vec![],
        }
    }

    fn telemetry(id: &str, seq: u64, behaviour: Behaviour) -> Telemetry {
        Telemetry {
            id: id.into(),
            seq,
            t: seq as f64,
            pose: Pose { x: seq as f64, y: 0.0, theta: 0.0 },
            velocity: Velocity::default(),
            behaviour,
            mission: None,
        }
    }

    fn registered(ids: &[&str]) -> SystemManager {
        let mut sm = SystemManager::new("node".into(), 0.0);
        for id in ids {
            assert_eq!(sm.handle(0.0, Event::RobotAlive { id: (*id).into() }), vec![Command::FetchInfo { id: (*id).into() }]);
            assert!(sm.handle(0.0, Event::RobotRegistered(info(id))).is_empty());
        }
        sm
    }

    fn reply(cmds: Vec<Command>) -> Result<Value, String> {
        match cmds.as_slice() {
            [Command::Reply { result, .. }] => result.clone(),
            other => panic!("expected one reply, got {other:?}"),
        }
    }

    #[test]
    fn registration_then_loss() {
        let mut sm = registered(&["r1", "r2"]);
        let views = sm.views();
        assert_eq!(views.len(), 2);
        assert!(views.iter().all(|v| v.status == RobotStatus::Idle));
        sm.handle(1.0, Event::RobotGone { id: "r2".into() });
        assert_eq!(sm.view("r2").map(|v| v.status), Some(RobotStatus::Lost));
        let st = sm.status(2.0);
        assert_eq!((st.robots_total, st.idle, st.lost), (2, 1, 1));
        // Comes back: alive again, info asked again.
        assert_eq!(sm.handle(3.0, Event::RobotAlive { id: "r2".into() }), vec![Command::FetchInfo { id: "r2".into() }]);
        assert_eq!(sm.view("r2").map(|v| v.status), Some(RobotStatus::Idle));
    }

    #[test]
    fn unregistered_robots_are_not_listed_and_info_is_retried() {
        let mut sm = SystemManager::new("n".into(), 0.0);
        sm.handle(0.0, Event::RobotAlive { id: "r1".into() });
        assert!(sm.views().is_empty());
        assert!(sm.handle(0.5, Event::Tick).is_empty());
        assert_eq!(sm.handle(1.2, Event::Tick), vec![Command::FetchInfo { id: "r1".into() }]);
        assert!(sm.handle(1.5, Event::Tick).is_empty());
        // Info from a robot never seen alive is ignored.
        sm.handle(2.0, Event::RobotRegistered(info("ghost")));
        assert!(sm.view("ghost").is_none());
    }

    #[test]
    fn telemetry_updates_pose_and_status() {
        let mut sm = registered(&["r1"]);
        sm.handle(1.0, Event::Telemetry(telemetry("r1", 2, Behaviour::Navigate { x: 5.0, y: 0.0 })));
        let v = sm.view("r1").expect("r1");
        assert_eq!(v.status, RobotStatus::Busy);
        assert_eq!(v.pose.map(|p| p.x), Some(2.0));
        // An older message does not overwrite a newer one.
        sm.handle(1.1, Event::Telemetry(telemetry("r1", 1, Behaviour::Hold)));
        assert_eq!(sm.view("r1").and_then(|v| v.pose).map(|p| p.x), Some(2.0));
        sm.handle(1.2, Event::Telemetry(telemetry("r1", 3, Behaviour::Hold)));
        assert_eq!(sm.view("r1").map(|v| v.status), Some(RobotStatus::Idle));
        // Unknown robots' telemetry is dropped.
        sm.handle(1.3, Event::Telemetry(telemetry("zz", 1, Behaviour::Hold)));
        assert!(sm.view("zz").is_none());
    }

    #[test]
    fn goto_is_validated_then_relayed() {
        let mut sm = registered(&["r1", "r2"]);
        let go = |sm: &mut SystemManager, body: &str| {
            sm.handle(1.0, Event::Operator { req: 7, request: Request::Goto(body.as_bytes().to_vec()) })
        };
        assert_eq!(
            go(&mut sm, r#"{"robot":"r1","x":3,"y":4}"#),
            vec![Command::SendToRobot { req: 7, robot: "r1".into(), cmd: RobotCommand::Goto { x: 3.0, y: 4.0 } }]
        );
        let e = reply(go(&mut sm, r#"{"robot":"nope","x":3,"y":4}"#)).expect_err("unknown");
        assert!(e.contains("unknown robot \"nope\""), "{e}");
        let e = reply(go(&mut sm, "not json")).expect_err("garbage");
        assert!(e.contains("goto request"), "{e}");
        sm.handle(1.0, Event::RobotGone { id: "r2".into() });
        let e = reply(go(&mut sm, r#"{"robot":"r2","x":3,"y":4}"#)).expect_err("lost");
        assert!(e.contains("lost"), "{e}");
        let ack = CommandAck { ok: true, robot: "r1".into(), behaviour: Behaviour::Navigate { x: 3.0, y: 4.0 } };
        let v = reply(sm.handle(2.0, Event::RobotCommandDone { req: 7, robot: "r1".into(), result: Ok(ack) }))
            .expect("ack");
        assert_eq!(v["ok"], Value::Bool(true));
        let e = reply(sm.handle(2.0, Event::RobotCommandDone { req: 8, robot: "r1".into(), result: Err("timeout".into()) }))
            .expect_err("failed");
        assert_eq!(e, "robot r1: timeout");
    }

    #[test]
    fn operator_queries_answer_json() {
        let mut sm = registered(&["r1"]);
        let v = reply(sm.handle(1.0, Event::Operator { req: 1, request: Request::Robots })).expect("robots");
        assert_eq!(v[0]["id"], "r1");
        assert_eq!(v[0]["type"], "ground");
        assert_eq!(v[0]["status"], "idle");
        assert_eq!(v[0]["mission"], Value::Null);
        let e = reply(sm.handle(1.0, Event::Operator { req: 2, request: Request::Robot("x".into()) })).expect_err("unknown");
        assert!(e.contains("unknown robot"));
        let v = reply(sm.handle(5.0, Event::Operator { req: 3, request: Request::Status })).expect("status");
        assert_eq!(v["robots_total"], 1);
        assert_eq!(v["uptime_s"], 5.0);
    }
}

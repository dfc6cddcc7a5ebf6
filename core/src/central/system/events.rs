//! What the system manager takes and gives: operator requests, the [`Event`]s its driver hands
//! it and the [`Command`]s it returns.

use std::collections::BTreeMap;

use mrmm_proto::edge::Refused;
use mrmm_proto::ErrorReply;
use mrmm_proto::{
    self as proto, CapabilitiesRequest, ChainEnvelope, CommandAck, GotoRequest, JournalEvent, Key, MissionCreate, MissionCtl, MissionName, MissionStart,
    MissionTerminate, MissionView, NodeId, RobotCommand, RobotId, RobotInfo, RobotMove, Sender, Telemetry,
};
use serde_json::Value;

use super::missions;
use crate::Failure;

/// Who asked: an operator query held by the driver, or the advising agent (for an advice).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Req {
    Query(u64),
    Agent(String),
}

/// An operator request, decoded at the edge.
#[derive(Debug, Clone, PartialEq)]
pub enum Request {
    Status,
    Robots,
    Robot(RobotId),
    Missions,
    Mission(MissionName),
    Maps,
    /// Traffic on every graph map (central's traffic authority answers it).
    Traffic,
    /// Take a lost robot off the lanes (central's traffic authority answers it).
    ClearTraffic(mrmm_proto::traffic::TrafficClear),
    Goto(GotoRequest),
    Move(RobotMove),
    Capabilities(CapabilitiesRequest),
    Crash(proto::CrashRequest),
    /// Send a robot to charge now (central's charging policy answers it).
    Charge(proto::ChargeRequest),
    /// End a robot's charging errand (central's charging policy answers it).
    Release(proto::ChargeRequest),
    Create(MissionCreate),
    Terminate(MissionTerminate),
    Update(mrmm_proto::MissionUpdate),
    Pause(mrmm_proto::MissionPause),
    Resume(mrmm_proto::MissionPause),
}

impl Request {
    /// The request an operator query on `key` with `payload` makes: the one decoder of operator
    /// input (the driver answers its error to the query).
    pub fn decode(key: &str, payload: &[u8]) -> Result<Request, String> {
        use mrmm_proto::SystemCmd;
        let r = match Key::parse(key) {
            Some(Key::SystemStatus) => Ok(Request::Status),
            Some(Key::SystemRobots) => Ok(Request::Robots),
            Some(Key::SystemRobot(id)) => Ok(Request::Robot(id)),
            Some(Key::SystemMissions) => Ok(Request::Missions),
            Some(Key::SystemMission(name)) => Ok(Request::Mission(name)),
            Some(Key::SystemMaps) => Ok(Request::Maps),
            Some(Key::SystemTraffic) => Ok(Request::Traffic),
            Some(Key::SystemCmd(SystemCmd::Goto)) => proto::from_json("goto request", payload).map(Request::Goto),
            Some(Key::SystemCmd(SystemCmd::Move)) => proto::from_json("robot move request", payload).map(Request::Move),
            Some(Key::SystemCmd(SystemCmd::Capabilities)) => proto::from_json("robot capabilities request", payload).map(Request::Capabilities),
            Some(Key::SystemCmd(SystemCmd::Crash)) => proto::from_json("robot crash request", payload).map(Request::Crash),
            Some(Key::SystemCmd(SystemCmd::Charge)) => proto::from_json("robot charge request", payload).map(Request::Charge),
            Some(Key::SystemCmd(SystemCmd::Release)) => proto::from_json("robot release request", payload).map(Request::Release),
            Some(Key::SystemCmd(SystemCmd::Create)) => proto::from_json("mission create request", payload).map(Request::Create),
            Some(Key::SystemCmd(SystemCmd::Terminate)) => proto::from_json("mission terminate request", payload).map(Request::Terminate),
            Some(Key::SystemCmd(SystemCmd::Update)) => proto::from_json("mission update request", payload).map(Request::Update),
            Some(Key::SystemCmd(SystemCmd::Pause)) => proto::from_json("mission pause request", payload).map(Request::Pause),
            Some(Key::SystemCmd(SystemCmd::Resume)) => proto::from_json("mission resume request", payload).map(Request::Resume),
            Some(Key::SystemCmd(SystemCmd::ClearTraffic)) => proto::from_json("traffic clear request", payload).map(Request::ClearTraffic),
            _ => return Err(format!("unknown key {key}")),
        };
        r.map_err(|e| e.to_string())
    }

    /// Whether the request changes the fleet (the agent waits while the operator is busy).
    pub fn is_command(&self) -> bool {
        matches!(
            self,
            Request::Goto(_)
                | Request::Move(_)
                | Request::Capabilities(_)
                | Request::Crash(_)
                | Request::Create(_)
                | Request::Terminate(_)
                | Request::Update(_)
                | Request::Pause(_)
                | Request::Resume(_)
                | Request::ClearTraffic(_)
                | Request::Charge(_)
                | Request::Release(_)
        )
    }
}

/// Something that happened.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// A robot's liveliness token appeared.
    RobotAlive {
        id: RobotId,
    },
    /// A robot's liveliness token disappeared (crash, freeze past the lease, or clean exit).
    RobotGone {
        id: RobotId,
    },
    /// A robot answered its info query.
    RobotRegistered(RobotInfo),
    /// An info query failed.
    InfoFailed {
        id: RobotId,
        reason: String,
    },
    Telemetry(Box<Telemetry>),
    /// An operator request.
    Operator {
        req: Req,
        request: Request,
    },
    /// A command to a robot completed; `req` is the request it answers, if any.
    RobotCommandDone {
        req: Option<Req>,
        robot: RobotId,
        result: Result<CommandAck, ErrorReply>,
    },
    /// A mission host answered a start: the first plans are out, or planning failed (or, when
    /// `retryable`, nobody answered: the mission may or may not run).
    MissionStarted {
        mission: MissionName,
        result: Result<Box<MissionView>, Failure>,
    },
    /// The answer to [`Command::Forward`], for the operator as it came.
    Forwarded {
        req: Req,
        result: Result<Value, ErrorReply>,
    },
    /// The answer to [`Command::Ctl`] `id`.
    CtlDone {
        id: u64,
        result: Result<(), Failure>,
    },
    /// A mission's head published its status; `from` is its proven sender.
    MissionStatus {
        view: Box<MissionView>,
        from: Sender,
    },
    /// A mission host's liveliness token appeared.
    HostAlive {
        node: NodeId,
    },
    /// A mission host's liveliness token disappeared.
    HostGone {
        node: NodeId,
    },
    /// What the driver refused so far, by reason (reported in the fleet status).
    Refusals(BTreeMap<String, u64>),
    /// Messages the driver took, by how their sender was proven.
    Proofs(BTreeMap<String, u64>),
    /// The answer to [`Command::DryRun`] `id`.
    DryRunDone {
        id: u64,
        result: Result<(), String>,
    },
    /// The answer to [`Command::RollCall`]: the tokens up, or why there is no answer.
    RollCall(Result<crate::roll_call::Present, String>),
    /// Periodic tick.
    Tick,
}

impl Event {
    /// The key of the liveliness token this event is a change of, if it is one (what a roll
    /// call compares, `mrmm_core::roll_call`).
    pub fn token(&self) -> Option<Key> {
        match self {
            Event::RobotAlive { id } | Event::RobotGone { id } => Some(Key::RobotAlive(id.clone())),
            Event::HostAlive { node } | Event::HostGone { node } => Some(Key::HostAlive(node.clone())),
            _ => None,
        }
    }

    /// What kind of event this is, for logs and the driver's load figures.
    pub fn kind(&self) -> &'static str {
        match self {
            Event::RobotAlive { .. } => "robot alive",
            Event::RobotGone { .. } => "robot gone",
            Event::RobotRegistered(_) => "robot registered",
            Event::InfoFailed { .. } => "info failed",
            Event::Telemetry(_) => "telemetry",
            Event::Operator { .. } => "operator",
            Event::RobotCommandDone { .. } => "robot command done",
            Event::MissionStarted { .. } => "mission started",
            Event::Forwarded { .. } => "forwarded",
            Event::CtlDone { .. } => "ctl done",
            Event::MissionStatus { .. } => "mission status",
            Event::HostAlive { .. } => "host alive",
            Event::HostGone { .. } => "host gone",
            Event::Refusals(_) => "refusals",
            Event::Proofs(_) => "proofs",
            Event::DryRunDone { .. } => "dry run done",
            Event::RollCall(_) => "roll call",
            Event::Tick => "tick",
        }
    }
}

/// Something the driver must do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Ask robot `id` for its [`RobotInfo`]; answer with [`Event::RobotRegistered`] or [`Event::InfoFailed`].
    FetchInfo { id: RobotId },
    /// Send `cmd` to `robot`; answer with [`Event::RobotCommandDone`].
    SendToRobot { req: Option<Req>, robot: RobotId, cmd: RobotCommand },
    /// Answer request `req` with JSON, or with a reply error.
    /// Errors carry their code (`mrmm_proto::ErrorCode`): an operator's client acts on it.
    Reply { req: Req, result: Result<Value, ErrorReply> },
    /// Start a mission on a host; answer with [`Event::MissionStarted`].
    StartMission { host: NodeId, start: Box<MissionStart> },
    /// Steer a mission through its head; answer with [`Event::CtlDone`]. Only an answer from
    /// one of `managers` (the mission's chain as last reported, or its host) counts.
    Ctl { id: u64, mission: MissionName, ctl: MissionCtl, managers: Vec<NodeId> },
    /// Answer request `req` with whatever `key` answers (a head's mission view), taking only an
    /// answer from one of `managers`.
    Forward { req: Req, key: Key, managers: Vec<NodeId> },
    /// A proven sender sent what it may not: count it and say so in the log (always
    /// [`Refused::NotEntitled`]: the machine judges only proven senders).
    Refused(Refused),
    /// Plan `DryRun` off this loop; answer with [`Event::DryRunDone`].
    DryRun(Box<missions::DryRun>),
    /// Commit these entries to the journal (fsync) before carrying out any command after this
    /// one: it always comes first, so nothing of a change is said or done before it is on disk.
    Journal(Vec<JournalEvent>),
    /// Ask the network which robots' and mission hosts' liveliness tokens are up (a liveliness
    /// query on both); answer with [`Event::RollCall`] (`mrmm_core::roll_call`).
    RollCall,
    /// Send a chain message to host `to` (on `mrmm/hosts/<to>/chain`): the head of a lineage
    /// that was replaced is told that a newer one runs the mission, and steps down.
    Chain { to: NodeId, envelope: Box<ChainEnvelope> },
}

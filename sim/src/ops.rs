//! The simulated operator: what it asks for, and what it was told.

use std::collections::{BTreeMap, BTreeSet};

use mrmm_core::central::system::Request;
use mrmm_proto::{CapabilitiesRequest, MissionCreate, MissionName, MissionPause, MissionTerminate, MissionUpdate, RobotId, RobotMove};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde_json::json;

/// Each create asks for a new mission name: a restarted central forgets missions (its memory is
/// not durable yet), so a name created before may still be in use somewhere it cannot see, and
/// the invariants key missions by name.
fn fresh(n: u64) -> String {
    format!("m{n}")
}

/// A cheap recipe parameter set, so thousands of seeds plan quickly.
pub fn cheap_params(patrol: bool) -> BTreeMap<String, serde_json::Value> {
    if patrol {
        [("waypoints".to_string(), json!([[0, 0], [8, 0], [8, 8], [0, 8]])), ("max_kicks".to_string(), json!(20))].into()
    } else {
        [
            ("region".to_string(), json!([[0, -20], [10, -20], [10, -10], [0, -10]])),
            ("samples".to_string(), json!(120)),
            ("lloyd_iterations".to_string(), json!(2)),
            ("minimax_iterations".to_string(), json!(2)),
        ]
        .into()
    }
}

/// The bank's patrol, requiring a camera of every robot.
fn camera_patrol() -> String {
    mrmm_planner::recipe::bank("patrol").unwrap_or_default().replace("  <params>", "  <requires capability=\"camera\"/>\n  <params>")
}

/// The operator of a run with central: random commands, and what came back.
#[derive(Debug, Default)]
pub struct Operator {
    pub next_req: u64,
    /// Requests sent and not yet answered: id → what.
    pub pending: BTreeMap<u64, Request>,
    /// Missions the operator terminated (answered ok).
    pub terminated: BTreeSet<MissionName>,
    /// Missions whose create was answered ok.
    pub created: BTreeSet<MissionName>,
    pub ok: u32,
    /// Mission names asked for so far.
    pub names: Vec<String>,
}

impl Operator {
    /// A random command over `robots`.
    pub fn command(&mut self, rng: &mut ChaCha8Rng, robots: &[String]) -> (u64, Request) {
        let known: Option<MissionName> = self.names.get(rng.gen_range(0..self.names.len().max(1))).map(MissionName::from);
        let robot = RobotId::from(&robots[rng.gen_range(0..robots.len())]);
        let request = match (rng.gen_range(0..10), known) {
            (0..=3, _) | (_, None) => {
                let name = fresh(self.names.len() as u64 + 1);
                self.names.push(name.clone());
                let patrol = rng.gen_bool(0.6);
                let mut params = cheap_params(patrol);
                // Every other mission runs the paper's leader barrier (no draw: seeds keep their runs).
                if patrol && self.names.len() % 2 == 1 {
                    params.insert("barrier".to_string(), json!("leader"));
                }
                // Every third patrol requires a camera (no draw: seeds keep their runs until an
                // operator takes a camera away).
                let recipe = match (patrol, self.names.len().is_multiple_of(3)) {
                    (true, true) => camera_patrol(),
                    (true, false) => "patrol".into(),
                    (false, _) => "coverage".into(),
                };
                Request::Create(MissionCreate {
                    name: name.into(),
                    recipe,
                    count: Some(rng.gen_range(1..=2)),
                    params,
                    replicas: Some(rng.gen_range(1..=2)),
                    ..MissionCreate::default()
                })
            }
            // Every fourth command that would move a robot into a mission changes the mission
            // instead: an update, a pause, a resume in turn (no draw: the rest of a seed's run
            // keeps its commands).
            (4..=6, Some(name)) if self.next_req % 4 == 3 => match (self.next_req / 4) % 3 {
                0 => Request::Update(MissionUpdate { name, params: [("seed".into(), json!(self.next_req))].into(), ..MissionUpdate::default() }),
                1 => Request::Pause(MissionPause { name }),
                _ => Request::Resume(MissionPause { name }),
            },
            (4..=6, Some(name)) => Request::Move(RobotMove { robot, to: Some(name), replaces: None }),
            (7, _) => Request::Move(RobotMove { robot, to: None, replaces: None }),
            (_, Some(name)) => Request::Terminate(MissionTerminate { name }),
        };
        self.next_req += 1;
        self.pending.insert(self.next_req, request.clone());
        (self.next_req, request)
    }

    /// A change of `robot`'s camera: taken away if it has one, else fitted.
    pub fn camera(&mut self, robot: String, has: bool) -> (u64, Request) {
        let camera = vec!["camera".to_string()];
        let (add, remove) = if has { (vec![], camera) } else { (camera, vec![]) };
        let request = Request::Capabilities(CapabilitiesRequest { robot: robot.into(), add, remove });
        self.next_req += 1;
        self.pending.insert(self.next_req, request.clone());
        (self.next_req, request)
    }

    /// `robot` takes `out`'s place in mission `to` (a hand-over).
    pub fn replace(&mut self, robot: String, to: MissionName, out: RobotId) -> (u64, Request) {
        let request = Request::Move(RobotMove { robot: robot.into(), to: Some(to), replaces: Some(out) });
        self.next_req += 1;
        self.pending.insert(self.next_req, request.clone());
        (self.next_req, request)
    }

    /// The answer to request `req`.
    pub fn answered(&mut self, req: u64, ok: bool) {
        let Some(request) = self.pending.remove(&req) else { return };
        if ok {
            self.ok += 1;
            match request {
                Request::Terminate(t) => {
                    self.terminated.insert(t.name);
                }
                Request::Create(c) => {
                    self.created.insert(c.name);
                }
                _ => {}
            }
        }
    }
}
